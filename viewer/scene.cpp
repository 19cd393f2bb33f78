// Scene building: stage results to coloured batches. Everything is plain CPU work so the
// viewer's logic is tested without a display (polyscope's mock-backend approach).

#include "viewer/scene.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <unordered_set>

#include "viewer/colors.h"

namespace sm::viewer {

namespace {

constexpr const char* kLayerNames[kLayerCount] = {"skeleton", "discs", "frames",    "particles", "strands",
                                                  "contours", "mesh",  "wireframe", "normals",   "problems"};

glm::vec3 local(const glm::dvec3& p, const glm::dvec3& origin) {
  return glm::vec3(p - origin);
}

void add_line(Batch& b, const glm::vec3& p, const glm::vec3& q, Rgba8 c) {
  b.positions.push_back(p);
  b.positions.push_back(q);
  b.colors.push_back(c);
  b.colors.push_back(c);
}

void add_circle(Batch& b, const glm::dvec3& center, const Frame& f, double r, int segments, Rgba8 c,
                const glm::dvec3& origin) {
  const int n = std::max(segments, 3);
  glm::dvec3 prev = center + f.to_world({r, 0.0});
  for (int k = 1; k <= n; ++k) {
    const double a = 2.0 * std::numbers::pi * k / n;
    const glm::dvec3 cur = center + f.to_world({r * std::cos(a), r * std::sin(a)});
    add_line(b, local(prev, origin), local(cur, origin), c);
    prev = cur;
  }
}

glm::dvec3 particle_point(const Skeleton& s, const ParticleField& f, const StrandSet* strands, NodeId n,
                          std::uint32_t p) {
  if (strands && p < strands->point.size()) return strands->point[p];
  return s.position[n.idx()] + s.frame[n.idx()].to_world(f.position[p]);
}

}  // namespace

Rgba8 particle_color(const ParticleField& f, std::uint32_t p, StrandColoring coloring) {
  const StrandId s = f.strand[p];
  if (!s.valid()) return palette::skeleton_edge;
  if (coloring == StrandColoring::by_tip && s.idx() < f.strand_start.size()) {
    // Offset the key so tip colours differ from strand colours of the same number.
    return key_color(0x7100000000ull + f.strand_start[s.idx()].value);
  }
  return key_color(s.value);
}

const char* layer_name(Layer layer) {
  const auto i = static_cast<std::size_t>(layer);
  return i < kLayerCount ? kLayerNames[i] : "?";
}

std::optional<Layer> layer_from_name(const std::string& name) {
  for (std::size_t i = 0; i < kLayerCount; ++i) {
    if (name == kLayerNames[i]) return static_cast<Layer>(i);
  }
  return std::nullopt;
}

std::size_t Scene::vertex_count(Layer l) const {
  std::size_t n = 0;
  for (const auto& b : layer(l)) n += b.vertex_count();
  return n;
}

Bounds world_bounds(const StageView& view) {
  Bounds b;
  if (view.skeleton) {
    for (std::size_t i = 0; i < view.skeleton->size(); ++i)
      b.add_sphere(view.skeleton->position[i], view.skeleton->radius[i]);
  }
  if (view.mesh) {
    for (const auto& p : view.mesh->positions) {
      if (std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z)) b.add(p);
    }
  }
  if (b.empty() && view.contours) {
    for (const auto& p : view.contours->point) b.add(p);
  }
  return b;
}

Bounds subtree_bounds(const Skeleton& s, NodeId node) {
  Bounds b;
  if (!node.valid() || node.idx() >= s.size()) return b;
  // parent[i] < i: one forward pass marks the subtree without recursion.
  std::vector<char> in(s.size(), 0);
  in[node.idx()] = 1;
  b.add_sphere(s.position[node.idx()], s.radius[node.idx()]);
  for (std::size_t i = node.idx() + 1; i < s.size(); ++i) {
    const NodeId p = s.parent[i];
    if (p.valid() && in[p.idx()]) {
      in[i] = 1;
      b.add_sphere(s.position[i], s.radius[i]);
    }
  }
  return b;
}

std::vector<Batch> skeleton_batches(const Skeleton& s, const glm::dvec3& origin) {
  Batch b;
  b.primitive = Primitive::lines;
  b.line_width = 2.0f;
  b.label = "skeleton edges";
  for (std::size_t i = 1; i < s.size(); ++i) {
    const NodeId p = s.parent[i];
    if (!p.valid()) continue;
    add_line(b, local(s.position[p.idx()], origin), local(s.position[i], origin), palette::skeleton_edge);
  }
  Batch nodes;
  nodes.primitive = Primitive::points;
  nodes.point_size = 4.0f;
  nodes.label = "skeleton nodes";
  for (std::size_t i = 0; i < s.size(); ++i) {
    nodes.positions.push_back(local(s.position[i], origin));
    nodes.colors.push_back(s.is_fork(NodeId(i)) ? palette::axis_normal : palette::skeleton_edge);
  }
  std::vector<Batch> out;
  if (!b.empty()) out.push_back(std::move(b));
  if (!nodes.empty()) out.push_back(std::move(nodes));
  return out;
}

std::vector<Batch> disc_batches(const Skeleton& s, const glm::dvec3& origin, const SceneOptions& options) {
  Batch b;
  b.primitive = Primitive::lines;
  b.label = "node discs";
  for (std::size_t i = 0; i < s.size(); ++i) {
    add_circle(b, s.position[i], s.frame[i], s.radius[i], options.disc_segments, palette::disc, origin);
  }
  if (b.empty()) return {};
  return {std::move(b)};
}

std::vector<Batch> frame_batches(const Skeleton& s, const glm::dvec3& origin, const SceneOptions& options) {
  Batch b;
  b.primitive = Primitive::lines;
  b.line_width = 1.5f;
  b.label = "node frames";
  for (std::size_t i = 0; i < s.size(); ++i) {
    const double len = options.frame_length * s.radius[i];
    const glm::vec3 c = local(s.position[i], origin);
    const Frame& f = s.frame[i];
    add_line(b, c, local(s.position[i] + len * f.tangent, origin), palette::axis_tangent);
    add_line(b, c, local(s.position[i] + len * f.normal, origin), palette::axis_normal);
    add_line(b, c, local(s.position[i] + len * f.binormal, origin), palette::axis_binormal);
  }
  if (b.empty()) return {};
  return {std::move(b)};
}

std::vector<Batch> particle_batches(const Skeleton& s, const ParticleField& f, const StrandSet* strands,
                                    const glm::dvec3& origin, const SceneOptions& options) {
  Batch b;
  b.primitive = Primitive::points;
  b.point_size = options.particle_size;
  b.label = "particles";
  const std::size_t nodes = std::min(s.size(), f.node_count());
  b.positions.reserve(f.position.size());
  b.colors.reserve(f.position.size());
  for (std::size_t n = 0; n < nodes; ++n) {
    for (std::uint32_t p = f.node_begin[n]; p < f.node_begin[n + 1] && p < f.position.size(); ++p) {
      b.positions.push_back(local(particle_point(s, f, strands, NodeId(n), p), origin));
      b.colors.push_back(particle_color(f, p, options.strand_coloring));
    }
  }
  if (b.empty()) return {};
  return {std::move(b)};
}

std::vector<Batch> strand_batches(const Skeleton& s, const ParticleField& f, const StrandSet& strands,
                                  const glm::dvec3& origin, const SceneOptions& options) {
  // Each non-root particle (n, j) owns its strand's segment on n's edge (strands.h), so the
  // strands are drawn edge by edge. Large trees first lose curve samples, then strands.
  const std::size_t nodes = std::min(s.size(), f.node_count());
  std::size_t segments_total = 0;
  for (std::size_t n = 1; n < nodes; ++n) segments_total += f.node_begin[n + 1] - f.node_begin[n];
  int samples = std::max(1, options.strand_samples_per_edge);
  std::size_t budget = std::max<std::size_t>(options.max_strand_segments, 1);
  if (segments_total * static_cast<std::size_t>(samples) > budget) samples = 1;
  std::uint32_t stride = 1;
  if (segments_total > budget) stride = static_cast<std::uint32_t>((segments_total + budget - 1) / budget);

  Batch b;
  b.primitive = Primitive::lines;
  b.label = stride > 1 ? "strands (every " + std::to_string(stride) + "th)" : "strands";
  b.positions.reserve(2 * std::min(segments_total * static_cast<std::size_t>(samples), budget * 2));
  const bool have_curves = strands.point.size() == f.position.size();
  for (std::size_t n = 1; n < nodes; ++n) {
    const NodeId node(n);
    const NodeId parent = s.parent[n];
    if (!parent.valid()) continue;
    const std::uint32_t count = f.node_begin[n + 1] - f.node_begin[n];
    for (std::uint32_t j = 0; j < count; ++j) {
      const std::uint32_t p = f.node_begin[n] + j;
      const StrandId sid = f.strand[p];
      if (stride > 1 && sid.valid() && sid.value % stride != 0) continue;
      const Rgba8 c = particle_color(f, p, options.strand_coloring);
      if (!have_curves) {
        // Straight segment from the parent's particle to this one.
        const std::uint32_t pj = parent_index(s, f, node, j);
        add_line(b, local(particle_point(s, f, nullptr, parent, f.global(parent, pj)), origin),
                 local(particle_point(s, f, nullptr, node, p), origin), c);
        continue;
      }
      glm::vec3 prev = local(strands.evaluate(s, f, node, j, 0.0), origin);
      for (int k = 1; k <= samples; ++k) {
        const glm::vec3 cur = local(strands.evaluate(s, f, node, j, static_cast<double>(k) / samples), origin);
        add_line(b, prev, cur, c);
        prev = cur;
      }
    }
  }
  if (b.empty()) return {};
  return {std::move(b)};
}

std::vector<Batch> contour_batches(const ContourSet& c, const glm::dvec3& origin) {
  // Split loops go into their own, wider batch with a cross at their centre, so the place
  // where two bundles separate stands out (the usual suspect when a fork looks wrong).
  Batch loops;
  loops.primitive = Primitive::lines;
  loops.label = "contour loops";
  Batch splits;
  splits.primitive = Primitive::lines;
  splits.line_width = 3.0f;
  splits.label = "split slices";
  for (std::uint32_t l = 0; l < c.loop_count(); ++l) {
    const std::uint32_t begin = c.loop_begin[l], end = c.loop_begin[l + 1];
    if (end <= begin) continue;
    const LoopKind kind = c.loop_kind[l];
    Batch& b = kind == LoopKind::split ? splits : loops;
    const Rgba8 col = loop_color(kind);
    for (std::uint32_t v = begin; v < end; ++v) {
      const std::uint32_t w = v + 1 < end ? v + 1 : begin;
      add_line(b, local(c.point[v], origin), local(c.point[w], origin), col);
    }
    if (kind == LoopKind::split && l < c.loop_center.size()) {
      const Frame f = l < c.loop_frame.size() ? c.loop_frame[l] : Frame{};
      const double r = l < c.loop_radius.size() ? 0.35 * c.loop_radius[l] : 0.0;
      const glm::dvec3 ctr = c.loop_center[l];
      add_line(b, local(ctr - r * f.normal, origin), local(ctr + r * f.normal, origin), col);
      add_line(b, local(ctr - r * f.binormal, origin), local(ctr + r * f.binormal, origin), col);
    }
  }
  std::vector<Batch> out;
  if (!loops.empty()) out.push_back(std::move(loops));
  if (!splits.empty()) out.push_back(std::move(splits));
  return out;
}

std::vector<Batch> mesh_batches(const Mesh& m, const glm::dvec3& origin) {
  Batch b;
  b.primitive = Primitive::triangles;
  b.label = "mesh";
  const std::size_t nv = m.positions.size();
  const std::vector<glm::dvec3> computed =
      m.normals.size() == nv ? std::vector<glm::dvec3>{} : angle_weighted_normals(m);
  const std::vector<glm::dvec3>& normals = m.normals.size() == nv ? m.normals : computed;
  const bool uvs = m.corner_uvs.size() == m.triangles.size();
  const bool corner_normals = m.corner_normals.size() == m.triangles.size();  // smoothing groups
  b.positions.reserve(3 * m.triangles.size());
  b.normals.reserve(3 * m.triangles.size());
  b.colors.reserve(3 * m.triangles.size());
  if (uvs) b.uvs.reserve(3 * m.triangles.size());
  for (std::size_t t = 0; t < m.triangles.size(); ++t) {
    const auto& tri = m.triangles[t];
    if (tri[0] >= nv || tri[1] >= nv || tri[2] >= nv) continue;
    for (int k = 0; k < 3; ++k) {
      b.positions.push_back(local(m.positions[tri[k]], origin));
      b.normals.push_back(corner_normals ? m.corner_normals[t][k] : glm::vec3(normals[tri[k]]));
      b.colors.push_back(palette::bark);
      if (uvs) b.uvs.push_back(m.corner_uvs[t][k]);
    }
  }
  if (b.empty()) return {};
  return {std::move(b)};
}

std::vector<Batch> wireframe_batches(const Mesh& m, const glm::dvec3& origin) {
  Batch b;
  b.primitive = Primitive::lines;
  b.label = "mesh edges";
  const std::size_t nv = m.positions.size();
  std::unordered_set<std::uint64_t> seen;
  seen.reserve(3 * m.triangles.size());
  for (const auto& tri : m.triangles) {
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t a = tri[k], c = tri[(k + 1) % 3];
      if (a >= nv || c >= nv) continue;
      const std::uint64_t key = (std::uint64_t(std::min(a, c)) << 32) | std::max(a, c);
      if (!seen.insert(key).second) continue;
      add_line(b, local(m.positions[a], origin), local(m.positions[c], origin), palette::wireframe);
    }
  }
  if (b.empty()) return {};
  return {std::move(b)};
}

std::vector<Batch> normal_batches(const Mesh& m, const glm::dvec3& origin, const SceneOptions& options) {
  const std::size_t nv = m.positions.size();
  if (nv == 0 || m.triangles.empty()) return {};
  double edge_sum = 0;
  std::size_t edges = 0;
  for (const auto& tri : m.triangles) {
    for (int k = 0; k < 3; ++k) {
      if (tri[k] >= nv || tri[(k + 1) % 3] >= nv) continue;
      edge_sum += glm::length(m.positions[tri[k]] - m.positions[tri[(k + 1) % 3]]);
      ++edges;
    }
  }
  const double len = options.normal_length * (edges ? edge_sum / static_cast<double>(edges) : 1.0);
  const std::vector<glm::dvec3> normals = m.normals.size() == nv ? m.normals : angle_weighted_normals(m);
  std::vector<char> used(nv, 0);
  for (const auto& tri : m.triangles) {
    for (auto v : tri) {
      if (v < nv) used[v] = 1;
    }
  }
  Batch b;
  b.primitive = Primitive::lines;
  b.label = "vertex normals";
  for (std::size_t v = 0; v < nv; ++v) {
    if (!used[v]) continue;
    add_line(b, local(m.positions[v], origin), local(m.positions[v] + len * normals[v], origin), palette::normal_line);
  }
  if (b.empty()) return {};
  return {std::move(b)};
}

Batch selection_batch(const Skeleton& s, NodeId node, const glm::dvec3& origin, int segments) {
  Batch b;
  b.primitive = Primitive::lines;
  b.line_width = 3.0f;
  b.label = "selected node";
  if (!node.valid() || node.idx() >= s.size()) return b;
  const std::size_t n = node.idx();
  const Frame& f = s.frame[n];
  const double r = s.radius[n];
  add_circle(b, s.position[n], f, r, segments, palette::selection, origin);
  add_circle(b, s.position[n], f, 1.3 * r, segments, palette::selection, origin);
  const glm::dvec3 c = s.position[n];
  add_line(b, local(c - r * f.normal, origin), local(c + r * f.normal, origin), palette::selection);
  add_line(b, local(c - r * f.binormal, origin), local(c + r * f.binormal, origin), palette::selection);
  if (s.parent[n].valid())
    add_line(b, local(s.position[s.parent[n].idx()], origin), local(c, origin), palette::selection);
  return b;
}

std::vector<Batch> problem_batches(const Mesh& m, const Skeleton* s, const MeshCheckReport& report,
                                   const glm::dvec3& origin) {
  const std::size_t nv = m.positions.size();
  std::vector<Batch> out;
  // Triangles: filled (flat normals) and outlined, so a sliver inside the surface still shows.
  auto add_triangles = [&](const std::vector<std::uint32_t>& faces, Rgba8 color, const char* label) {
    Batch fill, outline;
    fill.primitive = Primitive::triangles;
    fill.label = label;
    outline.primitive = Primitive::lines;
    outline.line_width = 2.0f;
    outline.label = std::string(label) + " (outlines)";
    for (const std::uint32_t f : faces) {
      if (f >= m.triangles.size()) continue;
      const auto& t = m.triangles[f];
      if (t[0] >= nv || t[1] >= nv || t[2] >= nv) continue;
      const glm::dvec3 n = glm::cross(m.positions[t[1]] - m.positions[t[0]], m.positions[t[2]] - m.positions[t[0]]);
      const double len = glm::length(n);
      const glm::vec3 normal = len > 0 ? glm::vec3(n / len) : glm::vec3(0, 0, 1);
      for (int k = 0; k < 3; ++k) {
        fill.positions.push_back(local(m.positions[t[k]], origin));
        fill.normals.push_back(normal);
        fill.colors.push_back(color);
        add_line(outline, local(m.positions[t[k]], origin), local(m.positions[t[(k + 1) % 3]], origin), color);
      }
    }
    if (fill.empty()) return;
    out.push_back(std::move(fill));
    out.push_back(std::move(outline));
  };
  std::vector<std::uint32_t> crossing;
  for (const auto& [a, b] : report.self_intersection_examples) {
    crossing.push_back(a);
    crossing.push_back(b);
  }
  std::sort(crossing.begin(), crossing.end());
  crossing.erase(std::unique(crossing.begin(), crossing.end()), crossing.end());
  add_triangles(crossing, palette::problem_crossing, "self-intersecting triangles");
  add_triangles(report.degenerate_triangle_examples, palette::problem_degenerate, "degenerate triangles");

  Batch edges;
  edges.primitive = Primitive::lines;
  edges.line_width = 3.0f;
  edges.label = "boundary, non-manifold and misoriented edges";
  for (const auto* list :
       {&report.boundary_edge_examples, &report.nonmanifold_edge_examples, &report.misoriented_edge_examples}) {
    for (const auto& [a, b] : *list) {
      if (a < nv && b < nv)
        add_line(edges, local(m.positions[a], origin), local(m.positions[b], origin), palette::problem_edge);
    }
  }
  if (!edges.empty()) out.push_back(std::move(edges));

  Batch far;
  far.primitive = Primitive::points;
  far.point_size = 5.0f;
  far.label = "vertices beyond the fidelity tolerance";
  for (const std::uint32_t v : report.fidelity_outlier_examples) {
    if (v >= nv) continue;
    far.positions.push_back(local(m.positions[v], origin));
    far.colors.push_back(palette::problem_fidelity);
  }
  if (!far.empty()) out.push_back(std::move(far));

  if (s) {
    Batch nodes;
    nodes.primitive = Primitive::points;
    nodes.point_size = 10.0f;
    nodes.label = "thick nodes outside the mesh";
    for (const std::uint32_t n : report.outside_node_examples) {
      if (n >= s->size()) continue;
      nodes.positions.push_back(local(s->position[n], origin));
      nodes.colors.push_back(palette::problem_node);
    }
    if (!nodes.empty()) out.push_back(std::move(nodes));
  }
  return out;
}

Scene build_scene(const StageView& view, const SceneOptions& options) {
  Scene scene;
  const Bounds wb = world_bounds(view);
  scene.origin = wb.center();
  if (!wb.empty()) {
    scene.bounds.lo = wb.lo - scene.origin;
    scene.bounds.hi = wb.hi - scene.origin;
  }
  const glm::dvec3 o = scene.origin;
  if (view.skeleton && !view.skeleton->empty()) {
    const Skeleton& s = *view.skeleton;
    scene.up_axis = s.up_axis;
    scene.layer(Layer::skeleton) = skeleton_batches(s, o);
    scene.layer(Layer::discs) = disc_batches(s, o, options);
    scene.layer(Layer::frames) = frame_batches(s, o, options);
    if (view.particles && view.particles->node_count() == s.size()) {
      const StrandSet* strands =
          view.strands && view.strands->point.size() == view.particles->position.size() ? view.strands : nullptr;
      scene.layer(Layer::particles) = particle_batches(s, *view.particles, strands, o, options);
      if (strands) scene.layer(Layer::strands) = strand_batches(s, *view.particles, *strands, o, options);
    }
  }
  if (view.contours) scene.layer(Layer::contours) = contour_batches(*view.contours, o);
  if (view.mesh && !view.mesh->empty()) {
    scene.layer(Layer::mesh) = mesh_batches(*view.mesh, o);
    scene.layer(Layer::wireframe) = wireframe_batches(*view.mesh, o);
    scene.layer(Layer::normals) = normal_batches(*view.mesh, o, options);
  }
  return scene;
}

}  // namespace sm::viewer
