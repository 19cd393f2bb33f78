#pragma once
/// UV quality: where a bark texture would jump (seams) and how it would be stretched, the
/// figures of `strandmesh check` under "uv seams" and "uv stretch" (informative).
///
/// Definitions (the mesh is welded; its UVs are per corner, Mesh::corner_uvs):
///  - seam edge: an edge with two triangles that give one of its vertices different UVs.
///    An "around" seam is the one that wrapping u around a branch needs: at both ends the UVs
///    differ in u only (|dv| at most 1e-3 |du|), the same way and by about as much (within a
///    factor 1.5: the turns of neighbouring loops); between two cap triangles one end may be
///    the cap's pole, where they do not differ. Every other seam edge is an "other" seam
///    (jumps in v, a seam that starts or ends inside the surface, ...).
///  - the map of a triangle: the linear map from its plane (metres) to UV. Its singular
///    values s1 >= s2 give the anisotropy s1 / s2 (1: squares stay square; a shear or an
///    uneven scale raises it) and the texel density sqrt(s1 s2) (UV units per metre). The
///    density is compared with the median over the mesh: the figure is max(d / median,
///    median / d), 1 where the texture has the tree's usual scale. Triangles of zero area are
///    left out; so, with a skeleton, are cap triangles (quality.h: caps), where u meets at
///    a pole. A triangle of zero area in UV is "collapsed" (left out of the percentiles); a
///    triangle whose map reverses orientation against the majority is "flipped" (the texture
///    mirrored).
///  - junctions (with a skeleton): seam edges whose midpoint, and triangles whose centroid,
///    lies within `junction_radii` fork radii of a node with two or more children (as for the
///    dihedral angles, quality.h).
///
/// Cost: one pass over the triangles and one over the edges; with a skeleton a nearest-ball
/// query per vertex, seam edge and triangle.

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/mesh.h"
#include "meshcheck/quality.h"
#include "skeleton/skeleton.h"

namespace sm {

struct UvQuality {
  std::size_t seam_edges = 0;            ///< edges whose two triangles give a vertex different UVs
  std::size_t around_seams = 0;          ///< of those, the wrap of u around a branch
  std::size_t other_seams = 0;           ///< the rest
  std::size_t junction_around_seams = 0; ///< around seams at junctions (with a skeleton)
  std::size_t junction_other_seams = 0;  ///< other seams at junctions (with a skeleton)
  std::vector<std::array<std::uint32_t, 2>> other_seam_examples;  ///< vertex pairs of the first other seams

  bool caps_known = false;               ///< a skeleton told where caps and junctions are
  std::size_t triangles = 0;             ///< triangles measured for stretch (zero-area and cap triangles left out)
  std::size_t junction_triangles = 0;    ///< of those, at junctions
  std::size_t collapsed = 0;             ///< of those, zero area in UV (left out of the figures below)
  std::size_t flipped = 0;               ///< of those, mirrored in UV against the majority
  double density_median = 0;             ///< median texel density (UV units per metre)
  double anisotropy_p95 = 0;             ///< 95th percentile of s1 / s2 (1 = square texels)
  double anisotropy_max = 0;             ///< largest s1 / s2
  double density_p95 = 0;                ///< 95th percentile of max(d / median, median / d)
  double junction_anisotropy_p95 = 0;    ///< the same two at junctions
  double junction_density_p95 = 0;
};

/// Measures the corner UVs of `mesh` (all zero when it has none: Mesh::corner_uvs empty).
/// `skeleton` (optional, the mesh's frame) tells where the caps and junctions are. Precondition: every triangle index is a vertex of the mesh.
UvQuality measure_uv_quality(const Mesh& mesh, const Skeleton* skeleton = nullptr, const QualityParams& params = {});

}  // namespace sm
