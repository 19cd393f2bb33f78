#pragma once
/// The OpenGL 3.3 core backend, and an offscreen render target for screenshots.
///
/// Requires a current OpenGL 3.3 core context (viewer/window.h makes one with GLFW). Entry
/// points come from libGL directly (GL_GLEXT_PROTOTYPES), which Mesa exports on Linux.

#include <cstdint>
#include <unordered_map>

#include "viewer/backend.h"

namespace sm::viewer {

class GlBackend final : public Backend {
 public:
  /// Compiles the shaders. Throws InternalError with the GL log when they do not compile.
  GlBackend();
  ~GlBackend() override;
  GlBackend(const GlBackend&) = delete;
  GlBackend& operator=(const GlBackend&) = delete;

  BatchHandle upload(const Batch& batch) override;
  void release(BatchHandle handle) override;
  void begin_frame(int width, int height, Rgba8 clear) override;
  void draw(BatchHandle handle, const DrawParams& params) override;
  void end_frame() override;
  /// Reads the currently bound read framebuffer (rows flipped to top-first).
  Image read_pixels() override;

 private:
  struct GpuBatch {
    std::uint32_t vao = 0;
    std::uint32_t buffers[4] = {0, 0, 0, 0};  // positions, colours, normals, uvs
    std::int32_t count = 0;
    Primitive primitive = Primitive::lines;
    float point_size = 1;
    float line_width = 1;
  };
  std::uint32_t line_program_ = 0;
  std::uint32_t mesh_program_ = 0;
  std::unordered_map<BatchHandle, GpuBatch> batches_;
  BatchHandle next_ = 1;
  int width_ = 0, height_ = 0;
  float max_line_width_ = 1;
};

/// A multisampled framebuffer of a fixed size with a resolve target, for rendering
/// screenshots independently of any window's size.
class OffscreenTarget {
 public:
  /// Throws InternalError when the framebuffer is incomplete.
  OffscreenTarget(int width, int height, int samples = 4);
  ~OffscreenTarget();
  OffscreenTarget(const OffscreenTarget&) = delete;
  OffscreenTarget& operator=(const OffscreenTarget&) = delete;

  /// Binds the multisampled framebuffer for drawing.
  void bind();
  /// Resolves the samples and binds the resolved framebuffer for reading (read_pixels).
  void resolve();

 private:
  int width_, height_;
  std::uint32_t msaa_fbo_ = 0, msaa_color_ = 0, msaa_depth_ = 0;
  std::uint32_t fbo_ = 0, color_ = 0;
};

}  // namespace sm::viewer
