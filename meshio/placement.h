#pragma once
/// Where a written mesh sits: its up axis, its origin (the pivot) and its units, shared by the
/// writers (which apply it) and the readers (which undo it, so `strandmesh check` compares a
/// file with the skeleton it came from whatever placement it was written with).
///
/// A file written by strandmesh records its placement: glTF in `asset.extras.strandmesh`
/// (`up_axis`, `scale`; the pivot is the node's translation), OBJ and PLY in a comment line
/// `strandmesh-placement up y scale 1 translation X Y Z`, the translation in the file's axes
/// and units (added to a file coordinate it gives the absolute one).

#include <optional>
#include <string>
#include <string_view>

#include <glm/glm.hpp>

#include "skeleton/skeleton.h"

namespace sm {

/// `p` with up axis `from` expressed with up axis `to`: z-up (x, y, z) is y-up (x, z, -y) and
/// back (x, -z, y); rotations, so triangles keep their orientation.
inline glm::dvec3 change_up_axis(const glm::dvec3& p, UpAxis from, UpAxis to) {
  if (from == to) return p;
  return from == UpAxis::z ? glm::dvec3(p.x, p.z, -p.y) : glm::dvec3(p.x, -p.z, p.y);
}

/// The map from mesh coordinates (input axes, metres) to file coordinates.
struct Placement {
  UpAxis from = UpAxis::z;  ///< up axis of the mesh coordinates
  UpAxis to = UpAxis::y;    ///< up axis of the file
  glm::dvec3 pivot{0.0};    ///< the point (mesh coordinates, metres) that becomes the file's origin
  double scale = 1.0;       ///< file units per metre, > 0

  /// File coordinates of mesh point p.
  [[nodiscard]] glm::dvec3 position(const glm::dvec3& p) const { return change_up_axis(p - pivot, from, to) * scale; }
  /// File direction of mesh direction d (not rescaled).
  [[nodiscard]] glm::dvec3 direction(const glm::dvec3& d) const { return change_up_axis(d, from, to); }
  /// The pivot in file axes and units: what a file coordinate needs added to be absolute.
  [[nodiscard]] glm::dvec3 translation() const { return change_up_axis(pivot, from, to) * scale; }
};

/// What a reader learns from a file's placement record.
struct FilePlacement {
  UpAxis up = UpAxis::y;            ///< up axis of the file's coordinates
  double scale = 1.0;               ///< file units per metre
  glm::dvec3 translation{0.0};      ///< added to a file coordinate (OBJ, PLY; glTF keeps it in the node)
};

/// The comment text `strandmesh-placement up y scale 1 translation X Y Z` (no comment marker,
/// no newline; numbers round-trip exactly).
std::string placement_comment(const Placement& p);
/// Finds and parses that comment in the first `head` bytes of a text header; nullopt when it
/// is absent or malformed (a file from another tool).
std::optional<FilePlacement> find_placement_comment(std::string_view bytes, std::size_t head = 4096);

}  // namespace sm
