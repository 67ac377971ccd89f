#include "render/renderer.h"

#include <EGL/egl.h>
#include <EGL/eglext.h>
#include <GLES3/gl3.h>

#include <algorithm>
#include <cstdio>
#include <map>
#include <opencv2/imgproc.hpp>
#include <utility>
#include <vector>

namespace mm {
namespace {

std::string Hex(unsigned value) {
  char buf[16];
  std::snprintf(buf, sizeof(buf), "0x%04x", value);
  return buf;
}

// RAII for one GL object name; `destroy` is glDeleteBuffers, glDeleteTextures, ... (all share
// the (GLsizei, const GLuint*) form), or a single-name deleter for programs and shaders.
class GlName {
 public:
  using MultiDeleter = void (*)(GLsizei, const GLuint*);
  using SingleDeleter = void (*)(GLuint);
  GlName() = default;
  GlName(GLuint name, MultiDeleter multi) : name_(name), multi_(multi) {}
  GlName(GLuint name, SingleDeleter single) : name_(name), single_(single) {}
  GlName(GlName&& other) noexcept { *this = std::move(other); }
  GlName& operator=(GlName&& other) noexcept {
    if (this != &other) {
      Reset();
      name_ = std::exchange(other.name_, 0);
      multi_ = other.multi_;
      single_ = other.single_;
    }
    return *this;
  }
  GlName(const GlName&) = delete;
  GlName& operator=(const GlName&) = delete;
  ~GlName() { Reset(); }
  [[nodiscard]] GLuint get() const { return name_; }

 private:
  void Reset() {
    if (name_ == 0) return;
    if (multi_ != nullptr) multi_(1, &name_);
    if (single_ != nullptr) single_(name_);
    name_ = 0;
  }
  GLuint name_ = 0;
  MultiDeleter multi_ = nullptr;
  SingleDeleter single_ = nullptr;
};

GlName MakeBuffer() {
  GLuint n = 0;
  glGenBuffers(1, &n);
  return {n, glDeleteBuffers};
}
GlName MakeTexture() {
  GLuint n = 0;
  glGenTextures(1, &n);
  return {n, glDeleteTextures};
}
GlName MakeRenderbuffer() {
  GLuint n = 0;
  glGenRenderbuffers(1, &n);
  return {n, glDeleteRenderbuffers};
}
GlName MakeFramebuffer() {
  GLuint n = 0;
  glGenFramebuffers(1, &n);
  return {n, glDeleteFramebuffers};
}
GlName MakeVertexArray() {
  GLuint n = 0;
  glGenVertexArrays(1, &n);
  return {n, glDeleteVertexArrays};
}

constexpr const char* kVertexShader = R"(#version 300 es
layout(location = 0) in vec3 a_position;
layout(location = 1) in vec2 a_uv;
layout(location = 2) in vec3 a_color;
uniform mat4 u_projection;
uniform mat4 u_cam_from_world;
out vec2 v_texcoord;
out vec3 v_color;
out float v_z;
void main() {
  vec4 p = u_cam_from_world * vec4(a_position, 1.0);
  v_z = p.z;
  v_texcoord = vec2(a_uv.x, 1.0 - a_uv.y);  // Texture rows are uploaded top row first.
  v_color = a_color;
  gl_Position = u_projection * p;
}
)";

// Colour to attachment 0; linear z / far packed in 24 bits to attachment 1 (GLES 3.0 can
// neither read the depth buffer nor render to float without an extension).
constexpr const char* kFragmentShader = R"(#version 300 es
precision highp float;
precision highp int;
uniform sampler2D u_texture;
uniform int u_textured;
uniform float u_far;
in vec2 v_texcoord;
in vec3 v_color;
in float v_z;
layout(location = 0) out vec4 o_color;
layout(location = 1) out vec4 o_depth;
void main() {
  o_color = u_textured == 1 ? vec4(texture(u_texture, v_texcoord).rgb, 1.0) : vec4(v_color, 1.0);
  uint q = uint(clamp(v_z / u_far, 0.0, 1.0) * 16777215.0 + 0.5);
  o_depth = vec4(float((q >> 16u) & 255u), float((q >> 8u) & 255u), float(q & 255u), 255.0) / 255.0;
}
)";

}  // namespace

std::string RenderCamera::Check() const {
  if (width <= 0 || height <= 0) return "width/height: must be > 0";
  if (!(K(0, 0) > 0 && K(1, 1) > 0) || K(2, 2) != 1.0 || K(1, 0) != 0 || K(2, 0) != 0 ||
      K(2, 1) != 0) {
    return "K: must be upper triangular with fx, fy > 0 and K(2,2) = 1";
  }
  if (!(near_plane > 0 && far_plane > near_plane)) return "near_plane/far_plane: 0 < near < far";
  return {};
}

Eigen::Matrix4f GlProjectionFromK(const Eigen::Matrix3d& K, int width, int height,
                                  double near_plane, double far_plane) {
  // NDC x = 2 (u + 0.5) / W - 1 and NDC y = 2 (v + 0.5) / H - 1 with (u, v) = K x / z: the
  // centre of OpenCV pixel (u, v) lands on the centre of framebuffer pixel (u, v); GL's
  // bottom row is image row 0, so glReadPixels returns the image top row first.
  const double w = width, h = height, n = near_plane, f = far_plane;
  Eigen::Matrix4d P = Eigen::Matrix4d::Zero();
  P(0, 0) = 2 * K(0, 0) / w;
  P(0, 1) = 2 * K(0, 1) / w;
  P(0, 2) = 2 * (K(0, 2) + 0.5) / w - 1;
  P(1, 1) = 2 * K(1, 1) / h;
  P(1, 2) = 2 * (K(1, 2) + 0.5) / h - 1;
  P(2, 2) = (f + n) / (f - n);  // z = n -> NDC -1, z = f -> NDC +1.
  P(2, 3) = -2 * f * n / (f - n);
  P(3, 2) = 1;
  return P.cast<float>();
}

// The surfaceless EGLDisplay is one per process, shared by every Renderer and initialized by the
// first (eglInitialize of an initialized display is a no-op; EGL calls are thread-safe). It is
// never terminated: eglTerminate would pull it from under other Renderers, and Mesa's terminate
// unloads the driver (llvmpipe), which each entry's preview would then load again, and leaves
// blocks allocated by the unloaded driver unreachable (LeakSanitizer reports them when the
// daemon exits). The process's exit releases it.
struct Renderer::Impl {
  // Destroyed in reverse order: GL names (with this context made current first, in ~Impl),
  // then the context.
  EGLDisplay display = EGL_NO_DISPLAY;
  struct Context {
    EGLDisplay display = EGL_NO_DISPLAY;
    EGLContext handle = EGL_NO_CONTEXT;
    ~Context() {
      if (handle != EGL_NO_CONTEXT) {
        if (eglGetCurrentContext() == handle) {
          eglMakeCurrent(display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
        }
        eglDestroyContext(display, handle);
      }
    }
  } context;
  GlName program;
  GLint u_projection = -1, u_cam_from_world = -1, u_texture = -1, u_textured = -1, u_far = -1;
  std::string error;
  // Uploaded meshes (Renderer::Upload), by handle.
  struct GpuMesh {
    GlName vao, vbo, ebo, texture;
    GLsizei index_count = 0;
    bool textured = false;
  };
  std::map<int, GpuMesh> meshes;
  int next_mesh_id = 0;
  // The framebuffer of the last draw, kept while the image size stays the same.
  struct Target {
    GlName fbo, color, packed_depth, z_buffer;
    int width = 0, height = 0;
  } target;

  ~Impl() { MakeCurrent(); }  // The GL names below are deleted in this context.
  bool Init();
  bool BuildProgram();
  /// Makes this renderer's context current on the calling thread (another Renderer may have
  /// taken it).
  bool MakeCurrent() {
    if (context.handle == EGL_NO_CONTEXT) return false;
    if (eglGetCurrentContext() == context.handle) return true;
    return eglMakeCurrent(display, EGL_NO_SURFACE, EGL_NO_SURFACE, context.handle) == EGL_TRUE;
  }
};

bool Renderer::Impl::Init() {
  auto get_platform_display = reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(
      eglGetProcAddress("eglGetPlatformDisplayEXT"));
  if (get_platform_display == nullptr) {
    error = "EGL: eglGetPlatformDisplayEXT is missing (EGL_EXT_platform_base)";
    return false;
  }
  display = get_platform_display(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
  if (display == EGL_NO_DISPLAY) {
    error = "EGL: no surfaceless display (EGL_MESA_platform_surfaceless; Mesa's libegl-mesa0)";
    return false;
  }
  EGLint major = 0, minor = 0;
  if (!eglInitialize(display, &major, &minor)) {  // Idempotent when initialized.
    error = "EGL: eglInitialize failed " + Hex(static_cast<unsigned>(eglGetError()));
    return false;
  }
  if (!eglBindAPI(EGL_OPENGL_ES_API)) {
    error = "EGL: OpenGL ES API unavailable";
    return false;
  }
  const EGLint config_attribs[] = {EGL_RENDERABLE_TYPE, EGL_OPENGL_ES3_BIT, EGL_SURFACE_TYPE,
                                   EGL_PBUFFER_BIT, EGL_NONE};
  EGLConfig config = nullptr;
  EGLint num_configs = 0;
  if (!eglChooseConfig(display, config_attribs, &config, 1, &num_configs) || num_configs < 1) {
    config = nullptr;  // EGL_NO_CONFIG_KHR: surfaceless contexts need no config.
  }
  const EGLint context_attribs[] = {EGL_CONTEXT_MAJOR_VERSION, 3, EGL_CONTEXT_MINOR_VERSION, 0,
                                    EGL_NONE};
  context.display = display;
  context.handle = eglCreateContext(display, config, EGL_NO_CONTEXT, context_attribs);
  if (context.handle == EGL_NO_CONTEXT) {
    error = "EGL: no OpenGL ES 3.0 context " + Hex(static_cast<unsigned>(eglGetError()));
    return false;
  }
  if (!eglMakeCurrent(display, EGL_NO_SURFACE, EGL_NO_SURFACE, context.handle)) {
    error = "EGL: surfaceless eglMakeCurrent failed (EGL_KHR_surfaceless_context) " +
            Hex(static_cast<unsigned>(eglGetError()));
    return false;
  }
  return BuildProgram();
}

bool Renderer::Impl::BuildProgram() {
  auto compile = [this](GLenum type, const char* source) -> GlName {
    GlName shader(glCreateShader(type), glDeleteShader);
    glShaderSource(shader.get(), 1, &source, nullptr);
    glCompileShader(shader.get());
    GLint ok = 0;
    glGetShaderiv(shader.get(), GL_COMPILE_STATUS, &ok);
    if (!ok) {
      char log[1024] = {};
      glGetShaderInfoLog(shader.get(), sizeof(log), nullptr, log);
      error = std::string("GL: shader compile failed: ") + log;
      return {};
    }
    return shader;
  };
  GlName vs = compile(GL_VERTEX_SHADER, kVertexShader);
  if (vs.get() == 0) return false;
  GlName fs = compile(GL_FRAGMENT_SHADER, kFragmentShader);
  if (fs.get() == 0) return false;
  program = GlName(glCreateProgram(), glDeleteProgram);
  glAttachShader(program.get(), vs.get());
  glAttachShader(program.get(), fs.get());
  glLinkProgram(program.get());
  GLint ok = 0;
  glGetProgramiv(program.get(), GL_LINK_STATUS, &ok);
  if (!ok) {
    char log[1024] = {};
    glGetProgramInfoLog(program.get(), sizeof(log), nullptr, log);
    error = std::string("GL: program link failed: ") + log;
    return false;
  }
  u_projection = glGetUniformLocation(program.get(), "u_projection");
  u_cam_from_world = glGetUniformLocation(program.get(), "u_cam_from_world");
  u_texture = glGetUniformLocation(program.get(), "u_texture");
  u_textured = glGetUniformLocation(program.get(), "u_textured");
  u_far = glGetUniformLocation(program.get(), "u_far");
  return true;
}

Renderer::Renderer() : impl_(std::make_unique<Impl>()) {
  if (!impl_->Init()) impl_->program = GlName();
}

Renderer::~Renderer() = default;

std::string WarmUpRenderer() {
  const Renderer renderer;
  return renderer.error();
}

bool Renderer::ok() const { return impl_->error.empty(); }
const std::string& Renderer::error() const { return impl_->error; }

std::string Renderer::gl_renderer() const {
  if (!ok() || !impl_->MakeCurrent()) return {};
  const auto* s = reinterpret_cast<const char*>(glGetString(GL_RENDERER));
  return s != nullptr ? s : "";
}

RenderResult Renderer::Render(const Mesh& mesh, const cv::Mat& texture_bgr,
                              const RenderCamera& camera) {
  RenderResult out;
  const int id = Upload(mesh, texture_bgr, UploadOptions{}, &out.failure_reason);
  if (id < 0) return out;
  out = Draw(id, camera);
  Release(id);
  return out;
}

int Renderer::Upload(const Mesh& mesh, const cv::Mat& texture_bgr, const UploadOptions& options,
                     std::string* error) {
  if (!ok()) {
    *error = impl_->error;
    return -1;
  }
  if (!impl_->MakeCurrent()) {
    *error = "EGL: cannot make the context current " + Hex(static_cast<unsigned>(eglGetError()));
    return -1;
  }
  if (!texture_bgr.empty() && texture_bgr.type() != CV_8UC3) {
    *error = "texture must be BGR8";
    return -1;
  }
  const bool textured = !texture_bgr.empty() && mesh.uvs.size() == mesh.vertices.size();
  Impl::GpuMesh gpu;
  gpu.textured = textured;

  // Vertex data: position (3), uv (2), colour (3), interleaved floats.
  std::vector<float> vertices;
  vertices.reserve(mesh.vertices.size() * 8);
  const bool has_colors = mesh.colors.size() == mesh.vertices.size();
  for (size_t i = 0; i < mesh.vertices.size(); ++i) {
    const Eigen::Vector3f& p = mesh.vertices[i];
    const Eigen::Vector2f uv = textured ? mesh.uvs[i] : Eigen::Vector2f::Zero();
    vertices.insert(vertices.end(), {p.x(), p.y(), p.z(), uv.x(), uv.y()});
    for (int k = 0; k < 3; ++k) {
      vertices.push_back(has_colors ? static_cast<float>(mesh.colors[i][k]) / 255.0f : 0.6f);
    }
  }
  std::vector<GLuint> indices;
  indices.reserve(mesh.triangles.size() * 3);
  for (const Eigen::Vector3i& t : mesh.triangles) {
    for (int k = 0; k < 3; ++k) indices.push_back(static_cast<GLuint>(t[k]));
  }
  gpu.index_count = static_cast<GLsizei>(indices.size());
  gpu.vao = MakeVertexArray();
  gpu.vbo = MakeBuffer();
  gpu.ebo = MakeBuffer();
  glBindVertexArray(gpu.vao.get());
  glBindBuffer(GL_ARRAY_BUFFER, gpu.vbo.get());
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(vertices.size() * sizeof(float)),
               vertices.data(), GL_STATIC_DRAW);
  glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, gpu.ebo.get());
  glBufferData(GL_ELEMENT_ARRAY_BUFFER, static_cast<GLsizeiptr>(indices.size() * sizeof(GLuint)),
               indices.data(), GL_STATIC_DRAW);
  const GLsizei stride = 8 * sizeof(float);
  glEnableVertexAttribArray(0);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, stride, reinterpret_cast<void*>(0));
  glEnableVertexAttribArray(1);
  glVertexAttribPointer(1, 2, GL_FLOAT, GL_FALSE, stride,
                        reinterpret_cast<void*>(3 * sizeof(float)));
  glEnableVertexAttribArray(2);
  glVertexAttribPointer(2, 3, GL_FLOAT, GL_FALSE, stride,
                        reinterpret_cast<void*>(5 * sizeof(float)));
  glBindVertexArray(0);

  if (textured) {
    GLint max_texture = 0;
    glGetIntegerv(GL_MAX_TEXTURE_SIZE, &max_texture);
    if (texture_bgr.cols > max_texture || texture_bgr.rows > max_texture) {
      *error = "texture larger than GL_MAX_TEXTURE_SIZE " + std::to_string(max_texture);
      return -1;
    }
    cv::Mat rgb;
    cv::cvtColor(texture_bgr, rgb, cv::COLOR_BGR2RGB);
    gpu.texture = MakeTexture();
    glActiveTexture(GL_TEXTURE0);
    glBindTexture(GL_TEXTURE_2D, gpu.texture.get());
    glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
    glTexImage2D(GL_TEXTURE_2D, 0, GL_RGB8, rgb.cols, rgb.rows, 0, GL_RGB, GL_UNSIGNED_BYTE,
                 rgb.data);
    if (options.mipmaps) glGenerateMipmap(GL_TEXTURE_2D);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER,
                    options.mipmaps ? GL_LINEAR_MIPMAP_LINEAR : GL_LINEAR);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  }
  if (const GLenum err = glGetError(); err != GL_NO_ERROR) {
    *error = "GL error " + Hex(err) + " while uploading";
    return -1;
  }
  const int id = impl_->next_mesh_id++;
  impl_->meshes.emplace(id, std::move(gpu));
  return id;
}

void Renderer::Release(int mesh_id) {
  if (!impl_->MakeCurrent()) return;
  impl_->meshes.erase(mesh_id);
}

RenderResult Renderer::Draw(int mesh_id, const RenderCamera& camera) {
  RenderResult out;
  if (!ok()) {
    out.failure_reason = impl_->error;
    return out;
  }
  if (!impl_->MakeCurrent()) {
    out.failure_reason =
        "EGL: cannot make the context current " + Hex(static_cast<unsigned>(eglGetError()));
    return out;
  }
  if (const std::string problem = camera.Check(); !problem.empty()) {
    out.failure_reason = "camera " + problem;
    return out;
  }
  const auto found = impl_->meshes.find(mesh_id);
  if (found == impl_->meshes.end()) {
    out.failure_reason = "no uploaded mesh " + std::to_string(mesh_id);
    return out;
  }
  const Impl::GpuMesh& gpu = found->second;
  GLint max_size = 0;
  glGetIntegerv(GL_MAX_RENDERBUFFER_SIZE, &max_size);
  if (camera.width > max_size || camera.height > max_size) {
    out.failure_reason = "image larger than GL_MAX_RENDERBUFFER_SIZE " + std::to_string(max_size);
    return out;
  }
  const int w = camera.width, h = camera.height;

  // Framebuffer: colour, packed depth, z-buffer; made again only when the size changes.
  Impl::Target& target = impl_->target;
  if (target.width != w || target.height != h || target.fbo.get() == 0) {
    target = Impl::Target{};
    target.fbo = MakeFramebuffer();
    target.color = MakeRenderbuffer();
    target.packed_depth = MakeRenderbuffer();
    target.z_buffer = MakeRenderbuffer();
    glBindFramebuffer(GL_FRAMEBUFFER, target.fbo.get());
    glBindRenderbuffer(GL_RENDERBUFFER, target.color.get());
    glRenderbufferStorage(GL_RENDERBUFFER, GL_RGBA8, w, h);
    glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER,
                              target.color.get());
    glBindRenderbuffer(GL_RENDERBUFFER, target.packed_depth.get());
    glRenderbufferStorage(GL_RENDERBUFFER, GL_RGBA8, w, h);
    glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT1, GL_RENDERBUFFER,
                              target.packed_depth.get());
    glBindRenderbuffer(GL_RENDERBUFFER, target.z_buffer.get());
    glRenderbufferStorage(GL_RENDERBUFFER, GL_DEPTH_COMPONENT24, w, h);
    glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER,
                              target.z_buffer.get());
    const GLenum status = glCheckFramebufferStatus(GL_FRAMEBUFFER);
    if (status != GL_FRAMEBUFFER_COMPLETE) {
      target = Impl::Target{};
      out.failure_reason = "GL: framebuffer incomplete " + Hex(status);
      return out;
    }
    target.width = w;
    target.height = h;
  }
  glBindFramebuffer(GL_FRAMEBUFFER, target.fbo.get());
  const GLenum draw_buffers[] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1};
  glDrawBuffers(2, draw_buffers);
  glViewport(0, 0, w, h);
  glClearColor(0, 0, 0, 0);
  glClearDepthf(1.0f);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LESS);
  glDisable(GL_CULL_FACE);  // The y flip of the projection mirrors the winding; draw both.
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);

  glBindVertexArray(gpu.vao.get());
  if (gpu.textured) {
    glActiveTexture(GL_TEXTURE0);
    glBindTexture(GL_TEXTURE_2D, gpu.texture.get());
  }
  glUseProgram(impl_->program.get());
  const Eigen::Matrix4f projection =
      GlProjectionFromK(camera.K, w, h, camera.near_plane, camera.far_plane);
  const Eigen::Matrix4f view = camera.cam_from_world.matrix().cast<float>();
  glUniformMatrix4fv(impl_->u_projection, 1, GL_FALSE, projection.data());  // Column-major.
  glUniformMatrix4fv(impl_->u_cam_from_world, 1, GL_FALSE, view.data());
  glUniform1i(impl_->u_texture, 0);
  glUniform1i(impl_->u_textured, gpu.textured ? 1 : 0);
  glUniform1f(impl_->u_far, static_cast<float>(camera.far_plane));
  glDrawElements(GL_TRIANGLES, gpu.index_count, GL_UNSIGNED_INT, nullptr);

  cv::Mat color(h, w, CV_8UC4), packed(h, w, CV_8UC4);
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadBuffer(GL_COLOR_ATTACHMENT0);
  glReadPixels(0, 0, w, h, GL_RGBA, GL_UNSIGNED_BYTE, color.data);
  glReadBuffer(GL_COLOR_ATTACHMENT1);
  glReadPixels(0, 0, w, h, GL_RGBA, GL_UNSIGNED_BYTE, packed.data);
  glBindVertexArray(0);
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  if (const GLenum err = glGetError(); err != GL_NO_ERROR) {
    out.failure_reason = "GL error " + Hex(err);
    return out;
  }

  cv::cvtColor(color, out.rgb, cv::COLOR_RGBA2BGR);
  out.depth = cv::Mat(h, w, CV_32FC1, cv::Scalar(0));
  out.mask = cv::Mat(h, w, CV_8UC1, cv::Scalar(0));
  const double scale = camera.far_plane / 16777215.0;
  for (int y = 0; y < h; ++y) {
    const cv::Vec4b* row = packed.ptr<cv::Vec4b>(y);
    float* depth_row = out.depth.ptr<float>(y);
    uint8_t* mask_row = out.mask.ptr<uint8_t>(y);
    for (int x = 0; x < w; ++x) {
      if (row[x][3] == 0) continue;
      const uint32_t q = (static_cast<uint32_t>(row[x][0]) << 16) |
                         (static_cast<uint32_t>(row[x][1]) << 8) | row[x][2];
      depth_row[x] = static_cast<float>(q * scale);
      mask_row[x] = 255;
      ++out.covered_pixels;
    }
  }
  out.success = true;
  return out;
}

double FarPlaneFor(const Mesh& mesh, const Eigen::Isometry3d& cam_from_world) {
  double far_plane = 1.0;
  for (const Eigen::Vector3f& v : mesh.vertices) {
    far_plane = std::max(far_plane, (cam_from_world * v.cast<double>()).z());
  }
  return 2.0 * far_plane;
}

}  // namespace mm
