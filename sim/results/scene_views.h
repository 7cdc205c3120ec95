// Views of a run in 3D, for people: a chase camera behind a chosen car and an overview of the
// whole track from above one side, rasterised offscreen by the GL backend (vehicle/gl_camera.h)
// from the same floor and boxes the cameras see. The cars wear their colours of the run's other
// figures (track_figure.h: the top-down video, the report), each with its id above it, and each
// view its title and clock in a corner. For `autonomsim video --chase ID --overview` and the
// report's stills.
#pragma once

#include <memory>
#include <opencv2/core.hpp>
#include <string>

#include "sim/results/render.h"
#include "sim/scenario/scenario.h"
#include "vehicle/gl_camera.h"
#include "world/track.h"

namespace autonomsim::sim {

// Where the views look from. The figures are picked to read well on the lab's 5 m track.
struct SceneViewParams {
  double chase_behind_m{1.1};      // the chase camera: this far behind the car's centre,
  double chase_height_m{0.65};     // this high,
  double chase_look_ahead_m{0.9};  // looking at the floor this far ahead of the car
  double chase_hfov_deg{75.0};
  double overview_back{0.80};        // the overview: back (south) from the track's centre and up,
  double overview_height{1.05};      // in track sizes,
  double overview_look_south{0.12};  // looking at the floor this far south of the centre
  double overview_hfov_deg{68.0};
  double near_m{0.02};  // nothing nearer to the camera (optical z) is drawn,
  double far_m{40.0};   // nothing farther
};

class SceneViews {
 public:
  // vehicle::GlUnavailable where no OpenGL ES context can be made.
  SceneViews(const world::Track& track, const Scenario& scenario, SceneViewParams params = {});

  // BGR8 images of `size`. Chase: std::invalid_argument if car `car_id` is not in the snapshot.
  cv::Mat Chase(const WorldSnapshot& snapshot, int car_id, cv::Size size);
  cv::Mat Overview(const WorldSnapshot& snapshot, cv::Size size);
  // "llvmpipe (LLVM 15.0.6, 256 bits)" or a GPU's name.
  const std::string& renderer() const { return scene_->context().renderer(); }

 private:
  cv::Mat Draw(const Eigen::Vector3d& eye, const Eigen::Vector3d& target, double hfov_deg,
               cv::Size size, const WorldSnapshot& snapshot, const std::string& title);

  SceneViewParams params_;
  vehicle::SceneAppearance appearance_;  // the scenario's, with the cars' figure colours
  Eigen::Vector2d centre_m_;
  double size_m_;
  std::shared_ptr<vehicle::GlScene> scene_;
  vehicle::GlFrame frame_;
};

}  // namespace autonomsim::sim
