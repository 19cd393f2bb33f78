// OpenGL 3.3 core drawing of the viewer's batches.
//
// Two small programs: one for lines and points (flat colour, round points), one for
// triangles (head-light shading with a little ambient, or a UV checkerboard). The mesh is
// drawn with a polygon offset so that wireframe, contour loops and strands that lie exactly
// on its surface stay visible (the usual hidden-line trick; contour points are mesh vertices).

#define GL_GLEXT_PROTOTYPES
#include "viewer/gl_backend.h"

#include <algorithm>
#include <string>
#include <vector>

#include <GL/gl.h>
#include <GL/glext.h>
#include <glm/gtc/type_ptr.hpp>

#include "core/errors.h"

namespace sm::viewer {

namespace {

const char* kLineVs = R"(#version 330 core
layout(location = 0) in vec3 a_pos;
layout(location = 1) in vec4 a_color;
uniform mat4 u_view;
uniform mat4 u_proj;
uniform float u_point_size;
uniform float u_depth_bias;
out vec4 v_color;
void main() {
  vec4 p = u_proj * (u_view * vec4(a_pos, 1.0));
  p.z -= u_depth_bias * p.w;
  gl_Position = p;
  gl_PointSize = u_point_size;
  v_color = a_color;
}
)";

const char* kLineFs = R"(#version 330 core
in vec4 v_color;
uniform int u_round;
out vec4 o_color;
void main() {
  if (u_round == 1) {
    vec2 d = gl_PointCoord * 2.0 - 1.0;
    if (dot(d, d) > 1.0) discard;
  }
  o_color = v_color;
}
)";

const char* kMeshVs = R"(#version 330 core
layout(location = 0) in vec3 a_pos;
layout(location = 1) in vec4 a_color;
layout(location = 2) in vec3 a_normal;
layout(location = 3) in vec2 a_uv;
uniform mat4 u_view;
uniform mat4 u_proj;
out vec3 v_pos;
out vec3 v_normal;
out vec2 v_uv;
out vec4 v_color;
void main() {
  vec4 pv = u_view * vec4(a_pos, 1.0);
  v_pos = pv.xyz;
  v_normal = mat3(u_view) * a_normal;
  v_uv = a_uv;
  v_color = a_color;
  gl_Position = u_proj * pv;
}
)";

const char* kMeshFs = R"(#version 330 core
in vec3 v_pos;
in vec3 v_normal;
in vec2 v_uv;
in vec4 v_color;
uniform int u_checker;
out vec4 o_color;
void main() {
  vec3 n = normalize(v_normal);
  if (!gl_FrontFacing) n = -n;
  vec3 l = normalize(-v_pos);          // head light at the eye
  float diffuse = max(dot(n, l), 0.0);
  vec3 h = l;                          // eye and light coincide
  float spec = pow(max(dot(n, h), 0.0), 40.0) * 0.15;
  vec3 base = v_color.rgb;
  if (u_checker == 1) {
    float c = mod(floor(v_uv.x * 8.0) + floor(v_uv.y * 8.0), 2.0);
    vec3 tint = mix(vec3(1.0, 0.55, 0.45), vec3(0.45, 0.6, 1.0), fract(v_uv.x));
    base = mix(vec3(0.96), tint * 0.55, c);
  }
  vec3 color = base * (0.28 + 0.72 * diffuse) + vec3(spec);
  if (!gl_FrontFacing) color *= vec3(1.0, 0.45, 0.45);  // inside-out faces show red
  o_color = vec4(color, 1.0);
}
)";

GLuint compile(GLenum type, const char* src) {
  const GLuint s = glCreateShader(type);
  glShaderSource(s, 1, &src, nullptr);
  glCompileShader(s);
  GLint ok = 0;
  glGetShaderiv(s, GL_COMPILE_STATUS, &ok);
  if (!ok) {
    char log[2048];
    glGetShaderInfoLog(s, sizeof log, nullptr, log);
    glDeleteShader(s);
    throw InternalError(std::string("viewer shader does not compile: ") + log);
  }
  return s;
}

GLuint link(const char* vs, const char* fs) {
  const GLuint v = compile(GL_VERTEX_SHADER, vs);
  const GLuint f = compile(GL_FRAGMENT_SHADER, fs);
  const GLuint p = glCreateProgram();
  glAttachShader(p, v);
  glAttachShader(p, f);
  glLinkProgram(p);
  glDeleteShader(v);
  glDeleteShader(f);
  GLint ok = 0;
  glGetProgramiv(p, GL_LINK_STATUS, &ok);
  if (!ok) {
    char log[2048];
    glGetProgramInfoLog(p, sizeof log, nullptr, log);
    glDeleteProgram(p);
    throw InternalError(std::string("viewer shader does not link: ") + log);
  }
  return p;
}

template <class T>
GLuint array_buffer(const std::vector<T>& data) {
  GLuint b = 0;
  glGenBuffers(1, &b);
  glBindBuffer(GL_ARRAY_BUFFER, b);
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(data.size() * sizeof(T)), data.data(), GL_STATIC_DRAW);
  return b;
}

}  // namespace

GlBackend::GlBackend() {
  line_program_ = link(kLineVs, kLineFs);
  mesh_program_ = link(kMeshVs, kMeshFs);
  GLfloat range[2] = {1, 1};
  glGetFloatv(GL_ALIASED_LINE_WIDTH_RANGE, range);
  max_line_width_ = std::max(1.0f, range[1]);
}

GlBackend::~GlBackend() {
  for (auto& [h, b] : batches_) {
    glDeleteBuffers(4, b.buffers);
    glDeleteVertexArrays(1, &b.vao);
  }
  glDeleteProgram(line_program_);
  glDeleteProgram(mesh_program_);
}

BatchHandle GlBackend::upload(const Batch& batch) {
  GpuBatch g;
  g.primitive = batch.primitive;
  g.point_size = batch.point_size;
  g.line_width = batch.line_width;
  g.count = static_cast<GLint>(batch.positions.size());
  glGenVertexArrays(1, &g.vao);
  glBindVertexArray(g.vao);
  g.buffers[0] = array_buffer(batch.positions);
  glEnableVertexAttribArray(0);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 0, nullptr);
  if (batch.colors.size() == batch.positions.size()) {
    g.buffers[1] = array_buffer(batch.colors);
    glEnableVertexAttribArray(1);
    glVertexAttribPointer(1, 4, GL_UNSIGNED_BYTE, GL_TRUE, 0, nullptr);
  } else {
    glVertexAttrib4f(1, 0.5f, 0.5f, 0.5f, 1.0f);
  }
  if (batch.normals.size() == batch.positions.size()) {
    g.buffers[2] = array_buffer(batch.normals);
    glEnableVertexAttribArray(2);
    glVertexAttribPointer(2, 3, GL_FLOAT, GL_FALSE, 0, nullptr);
  }
  if (batch.uvs.size() == batch.positions.size()) {
    g.buffers[3] = array_buffer(batch.uvs);
    glEnableVertexAttribArray(3);
    glVertexAttribPointer(3, 2, GL_FLOAT, GL_FALSE, 0, nullptr);
  }
  glBindVertexArray(0);
  const BatchHandle h = next_++;
  batches_.emplace(h, g);
  return h;
}

void GlBackend::release(BatchHandle handle) {
  auto it = batches_.find(handle);
  if (it == batches_.end()) return;
  glDeleteBuffers(4, it->second.buffers);
  glDeleteVertexArrays(1, &it->second.vao);
  batches_.erase(it);
}

void GlBackend::begin_frame(int width, int height, Rgba8 clear) {
  width_ = width;
  height_ = height;
  glViewport(0, 0, width, height);
  glClearColor(clear.r / 255.0f, clear.g / 255.0f, clear.b / 255.0f, clear.a / 255.0f);
  glClearDepth(1.0);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LEQUAL);
  glDepthMask(GL_TRUE);
  glDisable(GL_SCISSOR_TEST);
  glDisable(GL_CULL_FACE);
  glEnable(GL_PROGRAM_POINT_SIZE);
  glEnable(GL_BLEND);
  glBlendFunc(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA);
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
}

void GlBackend::draw(BatchHandle handle, const DrawParams& params) {
  auto it = batches_.find(handle);
  if (it == batches_.end() || it->second.count == 0) return;
  const GpuBatch& b = it->second;
  if (params.on_top) glDisable(GL_DEPTH_TEST);
  if (b.primitive == Primitive::triangles) {
    glUseProgram(mesh_program_);
    glUniformMatrix4fv(glGetUniformLocation(mesh_program_, "u_view"), 1, GL_FALSE, glm::value_ptr(params.view));
    glUniformMatrix4fv(glGetUniformLocation(mesh_program_, "u_proj"), 1, GL_FALSE, glm::value_ptr(params.projection));
    glUniform1i(glGetUniformLocation(mesh_program_, "u_checker"), params.shading == MeshShading::uv_checker ? 1 : 0);
    glEnable(GL_POLYGON_OFFSET_FILL);
    glPolygonOffset(1.0f, 2.0f);
    glBindVertexArray(b.vao);
    glDrawArrays(GL_TRIANGLES, 0, b.count);
    glDisable(GL_POLYGON_OFFSET_FILL);
  } else {
    glUseProgram(line_program_);
    glUniformMatrix4fv(glGetUniformLocation(line_program_, "u_view"), 1, GL_FALSE, glm::value_ptr(params.view));
    glUniformMatrix4fv(glGetUniformLocation(line_program_, "u_proj"), 1, GL_FALSE, glm::value_ptr(params.projection));
    glUniform1f(glGetUniformLocation(line_program_, "u_point_size"), b.point_size);
    glUniform1f(glGetUniformLocation(line_program_, "u_depth_bias"), params.depth_bias ? 2e-5f : 0.0f);
    glUniform1i(glGetUniformLocation(line_program_, "u_round"), b.primitive == Primitive::points ? 1 : 0);
    glLineWidth(std::clamp(b.line_width, 1.0f, max_line_width_));
    glBindVertexArray(b.vao);
    glDrawArrays(b.primitive == Primitive::points ? GL_POINTS : GL_LINES, 0, b.count);
    glLineWidth(1.0f);
  }
  glBindVertexArray(0);
  if (params.on_top) glEnable(GL_DEPTH_TEST);
}

void GlBackend::end_frame() {
  glUseProgram(0);
}

Image GlBackend::read_pixels() {
  Image img;
  img.width = width_;
  img.height = height_;
  img.rgba.resize(static_cast<std::size_t>(std::max(width_, 0)) * static_cast<std::size_t>(std::max(height_, 0)) * 4);
  if (img.rgba.empty()) return img;
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadPixels(0, 0, width_, height_, GL_RGBA, GL_UNSIGNED_BYTE, img.rgba.data());
  // OpenGL's first row is the bottom one.
  const std::size_t row = static_cast<std::size_t>(width_) * 4;
  std::vector<std::uint8_t> tmp(row);
  for (int y = 0; y < height_ / 2; ++y) {
    std::uint8_t* a = img.rgba.data() + row * static_cast<std::size_t>(y);
    std::uint8_t* c = img.rgba.data() + row * static_cast<std::size_t>(height_ - 1 - y);
    std::copy(a, a + row, tmp.data());
    std::copy(c, c + row, a);
    std::copy(tmp.data(), tmp.data() + row, c);
  }
  return img;
}

// ---- OffscreenTarget ------------------------------------------------------------------

OffscreenTarget::OffscreenTarget(int width, int height, int samples) : width_(width), height_(height) {
  GLint max_samples = 0;
  glGetIntegerv(GL_MAX_SAMPLES, &max_samples);
  samples = std::clamp(samples, 0, std::max(max_samples, 0));
  glGenFramebuffers(1, &msaa_fbo_);
  glBindFramebuffer(GL_FRAMEBUFFER, msaa_fbo_);
  glGenRenderbuffers(1, &msaa_color_);
  glBindRenderbuffer(GL_RENDERBUFFER, msaa_color_);
  glRenderbufferStorageMultisample(GL_RENDERBUFFER, samples, GL_RGBA8, width, height);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, msaa_color_);
  glGenRenderbuffers(1, &msaa_depth_);
  glBindRenderbuffer(GL_RENDERBUFFER, msaa_depth_);
  glRenderbufferStorageMultisample(GL_RENDERBUFFER, samples, GL_DEPTH_COMPONENT24, width, height);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, msaa_depth_);
  if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE) {
    throw InternalError("offscreen framebuffer (multisampled) is incomplete");
  }
  glGenFramebuffers(1, &fbo_);
  glBindFramebuffer(GL_FRAMEBUFFER, fbo_);
  glGenRenderbuffers(1, &color_);
  glBindRenderbuffer(GL_RENDERBUFFER, color_);
  glRenderbufferStorage(GL_RENDERBUFFER, GL_RGBA8, width, height);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, color_);
  if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE) {
    throw InternalError("offscreen framebuffer is incomplete");
  }
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
}

OffscreenTarget::~OffscreenTarget() {
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  glDeleteFramebuffers(1, &msaa_fbo_);
  glDeleteFramebuffers(1, &fbo_);
  const GLuint rbs[3] = {msaa_color_, msaa_depth_, color_};
  glDeleteRenderbuffers(3, rbs);
}

void OffscreenTarget::bind() {
  glBindFramebuffer(GL_FRAMEBUFFER, msaa_fbo_);
  glViewport(0, 0, width_, height_);
}

void OffscreenTarget::resolve() {
  glBindFramebuffer(GL_READ_FRAMEBUFFER, msaa_fbo_);
  glBindFramebuffer(GL_DRAW_FRAMEBUFFER, fbo_);
  glBlitFramebuffer(0, 0, width_, height_, 0, 0, width_, height_, GL_COLOR_BUFFER_BIT, GL_NEAREST);
  glBindFramebuffer(GL_FRAMEBUFFER, fbo_);
}

}  // namespace sm::viewer
