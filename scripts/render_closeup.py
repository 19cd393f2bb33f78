# A close-up of a mesh in Blender (Debian's `blender`; its glTF importer needs python3-numpy):
#   blender -b -P scripts/render_closeup.py -- MESH.glb OUT.png X Y Z DISTANCE YAW PITCH ENGINE [checker]
# The camera looks at (X, Y, Z) (the skeleton's coordinates, z up) from DISTANCE metres at YAW and
# PITCH degrees; ENGINE is CYCLES or BLENDER_WORKBENCH. The material is a procedural bark along the
# mesh's UVs (v along the strands), or a checker of the UVs with `checker`.
# docs/images/closeup_aspen_blender.png: sapling_quaking_aspen.json meshed with the defaults, then
#   blender -b -P scripts/render_closeup.py -- aspen.glb out.png -0.010153 0.009637 7.75 1.4 30 10 CYCLES
import bpy, sys, math, mathutils
import numpy
if not hasattr(numpy, "bool"): numpy.bool = numpy.bool_  # Blender 3.4 glTF importer with numpy >= 1.24
a = sys.argv[sys.argv.index("--") + 1:]
path, out = a[0], a[1]
target = mathutils.Vector((float(a[2]), float(a[3]), float(a[4])))
dist, yaw, pitch, engine = float(a[5]), float(a[6]), float(a[7]), a[8]
checker = len(a) > 9 and a[9] == "checker"
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.import_scene.gltf(filepath=path)
mat = bpy.data.materials.new("bark")
mat.use_nodes = True
nt = mat.node_tree
bsdf = nt.nodes["Principled BSDF"]
uv = nt.nodes.new("ShaderNodeTexCoord")
if checker:
    tex = nt.nodes.new("ShaderNodeTexChecker")
    tex.inputs["Scale"].default_value = 1.0
    tex.inputs["Color1"].default_value = (0.85, 0.8, 0.7, 1)
    tex.inputs["Color2"].default_value = (0.25, 0.2, 0.15, 1)
    nt.links.new(uv.outputs["UV"], tex.inputs["Vector"])
    nt.links.new(tex.outputs["Color"], bsdf.inputs["Base Color"])
else:
    # Bark: noise stretched along v (the strands), coloured grey-brown.
    mapn = nt.nodes.new("ShaderNodeMapping")
    mapn.inputs["Scale"].default_value = (14.0, 2.0, 1.0)
    noise = nt.nodes.new("ShaderNodeTexNoise")
    noise.inputs["Scale"].default_value = 4.0
    noise.inputs["Detail"].default_value = 8.0
    ramp = nt.nodes.new("ShaderNodeValToRGB")
    ramp.color_ramp.elements[0].color = (0.18, 0.15, 0.12, 1)
    ramp.color_ramp.elements[1].color = (0.62, 0.58, 0.52, 1)
    nt.links.new(uv.outputs["UV"], mapn.inputs["Vector"])
    nt.links.new(mapn.outputs["Vector"], noise.inputs["Vector"])
    nt.links.new(noise.outputs["Fac"], ramp.inputs["Fac"])
    nt.links.new(ramp.outputs["Color"], bsdf.inputs["Base Color"])
    bump = nt.nodes.new("ShaderNodeBump")
    bump.inputs["Strength"].default_value = 0.3
    nt.links.new(noise.outputs["Fac"], bump.inputs["Height"])
    nt.links.new(bump.outputs["Normal"], bsdf.inputs["Normal"])
bsdf.inputs["Roughness"].default_value = 0.8
for o in bpy.context.scene.objects:
    if o.type == "MESH":
        o.data.materials.clear()
        o.data.materials.append(mat)
scene = bpy.context.scene
cam = bpy.data.objects.new("cam", bpy.data.cameras.new("cam"))
scene.collection.objects.link(cam)
d = mathutils.Vector((math.cos(math.radians(yaw)) * math.cos(math.radians(pitch)),
                      math.sin(math.radians(yaw)) * math.cos(math.radians(pitch)), math.sin(math.radians(pitch))))
cam.location = target + d * dist
cam.rotation_euler = (target - cam.location).to_track_quat("-Z", "Y").to_euler()
cam.data.lens = 50
cam.data.clip_start = 0.001
scene.camera = cam
sun = bpy.data.objects.new("sun", bpy.data.lights.new("sun", "SUN"))
sun.data.energy = 3.0
sun.rotation_euler = (math.radians(40), math.radians(10), math.radians(yaw + 60))
scene.collection.objects.link(sun)
world = bpy.data.worlds.new("w"); scene.world = world; world.use_nodes = True
world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.75, 0.8, 0.85, 1)
world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.6
scene.render.engine = engine
if engine == "CYCLES":
    scene.cycles.samples = 24
    scene.cycles.use_denoising = False
scene.render.resolution_x, scene.render.resolution_y = 800, 600
scene.render.filepath = out
bpy.ops.render.render(write_still=True)
