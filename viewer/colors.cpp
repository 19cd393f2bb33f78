#include "viewer/colors.h"

#include <algorithm>
#include <cmath>

namespace sm::viewer {

Rgba8 hsv(double h, double s, double v, std::uint8_t alpha) {
  h = h - std::floor(h);
  const double c = v * s;
  const double hp = h * 6.0;
  const double x = c * (1.0 - std::fabs(std::fmod(hp, 2.0) - 1.0));
  double r = 0, g = 0, b = 0;
  switch (static_cast<int>(hp) % 6) {
    case 0:
      r = c, g = x;
      break;
    case 1:
      r = x, g = c;
      break;
    case 2:
      g = c, b = x;
      break;
    case 3:
      g = x, b = c;
      break;
    case 4:
      r = x, b = c;
      break;
    default:
      r = c, b = x;
      break;
  }
  const double m = v - c;
  auto u8 = [](double t) { return static_cast<std::uint8_t>(std::clamp(std::lround(t * 255.0), 0L, 255L)); };
  return {u8(r + m), u8(g + m), u8(b + m), alpha};
}

Rgba8 key_color(std::uint64_t key) {
  // splitmix64 finaliser: consecutive keys land far apart, then the golden-ratio hue keeps
  // the colours spread evenly around the wheel. Saturation and value vary a little with
  // other bits so that keys with similar hues still differ.
  std::uint64_t z = key + 0x9e3779b97f4a7c15ull;
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  z ^= z >> 31;
  const double hue = static_cast<double>(z & 0xffffu) / 65536.0 * 0.618033988749895 * 7.0;
  const double sat = 0.55 + 0.4 * static_cast<double>((z >> 16) & 0xffu) / 255.0;
  const double val = 0.7 + 0.28 * static_cast<double>((z >> 24) & 0xffu) / 255.0;
  return hsv(hue, sat, val);
}

Rgba8 loop_color(LoopKind kind) {
  switch (kind) {
    case LoopKind::plain:
      return palette::loop_plain;
    case LoopKind::fused:
      return palette::loop_fused;
    case LoopKind::split:
      return palette::loop_split;
    case LoopKind::tip:
      return palette::loop_tip;
  }
  return palette::loop_plain;
}

std::vector<LegendEntry> legend_entries(const std::array<bool, kLayerCount>& visible, StrandColoring coloring,
                                        bool uv_checker) {
  auto on = [&](Layer l) { return visible[static_cast<std::size_t>(l)]; };
  const char* strand_text =
      coloring == StrandColoring::by_strand ? "one colour per strand" : "one colour per start tip";
  std::vector<LegendEntry> out;
  if (on(Layer::skeleton)) out.push_back({palette::skeleton_edge, "skeleton edge"});
  if (on(Layer::discs)) out.push_back({palette::disc, "node disc (radius)"});
  if (on(Layer::frames)) {
    out.push_back({palette::axis_tangent, "frame tangent"});
    out.push_back({palette::axis_normal, "frame normal (particle x)"});
    out.push_back({palette::axis_binormal, "frame binormal (particle y)"});
  }
  if (on(Layer::particles)) out.push_back({key_color(7), std::string("particles: ") + strand_text});
  if (on(Layer::strands)) out.push_back({key_color(11), std::string("strands: ") + strand_text});
  if (on(Layer::contours)) {
    out.push_back({palette::loop_plain, "contour loop"});
    out.push_back({palette::loop_fused, "fused loop (both bundles, below a split)"});
    out.push_back({palette::loop_split, "split slice (first loop of a child tube)"});
    out.push_back({palette::loop_tip, "tip loop"});
  }
  if (on(Layer::mesh)) {
    out.push_back({palette::bark, uv_checker ? "mesh: UV checker" : "mesh: smooth normals"});
    out.push_back({palette::back_face, "back faces (inside out, or seen through a hole)"});
  }
  if (on(Layer::wireframe)) out.push_back({palette::wireframe, "mesh edges"});
  if (on(Layer::normals)) out.push_back({palette::normal_line, "vertex normals"});
  if (on(Layer::problems)) {
    out.push_back({palette::problem_crossing, "self-intersecting triangle (checks)"});
    out.push_back({palette::problem_degenerate, "degenerate triangle (checks)"});
    out.push_back({palette::problem_edge, "open / non-manifold / misoriented edge (checks)"});
    out.push_back({palette::problem_node, "thick node outside the mesh (checks)"});
    out.push_back({palette::problem_fidelity, "vertex farther from the skeleton than the tolerance (checks)"});
  }
  return out;
}

}  // namespace sm::viewer
