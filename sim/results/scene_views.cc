#include "sim/results/scene_views.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

#include "sim/results/track_figure.h"
#include "world/floor_raster.h"

namespace autonomsim::sim {
namespace {

const cv::Scalar kViewText(235, 235, 235), kViewShadow(0, 0, 0);
constexpr int kViewFont = cv::FONT_HERSHEY_SIMPLEX;

void ViewText(cv::Mat& image, const std::string& text, cv::Point at, double scale, int thickness) {
  cv::putText(image, text, at, kViewFont, scale, kViewShadow, thickness + 3, cv::LINE_AA);
  cv::putText(image, text, at, kViewFont, scale, kViewText, thickness, cv::LINE_AA);
}

}  // namespace

SceneViews::SceneViews(const world::Track& track, const Scenario& scenario, SceneViewParams params)
    : params_(params), appearance_(scenario.appearance) {
  // the cars in their colours of the run's other figures (car_body_rgb is by id)
  int last_id = 0;
  for (const CarConfig& car : scenario.cars) last_id = std::max(last_id, car.id);
  appearance_.car_body_rgb.assign(static_cast<std::size_t>(last_id) + 1, {0, 0, 0});
  for (const CarConfig& car : scenario.cars) {
    const cv::Scalar bgr = CarColourBgr(scenario, car.id);
    appearance_.car_body_rgb[static_cast<std::size_t>(car.id)] = {
        static_cast<int>(bgr[2]), static_cast<int>(bgr[1]), static_cast<int>(bgr[0])};
  }
  const world::FloorRaster floor = world::RasterizeFloor(track);
  size_m_ = std::max(floor.width_px, floor.height_px) * floor.m_per_px;
  centre_m_ = Eigen::Vector2d(floor.origin_m.x() + 0.5 * floor.width_px * floor.m_per_px,
                              floor.origin_m.y() - 0.5 * floor.height_px * floor.m_per_px);
  scene_ = std::make_shared<vehicle::GlScene>(vehicle::GlContext::Create(),
                                              vehicle::FloorTexture(floor), appearance_.surround());
}

cv::Mat SceneViews::Chase(const WorldSnapshot& snapshot, int car_id, cv::Size size) {
  const auto car = std::find_if(snapshot.cars.begin(), snapshot.cars.end(),
                                [&](const CarBody& c) { return c.id == car_id; });
  if (car == snapshot.cars.end()) {
    throw std::invalid_argument("no car " + std::to_string(car_id) + " in the run");
  }
  const Eigen::Vector2d at(car->pose.x_m, car->pose.y_m);
  const Eigen::Vector2d heading(std::cos(car->pose.yaw_rad), std::sin(car->pose.yaw_rad));
  const Eigen::Vector2d eye = at - params_.chase_behind_m * heading;
  const Eigen::Vector2d target = at + params_.chase_look_ahead_m * heading;
  return Draw({eye.x(), eye.y(), params_.chase_height_m}, {target.x(), target.y(), 0.0},
              params_.chase_hfov_deg, size, snapshot, fmt::format("chase: car {}", car_id));
}

cv::Mat SceneViews::Overview(const WorldSnapshot& snapshot, cv::Size size) {
  const Eigen::Vector3d eye(centre_m_.x(), centre_m_.y() - params_.overview_back * size_m_,
                            params_.overview_height * size_m_);
  const Eigen::Vector3d target(centre_m_.x(), centre_m_.y() - params_.overview_look_south * size_m_,
                               0.0);
  return Draw(eye, target, params_.overview_hfov_deg, size, snapshot, "overview from the south");
}

cv::Mat SceneViews::Draw(const Eigen::Vector3d& eye, const Eigen::Vector3d& target, double hfov_deg,
                         cv::Size size, const WorldSnapshot& snapshot, const std::string& title) {
  // the optical frame: z at the target, x to the right (level), y down
  const Eigen::Vector3d z = (target - eye).normalized();
  const Eigen::Vector3d x = z.cross(Eigen::Vector3d::UnitZ()).normalized();
  const Eigen::Vector3d y = z.cross(x);
  vehicle::GlView view;
  view.width_px = size.width;
  view.height_px = size.height;
  const double f = 0.5 * size.width / std::tan(0.5 * hfov_deg * std::numbers::pi / 180.0);
  view.K = {f, 0.0, 0.5 * (size.width - 1), 0.0, f, 0.5 * (size.height - 1), 0.0, 0.0, 1.0};
  view.X_map_optical.linear() << x, y, z;
  view.X_map_optical.translation() = eye;
  view.near_m = params_.near_m;
  view.far_m = params_.far_m;

  const std::vector<vehicle::Prism> prisms =
      ScenePrisms(snapshot.cars, snapshot.obstacles, appearance_, /*exclude_car_id=*/-1);
  scene_->Render(view, prisms, &frame_, vehicle::GlImages{.colour = true, .z = false});
  cv::Mat image = cv::Mat(size, CV_8UC3, frame_.bgr.data()).clone();

  // each car's id above its roof
  const Eigen::Isometry3d X_optical_map = view.X_map_optical.inverse();
  for (const CarBody& car : snapshot.cars) {
    const Eigen::Vector3d p =
        X_optical_map * Eigen::Vector3d(car.pose.x_m, car.pose.y_m, car.height_m + 0.06);
    if (p.z() <= view.near_m) continue;
    const cv::Point at(static_cast<int>(std::lround(f * p.x() / p.z() + view.K[2])) - 8,
                       static_cast<int>(std::lround(f * p.y() / p.z() + view.K[5])));
    if (at.x < -20 || at.y < 0 || at.x > size.width || at.y > size.height + 20) continue;
    ViewText(image, std::to_string(car.id), at, 0.6, 2);
  }
  ViewText(image, title, {10, 24}, 0.6, 1);
  ViewText(image, fmt::format("t = {:.2f} s", ToSeconds(snapshot.t)), {size.width - 120, 24}, 0.55,
           1);
  return image;
}

}  // namespace autonomsim::sim
