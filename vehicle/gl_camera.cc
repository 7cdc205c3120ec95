#include "vehicle/gl_camera.h"

#include <EGL/egl.h>
#include <EGL/eglext.h>
#include <GLES3/gl3.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <string_view>

namespace autonomsim::vehicle {
namespace {

// Window depth is optical z / far_m: linear, so that the 24-bit depth test resolves far / 2^24
// (0.6 µm at 10 m) at every distance.
constexpr const char* kVertexShader = R"(#version 300 es
layout(location = 0) in vec3 a_map;
layout(location = 1) in vec4 a_colour;
uniform mat4 u_clip_from_map;
uniform vec4 u_optical_z_row;  // the optical z of a map point: dot(row, (p, 1))
out vec3 v_map;
out float v_z;
flat out vec4 v_colour;
void main() {
  vec4 p = vec4(a_map, 1.0);
  v_map = a_map;
  v_z = dot(u_optical_z_row, p);
  v_colour = a_colour;
  gl_Position = u_clip_from_map * p;
}
)";

// Colours are B, G, R in the red, green and blue channels (memory order B, G, R, A on read-back).
// A vertex colour of alpha 0 marks the floor, which takes its texel by index.
constexpr const char* kFragmentShader = R"(#version 300 es
precision highp float;
precision highp int;
uniform highp sampler2D u_floor;
uniform ivec2 u_floor_texels;   // columns, rows
uniform vec2 u_floor_origin_m;  // the map point of the raster's top-left corner
uniform float u_texels_per_m;
uniform vec4 u_outside;         // the bare floor beyond the raster
uniform float u_far_m;
in vec3 v_map;
in float v_z;
flat in vec4 v_colour;
layout(location = 0) out vec4 o_colour;
layout(location = 1) out float o_z;
void main() {
  vec4 colour = v_colour;
  if (colour.a == 0.0) {
    float col = (v_map.x - u_floor_origin_m.x) * u_texels_per_m;
    float row = (u_floor_origin_m.y - v_map.y) * u_texels_per_m;
    bool inside = col >= 0.0 && row >= 0.0 && col < float(u_floor_texels.x) &&
                  row < float(u_floor_texels.y);
    colour = inside ? texelFetch(u_floor, ivec2(int(col), int(row)), 0) : u_outside;
  }
  o_colour = vec4(colour.rgb, 1.0);
  o_z = v_z;
  gl_FragDepth = clamp(v_z / u_far_m, 0.0, 1.0);
}
)";

std::string Hex(unsigned value) {
  char text[16];
  std::snprintf(text, sizeof text, "0x%04x", value);
  return text;
}

std::string EglFailure(const std::string& what) {
  return what + " failed (EGL error " + Hex(static_cast<unsigned>(eglGetError())) + ")";
}

bool HasExtension(const char* list, std::string_view name) {
  if (list == nullptr) return false;
  std::string_view all(list);
  for (std::size_t at = all.find(name); at != std::string_view::npos; at = all.find(name, at + 1)) {
    const bool starts = at == 0 || all[at - 1] == ' ';
    const std::size_t end = at + name.size();
    if (starts && (end == all.size() || all[end] == ' ')) return true;
  }
  return false;
}

// A display from `platform`, initialized; EGL_NO_DISPLAY if it cannot be.
EGLDisplay InitializedDisplay(EGLenum platform, void* native) {
  const EGLDisplay display = eglGetPlatformDisplay(platform, native, nullptr);
  if (display == EGL_NO_DISPLAY) return EGL_NO_DISPLAY;
  EGLint major = 0, minor = 0;
  if (eglInitialize(display, &major, &minor) != EGL_TRUE) return EGL_NO_DISPLAY;
  return display;
}

void CheckGl(const char* what) {
  const GLenum error = glGetError();
  if (error != GL_NO_ERROR) {
    throw GlUnavailable(std::string("OpenGL ES: ") + what + " failed (GL error " + Hex(error) +
                        ")");
  }
}

GLuint CompileShader(GLenum kind, const char* source) {
  const GLuint shader = glCreateShader(kind);
  glShaderSource(shader, 1, &source, nullptr);
  glCompileShader(shader);
  GLint ok = 0;
  glGetShaderiv(shader, GL_COMPILE_STATUS, &ok);
  if (ok != GL_TRUE) {
    char log[2048] = {};
    glGetShaderInfoLog(shader, sizeof log, nullptr, log);
    glDeleteShader(shader);
    throw GlUnavailable(std::string("OpenGL ES: a shader does not compile: ") + log);
  }
  return shader;
}

std::uint32_t PackColour(const Bgr& bgr, std::uint8_t alpha) {
  const std::array<std::uint8_t, 4> bytes{bgr[0], bgr[1], bgr[2], alpha};
  std::uint32_t packed = 0;
  std::memcpy(&packed, bytes.data(), 4);
  return packed;
}

std::array<float, 4> Normalized(const Bgr& bgr) {
  return {bgr[0] / 255.0f, bgr[1] / 255.0f, bgr[2] / 255.0f, 1.0f};
}

// Under lens distortion, the depth interpolated at a ray's exact position is taken where it is
// within this fraction of the nearest pixel's (the four pixels around it see one surface).
constexpr float kOneSurfaceTolerance = 0.1f;

}  // namespace

// --- GlContext --------------------------------------------------------------------------------

std::shared_ptr<GlContext> GlContext::Create() {
  const char* client = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
  if (client == nullptr || !HasExtension(client, "EGL_EXT_platform_base")) {
    throw GlUnavailable("EGL: no platform displays (EGL_EXT_platform_base) in this libEGL");
  }
  std::string tried;
  EGLDisplay display = EGL_NO_DISPLAY;
  std::string platform;
  // an EGL device: a GPU first, then a software one as the last resort
  std::vector<EGLDeviceEXT> devices;
  if (HasExtension(client, "EGL_EXT_platform_device")) {
    const auto query_devices =
        reinterpret_cast<PFNEGLQUERYDEVICESEXTPROC>(eglGetProcAddress("eglQueryDevicesEXT"));
    const auto device_string = reinterpret_cast<PFNEGLQUERYDEVICESTRINGEXTPROC>(
        eglGetProcAddress("eglQueryDeviceStringEXT"));
    EGLint count = 0;
    if (query_devices != nullptr && device_string != nullptr &&
        query_devices(0, nullptr, &count) == EGL_TRUE && count > 0) {
      devices.resize(static_cast<std::size_t>(count));
      query_devices(count, devices.data(), &count);
      devices.resize(static_cast<std::size_t>(count));
      std::stable_partition(devices.begin(), devices.end(), [&](EGLDeviceEXT d) {
        return !HasExtension(device_string(d, EGL_EXTENSIONS), "EGL_MESA_device_software");
      });
      for (std::size_t i = 0; i < devices.size() && display == EGL_NO_DISPLAY; ++i) {
        if (HasExtension(device_string(devices[i], EGL_EXTENSIONS), "EGL_MESA_device_software"))
          break;  // hardware only here
        display = InitializedDisplay(EGL_PLATFORM_DEVICE_EXT, devices[i]);
        if (display != EGL_NO_DISPLAY) platform = "EGL device " + std::to_string(i);
      }
    }
    tried += "EGL devices (" + std::to_string(devices.size()) + " found)";
  }
  if (display == EGL_NO_DISPLAY && HasExtension(client, "EGL_MESA_platform_surfaceless")) {
    display = InitializedDisplay(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY);
    if (display != EGL_NO_DISPLAY) platform = "Mesa surfaceless";
    tried += std::string(tried.empty() ? "" : ", ") + "Mesa surfaceless";
  }
  for (std::size_t i = 0; i < devices.size() && display == EGL_NO_DISPLAY; ++i) {
    display = InitializedDisplay(EGL_PLATFORM_DEVICE_EXT, devices[i]);
    if (display != EGL_NO_DISPLAY) platform = "EGL software device " + std::to_string(i);
  }
  if (display == EGL_NO_DISPLAY) {
    throw GlUnavailable(
        "EGL: no display could be initialized (tried: " +
        (tried.empty() ? std::string("nothing: no device or surfaceless platform") : tried) +
        "); on Debian, install libegl-mesa0 and libgl1-mesa-dri");
  }
  const char* display_extensions = eglQueryString(display, EGL_EXTENSIONS);
  if (!HasExtension(display_extensions, "EGL_KHR_surfaceless_context")) {
    throw GlUnavailable("EGL: " + platform + " has no EGL_KHR_surfaceless_context");
  }
  if (eglBindAPI(EGL_OPENGL_ES_API) != EGL_TRUE) throw GlUnavailable(EglFailure("eglBindAPI"));
  EGLConfig config = EGL_NO_CONFIG_KHR;
  if (!HasExtension(display_extensions, "EGL_KHR_no_config_context")) {
    const EGLint wanted[] = {EGL_RENDERABLE_TYPE, EGL_OPENGL_ES3_BIT, EGL_NONE};
    EGLint found = 0;
    if (eglChooseConfig(display, wanted, &config, 1, &found) != EGL_TRUE || found < 1) {
      throw GlUnavailable("EGL: " + platform + " offers no OpenGL ES 3 configuration");
    }
  }
  const EGLint attributes[] = {EGL_CONTEXT_MAJOR_VERSION, 3, EGL_CONTEXT_MINOR_VERSION, 0,
                               EGL_NONE};
  const EGLContext context = eglCreateContext(display, config, EGL_NO_CONTEXT, attributes);
  if (context == EGL_NO_CONTEXT) {
    throw GlUnavailable(EglFailure("eglCreateContext (OpenGL ES 3.0 on " + platform + ")"));
  }
  std::shared_ptr<GlContext> out(new GlContext());
  out->display_ = display;
  out->context_ = context;
  out->platform_ = platform;
  out->MakeCurrent();
  const auto* name = reinterpret_cast<const char*>(glGetString(GL_RENDERER));
  out->renderer_ = name != nullptr ? name : "unknown";
  return out;
}

GlContext::~GlContext() {
  if (eglGetCurrentContext() == context_) {
    eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
  }
  eglDestroyContext(display_, context_);
}

void GlContext::MakeCurrent() const {
  if (eglGetCurrentContext() == context_) return;
  if (eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, context_) != EGL_TRUE) {
    throw GlUnavailable(EglFailure("eglMakeCurrent"));
  }
}

// --- GlScene ----------------------------------------------------------------------------------

struct GlScene::Target {
  int width{0}, height{0};
  GLuint framebuffer{0};
  std::array<GLuint, 3> renderbuffers{};  // colour (RGBA8), optical z (R32F), depth
};

GlScene::GlScene(std::shared_ptr<GlContext> context, const FloorTexture& floor, Bgr surround)
    : context_(std::move(context)), surround_(surround) {
  if (context_ == nullptr) throw std::invalid_argument("GlScene needs a context");
  context_->MakeCurrent();
  const auto* extensions = reinterpret_cast<const char*>(glGetString(GL_EXTENSIONS));
  if (!HasExtension(extensions, "GL_EXT_color_buffer_float")) {
    throw GlUnavailable("OpenGL ES: " + context_->renderer() +
                        " cannot render to float images (no GL_EXT_color_buffer_float)");
  }
  GLint max_size = 0;
  glGetIntegerv(GL_MAX_TEXTURE_SIZE, &max_size);
  if (floor.width() > max_size || floor.height() > max_size) {
    throw GlUnavailable("OpenGL ES: the floor raster (" + std::to_string(floor.width()) + " x " +
                        std::to_string(floor.height()) + " texels) exceeds the largest texture " +
                        std::to_string(max_size) + " of " + context_->renderer());
  }
  // the shaders
  const GLuint vertex = CompileShader(GL_VERTEX_SHADER, kVertexShader);
  const GLuint fragment = CompileShader(GL_FRAGMENT_SHADER, kFragmentShader);
  program_ = glCreateProgram();
  glAttachShader(program_, vertex);
  glAttachShader(program_, fragment);
  glLinkProgram(program_);
  glDeleteShader(vertex);
  glDeleteShader(fragment);
  GLint linked = 0;
  glGetProgramiv(program_, GL_LINK_STATUS, &linked);
  if (linked != GL_TRUE) throw GlUnavailable("OpenGL ES: the shader program does not link");
  // the floor: its texels as B, G, R, 0 (the palette's own bytes)
  std::vector<std::uint32_t> texels(static_cast<std::size_t>(floor.width()) * floor.height());
  for (std::size_t i = 0; i < texels.size(); ++i) {
    texels[i] = floor.palette()[floor.palette_index()[i]];
  }
  glGenTextures(1, &floor_texture_);
  glBindTexture(GL_TEXTURE_2D, floor_texture_);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
  glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA8, floor.width(), floor.height(), 0, GL_RGBA,
               GL_UNSIGNED_BYTE, texels.data());
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAX_LEVEL, 0);
  floor_texels_[0] = floor.width();
  floor_texels_[1] = floor.height();
  std::uint32_t outside = floor.palette()[floor.palette_index()[floor.outside_index()]];
  Bgr outside_bgr{};
  std::memcpy(outside_bgr.data(), &outside, 3);
  glUseProgram(program_);
  glUniform1i(glGetUniformLocation(program_, "u_floor"), 0);
  glUniform2i(glGetUniformLocation(program_, "u_floor_texels"), floor.width(), floor.height());
  glUniform2f(glGetUniformLocation(program_, "u_floor_origin_m"),
              static_cast<float>(floor.origin_m().x()), static_cast<float>(floor.origin_m().y()));
  glUniform1f(glGetUniformLocation(program_, "u_texels_per_m"),
              static_cast<float>(1.0 / floor.m_per_px()));
  const std::array<float, 4> outside_colour = Normalized(outside_bgr);
  glUniform4fv(glGetUniformLocation(program_, "u_outside"), 1, outside_colour.data());
  clip_from_map_at_ = glGetUniformLocation(program_, "u_clip_from_map");
  optical_z_row_at_ = glGetUniformLocation(program_, "u_optical_z_row");
  far_at_ = glGetUniformLocation(program_, "u_far_m");
  // the vertices: x, y, z (map frame, metres) and a packed B, G, R, A colour
  glGenVertexArrays(1, &vertex_array_);
  glBindVertexArray(vertex_array_);
  glGenBuffers(1, &vertex_buffer_);
  glBindBuffer(GL_ARRAY_BUFFER, vertex_buffer_);
  glEnableVertexAttribArray(0);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 16, nullptr);
  glEnableVertexAttribArray(1);
  glVertexAttribPointer(1, 4, GL_UNSIGNED_BYTE, GL_TRUE, 16, reinterpret_cast<void*>(12));
  CheckGl("setting the scene up");
}

GlScene::~GlScene() {
  try {
    context_->MakeCurrent();
  } catch (const GlUnavailable&) {
    return;  // the objects go with the context
  }
  for (const auto& target : targets_) {
    glDeleteFramebuffers(1, &target->framebuffer);
    glDeleteRenderbuffers(3, target->renderbuffers.data());
  }
  glDeleteBuffers(1, &vertex_buffer_);
  glDeleteVertexArrays(1, &vertex_array_);
  glDeleteTextures(1, &floor_texture_);
  glDeleteProgram(program_);
}

GlScene::Target& GlScene::TargetOfSize(int width, int height) {
  for (const auto& target : targets_) {
    if (target->width == width && target->height == height) return *target;
  }
  GLint max_size = 0;
  glGetIntegerv(GL_MAX_RENDERBUFFER_SIZE, &max_size);
  if (width > max_size || height > max_size) {
    throw GlUnavailable("OpenGL ES: a " + std::to_string(width) + " x " + std::to_string(height) +
                        " image exceeds the largest renderbuffer " + std::to_string(max_size) +
                        " of " + context_->renderer());
  }
  auto target = std::make_unique<Target>();
  target->width = width;
  target->height = height;
  glGenFramebuffers(1, &target->framebuffer);
  glBindFramebuffer(GL_FRAMEBUFFER, target->framebuffer);
  glGenRenderbuffers(3, target->renderbuffers.data());
  const std::array<GLenum, 3> formats{GL_RGBA8, GL_R32F, GL_DEPTH_COMPONENT24};
  const std::array<GLenum, 3> attachments{GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1,
                                          GL_DEPTH_ATTACHMENT};
  for (std::size_t k = 0; k < 3; ++k) {
    glBindRenderbuffer(GL_RENDERBUFFER, target->renderbuffers[k]);
    glRenderbufferStorage(GL_RENDERBUFFER, formats[k], width, height);
    glFramebufferRenderbuffer(GL_FRAMEBUFFER, attachments[k], GL_RENDERBUFFER,
                              target->renderbuffers[k]);
  }
  if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE) {
    throw GlUnavailable("OpenGL ES: a " + std::to_string(width) + " x " + std::to_string(height) +
                        " offscreen framebuffer is incomplete on " + context_->renderer());
  }
  glReadBuffer(GL_COLOR_ATTACHMENT1);
  GLint format = 0, type = 0;
  glGetIntegerv(GL_IMPLEMENTATION_COLOR_READ_FORMAT, &format);
  glGetIntegerv(GL_IMPLEMENTATION_COLOR_READ_TYPE, &type);
  read_red_ = format == GL_RED && type == GL_FLOAT;
  CheckGl("making an offscreen framebuffer");
  targets_.push_back(std::move(target));
  return *targets_.back();
}

namespace {

// The view's transforms, as the vertex shader takes them.
struct ViewTransforms {
  Eigen::Matrix4f clip_from_map;
  Eigen::Vector4f optical_z_row;  // p_map → the optical z
};

// The projection: pixel (u, v) = K · p / z has its centre at window (u + 0.5, v + 0.5), row 0 at
// window y = 0 (the first row read back), z in [near, far] to [-1, 1].
ViewTransforms TransformsOf(const GlView& view) {
  const int w = view.width_px, h = view.height_px;
  const double n = view.near_m, f = view.far_m;
  Eigen::Matrix4d projection = Eigen::Matrix4d::Zero();
  projection(0, 0) = 2.0 * view.K[0] / w;
  projection(0, 1) = 2.0 * view.K[1] / w;
  projection(0, 2) = 2.0 * (view.K[2] + 0.5) / w - 1.0;
  projection(1, 1) = 2.0 * view.K[4] / h;
  projection(1, 2) = 2.0 * (view.K[5] + 0.5) / h - 1.0;
  projection(2, 2) = (f + n) / (f - n);
  projection(2, 3) = -2.0 * f * n / (f - n);
  projection(3, 2) = 1.0;
  const Eigen::Matrix4d X_optical_map = view.X_map_optical.inverse().matrix();
  return {(projection * X_optical_map).cast<float>(),
          X_optical_map.row(2).transpose().cast<float>()};
}

// Two triangles a-b-c, a-c-d: x, y, z and the packed colour per vertex.
void AppendQuad(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                const Eigen::Vector3d& d, std::uint32_t colour, std::vector<float>* vertices) {
  for (const Eigen::Vector3d* p : {&a, &b, &c, &a, &c, &d}) {
    vertices->push_back(static_cast<float>(p->x()));
    vertices->push_back(static_cast<float>(p->y()));
    vertices->push_back(static_cast<float>(p->z()));
    float bits = 0.0f;
    std::memcpy(&bits, &colour, 4);
    vertices->push_back(bits);
  }
}

// The floor: a square about the camera holding every floor point within the far plane.
void AppendFloor(const GlView& view, std::vector<float>* vertices) {
  const int w = view.width_px, h = view.height_px;
  const double half_w = std::max(view.K[2] + 0.5, w - 0.5 - view.K[2]) / view.K[0];
  const double half_h = std::max(view.K[5] + 0.5, h - 0.5 - view.K[5]) / view.K[4];
  const double reach = view.far_m * std::sqrt(1.0 + half_w * half_w + half_h * half_h) + 1.0;
  const Eigen::Vector3d eye = view.X_map_optical.translation();
  AppendQuad({eye.x() - reach, eye.y() - reach, 0.0}, {eye.x() + reach, eye.y() - reach, 0.0},
             {eye.x() + reach, eye.y() + reach, 0.0}, {eye.x() - reach, eye.y() + reach, 0.0},
             PackColour({0, 0, 0}, 0), vertices);
}

// A prism's six faces, in PrismFaceColours' order; nothing for a flat one.
void AppendPrism(const Prism& prism, std::vector<float>* vertices) {
  const world::OrientedBox& box = prism.footprint;
  if (!(box.length_m > 0.0 && box.width_m > 0.0 && prism.height_m > 0.0)) return;
  const std::array<Bgr, 7> faces = PrismFaceColours(prism);
  const double c = std::cos(box.pose.yaw_rad), s = std::sin(box.pose.yaw_rad);
  const auto corner = [&](double sx, double sy, double z) {
    const double lx = 0.5 * sx * box.length_m, ly = 0.5 * sy * box.width_m;
    return Eigen::Vector3d(box.pose.x_m + c * lx - s * ly, box.pose.y_m + s * lx + c * ly, z);
  };
  const double top = prism.height_m;
  const auto quad = [&](const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                        const Eigen::Vector3d& cc, const Eigen::Vector3d& d, int face) {
    AppendQuad(a, b, cc, d, PackColour(faces[face], 255), vertices);
  };
  quad(corner(-1, -1, 0), corner(-1, 1, 0), corner(-1, 1, top), corner(-1, -1, top), 0);
  quad(corner(1, -1, 0), corner(1, 1, 0), corner(1, 1, top), corner(1, -1, top), 1);
  quad(corner(-1, -1, 0), corner(1, -1, 0), corner(1, -1, top), corner(-1, -1, top), 2);
  quad(corner(-1, 1, 0), corner(1, 1, 0), corner(1, 1, top), corner(-1, 1, top), 3);
  quad(corner(-1, -1, top), corner(1, -1, top), corner(1, 1, top), corner(-1, 1, top), 4);
  quad(corner(-1, -1, 0), corner(1, -1, 0), corner(1, 1, 0), corner(-1, 1, 0), 5);
}

}  // namespace

void GlScene::Render(const GlView& view, std::span<const Prism> prisms, GlFrame* out,
                     GlImages wanted) {
  if (!(view.width_px > 0 && view.height_px > 0 && view.near_m > 0.0 && view.far_m > view.near_m &&
        view.K[0] > 0.0 && view.K[4] > 0.0)) {
    throw std::invalid_argument(
        "GlScene::Render: a view needs a size, fx, fy > 0 and 0 < near < far");
  }
  context_->MakeCurrent();
  ClearTarget(view.width_px, view.height_px);
  vertices_.clear();
  AppendFloor(view, &vertices_);
  for (const Prism& prism : prisms) AppendPrism(prism, &vertices_);
  const ViewTransforms transforms = TransformsOf(view);
  Draw(transforms.clip_from_map, transforms.optical_z_row, view.far_m);
  ReadBack(view.width_px, view.height_px, wanted, out);
  CheckGl("rendering a view");
}

void GlScene::ClearTarget(int w, int h) {
  Target& target = TargetOfSize(w, h);
  glBindFramebuffer(GL_FRAMEBUFFER, target.framebuffer);
  glViewport(0, 0, w, h);
  const std::array<GLenum, 2> draw{GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1};
  glDrawBuffers(2, draw.data());
  glDisable(GL_DITHER);
  glDisable(GL_BLEND);
  glDisable(GL_CULL_FACE);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LESS);  // the first drawn wins a tie: the floor, then the prisms in order
  const std::array<float, 4> surround = Normalized(surround_);
  const std::array<float, 4> no_z{0.0f, 0.0f, 0.0f, 0.0f};
  glClearBufferfv(GL_COLOR, 0, surround.data());
  glClearBufferfv(GL_COLOR, 1, no_z.data());
  glClearBufferfi(GL_DEPTH_STENCIL, 0, 1.0f, 0);
}

void GlScene::Draw(const Eigen::Matrix4f& clip_from_map, const Eigen::Vector4f& optical_z_row,
                   double far_m) {
  glUseProgram(program_);
  glUniformMatrix4fv(clip_from_map_at_, 1, GL_FALSE, clip_from_map.data());
  glUniform4fv(optical_z_row_at_, 1, optical_z_row.data());
  glUniform1f(far_at_, static_cast<float>(far_m));
  glActiveTexture(GL_TEXTURE0);
  glBindTexture(GL_TEXTURE_2D, floor_texture_);
  glBindVertexArray(vertex_array_);
  glBindBuffer(GL_ARRAY_BUFFER, vertex_buffer_);
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(vertices_.size() * sizeof(float)),
               vertices_.data(), GL_STREAM_DRAW);
  glDrawArrays(GL_TRIANGLES, 0, static_cast<GLsizei>(vertices_.size() / 4));
}

// Colour as B, G, R, A bytes, then the optical z; only what is wanted.
void GlScene::ReadBack(int w, int h, GlImages wanted, GlFrame* out) {
  const std::size_t pixels = static_cast<std::size_t>(w) * h;
  out->width = w;
  out->height = h;
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  if (wanted.colour) {
    out->bgr.resize(3 * pixels);
    glReadBuffer(GL_COLOR_ATTACHMENT0);
    rgba_bytes_.resize(4 * pixels);
    glReadPixels(0, 0, w, h, GL_RGBA, GL_UNSIGNED_BYTE, rgba_bytes_.data());
    cv::cvtColor(cv::Mat(h, w, CV_8UC4, rgba_bytes_.data()),
                 cv::Mat(h, w, CV_8UC3, out->bgr.data()), cv::COLOR_RGBA2RGB);
  }
  if (!wanted.z) return;
  out->z_m.resize(pixels);
  glReadBuffer(GL_COLOR_ATTACHMENT1);
  if (read_red_) {
    glReadPixels(0, 0, w, h, GL_RED, GL_FLOAT, out->z_m.data());
  } else {
    rgba_floats_.resize(4 * pixels);
    glReadPixels(0, 0, w, h, GL_RGBA, GL_FLOAT, rgba_floats_.data());
    for (std::size_t i = 0; i < pixels; ++i) out->z_m[i] = rgba_floats_[4 * i];
  }
}

// --- GlCameraRenderer -------------------------------------------------------------------------

GlCameraRenderer::GlCameraRenderer(std::shared_ptr<GlScene> scene,
                                   std::shared_ptr<const CameraRays> rays)
    : scene_(std::move(scene)), rays_(std::move(rays)) {
  if (scene_ == nullptr || rays_ == nullptr) {
    throw std::invalid_argument("GlCameraRenderer needs a scene and the camera's rays");
  }
  const CameraParams& params = camera().params();
  pinhole_.near_m = kProjectionNearZ_m;
  pinhole_.far_m = params.clip_far_m;
  resample_ = params.lens_distortion;
  if (!resample_) {
    pinhole_.width_px = params.width_px;
    pinhole_.height_px = params.height_px;
    pinhole_.K = params.K;
    return;
  }
  // a pinhole image over every ray of the raw image, kDistortedSupersampling times finer
  const std::vector<float>& rx = rays_->ray_x();
  const std::vector<float>& ry = rays_->ray_y();
  const auto [x_lo, x_hi] = std::minmax_element(rx.begin(), rx.end());
  const auto [y_lo, y_hi] = std::minmax_element(ry.begin(), ry.end());
  const double fx = kDistortedSupersampling * params.K[0];
  const double fy = kDistortedSupersampling * params.K[4];
  const double cx = -fx * *x_lo + 1.0, cy = -fy * *y_lo + 1.0;
  const double width = std::ceil(fx * (*x_hi - *x_lo)) + 3.0;
  const double height = std::ceil(fy * (*y_hi - *y_lo)) + 3.0;
  if (!(width <= kMaxPinholePx && height <= kMaxPinholePx)) {
    throw GlUnavailable("the GL backend would render camera '" + params.name + "' through a " +
                        std::to_string(width) + " x " + std::to_string(height) +
                        " px pinhole image (its lens distortion sees too wide a field); at most " +
                        std::to_string(kMaxPinholePx) + " px a side");
  }
  pinhole_.width_px = static_cast<int>(width);
  pinhole_.height_px = static_cast<int>(height);
  pinhole_.K = {fx, 0.0, cx, 0.0, fy, cy, 0.0, 0.0, 1.0};
  // each raw pixel: where its ray is in the pinhole image, and the pinhole pixel nearest to it
  map_xy_.resize(2 * rx.size());
  exact_xy_.resize(2 * rx.size());
  for (std::size_t i = 0; i < rx.size(); ++i) {
    exact_xy_[2 * i] = static_cast<float>(fx * rx[i] + cx);
    exact_xy_[2 * i + 1] = static_cast<float>(fy * ry[i] + cy);
    const long u = std::lround(exact_xy_[2 * i]), v = std::lround(exact_xy_[2 * i + 1]);
    map_xy_[2 * i] = static_cast<std::int16_t>(std::clamp(u, 0L, pinhole_.width_px - 1L));
    map_xy_[2 * i + 1] = static_cast<std::int16_t>(std::clamp(v, 0L, pinhole_.height_px - 1L));
  }
}

void GlCameraRenderer::Render(const world::Pose2& X_map_car, std::span<const Prism> prisms,
                              ColorImage* color, DepthImage* depth) {
  const CameraParams& params = camera().params();
  const int w = params.width_px, h = params.height_px;
  const std::size_t pixels = static_cast<std::size_t>(w) * h;
  if (color != nullptr) {
    color->width = w;
    color->height = h;
    color->bgr.resize(3 * pixels);
  }
  if (depth != nullptr) {
    depth->width = w;
    depth->height = h;
    depth->mm.resize(pixels);
  }
  pinhole_.X_map_optical = camera().X_map_camera(X_map_car);
  // a camera inside a prism sees its inside, unshaded, at depth 0 (the ray caster's face 6)
  const Eigen::Vector3d eye = pinhole_.X_map_optical.translation();
  for (const Prism& prism : prisms) {
    const world::OrientedBox& box = prism.footprint;
    const double c = std::cos(box.pose.yaw_rad), s = std::sin(box.pose.yaw_rad);
    const double dx = eye.x() - box.pose.x_m, dy = eye.y() - box.pose.y_m;
    if (std::abs(c * dx + s * dy) < 0.5 * box.length_m &&
        std::abs(-s * dx + c * dy) < 0.5 * box.width_m && eye.z() > 0.0 &&
        eye.z() < prism.height_m) {
      const Bgr inside = PrismFaceColours(prism)[6];
      if (color != nullptr) {
        for (std::size_t i = 0; i < pixels; ++i) std::memcpy(&color->bgr[3 * i], inside.data(), 3);
      }
      if (depth != nullptr) std::fill(depth->mm.begin(), depth->mm.end(), 0);
      return;
    }
  }
  scene_->Render(pinhole_, prisms, &frame_,
                 GlImages{.colour = color != nullptr, .z = depth != nullptr});
  const cv::Mat map = resample_ ? cv::Mat(h, w, CV_16SC2, map_xy_.data()) : cv::Mat();
  if (color != nullptr) {
    const cv::Mat frame_bgr(frame_.height, frame_.width, CV_8UC3, frame_.bgr.data());
    cv::Mat out(h, w, CV_8UC3, color->bgr.data());
    if (resample_) {
      cv::remap(frame_bgr, out, map, cv::noArray(), cv::INTER_NEAREST);
    } else {
      frame_bgr.copyTo(out);
    }
  }
  if (depth == nullptr) return;
  if (!resample_) {
    for (std::size_t i = 0; i < pixels; ++i) {
      depth->mm[i] = DepthMillimetres(frame_.z_m[i], params.clip_near_m, params.clip_far_m);
    }
    return;
  }
  // Depth under distortion: 1/z is linear across the image of a plane, so its bilinear
  // interpolation at the ray's exact position is the plane's depth there; where the four pinhole
  // pixels around it do not lie on one surface (the interpolated depth strays from the nearest
  // pixel's by more than 10 %, or one has no return), the nearest pixel's depth.
  inverse_z_.resize(frame_.z_m.size());
  for (std::size_t i = 0; i < frame_.z_m.size(); ++i) {
    inverse_z_[i] = frame_.z_m[i] > 0.0f ? 1.0f / frame_.z_m[i] : 0.0f;
  }
  nearest_z_.resize(pixels);
  interpolated_inverse_z_.resize(pixels);
  cv::Mat nearest(h, w, CV_32FC1, nearest_z_.data());
  cv::Mat interpolated(h, w, CV_32FC1, interpolated_inverse_z_.data());
  cv::remap(cv::Mat(frame_.height, frame_.width, CV_32FC1, frame_.z_m.data()), nearest, map,
            cv::noArray(), cv::INTER_NEAREST);
  cv::remap(cv::Mat(frame_.height, frame_.width, CV_32FC1, inverse_z_.data()), interpolated,
            cv::Mat(h, w, CV_32FC2, exact_xy_.data()), cv::noArray(), cv::INTER_LINEAR);
  for (std::size_t i = 0; i < pixels; ++i) {
    float z = nearest_z_[i];
    const float inverse = interpolated_inverse_z_[i];
    if (z > 0.0f && inverse > 0.0f && std::abs(1.0f / inverse - z) <= kOneSurfaceTolerance * z) {
      z = 1.0f / inverse;
    }
    depth->mm[i] = DepthMillimetres(z, params.clip_near_m, params.clip_far_m);
  }
}

}  // namespace autonomsim::vehicle
