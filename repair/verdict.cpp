// The repair's rule for keeping a change (see verdict.h).

#include "repair/verdict.h"

#include <algorithm>

#include "meshcheck/checks.h"

namespace sm {

MeshFigures figures_of(const MeshCheckReport& r) {
  MeshFigures f;
  f.sound = r.nonfinite_vertices == 0 && r.closed && r.edge_manifold && r.vertex_manifold && r.oriented;
  f.parts = r.components;
  f.genus = r.genus;
  f.volume = r.signed_volume;
  f.degenerate = r.degenerate_triangles;
  f.pairs = r.self_intersecting_pairs;
  if (r.inside_checked) f.thick_inside = r.thick_nodes_inside;
  if (r.fidelity_checked) f.fidelity_p95 = r.fidelity_p95;
  f.fidelity_tolerance = r.fidelity_tolerance;
  return f;
}

std::string worse(const MeshFigures& before, const MeshFigures& after, const KeepRule& rule) {
  const auto n = [](auto v) { return std::to_string(v); };
  if (!after.sound) return "not a closed, oriented 2-manifold";
  if (after.parts > before.parts) return n(after.parts) + " components";
  if (!rule.handles_allowed && after.genus != before.genus)
    return "genus " + (after.genus ? n(*after.genus) : std::string("?"));
  if (after.degenerate > before.degenerate) return n(after.degenerate) + " degenerate triangles";
  if (!(after.volume > 0)) return "negative volume";
  if (before.thick_inside && after.thick_inside && *after.thick_inside < *before.thick_inside)
    return n(*before.thick_inside - *after.thick_inside) + " more thick nodes outside";
  if (before.nodes_inside && after.nodes_inside && *after.nodes_inside < *before.nodes_inside)
    return n(*before.nodes_inside - *after.nodes_inside) + " more nodes outside";
  if (before.fidelity_p95 && after.fidelity_p95 &&
      *after.fidelity_p95 > std::max(*before.fidelity_p95, before.fidelity_tolerance))
    return "fidelity p95 " + n(*after.fidelity_p95);
  if (after.pairs > before.pairs) return n(after.pairs) + " self-intersecting pairs";
  return {};
}

std::string refuse(const MeshFigures& before, const MeshFigures& after, const KeepRule& rule) {
  std::string why = worse(before, after, rule);
  if (!why.empty()) return why;
  const bool more_inside = (before.thick_inside && after.thick_inside && *after.thick_inside > *before.thick_inside) ||
                           (before.nodes_inside && after.nodes_inside && *after.nodes_inside > *before.nodes_inside);
  if (after.pairs >= before.pairs && !more_inside) return "no fewer pairs and no more nodes inside";
  return {};
}

}  // namespace sm
