#include "skeleton/frames.h"

namespace sm {

dvec3 node_tangent(const Skeleton& s, NodeId n) {
  const std::size_t i = n.idx();
  const NodeId p = s.parent[i];
  const NodeId c = s.children[i][0];
  const dvec3 up(0, 0, 1);
  if (!p.valid()) {
    return c.valid() ? normalize_or(s.position[c.idx()] - s.position[i], up) : up;
  }
  const dvec3 in = normalize_or(s.position[i] - s.position[p.idx()], up);
  if (!c.valid()) return in;
  const dvec3 out = normalize_or(s.position[c.idx()] - s.position[i], in);
  // Opposite (or nearly) directions: the bisector is ill-defined; keep the incoming one.
  return normalize_or(in + out, in);
}

void compute_frames(Skeleton& s) {
  s.frame.resize(s.size());
  if (s.empty()) return;
  {
    const dvec3 t = node_tangent(s, Skeleton::root());
    const dvec3 x(1, 0, 0);
    Frame f;
    f.tangent = t;
    f.normal = normalize_or(x - t * glm::dot(x, t), any_perpendicular(t));
    f.binormal = glm::cross(t, f.normal);
    s.frame[0] = f;
  }
  // parent[i] < i: a forward sweep transports every frame from its parent's.
  for (std::size_t i = 1; i < s.size(); ++i) {
    s.frame[i] = transport_frame(s.frame[s.parent[i].idx()], node_tangent(s, NodeId(i)));
  }
}

}  // namespace sm
