#include "sim/results/camera_views.h"

#include <fmt/format.h>

#include <algorithm>
#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <vector>

#include "sim/car/perception_nodes.h"

namespace autonomsim::sim {
namespace {

const CarConfig& CarOf(const Scenario& scenario, int car_id) {
  const CarConfig* car = scenario.FindCar(car_id);
  if (car == nullptr) {
    throw std::invalid_argument("the scenario has no car " + std::to_string(car_id));
  }
  return *car;
}

const cv::Scalar kWarpRegionBgr(160, 160, 160), kTrajectoryBgr(80, 230, 80),
    kYellowLineBgr(0, 230, 255), kWhiteLineBgr(255, 255, 255);

// The bird's-eye curve col = f(row), rows 0..height, drawn in the raw image through the inverse
// warp.
void DrawBirdsEyeCurve(cv::Mat& image, const stack::RowPolynomial& curve, const cv::Mat& to_image,
                       const cv::Scalar& colour, int thickness) {
  std::vector<cv::Point2d> birds_eye;
  for (int row = 0; row <= image.rows; row += 8) birds_eye.emplace_back(curve(row), row);
  std::vector<cv::Point2d> in_image;
  cv::perspectiveTransform(birds_eye, in_image, to_image);
  std::vector<cv::Point> polyline;
  for (const cv::Point2d& p : in_image) {
    if (std::abs(p.x) < 1e5 && std::abs(p.y) < 1e5)
      polyline.emplace_back(cvRound(p.x), cvRound(p.y));
  }
  cv::polylines(image, polyline, false, cv::Scalar(0, 0, 0), thickness + 2, cv::LINE_AA);
  cv::polylines(image, polyline, false, colour, thickness, cv::LINE_AA);
}

std::string LaneInWords(const stack::LaneDetectionTrace& trace, const stack::LanePoints& out) {
  const std::string line = trace.line == stack::LaneLine::kYellow  ? "yellow line"
                           : trace.line == stack::LaneLine::kWhite ? "white line"
                                                                   : "no line";
  std::string counts = fmt::format("yellow {} px", trace.yellow_px);
  if (trace.white_px >= 0) counts += fmt::format(", white {} px", trace.white_px);
  return fmt::format("lane detection: {} ({}), {}", line, counts,
                     out.valid ? "trajectory sent" : "invalid (no trajectory)");
}

}  // namespace

CarCameraViewer::CarCameraViewer(const world::Track& track, const Scenario& scenario, int car_id)
    : car_id_(car_id),
      cameras_(track, CarOf(scenario, car_id).sensors, scenario.appearance,
               scenario.camera_backend) {
  const CarConfig& car = CarOf(scenario, car_id);
  const vehicle::CameraParams& color = car.sensors.color_camera.camera;
  if (car.has_board() && color.width_px == 640 && color.height_px == 480) {
    lanes_.emplace(car.perception.lane_detection, LaneCalibration(vehicle::CameraModel(color)));
  }
}

CameraViewImages CarCameraViewer::Render(const WorldSnapshot& snapshot, const RngStreams& streams) {
  CameraViewImages views;
  for (RenderedCamera& camera : cameras_.Render(snapshot, car_id_, streams)) {
    if (camera.has_color && views.color.empty()) {
      cv::Mat bgr(camera.color.height, camera.color.width, CV_8UC3, camera.color.bgr.data());
      views.color = bgr.clone();
      if (lanes_) {
        stack::LaneDetectionTrace trace;
        const stack::LanePoints out = lanes_->Step(bgr, &trace);
        const cv::Mat& to_image = lanes_->birds_eye_to_image();
        std::vector<cv::Point> region;
        for (const auto& [u, v] : lanes_->params().warp_source_px) {
          region.emplace_back(cvRound(u), cvRound(v));
        }
        std::swap(region[2], region[3]);  // around the quadrilateral, not across it
        cv::polylines(views.color, region, true, kWarpRegionBgr, 1, cv::LINE_AA);
        if (trace.line_fit) {
          DrawBirdsEyeCurve(views.color, *trace.line_fit, to_image,
                            trace.line == stack::LaneLine::kYellow ? kYellowLineBgr : kWhiteLineBgr,
                            2);
        }
        if (trace.trajectory && out.valid) {
          DrawBirdsEyeCurve(views.color, *trace.trajectory, to_image, kTrajectoryBgr, 3);
        }
        views.lane = LaneInWords(trace, out);
      }
    }
    if (camera.has_depth && views.depth.empty()) {
      views.depth = DepthPreviewWithColourBar(camera.depth, camera.params.clip_near_m,
                                              camera.params.clip_far_m);
    }
  }
  return views;
}

}  // namespace autonomsim::sim
