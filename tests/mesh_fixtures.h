#pragma once
/// Closed (and deliberately broken) triangle meshes built in code, for the export and check
/// tests. All are counter-clockwise seen from outside unless the name says otherwise; metres.

#include <cstdint>

#include <glm/glm.hpp>

#include "core/mesh.h"

namespace sm::test {

/// A sphere: the icosahedron subdivided `subdivisions` times (20·4^s triangles), genus 0.
Mesh icosphere(int subdivisions = 2, double radius = 1.0, glm::dvec3 centre = glm::dvec3(0));
/// A closed cylinder from `a` to `b`: `segments` around, `rings` rows of quads along the
/// axis, a triangle fan with a centre vertex on each end. With `uvs`, corner UVs: u = j /
/// segments around (a seam where u wraps from 1 to 0), v = distance along the axis; caps get
/// planar UVs (so the rim vertices split too). triangle_branch: 0 on the lower half of the
/// rings and the bottom cap, `upper_branch` above.
Mesh capped_tube(glm::dvec3 a = {0, 0, 0}, glm::dvec3 b = {0, 0, 1}, double radius = 0.1, int segments = 16,
                 int rings = 8, bool uvs = true, std::uint32_t upper_branch = 0);
/// A torus around the z axis (genus 1).
Mesh torus(double major = 1.0, double minor = 0.25, int nu = 24, int nv = 12);
/// The axis-aligned box [lo, hi] (8 vertices, 12 triangles).
Mesh box(glm::dvec3 lo = glm::dvec3(0), glm::dvec3 hi = glm::dvec3(1));
/// A sharp V: the prism over the isosceles triangle with apex angle `apex_degrees` at
/// (0, 1, z), base from (-w, 0) to (w, 0), from z = 0 to 1 (6 vertices, 8 triangles). The two
/// long sides meet at the apex edge (vertices 2 and 5) at a dihedral angle of 180 - apex, so
/// the angle-weighted normals there are nearly 90 degrees from both sides.
Mesh wedge(double apex_degrees);
/// Two disjoint spheres in one mesh (2 components).
Mesh two_spheres();
/// The unit box with its first triangle reversed (not consistently oriented).
Mesh box_with_flipped_triangle();
/// The unit box without its last triangle (3 boundary edges).
Mesh box_with_missing_triangle();
/// Boxes [0,1]³ and [0.5,1.5]³ in one mesh: they cross each other (self-intersections).
Mesh interpenetrating_boxes();
/// The unit box with one triangle replaced by two and a zero-area sliver (still closed).
Mesh box_with_degenerate_triangle();
/// The unit box plus a fin triangle on one edge (an edge with three triangles).
Mesh box_with_fin();
/// Two tetrahedra that share one vertex and nothing else (a non-manifold vertex).
Mesh tetrahedra_sharing_vertex();
/// Appends `b` to `a` (indices shifted, attributes kept only when both have them).
Mesh merged(const Mesh& a, const Mesh& b);
/// The mesh moved by `offset`.
Mesh translated(Mesh m, glm::dvec3 offset);

}  // namespace sm::test
