#pragma once
/// The orbit camera and node picking: pure math, no window.
///
/// The camera orbits a target point at a distance; yaw turns around the scene's up axis,
/// pitch lifts the eye above the horizon. Mouse motions are given in pixels of a viewport of
/// a given height, so rotation and panning feel the same at any window size.

#include <optional>
#include <string>

#include <glm/glm.hpp>

#include "core/ids.h"
#include "skeleton/skeleton.h"
#include "viewer/scene.h"

namespace sm::viewer {

class OrbitCamera {
 public:
  glm::dvec3 target{0.0};  ///< orbit centre (metres, scene-local coordinates)
  double distance = 1.0;   ///< eye-to-target distance (metres), > 0
  double yaw = 0.6;        ///< radians around the up axis (0: eye on +x)
  double pitch = 0.25;     ///< radians above the horizon, clamped to (-pi/2, pi/2)
  double fov_y = 0.7;      ///< vertical field of view (radians)
  UpAxis up = UpAxis::z;   ///< which local axis is up

  /// Eye position (local coordinates).
  [[nodiscard]] glm::dvec3 eye() const;
  /// Unit up vector of the scene (z or y).
  [[nodiscard]] glm::dvec3 up_vector() const;
  /// World-to-view matrix (right-handed, OpenGL conventions).
  [[nodiscard]] glm::mat4 view() const;
  /// Perspective projection for the aspect ratio width / height; near and far planes follow
  /// the distance and `scene_radius` so the whole scene fits the depth range.
  [[nodiscard]] glm::mat4 projection(double aspect, double scene_radius) const;

  /// Turns the camera by a mouse drag of (dx, dy) pixels in a viewport `height` pixels tall:
  /// a drag across the full height turns by about 180 degrees.
  void rotate(double dx, double dy, double height);
  /// Moves target and eye in the view plane so the point under the mouse follows it.
  void pan(double dx, double dy, double height);
  /// Zooms by `steps` wheel steps (positive: closer); each step scales the distance by 0.85.
  void zoom(double steps);
  /// Centres on `b` (local bounds) at the distance where its bounding sphere fills the view
  /// (for the aspect ratio), times `scale` (1: frame all). Keeps yaw and pitch.
  void frame(const Bounds& b, double aspect, double scale = 1.0);
};

/// A camera placement, parsed from `--camera`: comma-separated key=value pairs, all optional:
/// `yaw=DEG` (azimuth, degrees), `pitch=DEG` (elevation, degrees), `dist=F` (distance
/// relative to the framed distance; 0.5 = twice as close), `node=N` (frame node N's subtree
/// instead of everything), `around=K` (with node: frame a ball of K times the node's radius
/// around it instead of its subtree, for close-ups of a fork), `fov=DEG`.
/// Example: `--camera yaw=30,pitch=15,node=12,around=6`.
struct CameraSpec {
  std::optional<double> yaw_degrees;
  std::optional<double> pitch_degrees;
  std::optional<double> fov_degrees;
  double distance_scale = 1.0;
  std::optional<std::uint32_t> node;
  std::optional<double> around;  ///< radius multiple (> 0)
};
/// Parses the spec above; throws UsageError naming the bad key or value.
CameraSpec parse_camera_spec(const std::string& text);

/// Node under the mouse: projects every node with `view_proj` (scene-local coordinates, see
/// Scene::origin) into a viewport of width × height pixels (origin top-left, y down) and
/// returns the one whose centre is nearest to `mouse` within max(max_pixels, its projected
/// radius); among nodes at the same screen distance the one nearest the eye wins. Nodes
/// behind the eye are ignored. std::nullopt when none is close enough.
std::optional<NodeId> pick_node(const Skeleton& s, const glm::dvec3& origin, const glm::mat4& view_proj,
                                const glm::dvec2& mouse, int width, int height, double max_pixels = 8.0);

/// Projects a local point to pixels (origin top-left). std::nullopt when behind the eye.
std::optional<glm::dvec3> project_to_pixels(const glm::dvec3& local, const glm::mat4& view_proj, int width, int height);

}  // namespace sm::viewer
