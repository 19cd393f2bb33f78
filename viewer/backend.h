#pragma once
/// Drawing behind an interface (polyscope's render engine is the model): the viewer's logic
/// talks to a `Backend`, the GL 3.3 backend (viewer/gl_backend.h) draws, and `MockBackend`
/// records the calls so tests check what would be drawn without a display.
///
/// `Renderer` sits between a Scene and a Backend: it uploads each layer's batches once,
/// re-uploads only what changed, releases what is gone, and draws the visible layers in a
/// fixed order (opaque mesh first, then lines and points over it).

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "viewer/scene.h"

namespace sm::viewer {

/// An uploaded batch. 0 is never a valid handle.
using BatchHandle = std::uint32_t;

/// How triangles are shaded.
enum class MeshShading : std::uint8_t {
  smooth,      ///< per-vertex normals, a head light and a little ambient light
  uv_checker,  ///< a checkerboard from the UVs (8 squares per unit), lit the same way
};

/// Per-draw state.
struct DrawParams {
  glm::mat4 view{1.0f};        ///< world-to-view (scene-local coordinates)
  glm::mat4 projection{1.0f};  ///< view-to-clip
  MeshShading shading = MeshShading::smooth;
  /// Pull lines and points towards the eye so they stay visible on the surface they lie on
  /// (wireframe over the mesh, contours on it): a depth bias in normalized depth units.
  bool depth_bias = false;
  /// Draw without depth test, over everything (the selection highlight).
  bool on_top = false;
};

/// An RGBA8 image, rows top to bottom (#width × #height × 4 bytes).
struct Image {
  int width = 0;
  int height = 0;
  std::vector<std::uint8_t> rgba;
};

class Backend {
 public:
  virtual ~Backend() = default;
  /// Uploads a batch; returns its handle. The batch is not referenced afterwards.
  virtual BatchHandle upload(const Batch& batch) = 0;
  /// Frees an uploaded batch; unknown handles are ignored.
  virtual void release(BatchHandle handle) = 0;
  /// Starts a frame of width × height pixels cleared to `clear`.
  virtual void begin_frame(int width, int height, Rgba8 clear) = 0;
  /// Draws an uploaded batch with the batch's own primitive, size and colours.
  virtual void draw(BatchHandle handle, const DrawParams& params) = 0;
  /// Ends the frame (nothing is presented; the window or screenshot code does that).
  virtual void end_frame() = 0;
  /// The pixels of the last frame, rows top to bottom.
  virtual Image read_pixels() = 0;
};

/// Records every call; uploads keep a copy of the batch's primitive, size and label.
class MockBackend final : public Backend {
 public:
  struct Uploaded {
    Primitive primitive = Primitive::lines;
    std::size_t vertices = 0;
    std::string label;
  };
  struct DrawCall {
    BatchHandle handle = 0;
    Primitive primitive = Primitive::lines;
    std::size_t vertices = 0;
    std::string label;
    DrawParams params;
  };

  BatchHandle upload(const Batch& batch) override;
  void release(BatchHandle handle) override;
  void begin_frame(int width, int height, Rgba8 clear) override;
  void draw(BatchHandle handle, const DrawParams& params) override;
  void end_frame() override;
  Image read_pixels() override;

  std::size_t uploads = 0;      ///< upload() calls so far
  std::size_t releases = 0;     ///< release() calls of live handles so far
  std::size_t frames = 0;       ///< end_frame() calls so far
  std::vector<DrawCall> draws;  ///< draw() calls of the current (or last) frame
  int width = 0, height = 0;
  Rgba8 clear;
  /// Live batches by handle.
  [[nodiscard]] std::size_t live() const;
  [[nodiscard]] const Uploaded* find(BatchHandle h) const;
  /// Total vertices drawn this frame whose label contains `text`.
  [[nodiscard]] std::size_t drawn_vertices(const std::string& text) const;

 private:
  std::vector<std::pair<BatchHandle, Uploaded>> live_;
  BatchHandle next_ = 1;
};

/// What the renderer draws besides the scene.
struct RenderOptions {
  std::array<bool, kLayerCount> visible{};  ///< per layer
  MeshShading shading = MeshShading::smooth;
  Rgba8 background{245, 245, 242, 255};
};

/// Keeps a Scene uploaded on a Backend and draws it.
class Renderer {
 public:
  explicit Renderer(Backend& backend) : backend_(backend) {}
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  /// Replaces the scene: every layer's old batches are released and the new ones uploaded
  /// lazily (at the next draw of a visible layer, so hidden layers of a huge tree cost no GPU
  /// memory until shown).
  void set_scene(Scene scene);
  /// Replaces one layer's batches (e.g. after the strand colouring changed).
  void set_layer(Layer layer, std::vector<Batch> batches);
  /// Sets the overlay batch (the selection highlight); an empty batch removes it.
  void set_overlay(Batch batch);
  /// Draws one frame of width × height pixels.
  void draw(int width, int height, const glm::mat4& view, const glm::mat4& projection, const RenderOptions& options);
  /// Releases everything uploaded (before the backend goes away).
  void clear();

  [[nodiscard]] const Scene& scene() const { return scene_; }

 private:
  struct Slot {
    std::vector<BatchHandle> handles;  // parallel to the layer's batches once uploaded
    bool uploaded = false;
  };
  void release_slot(Slot& slot);
  void ensure_uploaded(Layer layer);

  Backend& backend_;
  Scene scene_;
  std::array<Slot, kLayerCount> slots_{};
  Batch overlay_;
  BatchHandle overlay_handle_ = 0;
  bool overlay_dirty_ = false;
};

}  // namespace sm::viewer
