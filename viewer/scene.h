#pragma once
/// Scene building: pure functions that turn stage results into coloured batches of lines,
/// points and triangles for the viewer. No OpenGL here: a batch is plain arrays that a
/// `Backend` (viewer/backend.h) uploads, so everything below is tested without a display.
///
/// Coordinates. Batches hold float positions relative to `Scene::origin` (the centre of the
/// stage results' bounding box, kept in double precision), so georeferenced trees (coordinates
/// of hundreds of metres, z ≈ 254 m in qsm_simpleforest_rtwig.json) keep float's relative
/// precision of about 1e-7 of the tree's size. The axes are the input's (z-up or y-up, see
/// Skeleton::up_axis); the camera takes the up axis into account.
///
/// Batches are not indexed: a `lines` batch holds 2 vertices per segment, a `triangles` batch
/// 3 vertices per triangle (per-corner UVs and flat per-batch settings need no index buffer).

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "contours/contours.h"
#include "core/mesh.h"
#include "meshcheck/checks.h"
#include "particles/particles.h"
#include "skeleton/skeleton.h"
#include "strands/strands.h"

namespace sm::viewer {

/// An 8-bit RGBA colour.
struct Rgba8 {
  std::uint8_t r = 0, g = 0, b = 0, a = 255;
  friend constexpr bool operator==(Rgba8, Rgba8) = default;
};

/// The layers a user toggles. Each stage has one or more; `count` is the number of layers.
enum class Layer : std::uint8_t {
  skeleton,   ///< skeleton edges (lines)
  discs,      ///< node discs at their radii, in the node frames (line circles)
  frames,     ///< node frames: tangent blue, normal red, binormal green (short lines)
  particles,  ///< particle clouds on every cross-section (points)
  strands,    ///< strand curves (lines)
  contours,   ///< contour loops; split slices marked (lines)
  mesh,       ///< the mesh, shaded with smooth normals or the UV checker (triangles)
  wireframe,  ///< mesh edges (lines, drawn over the shaded mesh)
  normals,    ///< mesh vertex normals as short lines
  problems,   ///< what the mesh checks found: self-intersecting triangles, open and non-manifold
              ///< edges, degenerate triangles, vertices beyond the fidelity tolerance, thick nodes
              ///< outside the mesh (drawn over everything)
  count
};
inline constexpr std::size_t kLayerCount = static_cast<std::size_t>(Layer::count);

/// Stable lower-case name of a layer ("skeleton", "discs", ..., as accepted by --layers).
const char* layer_name(Layer layer);
/// The layer with that name; std::nullopt for an unknown name.
std::optional<Layer> layer_from_name(const std::string& name);

/// How strands and particles are coloured.
enum class StrandColoring : std::uint8_t {
  by_strand,  ///< one colour per strand (neighbouring ids get distant hues)
  by_tip,     ///< one colour per start node: every strand that starts at the same tip shares it
};

/// Primitive type of a batch.
enum class Primitive : std::uint8_t { lines, points, triangles };

/// One drawable: non-indexed vertices with per-vertex colours (and normals and UVs for
/// triangles). #V = positions.size(); lines: #V = 2 × segments; triangles: #V = 3 × triangles.
struct Batch {
  Primitive primitive = Primitive::lines;
  std::vector<glm::vec3> positions;  ///< #V, metres relative to Scene::origin
  std::vector<Rgba8> colors;         ///< #V
  std::vector<glm::vec3> normals;    ///< #V unit normals (triangles only, else empty)
  std::vector<glm::vec2> uvs;        ///< #V texture coordinates (triangles with UVs, else empty)
  float point_size = 4.0f;           ///< points: diameter in pixels
  float line_width = 1.0f;           ///< lines: width in pixels (backends may clamp to 1)
  std::string label;                 ///< what it shows, for the legend and tests ("split loops")

  [[nodiscard]] std::size_t vertex_count() const { return positions.size(); }
  [[nodiscard]] bool empty() const { return positions.empty(); }
};

/// Axis-aligned bounds (metres, relative to Scene::origin). Empty when lo > hi.
struct Bounds {
  glm::dvec3 lo{1e300};
  glm::dvec3 hi{-1e300};
  [[nodiscard]] bool empty() const { return lo.x > hi.x; }
  void add(const glm::dvec3& p) {
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
  }
  void add_sphere(const glm::dvec3& c, double r) {
    add(c - glm::dvec3(r));
    add(c + glm::dvec3(r));
  }
  [[nodiscard]] glm::dvec3 center() const { return empty() ? glm::dvec3(0) : 0.5 * (lo + hi); }
  /// Half the diagonal (0 when empty).
  [[nodiscard]] double radius() const { return empty() ? 0.0 : 0.5 * glm::length(hi - lo); }
};

/// The stage results the viewer shows; any pointer may be null (a mesh file alone has no
/// skeleton; a stage that failed has no result). Pointers must stay valid while used.
struct StageView {
  const Skeleton* skeleton = nullptr;
  const ParticleField* particles = nullptr;  ///< requires skeleton
  const StrandSet* strands = nullptr;        ///< requires skeleton and particles
  const ContourSet* contours = nullptr;
  const Mesh* mesh = nullptr;
};

/// Options of scene building (appearance and size caps; no UI).
struct SceneOptions {
  StrandColoring strand_coloring = StrandColoring::by_strand;
  /// Line segments per edge when strands are drawn as curves (count, default 6); lowered to 1
  /// automatically when the strands would exceed `max_strand_segments`.
  int strand_samples_per_edge = 6;
  /// Upper bound on strand line segments (count, default 1.5 million); beyond it only every
  /// k-th strand is drawn (the batch label says so).
  std::size_t max_strand_segments = 1'500'000;
  /// Segments of a node disc circle (count, default 24).
  int disc_segments = 24;
  /// Length of the frame axes relative to the node radius (default 1.6).
  double frame_length = 1.6;
  /// Length of the drawn normals relative to the mesh's mean edge length (default 0.8).
  double normal_length = 0.8;
  /// Particle point size in pixels (default 4.5).
  float particle_size = 4.5f;
};

/// Everything the viewer draws, grouped by layer.
struct Scene {
  glm::dvec3 origin{0.0};                              ///< world position of local (0,0,0)
  Bounds bounds;                                       ///< of all stage results, local
  UpAxis up_axis = UpAxis::z;                          ///< from the skeleton (z for a mesh alone)
  std::array<std::vector<Batch>, kLayerCount> layers;  ///< batches per layer

  [[nodiscard]] const std::vector<Batch>& layer(Layer l) const { return layers[static_cast<std::size_t>(l)]; }
  [[nodiscard]] std::vector<Batch>& layer(Layer l) { return layers[static_cast<std::size_t>(l)]; }
  /// Total vertices of a layer's batches.
  [[nodiscard]] std::size_t vertex_count(Layer l) const;
  /// World position of a local point.
  [[nodiscard]] glm::dvec3 to_world(const glm::dvec3& local) const { return local + origin; }
  /// Local position of a world point.
  [[nodiscard]] glm::dvec3 to_local(const glm::dvec3& world) const { return world - origin; }
};

/// The colour of global particle p's strand under `coloring` (the strands, particles and node
/// panel all use it).
Rgba8 particle_color(const ParticleField& f, std::uint32_t p, StrandColoring coloring);

/// Bounds of the stage results in world coordinates (skeleton nodes grown by their radii and
/// mesh vertices; empty when there is neither).
Bounds world_bounds(const StageView& view);

/// Builds every layer that the view has data for (layers without data stay empty).
Scene build_scene(const StageView& view, const SceneOptions& options = {});

/// Individual layers (exposed for tests and for rebuilding one layer when its option changes).
/// `origin` is the scene origin. Each returns the batches of one layer.
std::vector<Batch> skeleton_batches(const Skeleton& s, const glm::dvec3& origin);
std::vector<Batch> disc_batches(const Skeleton& s, const glm::dvec3& origin, const SceneOptions& options = {});
std::vector<Batch> frame_batches(const Skeleton& s, const glm::dvec3& origin, const SceneOptions& options = {});
std::vector<Batch> particle_batches(const Skeleton& s, const ParticleField& f, const StrandSet* strands,
                                    const glm::dvec3& origin, const SceneOptions& options = {});
std::vector<Batch> strand_batches(const Skeleton& s, const ParticleField& f, const StrandSet& strands,
                                  const glm::dvec3& origin, const SceneOptions& options = {});
std::vector<Batch> contour_batches(const ContourSet& c, const glm::dvec3& origin);
std::vector<Batch> mesh_batches(const Mesh& m, const glm::dvec3& origin);
std::vector<Batch> wireframe_batches(const Mesh& m, const glm::dvec3& origin);
std::vector<Batch> normal_batches(const Mesh& m, const glm::dvec3& origin, const SceneOptions& options = {});

/// The problems layer: the offenders `report` lists (its `*_examples`; run the checks with a
/// large `max_examples` to see them all) on `m`, the mesh it checked: self-intersecting and
/// degenerate triangles (filled, outlined), boundary, non-manifold and misoriented edges (lines),
/// vertices farther from the skeleton than the fidelity tolerance (small points) and thick
/// skeleton nodes outside the mesh (large points; needs `s`, the checked skeleton). Indices
/// out of range are skipped. Empty when the report lists nothing.
std::vector<Batch> problem_batches(const Mesh& m, const Skeleton* s, const MeshCheckReport& report,
                                   const glm::dvec3& origin);

/// A highlight for the selected node: its disc in a bright colour, a cross at its centre and
/// its edge to the parent (lines; empty when the node does not exist).
Batch selection_batch(const Skeleton& s, NodeId node, const glm::dvec3& origin, int segments = 48);

/// Bounds (world) of the subtree of `node` grown by radii: "frame selection" frames these.
Bounds subtree_bounds(const Skeleton& s, NodeId node);

}  // namespace sm::viewer
