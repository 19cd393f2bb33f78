#include "batch/thumbnail.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <mutex>
#include <vector>

#include <stb/stb_image_write.h>

#include "core/errors.h"

namespace sm {
namespace {

void append(void* context, void* data, int size) {
  static_cast<std::string*>(context)->append(static_cast<const char*>(data), static_cast<std::size_t>(size));
}

}  // namespace

std::string render_thumbnail_png(const Mesh& mesh, UpAxis up, const ThumbnailParams& p) {
  if (p.size < 8 || p.size > 4096 || p.supersample < 1 || p.supersample > 4) {
    throw InvalidInputError("thumbnail: size must be 8..4096 and supersample 1..4");
  }
  const int n = p.size * p.supersample;
  // View frame: `right` and `upv` span the picture, `toward` points at the viewer.
  const double az = p.azimuth_degrees * M_PI / 180.0, el = p.elevation_degrees * M_PI / 180.0;
  const dvec3 world_up = up == UpAxis::z ? dvec3(0, 0, 1) : dvec3(0, 1, 0);
  const dvec3 east = up == UpAxis::z ? dvec3(1, 0, 0) : dvec3(1, 0, 0);
  const dvec3 north = glm::cross(world_up, east);  // z-up: +y; y-up: -z
  const dvec3 toward = std::cos(el) * (-std::sin(az) * east - std::cos(az) * north) + std::sin(el) * world_up;
  const dvec3 right = glm::normalize(glm::cross(world_up, toward));
  const dvec3 upv = glm::cross(toward, right);
  const dvec3 light = glm::normalize(toward + 0.6 * upv + 0.4 * right);

  // Project every vertex relative to the bounding-box centre (georeferenced meshes keep precision).
  dvec3 lo(std::numeric_limits<double>::max()), hi(-std::numeric_limits<double>::max());
  for (const dvec3& v : mesh.positions) {
    lo = glm::min(lo, v);
    hi = glm::max(hi, v);
  }
  const dvec3 centre = mesh.positions.empty() ? dvec3(0.0) : 0.5 * (lo + hi);
  std::vector<dvec3> q(mesh.positions.size());
  double u0 = 0, u1 = 0, v0 = 0, v1 = 0;
  for (std::size_t i = 0; i < q.size(); ++i) {
    const dvec3 d = mesh.positions[i] - centre;
    q[i] = dvec3(glm::dot(d, right), glm::dot(d, upv), glm::dot(d, toward));
    if (!std::isfinite(q[i].x) || !std::isfinite(q[i].y) || !std::isfinite(q[i].z)) q[i] = dvec3(0.0);
    u0 = std::min(u0, q[i].x), u1 = std::max(u1, q[i].x), v0 = std::min(v0, q[i].y), v1 = std::max(v1, q[i].y);
  }
  const double extent = std::max({u1 - u0, v1 - v0, 1e-12});
  const double scale = n * (1.0 - 2.0 * p.margin) / extent;
  const double cu = 0.5 * (u0 + u1), cv = 0.5 * (v0 + v1);
  for (dvec3& s : q) s = dvec3((s.x - cu) * scale + 0.5 * n, (cv - s.y) * scale + 0.5 * n, s.z);

  std::vector<float> depth(std::size_t(n) * std::size_t(n), -std::numeric_limits<float>::infinity());
  std::vector<float> shade(depth.size(), -1.0f);
  for (const auto& t : mesh.triangles) {
    if (t[0] >= q.size() || t[1] >= q.size() || t[2] >= q.size()) continue;
    const dvec3 &a = q[t[0]], &b = q[t[1]], &c = q[t[2]];
    const dvec3 normal = mesh.face_normal(t);
    const double len = glm::length(normal);
    if (!(len > 0)) continue;
    const double facing = glm::dot(normal / len, toward);
    if (facing <= 0) continue;  // back face: the mesh is closed, its front hides it
    const float lit = static_cast<float>(0.35 + 0.65 * std::max(0.0, glm::dot(normal / len, light)));
    const double area = (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
    if (area == 0) continue;
    const int x0 = std::max(0, int(std::floor(std::min({a.x, b.x, c.x}))));
    const int x1 = std::min(n - 1, int(std::ceil(std::max({a.x, b.x, c.x}))));
    const int y0 = std::max(0, int(std::floor(std::min({a.y, b.y, c.y}))));
    const int y1 = std::min(n - 1, int(std::ceil(std::max({a.y, b.y, c.y}))));
    for (int y = y0; y <= y1; ++y) {
      for (int x = x0; x <= x1; ++x) {
        const double px = x + 0.5, py = y + 0.5;
        const double w0 = ((b.x - px) * (c.y - py) - (b.y - py) * (c.x - px)) / area;
        const double w1 = ((c.x - px) * (a.y - py) - (c.y - py) * (a.x - px)) / area;
        const double w2 = 1.0 - w0 - w1;
        if (w0 < 0 || w1 < 0 || w2 < 0) continue;
        const float z = static_cast<float>(w0 * a.z + w1 * b.z + w2 * c.z);
        const std::size_t k = std::size_t(y) * std::size_t(n) + std::size_t(x);
        if (z > depth[k]) {
          depth[k] = z;
          shade[k] = lit;
        }
      }
    }
  }
  // Bark grey-brown on white, averaged over the supersamples.
  const int s = p.supersample, w = p.size;
  std::vector<unsigned char> rgb(std::size_t(w) * std::size_t(w) * 3);
  const float bark[3] = {150.0f, 118.0f, 90.0f};
  for (int y = 0; y < w; ++y) {
    for (int x = 0; x < w; ++x) {
      float sum[3] = {0, 0, 0};
      for (int dy = 0; dy < s; ++dy) {
        for (int dx = 0; dx < s; ++dx) {
          const float l = shade[std::size_t(y * s + dy) * std::size_t(n) + std::size_t(x * s + dx)];
          for (int c = 0; c < 3; ++c) sum[c] += l < 0 ? 255.0f : std::min(255.0f, bark[c] * l * 1.4f);
        }
      }
      for (int c = 0; c < 3; ++c) {
        rgb[(std::size_t(y) * std::size_t(w) + std::size_t(x)) * 3 + std::size_t(c)] =
            static_cast<unsigned char>(std::lround(sum[c] / float(s * s)));
      }
    }
  }
  std::string png;
  // stb's PNG writer is deterministic for a fixed compression level, a global of the library:
  // set once, before any thread encodes.
  static std::once_flag level;
  std::call_once(level, [] { stbi_write_png_compression_level = 8; });
  if (!stbi_write_png_to_func(append, &png, w, w, 3, rgb.data(), w * 3)) {
    throw InvalidInputError("thumbnail: PNG encoding failed");
  }
  return png;
}

}  // namespace sm
