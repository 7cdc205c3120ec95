// A second, independent way to make the cameras' images: the floor and the prisms rasterised with
// OpenGL ES 3 in an offscreen EGL context (no window, no display), beside the ray caster
// (ray_caster.h), which stays the default. Same scene, same camera model, same output: a
// GlCameraRenderer's images mean exactly what a CameraRenderer's do, so either can feed the
// stack, the render command or a dataset, and each checks the other (tests/gl_camera_test.cc).
//
// How the images are made, and where they can differ from the ray caster's:
//  - Geometry: one perspective projection from the camera's K (pixel (u, v) is the centre of
//    column u, row v, as in OpenCV), the optical frame from CameraModel::X_map_camera, the far
//    plane at clip_far_m. The floor is one quad whose fragments look their texel up by its exact
//    integer index (texelFetch, no filtering), the bare-floor colour beyond the raster; a prism is
//    six quads, each in its face's colour from PrismFaceColours (the ray caster's shading).
//  - Depth: each fragment writes its optical z (interpolated perspective-correctly, in float) to a
//    float colour attachment, and z / far as its window depth (linear, so that the depth test
//    resolves millimetres at any distance); the CPU turns it into uint16 millimetres with the ray
//    caster's rule (round half up, 0 outside [clip_near_m, clip_far_m]).
//  - Lens distortion (the colour camera's raw image): the pinhole image is rendered at
//    kDistortedSupersampling times the camera's focal length over the whole field of view, and
//    each raw pixel takes the colour of the pinhole pixel nearest to its own undistorted ray
//    (cv::remap, nearest neighbour, with the rays of CameraRays as the map), and the depth of its
//    ray's exact position (1/z interpolated bilinearly, exact on a plane; the nearest pixel's
//    where the four around it are not one surface). Without distortion the rasteriser's pixel
//    centres are the camera's own rays and nothing is resampled.
//  - What differs: float rounding where a ray meets a texel's or a face's border (a pixel there
//    may take the neighbour's colour, and its depth may round to the next millimetre), and, with
//    distortion, the resampling: a raw pixel near a painted line's edge can take the colour its
//    neighbour a quarter of a pixel away sees.
//  - A camera inside a prism sees the prism's unshaded colour all over and no depth, as the ray
//    caster does.
//
// Cost: a frame is a clear, one draw call, a read-back of the colour and the depth attachments
// (8 bytes per pixel), and a remap with distortion. Frames allocate nothing once sized. Contexts
// are per thread: a renderer makes its context current before it draws.
#pragma once

#include <Eigen/Geometry>
#include <array>
#include <memory>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include "vehicle/camera_model.h"
#include "vehicle/ray_caster.h"

namespace autonomsim::vehicle {

// No EGL display or OpenGL ES 3 context could be made here; what() says what failed.
class GlUnavailable : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// An OpenGL ES 3 context with no window. Create() takes, in this order, a hardware EGL device
// (EGL_EXT_platform_device: a GPU with its vendor's driver), Mesa's surfaceless platform
// (EGL_PLATFORM_SURFACELESS_MESA: llvmpipe on a machine without a GPU), then a software EGL
// device. The EGL display is the process's and stays initialized until exit (terminating it
// would pull it from under every other context of the process).
class GlContext {
 public:
  static std::shared_ptr<GlContext> Create();  // GlUnavailable if none can be made
  ~GlContext();
  GlContext(const GlContext&) = delete;
  GlContext& operator=(const GlContext&) = delete;

  // "llvmpipe (LLVM 15.0.6, 256 bits)" or a GPU's name, and the EGL platform it came from.
  const std::string& renderer() const { return renderer_; }
  const std::string& platform() const { return platform_; }
  // Makes the context current on the calling thread (nothing if it is already).
  void MakeCurrent() const;

 private:
  GlContext() = default;
  void* display_{nullptr};  // EGLDisplay
  void* context_{nullptr};  // EGLContext
  std::string renderer_;
  std::string platform_;
};

// A perspective view of the scene: any pinhole camera anywhere (the cameras on a car, a chase
// camera, an overview of the track). K in pixels, OpenCV's convention; X_map_optical the optical
// frame (z forward, x right, y down) in the map frame, with z = 0 the floor.
struct GlView {
  int width_px{0};
  int height_px{0};
  std::array<double, 9> K{};  // row-major
  Eigen::Isometry3d X_map_optical{Eigen::Isometry3d::Identity()};
  double near_m{1e-3};  // the projection's planes, optical z: nothing nearer or farther is drawn
  double far_m{10.0};
};

// What one view rendered: BGR8 and the optical z of each pixel (0 where only the surround is).
struct GlFrame {
  int width{0};
  int height{0};
  std::vector<std::uint8_t> bgr;
  std::vector<float> z_m;
};

// Which of a GlFrame's images a render reads back.
struct GlImages {
  bool colour{true};
  bool z{true};
};

// The scene on the GPU: the floor texture, the shaders, the prisms' vertex buffer, and the
// offscreen framebuffers (one per view size, kept). One per context; not thread-safe.
class GlScene {
 public:
  // GlUnavailable if the floor is larger than the context's largest texture or the context lacks
  // float colour attachments (EXT_color_buffer_float).
  GlScene(std::shared_ptr<GlContext> context, const FloorTexture& floor, Bgr surround);
  ~GlScene();
  GlScene(const GlScene&) = delete;
  GlScene& operator=(const GlScene&) = delete;

  const GlContext& context() const { return *context_; }
  Bgr surround() const { return surround_; }
  // The view of the floor and `prisms`, into `out` (resized); only the images asked for are read
  // back (the read-back is most of a frame's cost on a CPU renderer).
  void Render(const GlView& view, std::span<const Prism> prisms, GlFrame* out,
              GlImages wanted = GlImages{});

 private:
  struct Target;
  Target& TargetOfSize(int width, int height);
  // The steps of Render: a cleared target of the view's size, the draw of vertices_, the read-back.
  void ClearTarget(int width, int height);
  void Draw(const Eigen::Matrix4f& clip_from_map, const Eigen::Vector4f& optical_z_row,
            double far_m);
  void ReadBack(int width, int height, GlImages wanted, GlFrame* out);

  std::shared_ptr<GlContext> context_;
  Bgr surround_;
  unsigned program_{0}, floor_texture_{0}, vertex_array_{0}, vertex_buffer_{0};
  int clip_from_map_at_{-1}, optical_z_row_at_{-1}, far_at_{-1};  // the per-view uniforms
  int floor_texels_[2]{0, 0};
  std::vector<std::unique_ptr<Target>> targets_;
  std::vector<float> vertices_;  // scratch: x, y, z and a packed colour per vertex
  bool read_red_{true};          // the float attachment reads back as GL_RED (else GL_RGBA)
  std::vector<std::uint8_t> rgba_bytes_;  // scratch: read-backs
  std::vector<float> rgba_floats_;
};

// One camera on a car, rendered by `scene`: Render's images are those CameraRenderer::Render
// makes (see the opening comment for where they can differ).
class GlCameraRenderer {
 public:
  // Rendered pinhole pixels per raw pixel, along each axis, under lens distortion.
  static constexpr int kDistortedSupersampling = 2;
  // The largest side of that pinhole image (OpenGL ES 3.0 guarantees renderbuffers of 2048;
  // desktop drivers and llvmpipe take 8192 or more); a wider field is GlUnavailable.
  static constexpr int kMaxPinholePx = 8192;

  GlCameraRenderer(std::shared_ptr<GlScene> scene, std::shared_ptr<const CameraRays> rays);

  const CameraModel& camera() const { return rays_->camera(); }
  // Either output may be null; both are resized to the camera's size.
  void Render(const world::Pose2& X_map_car, std::span<const Prism> prisms, ColorImage* color,
              DepthImage* depth);

 private:
  std::shared_ptr<GlScene> scene_;
  std::shared_ptr<const CameraRays> rays_;
  GlView pinhole_;                    // the pinhole view rendered; its pose set per frame
  bool resample_{false};              // lens distortion: remap the pinhole image
  std::vector<std::int16_t> map_xy_;  // cv::remap's nearest-neighbour map (CV_16SC2)
  std::vector<float> exact_xy_;       // the rays' exact positions in it (CV_32FC2)
  GlFrame frame_;
  std::vector<float> inverse_z_, nearest_z_, interpolated_inverse_z_;  // scratch
};

}  // namespace autonomsim::vehicle
