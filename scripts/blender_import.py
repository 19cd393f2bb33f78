# Run by scripts/check_blender.sh inside Blender:
#   blender -b --factory-startup --python scripts/blender_import.py -- OUT.json FILE...
# Imports each mesh file (.glb/.gltf with Blender's glTF importer, .obj with its OBJ importer)
# into an empty scene and writes, per file: the objects made, the mesh objects' world-space
# bounds, their origins, and the triangle and welded vertex counts (vertices at exactly the
# same position counted once, as strandmesh's --stats counts them).
import json
import sys

import bpy
import numpy

# Blender 3.4's glTF importer uses numpy.bool, which numpy 1.24 (Debian 12's) removed: give it
# the alias back (numpy.bool_ is the same type).
if not hasattr(numpy, "bool") or "bool" in getattr(numpy, "__former_attrs__", {}):
    numpy.bool = numpy.bool_

args = sys.argv[sys.argv.index("--") + 1:]
out_path, files = args[0], args[1:]
results = []
for path in files:
    bpy.ops.wm.read_factory_settings(use_empty=True)
    if path.endswith((".glb", ".gltf")):
        bpy.ops.import_scene.gltf(filepath=path)
    elif hasattr(bpy.ops.wm, "obj_import"):
        bpy.ops.wm.obj_import(filepath=path)  # Blender 3.2+: forward -Z, up Y (the OBJ convention)
    else:
        bpy.ops.import_scene.obj(filepath=path)
    meshes = [o for o in bpy.context.scene.objects if o.type == "MESH"]
    r = {"file": path, "objects": len(bpy.context.scene.objects), "mesh_objects": len(meshes)}
    if meshes:
        o = meshes[0]
        bpy.context.view_layer.update()
        world = [o.matrix_world @ v.co for v in o.data.vertices]
        lo = [min(p[k] for p in world) for k in range(3)]
        hi = [max(p[k] for p in world) for k in range(3)]
        # Welded: vertices used by a face, one per distinct position (exact float values).
        used = {i for p in o.data.polygons for i in p.vertices}
        welded = len({tuple(o.data.vertices[i].co) for i in used})
        triangles = sum(len(p.vertices) - 2 for p in o.data.polygons)
        r.update({
            "name": o.name,
            "origin": list(o.matrix_world.translation),
            "lo": lo, "hi": hi,
            "triangles": triangles,
            "welded_vertices": welded,
            "uv_layers": [u.name for u in o.data.uv_layers],
            "color_attributes": [c.name for c in getattr(o.data, "color_attributes", [])],
        })
    results.append(r)
with open(out_path, "w") as f:
    json.dump(results, f, indent=1)
