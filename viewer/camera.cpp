// Orbit camera, camera specs for screenshots, and CPU picking of skeleton nodes.
//
// Picking runs on the CPU against the projected node centres rather than through an ID
// buffer: it needs no GPU round-trip, works the same in the mock backend (tests) and the GL
// one, and a tree has few enough nodes (tens of thousands) for a linear scan per click.

#include "viewer/camera.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <limits>
#include <numbers>

#include <glm/gtc/matrix_transform.hpp>

#include "core/errors.h"

namespace sm::viewer {

namespace {

constexpr double kMaxPitch = 1.55;  // just below 90 degrees: lookAt degenerates at the pole

glm::dvec3 up_of(UpAxis a) {
  return a == UpAxis::y ? glm::dvec3(0, 1, 0) : glm::dvec3(0, 0, 1);
}

// The horizontal direction at yaw 0 and the one 90 degrees further, for each up axis; both
// bases are right-handed with the up vector (x, y, z) and (z, x, y).
void horizontal_axes(UpAxis a, glm::dvec3& e0, glm::dvec3& e1) {
  if (a == UpAxis::y) {
    e0 = {0, 0, 1};
    e1 = {1, 0, 0};
  } else {
    e0 = {1, 0, 0};
    e1 = {0, 1, 0};
  }
}

double parse_number(const std::string& key, const std::string& value) {
  double v = 0;
  const char* b = value.data();
  const char* e = b + value.size();
  auto [ptr, ec] = std::from_chars(b, e, v);
  if (ec != std::errc{} || ptr != e || !std::isfinite(v)) {
    throw UsageError("--camera: " + key + "=" + value + " is not a number");
  }
  return v;
}

}  // namespace

glm::dvec3 OrbitCamera::up_vector() const {
  return up_of(up);
}

glm::dvec3 OrbitCamera::eye() const {
  glm::dvec3 e0, e1;
  horizontal_axes(up, e0, e1);
  const glm::dvec3 dir = std::cos(pitch) * (std::cos(yaw) * e0 + std::sin(yaw) * e1) + std::sin(pitch) * up_vector();
  return target + distance * dir;
}

glm::mat4 OrbitCamera::view() const {
  return glm::mat4(glm::lookAt(eye(), target, up_vector()));
}

glm::mat4 OrbitCamera::projection(double aspect, double scene_radius) const {
  // Near plane: a small fraction of the distance, but never so small that depth precision is
  // lost; far plane: beyond the far side of the scene from wherever the eye is.
  const double eye_to_origin = glm::length(eye());
  const double far_plane = std::max(eye_to_origin + 2.0 * std::max(scene_radius, 1e-6), 2.0 * distance);
  const double near_plane = std::max(distance * 1e-3, far_plane * 1e-5);
  return glm::mat4(glm::perspective(fov_y, std::max(aspect, 1e-6), near_plane, far_plane));
}

void OrbitCamera::rotate(double dx, double dy, double height) {
  const double h = std::max(height, 1.0);
  yaw -= dx / h * std::numbers::pi;
  pitch = std::clamp(pitch + dy / h * std::numbers::pi, -kMaxPitch, kMaxPitch);
}

void OrbitCamera::pan(double dx, double dy, double height) {
  const double h = std::max(height, 1.0);
  // World size of one pixel at the target's depth.
  const double pixel = 2.0 * distance * std::tan(0.5 * fov_y) / h;
  const glm::dvec3 forward = glm::normalize(target - eye());
  const glm::dvec3 right = glm::normalize(glm::cross(forward, up_vector()));
  const glm::dvec3 cam_up = glm::cross(right, forward);
  target += (-dx * right + dy * cam_up) * pixel;
}

void OrbitCamera::zoom(double steps) {
  distance = std::clamp(distance * std::pow(0.85, steps), 1e-6, 1e9);
}

void OrbitCamera::frame(const Bounds& b, double aspect, double scale) {
  if (b.empty()) return;
  target = b.center();
  // Fit the eight corners of the box for the current viewing direction rather than its
  // bounding sphere: trees are tall and thin, and a sphere would leave them small in the
  // middle of the picture. A corner at lateral offsets (x, y) and depth offset z from the
  // centre is inside the frustum when |x| <= tan(half_h) (d + z) and likewise for y.
  const double tan_v = std::tan(0.5 * fov_y);
  const double tan_h = tan_v * std::max(aspect, 1e-6);
  distance = 1.0;
  const glm::dvec3 forward = glm::normalize(target - eye());
  const glm::dvec3 right = glm::normalize(glm::cross(forward, up_vector()));
  const glm::dvec3 cam_up = glm::cross(right, forward);
  double d = 1e-6;
  for (int c = 0; c < 8; ++c) {
    const glm::dvec3 corner(c & 1 ? b.hi.x : b.lo.x, c & 2 ? b.hi.y : b.lo.y, c & 4 ? b.hi.z : b.lo.z);
    const glm::dvec3 q = corner - target;
    const double z = glm::dot(q, forward);
    d = std::max(d, std::fabs(glm::dot(q, right)) / tan_h - z);
    d = std::max(d, std::fabs(glm::dot(q, cam_up)) / tan_v - z);
  }
  // A small margin, and never so close that the eye is inside the box.
  d = std::max(1.06 * d, 1.01 * b.radius());
  distance = d * (scale > 0 ? scale : 1.0);
}

CameraSpec parse_camera_spec(const std::string& text) {
  CameraSpec spec;
  std::size_t pos = 0;
  while (pos <= text.size()) {
    const std::size_t comma = std::min(text.find(',', pos), text.size());
    const std::string item = text.substr(pos, comma - pos);
    pos = comma + 1;
    if (item.empty()) {
      if (comma >= text.size()) break;
      continue;
    }
    const std::size_t eq = item.find('=');
    if (eq == std::string::npos) {
      throw UsageError("--camera: '" + item + "' is not key=value (keys: yaw, pitch, dist, node, around, fov)");
    }
    const std::string key = item.substr(0, eq), value = item.substr(eq + 1);
    const double v = parse_number(key, value);
    if (key == "yaw") {
      spec.yaw_degrees = v;
    } else if (key == "pitch") {
      if (v <= -90 || v >= 90) throw UsageError("--camera: pitch=" + value + " must be between -90 and 90 degrees");
      spec.pitch_degrees = v;
    } else if (key == "dist") {
      if (v <= 0) throw UsageError("--camera: dist=" + value + " must be > 0");
      spec.distance_scale = v;
    } else if (key == "fov") {
      if (v <= 1 || v >= 170) throw UsageError("--camera: fov=" + value + " must be between 1 and 170 degrees");
      spec.fov_degrees = v;
    } else if (key == "around") {
      if (v <= 0) throw UsageError("--camera: around=" + value + " must be > 0");
      spec.around = v;
    } else if (key == "node") {
      if (v < 0 || v != std::floor(v) || v > 4e9) throw UsageError("--camera: node=" + value + " is not a node index");
      spec.node = static_cast<std::uint32_t>(v);
    } else {
      throw UsageError("--camera: unknown key '" + key + "' (keys: yaw, pitch, dist, node, around, fov)");
    }
  }
  return spec;
}

std::optional<glm::dvec3> project_to_pixels(const glm::dvec3& local, const glm::mat4& view_proj, int width,
                                            int height) {
  const glm::dvec4 clip = glm::dmat4(view_proj) * glm::dvec4(local, 1.0);
  if (clip.w <= 1e-12) return std::nullopt;
  const glm::dvec3 ndc = glm::dvec3(clip) / clip.w;
  return glm::dvec3((ndc.x * 0.5 + 0.5) * width, (1.0 - (ndc.y * 0.5 + 0.5)) * height, clip.w);
}

std::optional<NodeId> pick_node(const Skeleton& s, const glm::dvec3& origin, const glm::mat4& view_proj,
                                const glm::dvec2& mouse, int width, int height, double max_pixels) {
  std::optional<NodeId> best;
  double best_d = std::numeric_limits<double>::infinity();
  double best_depth = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < s.size(); ++i) {
    const glm::dvec3 c = s.position[i] - origin;
    const auto p = project_to_pixels(c, view_proj, width, height);
    if (!p) continue;
    const double d = glm::length(glm::dvec2(p->x, p->y) - mouse);
    // Projected radius: the largest screen offset of the three axis-aligned radius offsets
    // (at least one of them is far from the view direction).
    double radius_px = 0;
    for (int axis = 0; axis < 3; ++axis) {
      glm::dvec3 q = c;
      q[axis] += s.radius[i];
      if (const auto pq = project_to_pixels(q, view_proj, width, height)) {
        radius_px = std::max(radius_px, glm::length(glm::dvec2(pq->x - p->x, pq->y - p->y)));
      }
    }
    if (d > std::max(max_pixels, radius_px)) continue;
    if (d < best_d - 1e-9 || (d <= best_d + 1e-9 && p->z < best_depth)) {
      best = NodeId(i);
      best_d = d;
      best_depth = p->z;
    }
  }
  return best;
}

}  // namespace sm::viewer
