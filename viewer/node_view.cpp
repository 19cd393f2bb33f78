// The node panel's data. The boundary is computed with the contours stage's own
// boundary_loop (contours/contours.h) on the node's particles, so what the panel shows is
// what the stage would select for a slice exactly at the node.

#include "viewer/node_view.h"

#include <cstdio>

#include "contours/contours.h"
#include "core/errors.h"

namespace sm::viewer {

NodeCloud node_cloud(const Skeleton& s, const ParticleField& f, NodeId node, StrandColoring coloring,
                     double concave_turn_degrees) {
  if (!node.valid() || node.idx() >= s.size()) {
    throw InvalidInputError("node " + std::to_string(node.value) + " does not exist");
  }
  if (f.node_count() != s.size()) {
    throw InvalidInputError("the particle field has " + std::to_string(f.node_count()) + " nodes, the skeleton " +
                            std::to_string(s.size()));
  }
  const std::size_t n = node.idx();
  NodeCloud c;
  c.node = node;
  c.radius = s.radius[n];
  c.disc_radius = n < f.disc_radius.size() ? f.disc_radius[n] : 0.0;
  c.particles = f.count(node);
  c.steps = n < f.steps.size() ? f.steps[n] : 0;
  c.children = s.child_count(node);
  c.source_id = n < s.source_id.size() ? s.source_id[n] : -1;
  if (n < f.new_begin.size()) {
    const std::uint32_t nb = std::min(f.new_begin[n], c.particles);
    c.new_strands = c.particles - nb;
    const NodeId c0 = s.children[n][0], c1 = s.children[n][1];
    c.from_main = c0.valid() ? std::min(f.count(c0), nb) : 0;
    c.from_lateral = c1.valid() ? std::min(f.count(c1), nb - c.from_main) : 0;
  }
  c.points.reserve(c.particles);
  for (std::uint32_t j = 0; j < c.particles; ++j) {
    const std::uint32_t p = f.global(node, j);
    c.points.push_back(f.position[p]);
    c.colors.push_back(particle_color(f, p, coloring));
    c.strands.push_back(f.strand[p]);
  }
  if (c.points.size() >= 3) {
    try {
      c.boundary = boundary_loop(c.points, concave_turn_degrees);
    } catch (const std::exception& e) {
      c.boundary_error = e.what();
    }
  }
  return c;
}

std::vector<std::string> node_summary(const Skeleton& s, const NodeCloud& c) {
  std::vector<std::string> out;
  char line[200];
  out.push_back(s.describe(c.node));
  std::snprintf(line, sizeof line, "radius %.4g m (particle disc %.4g m)", c.radius, c.disc_radius);
  out.emplace_back(line);
  const char* kind = c.children == 0 ? "tip" : c.children == 1 ? "chain" : "fork";
  std::snprintf(line, sizeof line, "%s, %u particles: %u from main, %u from lateral, %u new", kind, c.particles,
                c.from_main, c.from_lateral, c.new_strands);
  out.emplace_back(line);
  std::snprintf(line, sizeof line, "relaxation steps %u", c.steps);
  out.emplace_back(line);
  std::snprintf(line, sizeof line, "boundary loop: %zu of %u particles", c.boundary.size(), c.particles);
  out.emplace_back(line);
  if (!c.boundary_error.empty()) out.push_back("boundary failed: " + c.boundary_error);
  return out;
}

}  // namespace sm::viewer
