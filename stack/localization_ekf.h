// The car's localization (reference §6): robot_localization's EKF in two_d_mode at 20 Hz, fusing
// the IMU's yaw and yaw rate and the wheel speed (vx). There is no absolute correction on the
// real car: map→odom is a static transform set from the start pose, so the map-frame estimate
// drifts with odometry. Config: code/ros_ws/src/nav2_local/params/nav2_car_params.yaml
// (ekf_filter_node); what it leaves unset takes robot_localization's defaults.
//
// State: x = [x, y, yaw, v, ω] of base_link in the odom frame (metres, radians, m/s, rad/s).
// robot_localization's 2D state also has vy and the accelerations; nothing on the car measures
// them (imu0_config leaves the accelerations off) and a car without side slip has vy = 0, so in
// its filter they stay at zero and only widen the covariance. Prediction moves along the exact
// constant-(v, ω) arc rather than robot_localization's first-order step, so that exact sensor
// data on an arc gives the exact arc (the two differ by O(ω·dt) per 10 ms step).
//
// One Step (the node calls it every `period`):
//   measurements  every IMU reading, wheel speed and pose fix since the last Step, in stamp order
//                 (ties: IMU, wheel, fix): predict to its stamp, then correct. A measurement older
//                 than the filter's time (another sensor's newer one came first) is fused at the
//                 filter's time without predicting back, as robot_localization does; each
//                 sensor's own stamps must not go backwards (an error);
//   timeout       when the last fused measurement is sensor_timeout or more before `now`, predict
//                 to `now` (robot_localization's sensor_timeout).
// The estimate is published at the filter's time (`stamp`), not extrapolated to `now`.
//
// Pose fixes (a map-frame pose with covariance, e.g. from a marker or an oracle) are beyond the
// real car and off by default (use_pose_fix); they let studies ask what an absolute correction
// would change.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <vector>

#include "world/geometry.h"
#include "world/time.h"

namespace autonomsim::stack {

struct LocalizationEkfParams {
  Duration period{Milliseconds(50)};           // reference §6: EKF at 20 Hz (frequency: 20.0)
  Duration sensor_timeout{Milliseconds(100)};  // nav2_car_params: sensor_timeout 0.1
  // nav2_car_params: imu0_relative true, the first IMU yaw is the odom frame's zero. False: the
  // IMU yaw is the odom yaw (then X_map_odom should hold no rotation).
  bool imu_yaw_relative{true};
  // Process noise, added as Q·dt per prediction (robot_localization scales by dt): its default
  // process_noise_covariance diagonal, which the car's config keeps.
  double q_position_m2_per_s{0.05};
  double q_yaw_rad2_per_s{0.06};
  double q_speed_m2_per_s3{0.025};
  double q_yaw_rate_rad2_per_s3{0.02};
  // robot_localization's default initial_estimate_covariance: the start pose is the odom origin.
  double initial_variance{1e-9};
  // The covariances the BNO055 driver puts in every bno055/imu message, which robot_localization
  // fuses as they come: the car's config leaves the driver's variance_* parameters commented out
  // (code/ros_ws/src/nav2_local/params/nav2_car_params.yaml:385-391), so they are the driver's
  // defaults, DEFAULT_VARIANCE_ORIENTATION 0.0159 rad² and DEFAULT_VARIANCE_ANGULAR_VEL
  // 0.04 (rad/s)² (flynneva/bno055 bno055/registers.py:256-257, used in
  // bno055/sensor/SensorService.py:158-184).
  double imu_yaw_variance_rad2{0.0159};
  double imu_yaw_rate_variance_rad2_per_s2{0.04};
  // rt_hallsensor never fills the twist covariance (zeros); robot_localization raises a zero
  // variance to 1e-9, so the filter takes the Hall speed almost as is.
  double wheel_speed_variance_m2_per_s2{1e-9};
  bool use_pose_fix{false};  // beyond the real car (see above)
  // Whether the IMU's heading is fused (the car's config: imu0 yaw true,
  // code/ros_ws/src/nav2_local/params/nav2_car_params.yaml:341-346). False fuses its yaw rate
  // only, as robot_localization users do when another source owns the heading: worth it with a
  // heading that drifts (vehicle::ImuHeadingSource::kGyro) beside a pose fix. The lab's BNO055
  // heading is magnetometer-referenced and does not drift, and every preset fuses it.
  bool fuse_imu_yaw{true};

  template <class V>
  void Describe(V& v) {
    v("period_s", period, "how often the EKF runs");
    v("sensor_timeout_s", sensor_timeout,
      "without a measurement for this long the EKF predicts on to now");
    v("imu_yaw_relative", imu_yaw_relative,
      "the first IMU heading is the odom frame's zero (false: the IMU heading is the odom "
      "heading)");
    v("q_position_m2_per_s", q_position_m2_per_s,
      "process noise of x and y, added as Q·dt per prediction");
    v("q_yaw_rad2_per_s", q_yaw_rad2_per_s, "process noise of the heading");
    v("q_speed_m2_per_s3", q_speed_m2_per_s3, "process noise of the speed");
    v("q_yaw_rate_rad2_per_s3", q_yaw_rate_rad2_per_s3, "process noise of the yaw rate");
    v("initial_variance", initial_variance,
      "the initial covariance's diagonal (the start pose is the odom origin)");
    v("imu_yaw_variance_rad2", imu_yaw_variance_rad2,
      "the variance each IMU message gives its heading");
    v("imu_yaw_rate_variance_rad2_per_s2", imu_yaw_rate_variance_rad2_per_s2,
      "the variance each IMU message gives its yaw rate");
    v("wheel_speed_variance_m2_per_s2", wheel_speed_variance_m2_per_s2,
      "the variance each wheel-speed message gives its speed");
    v("use_pose_fix", use_pose_fix,
      "fuse the external pose fix (`stack.pose_fix`), beyond the real car");
    v("fuse_imu_yaw", fuse_imu_yaw, "fuse the IMU's heading (false: its yaw rate only)");
  }
  void Validate() const;
};

// The state vector's layout.
enum EkfIndex { kEkfX = 0, kEkfY, kEkfYaw, kEkfSpeed, kEkfYawRate, kEkfSize };
using EkfVector = Eigen::Matrix<double, kEkfSize, 1>;
using EkfMatrix = Eigen::Matrix<double, kEkfSize, kEkfSize>;

// bno055/imu, reduced to what the filter fuses (sensor_msgs/Imu orientation yaw, angular z).
struct ImuMeasurement {
  Time stamp{kZeroTime};
  double yaw_rad{0.0};  // the sensor's heading, in its own reference
  double yaw_rate_rad_per_s{0.0};
};

// modelcar/speed: the Hall sensor's speed (>= 0 on the real car; the sign is used as given).
struct WheelSpeedMeasurement {
  Time stamp{kZeroTime};
  double speed_mps{0.0};
};

// An absolute pose in the map frame with its covariance over (x, y, yaw); use_pose_fix only.
struct PoseFix {
  Time stamp{kZeroTime};
  world::Pose2 X_map_base;
  Eigen::Matrix3d covariance{Eigen::Matrix3d::Identity() * 1e-4};
};

struct LocalizationEkfInput {
  Time now{kZeroTime};
  // Everything received since the last Step; within each list, stamps must not decrease.
  std::vector<ImuMeasurement> imu;
  std::vector<WheelSpeedMeasurement> wheel_speed;
  std::vector<PoseFix> pose_fixes;
};

struct LocalizationEkfOutput {
  Time stamp{kZeroTime};     // the estimate's time
  world::Pose2 X_odom_base;  // odometry/filtered
  world::Pose2 X_map_base;   // through the static map→odom transform
  double speed_mps{0.0};
  double yaw_rate_rad_per_s{0.0};
  EkfMatrix covariance{EkfMatrix::Zero()};  // over [x, y, yaw, v, ω] in the odom frame
  int fused{0};                             // measurements fused in this Step
  int late{0};  // of which older than the filter's time (fused without predicting back)
};

struct LocalizationEkfState {
  Time time{kZeroTime};  // the filter's time
  EkfVector mean{EkfVector::Zero()};
  EkfMatrix covariance{EkfMatrix::Zero()};
  world::Pose2 X_map_odom;  // static, from the start pose
  std::optional<double> imu_yaw_origin_rad;
  std::optional<Time> last_imu;
  std::optional<Time> last_wheel_speed;
  std::optional<Time> last_pose_fix;
  Time last_measurement{kZeroTime};
};

// The estimate jumps (a fault: a kidnapped car, a wrong fix taken): its map-frame position moves by
// (dx_m, dy_m) and its heading by dyaw_rad; the covariance stays, so the filter trusts it as
// before.
void JumpLocalizationEstimate(double dx_m, double dy_m, double dyaw_rad,
                              LocalizationEkfState* state);

// The filter at rest at the odom origin at `start`, with map→odom = the start pose (the real
// car's static transform). Validates params.
LocalizationEkfState InitialLocalizationEkfState(const LocalizationEkfParams& params, Time start,
                                                 const world::Pose2& X_map_odom);

// Throws std::invalid_argument (naming the sensor and the stamps) on non-finite values, a
// sensor's stamps going backwards, a stamp after `now`, `now` before the filter's time, a pose
// fix while use_pose_fix is off, or a fix covariance that is not symmetric positive definite.
LocalizationEkfOutput StepLocalizationEkf(const LocalizationEkfParams& params,
                                          const LocalizationEkfInput& input,
                                          LocalizationEkfState* state);

// X_map_base = X_map_odom · X_odom_base (the map-frame pose of an odom-frame estimate).
world::Pose2 MapFromOdom(const world::Pose2& X_map_odom, const world::Pose2& X_odom_base);
// X_odom_base = X_map_odom⁻¹ · X_map_base.
world::Pose2 OdomFromMap(const world::Pose2& X_map_odom, const world::Pose2& X_map_base);

// OdomFromMap's position of many map points under one map→odom transform, bit for bit
// (world::PointsInFrame with F the map and the body odom).
using OdomPointFromMap = world::PointsInFrame;

}  // namespace autonomsim::stack
