#pragma once
/// The viewer's colours: one place, so the legend and the layers always agree.

#include <cstdint>
#include <string>
#include <vector>

#include "contours/contours.h"
#include "viewer/scene.h"

namespace sm::viewer {

/// A bright, saturated colour for an integer key (strand id, node id). Hues follow the golden
/// ratio over a hash of the key, so neighbouring ids get clearly different colours and the
/// same key always gets the same colour.
Rgba8 key_color(std::uint64_t key);

/// RGB from hue, saturation, value, all in [0, 1].
Rgba8 hsv(double h, double s, double v, std::uint8_t alpha = 255);

/// Colours of the fixed elements.
namespace palette {
inline constexpr Rgba8 background{245, 245, 242, 255};
inline constexpr Rgba8 skeleton_edge{70, 55, 40, 255};
inline constexpr Rgba8 disc{150, 110, 70, 255};
inline constexpr Rgba8 axis_tangent{40, 90, 230, 255};
inline constexpr Rgba8 axis_normal{220, 50, 40, 255};
inline constexpr Rgba8 axis_binormal{40, 170, 60, 255};
inline constexpr Rgba8 bark{176, 148, 118, 255};
inline constexpr Rgba8 wireframe{45, 40, 35, 255};
inline constexpr Rgba8 back_face{200, 80, 70, 255};  ///< the mesh shader's tint of back faces
inline constexpr Rgba8 normal_line{30, 120, 220, 255};
inline constexpr Rgba8 selection{255, 0, 200, 255};
inline constexpr Rgba8 loop_plain{20, 140, 150, 255};
inline constexpr Rgba8 loop_fused{240, 140, 0, 255};
inline constexpr Rgba8 loop_split{225, 20, 40, 255};
inline constexpr Rgba8 loop_tip{110, 60, 200, 255};
inline constexpr Rgba8 problem_crossing{235, 0, 60, 255};    ///< self-intersecting triangles
inline constexpr Rgba8 problem_degenerate{255, 120, 0, 255};  ///< degenerate triangles
inline constexpr Rgba8 problem_edge{250, 200, 0, 255};        ///< boundary / non-manifold / misoriented edges
inline constexpr Rgba8 problem_node{0, 160, 255, 255};        ///< thick nodes outside the mesh
inline constexpr Rgba8 problem_fidelity{150, 40, 220, 255};   ///< vertices beyond the fidelity tolerance
}  // namespace palette

/// The colour of a contour loop of this kind.
Rgba8 loop_color(LoopKind kind);

/// One row of the legend: a colour swatch and what it means.
struct LegendEntry {
  Rgba8 color;
  std::string text;
};
/// The legend of the layers that are visible (`visible[layer]`), in layer order; strands and
/// particles get one row explaining the colouring instead of one per colour.
std::vector<LegendEntry> legend_entries(const std::array<bool, kLayerCount>& visible, StrandColoring coloring,
                                        bool uv_checker);

}  // namespace sm::viewer
