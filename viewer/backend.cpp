// The renderer (scene → backend bookkeeping) and the recording mock backend.

#include "viewer/backend.h"

#include <algorithm>

namespace sm::viewer {

// ---- MockBackend ----------------------------------------------------------------------

BatchHandle MockBackend::upload(const Batch& batch) {
  ++uploads;
  const BatchHandle h = next_++;
  live_.push_back({h, Uploaded{batch.primitive, batch.vertex_count(), batch.label}});
  return h;
}

void MockBackend::release(BatchHandle handle) {
  auto it = std::find_if(live_.begin(), live_.end(), [&](const auto& e) { return e.first == handle; });
  if (it == live_.end()) return;
  live_.erase(it);
  ++releases;
}

void MockBackend::begin_frame(int w, int h, Rgba8 c) {
  width = w;
  height = h;
  clear = c;
  draws.clear();
}

void MockBackend::draw(BatchHandle handle, const DrawParams& params) {
  const Uploaded* u = find(handle);
  if (!u) return;
  draws.push_back(DrawCall{handle, u->primitive, u->vertices, u->label, params});
}

void MockBackend::end_frame() {
  ++frames;
}

Image MockBackend::read_pixels() {
  // The mock draws nothing: the image is the clear colour.
  Image img;
  img.width = width;
  img.height = height;
  img.rgba.resize(static_cast<std::size_t>(std::max(width, 0)) * static_cast<std::size_t>(std::max(height, 0)) * 4);
  for (std::size_t i = 0; i + 3 < img.rgba.size(); i += 4) {
    img.rgba[i] = clear.r;
    img.rgba[i + 1] = clear.g;
    img.rgba[i + 2] = clear.b;
    img.rgba[i + 3] = clear.a;
  }
  return img;
}

std::size_t MockBackend::live() const {
  return live_.size();
}

const MockBackend::Uploaded* MockBackend::find(BatchHandle h) const {
  for (const auto& e : live_) {
    if (e.first == h) return &e.second;
  }
  return nullptr;
}

std::size_t MockBackend::drawn_vertices(const std::string& text) const {
  std::size_t n = 0;
  for (const auto& d : draws) {
    if (d.label.find(text) != std::string::npos) n += d.vertices;
  }
  return n;
}

// ---- Renderer -------------------------------------------------------------------------

Renderer::~Renderer() {
  clear();
}

void Renderer::release_slot(Slot& slot) {
  for (BatchHandle h : slot.handles) backend_.release(h);
  slot.handles.clear();
  slot.uploaded = false;
}

void Renderer::clear() {
  for (auto& s : slots_) release_slot(s);
  if (overlay_handle_) backend_.release(overlay_handle_);
  overlay_handle_ = 0;
  overlay_dirty_ = !overlay_.empty();
}

void Renderer::set_scene(Scene scene) {
  for (auto& s : slots_) release_slot(s);
  scene_ = std::move(scene);
}

void Renderer::set_layer(Layer layer, std::vector<Batch> batches) {
  release_slot(slots_[static_cast<std::size_t>(layer)]);
  scene_.layer(layer) = std::move(batches);
}

void Renderer::set_overlay(Batch batch) {
  overlay_ = std::move(batch);
  overlay_dirty_ = true;
}

void Renderer::ensure_uploaded(Layer layer) {
  Slot& slot = slots_[static_cast<std::size_t>(layer)];
  if (slot.uploaded) return;
  for (const Batch& b : scene_.layer(layer)) slot.handles.push_back(backend_.upload(b));
  slot.uploaded = true;
}

void Renderer::draw(int width, int height, const glm::mat4& view, const glm::mat4& projection,
                    const RenderOptions& options) {
  backend_.begin_frame(width, height, options.background);
  DrawParams params;
  params.view = view;
  params.projection = projection;
  params.shading = options.shading;
  // Opaque surfaces first, then everything that lies on them with a depth bias so that
  // wireframe and contours drawn exactly on the surface are not hidden by it.
  static constexpr Layer kOrder[] = {Layer::mesh,    Layer::skeleton,  Layer::discs,    Layer::frames,
                                     Layer::strands, Layer::particles, Layer::contours, Layer::wireframe,
                                     Layer::normals, Layer::problems};
  const bool mesh_visible = options.visible[static_cast<std::size_t>(Layer::mesh)];
  for (Layer l : kOrder) {
    if (!options.visible[static_cast<std::size_t>(l)]) continue;
    ensure_uploaded(l);
    params.depth_bias = l != Layer::mesh && mesh_visible;
    // Problems often lie inside the surface (a fold, a node outside a thin twig's wall):
    // drawn over everything, like the selection.
    params.on_top = l == Layer::problems;
    for (BatchHandle h : slots_[static_cast<std::size_t>(l)].handles) backend_.draw(h, params);
  }
  if (overlay_dirty_) {
    if (overlay_handle_) backend_.release(overlay_handle_);
    overlay_handle_ = overlay_.empty() ? 0 : backend_.upload(overlay_);
    overlay_dirty_ = false;
  }
  if (overlay_handle_) {
    params.depth_bias = true;
    params.on_top = true;
    backend_.draw(overlay_handle_, params);
  }
  backend_.end_frame();
}

}  // namespace sm::viewer
