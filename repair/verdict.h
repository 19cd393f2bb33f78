#pragma once
/// The repair stage's one rule for keeping a change: a change is judged on the mesh it leaves,
/// against the mesh before it, by `worse` and `keeps`. The whole-mesh steps (the outer surface,
/// the self-union) apply it as written; the local steps (fold repair, near-miss push) apply it
/// to the triangles around each change, where a whole-mesh judgement per change would cost a
/// pass over the mesh each, and the fork retry per crotch (docs/architecture.md).

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>

namespace sm {

struct MeshCheckReport;

/// What the rule reads of a mesh. Figures left unset are not compared (a step that does not
/// measure them cannot make them worse by its construction).
struct MeshFigures {
  bool sound = true;                    ///< closed, edge- and vertex-manifold, oriented, finite
  std::size_t parts = 0;                ///< connected components
  std::optional<std::int64_t> genus;    ///< total genus
  double volume = 0;                    ///< signed volume (m^3; > 0: outward)
  std::size_t degenerate = 0;           ///< degenerate triangles
  std::size_t pairs = 0;                ///< self-intersecting triangle pairs
  std::optional<std::size_t> thick_inside;  ///< skeleton nodes of at least the median radius inside
  std::optional<std::size_t> nodes_inside;  ///< all skeleton nodes inside (where a step measures them)
  std::optional<double> fidelity_p95;   ///< fidelity to the skeleton (x local radius)
  double fidelity_tolerance = 0;        ///< the tolerance fidelity_p95 is held to
};

/// The figures of a check_mesh report.
MeshFigures figures_of(const MeshCheckReport& report);

struct KeepRule {
  /// A handle may appear (crossings fused into a loop make one on purpose); otherwise the
  /// genus must stay.
  bool handles_allowed = false;
};

/// Why `after` does worse than `before` (empty if it does not): not sound, more parts, another
/// genus (unless allowed), more degenerate triangles, not outward, fewer thick nodes inside,
/// fewer nodes inside (where both count them), fidelity beyond both the tolerance and where
/// it was, more pairs.
std::string worse(const MeshFigures& before, const MeshFigures& after, const KeepRule& rule = {});

/// The rule: `after` is kept when it is no worse (above) and better in what the repair is for:
/// fewer pairs or more thick nodes inside (or more nodes, where both count them). Returns why
/// not (empty: kept).
std::string refuse(const MeshFigures& before, const MeshFigures& after, const KeepRule& rule = {});

}  // namespace sm
