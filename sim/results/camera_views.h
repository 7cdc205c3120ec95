// What a car's cameras saw at one instant, as a person reads it: the colour image with the lane
// detection's output drawn in (the region its warp reads, the line it fitted, the trajectory it
// sends), and the depth image in false colour with a colour bar. For the report's snapshots at a
// failure and the video's camera panels; the images come from the project's own renderer
// (render.h) and the lane detector the car's stack runs (stack/lane_detection.h).
#pragma once

#include <opencv2/core.hpp>
#include <optional>
#include <string>

#include "sim/results/render.h"
#include "stack/lane_detection.h"

namespace autonomsim::sim {

struct CameraViewImages {
  cv::Mat color;     // BGR8 with the lane output drawn in; empty if no camera publishes colour
  cv::Mat depth;     // BGR8 false colour with its colour bar; empty if none publishes depth
  std::string lane;  // what the lane detection found, in words ("" for a car without a board)
};

// One car's cameras and, for a car with a board, its lane detector: made once, rendered at any
// number of instants.
class CarCameraViewer {
 public:
  // std::invalid_argument if the scenario has no car `car_id`.
  CarCameraViewer(const world::Track& track, const Scenario& scenario, int car_id);

  int car_id() const { return car_id_; }
  CameraViewImages Render(const WorldSnapshot& snapshot, const RngStreams& streams);

 private:
  int car_id_;
  CarCameras cameras_;
  std::optional<stack::LaneDetector> lanes_;  // a car with perception
};

}  // namespace autonomsim::sim
