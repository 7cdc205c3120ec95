#include "stack/localization_ekf.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <cmath>
#include <functional>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>
#include <vector>

namespace autonomsim::stack {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;
using world::Pose2;
using world::Vec2;

// The real car's start pose (reference §1).
const Pose2 kStart{0.96, -2.18, 0.0};

// The car's true motion: constant speed and yaw rate from kStart (or a given start).
struct Truth {
  Pose2 start = kStart;
  double speed_mps{0.25};
  double yaw_rate_rad_per_s{0.0};

  Pose2 At(double t_s) const {
    const double w = yaw_rate_rad_per_s;
    const double yaw = start.yaw_rad + w * t_s;
    if (w == 0.0) {
      return {start.x_m + speed_mps * t_s * std::cos(yaw),
              start.y_m + speed_mps * t_s * std::sin(yaw), world::WrapAngle(yaw)};
    }
    const double r = speed_mps / w;
    return {start.x_m + r * (std::sin(yaw) - std::sin(start.yaw_rad)),
            start.y_m - r * (std::cos(yaw) - std::cos(start.yaw_rad)), world::WrapAngle(yaw)};
  }
};

// Drives the filter for duration_s: IMU at 100 Hz, wheel speed at 10 Hz, Step every 50 ms with
// the readings stamped since the previous Step. `imu_yaw` and `imu_rate` give the readings.
struct Drive {
  LocalizationEkfParams params;
  LocalizationEkfState state;
  std::function<double(double)> imu_yaw;
  std::function<double(double)> imu_rate;
  std::function<double(double)> wheel_speed;
  std::function<void(const LocalizationEkfOutput&)> each_step = [](const auto&) {};
  int ms = 0;  // simulated time

  explicit Drive(const Truth& truth, LocalizationEkfParams p = {}) : params(p) {
    state = InitialLocalizationEkfState(params, kZeroTime, truth.start);
    // The BNO055's heading has its own zero: 1 rad off the map's here.
    imu_yaw = [truth](double t) { return world::WrapAngle(truth.At(t).yaw_rad + 1.0); };
    imu_rate = [truth](double) { return truth.yaw_rate_rad_per_s; };
    wheel_speed = [truth](double) { return truth.speed_mps; };
  }

  LocalizationEkfOutput Run(double duration_s, std::vector<PoseFix> fixes = {}) {
    LocalizationEkfOutput out;
    const int end_ms = ms + static_cast<int>(std::lround(duration_s * 1000.0));
    while (ms < end_ms) {
      LocalizationEkfInput input;
      for (int k = 0; k < 5; ++k, ms += 10) {
        const double t = ms / 1000.0;
        input.imu.push_back({Milliseconds(ms), imu_yaw(t), imu_rate(t)});
        if (ms % 100 == 0) input.wheel_speed.push_back({Milliseconds(ms), wheel_speed(t)});
      }
      input.now = Milliseconds(ms - 10);
      if (!fixes.empty() && fixes.front().stamp <= input.now) {
        input.pose_fixes.push_back(fixes.front());
        fixes.erase(fixes.begin());
      }
      out = StepLocalizationEkf(params, input, &state);
      each_step(out);
    }
    return out;
  }
};

double PositionError(const Pose2& a, const Pose2& b) {
  return std::hypot(a.x_m - b.x_m, a.y_m - b.y_m);
}

void ExpectSymmetricPositiveDefinite(const EkfMatrix& P) {
  EXPECT_EQ(P, P.transpose());
  EXPECT_EQ(P.llt().info(), Eigen::Success);
  EXPECT_GT(Eigen::SelfAdjointEigenSolver<EkfMatrix>(P).eigenvalues().minCoeff(), 0.0);
}

TEST(LocalizationEkfParamsTest, DefaultsKeysAndValidation) {
  LocalizationEkfParams params;
  EXPECT_EQ(params.period, Milliseconds(50));
  EXPECT_EQ(params.sensor_timeout, Milliseconds(100));
  EXPECT_TRUE(params.imu_yaw_relative);
  EXPECT_FALSE(params.use_pose_fix);
  EXPECT_TRUE(params.fuse_imu_yaw);  // the car's config fuses the IMU's heading
  // what the BNO055 driver sends (its defaults: the car's config sets no variance_*)
  EXPECT_EQ(params.imu_yaw_variance_rad2, 0.0159);
  EXPECT_EQ(params.imu_yaw_rate_variance_rad2_per_s2, 0.04);
  EXPECT_NO_THROW(params.Validate());
  std::vector<std::string> keys;
  auto visit = [&](const std::string& key, auto&, auto&&...) { keys.push_back(key); };
  params.Describe(visit);
  EXPECT_THAT(keys, ElementsAre("period_s", "sensor_timeout_s", "imu_yaw_relative",
                                "q_position_m2_per_s", "q_yaw_rad2_per_s", "q_speed_m2_per_s3",
                                "q_yaw_rate_rad2_per_s3", "initial_variance",
                                "imu_yaw_variance_rad2", "imu_yaw_rate_variance_rad2_per_s2",
                                "wheel_speed_variance_m2_per_s2", "use_pose_fix", "fuse_imu_yaw"));
  params.imu_yaw_variance_rad2 = 0.0;
  try {
    params.Validate();
    FAIL() << "accepted a zero variance";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("imu_yaw_variance_rad2"));
  }
  params = {};
  params.period = Duration::zero();
  EXPECT_THROW(InitialLocalizationEkfState(params, kZeroTime, kStart), std::invalid_argument);
}

TEST(LocalizationEkfTest, MapOdomHelpersAreInverse) {
  const Pose2 X_map_odom{0.96, -2.18, 0.7};
  const Pose2 X_odom_base{1.0, 0.5, -0.2};
  const Pose2 X_map_base = MapFromOdom(X_map_odom, X_odom_base);
  EXPECT_NEAR(X_map_base.x_m, 0.96 + std::cos(0.7) - 0.5 * std::sin(0.7), 1e-12);
  EXPECT_NEAR(X_map_base.y_m, -2.18 + std::sin(0.7) + 0.5 * std::cos(0.7), 1e-12);
  EXPECT_NEAR(X_map_base.yaw_rad, 0.5, 1e-12);
  const Pose2 back = OdomFromMap(X_map_odom, X_map_base);
  EXPECT_NEAR(back.x_m, 1.0, 1e-12);
  EXPECT_NEAR(back.y_m, 0.5, 1e-12);
  EXPECT_NEAR(back.yaw_rad, -0.2, 1e-12);
}

TEST(LocalizationEkfTest, OdomPointFromMapIsOdomFromMapsPositionBitForBit) {
  // The collision check's cost query maps thousands of cells with one OdomPointFromMap; the
  // results must be the very doubles of the per-point formula it replaced (one sincos each).
  for (const double yaw : {0.0, 0.7, -2.9, 3.14159, 1e-9, -1.5707963267948966}) {
    const Pose2 X_map_odom{0.96, -2.18, yaw};
    const OdomPointFromMap to_odom(X_map_odom);
    for (int k = 0; k < 50; ++k) {
      const Vec2 p_map(-3.0 + 0.137 * k, 5.0 - 0.291 * k);
      const Vec2 p_odom = to_odom(p_map);
      const double c = std::cos(yaw);
      const double s = std::sin(yaw);
      const double dx = p_map.x() - 0.96;
      const double dy = p_map.y() - -2.18;
      EXPECT_EQ(p_odom.x(), c * dx + s * dy) << yaw << " " << k;
      EXPECT_EQ(p_odom.y(), -s * dx + c * dy) << yaw << " " << k;
      const Pose2 X_odom_p = OdomFromMap(X_map_odom, {p_map.x(), p_map.y(), 0.0});
      EXPECT_EQ(p_odom.x(), X_odom_p.x_m);
      EXPECT_EQ(p_odom.y(), X_odom_p.y_m);
    }
  }
}

TEST(LocalizationEkfTest, StartsAtTheOdomOriginWithMapOdomAtTheStartPose) {
  LocalizationEkfParams params;
  LocalizationEkfState state = InitialLocalizationEkfState(params, FromSeconds(2.0), kStart);
  LocalizationEkfInput input;
  input.now = FromSeconds(2.0);
  const LocalizationEkfOutput out = StepLocalizationEkf(params, input, &state);
  EXPECT_EQ(out.stamp, FromSeconds(2.0));
  EXPECT_EQ(out.X_odom_base.x_m, 0.0);
  EXPECT_EQ(out.X_map_base.x_m, kStart.x_m);
  EXPECT_EQ(out.X_map_base.y_m, kStart.y_m);
  EXPECT_EQ(out.fused, 0);
}

TEST(LocalizationEkfTest, StraightLineWithExactDataTracksTruth) {
  const Truth truth;  // 0.25 m/s along +x from the start pose
  Drive drive(truth);
  const LocalizationEkfOutput at5 = drive.Run(5.0);
  const LocalizationEkfOutput at10 = drive.Run(5.0);
  const Pose2 expected = truth.At(ToSeconds(at10.stamp));
  EXPECT_NEAR(at10.speed_mps, 0.25, 1e-6);
  EXPECT_NEAR(at10.yaw_rate_rad_per_s, 0.0, 1e-9);
  EXPECT_NEAR(at10.X_map_base.yaw_rad, 0.0, 1e-9);
  EXPECT_NEAR(at10.X_map_base.y_m, kStart.y_m, 1e-9);
  // The filter starts at rest: the first wheel reading takes it half way (robot_localization's
  // 1e-9 initial variance against the 1e-9 wheel variance), a ~1 cm lag that then stays fixed.
  const double error10 = PositionError(at10.X_map_base, expected);
  EXPECT_LT(error10, 0.015);
  EXPECT_NEAR(error10, PositionError(at5.X_map_base, truth.At(ToSeconds(at5.stamp))), 1e-4);
}

TEST(LocalizationEkfTest, ConstantTurnArcsWithExactDataTrackTruth) {
  for (const double w : {0.25, -0.5, 1.0}) {
    Truth truth;
    truth.start = Pose2{0.96, -2.18, 0.3};
    truth.yaw_rate_rad_per_s = w;
    Drive drive(truth);
    const LocalizationEkfOutput at5 = drive.Run(5.0);
    const LocalizationEkfOutput at10 = drive.Run(5.0);
    const Pose2 expected = truth.At(ToSeconds(at10.stamp));
    EXPECT_NEAR(at10.yaw_rate_rad_per_s, w, 1e-6) << "ω = " << w;
    EXPECT_NEAR(at10.speed_mps, 0.25, 1e-6);
    EXPECT_NEAR(world::WrapAngle(at10.X_map_base.yaw_rad - expected.yaw_rad), 0.0, 1e-6);
    const double error10 = PositionError(at10.X_map_base, expected);
    EXPECT_LT(error10, 0.015) << "ω = " << w;
    // Converged: the start-up offset does not grow.
    EXPECT_NEAR(error10, PositionError(at5.X_map_base, truth.At(ToSeconds(at5.stamp))), 1e-3);
  }
}

TEST(LocalizationEkfTest, YawRateBiasDriftsTheEstimateAsExpected) {
  // The BNO055 integrates its gyro: a rate bias b shows in the rate and, as b·t, in the heading.
  const double b = 0.01;  // rad/s
  const Truth truth;      // straight along +x
  Drive drive(truth);
  drive.imu_yaw = [&](double t) { return 1.0 + b * t; };
  drive.imu_rate = [&](double) { return b; };
  const LocalizationEkfOutput out = drive.Run(20.0);
  const double T = ToSeconds(out.stamp);
  // The estimate believes the car turned left at b: yaw b·T, on the arc of radius v/b.
  EXPECT_NEAR(out.X_odom_base.yaw_rad, b * T, 1e-6);
  EXPECT_NEAR(out.yaw_rate_rad_per_s, b, 1e-6);
  const double v = 0.25;
  EXPECT_NEAR(out.X_odom_base.x_m, v * std::sin(b * T) / b, 0.015);
  EXPECT_NEAR(out.X_odom_base.y_m, v * (1.0 - std::cos(b * T)) / b, 0.015);
  // So the map-frame estimate is about half a metre left of the truth after 20 s: no correction.
  EXPECT_NEAR(out.X_map_base.y_m - truth.At(T).y_m, 0.25 * (1.0 - std::cos(0.2)) / 0.01, 0.015);
}

TEST(LocalizationEkfTest, PoseFixPullsTheEstimate) {
  const double b = 0.01;
  const Truth truth;
  LocalizationEkfParams params;
  params.use_pose_fix = true;
  Drive drive(truth, params);
  drive.imu_yaw = [&](double t) { return b * t; };
  drive.imu_rate = [&](double) { return b; };
  const LocalizationEkfOutput before = drive.Run(10.0);
  const double drift = PositionError(before.X_map_base, truth.At(ToSeconds(before.stamp)));
  EXPECT_GT(drift, 0.1);
  // A fix at the truth, 1 cm standard deviation, in the next Step.
  PoseFix fix;
  fix.stamp = before.stamp + Milliseconds(10);
  fix.X_map_base = truth.At(ToSeconds(fix.stamp));
  fix.covariance = Eigen::Vector3d(1e-4, 1e-4, 1e-4).asDiagonal();
  const LocalizationEkfOutput after = drive.Run(0.05, {fix});
  EXPECT_EQ(after.fused, 5 + 1 + 1);  // IMU, wheel speed, fix
  EXPECT_LT(PositionError(after.X_map_base, truth.At(ToSeconds(after.stamp))), 0.02);
  ExpectSymmetricPositiveDefinite(after.covariance);
  // A vague fix (1 m) pulls only a little.
  Drive vague(truth, params);
  vague.imu_yaw = drive.imu_yaw;
  vague.imu_rate = drive.imu_rate;
  vague.Run(10.0);
  fix.covariance = Eigen::Matrix3d::Identity();
  const LocalizationEkfOutput weak = vague.Run(0.05, {fix});
  const double weak_error = PositionError(weak.X_map_base, truth.At(ToSeconds(weak.stamp)));
  EXPECT_LT(weak_error, drift);
  EXPECT_GT(weak_error, 0.5 * drift);
}

// With pose fixes that carry the heading, a drifting IMU heading (a gyro-integrated one:
// vehicle::ImuHeadingSource::kGyro) still pulls the estimate while it is fused, even at the BNO055
// driver's variance 0.0159 rad² (flynneva/bno055 bno055/registers.py:257) against the fixes'
// (0.02 rad)²: it comes 20 times as often. Fusing only its yaw rate leaves the heading to the
// fixes (stack.localization.fuse_imu_yaw). The lab's magnetometer heading does not drift
// (ImuTest.TheLabsMagnetometerHeadingDoesNotDriftWithTheGyroBias), so no preset turns it off.
TEST(LocalizationEkfTest, WithoutTheImuHeadingTheFixesHoldTheYaw) {
  const double b = 0.005;  // rad/s: 0.3 rad of drift in 60 s
  const Truth truth;       // straight along +x
  auto yaw_error_after_60_s = [&](bool fuse_imu_yaw) {
    LocalizationEkfParams params;
    params.use_pose_fix = true;
    params.fuse_imu_yaw = fuse_imu_yaw;
    Drive drive(truth, params);
    drive.imu_yaw = [&](double t) { return b * t; };
    drive.imu_rate = [&](double) { return b; };
    std::vector<PoseFix> fixes;
    for (int ms = 200; ms <= 60000; ms += 200) {  // 5 Hz, at the truth, σ 0.02 m and 0.02 rad
      PoseFix fix;
      fix.stamp = Milliseconds(ms);
      fix.X_map_base = truth.At(ms / 1000.0);
      fix.covariance = Eigen::Vector3d(4e-4, 4e-4, 4e-4).asDiagonal();
      fixes.push_back(fix);
    }
    const LocalizationEkfOutput out = drive.Run(60.0, fixes);
    return std::abs(
        world::WrapAngle(out.X_map_base.yaw_rad - truth.At(ToSeconds(out.stamp)).yaw_rad));
  };
  EXPECT_GT(yaw_error_after_60_s(true), 0.15);  // the estimate follows the drift
  EXPECT_LT(yaw_error_after_60_s(false), 0.02);
}

TEST(LocalizationEkfTest, CovarianceStaysSymmetricPositiveDefinite) {
  Truth truth;
  truth.yaw_rate_rad_per_s = 0.8;
  Drive drive(truth);
  int steps = 0;
  drive.each_step = [&](const LocalizationEkfOutput& out) {
    ++steps;
    ExpectSymmetricPositiveDefinite(out.covariance);
  };
  const LocalizationEkfOutput out = drive.Run(30.0);
  EXPECT_EQ(steps, 600);
  // Nothing measures position: its variance grows like q · t.
  EXPECT_GT(out.covariance(kEkfX, kEkfX), 0.05 * 29.0);
  // The wheel speed is measured every 0.1 s: at most 0.1 s of q_speed since.
  EXPECT_LT(out.covariance(kEkfSpeed, kEkfSpeed), 0.025 * 0.1 + 1e-6);
}

TEST(LocalizationEkfTest, LateReadingFromAnotherSensorIsFusedAtTheFilterTime) {
  LocalizationEkfParams params;
  LocalizationEkfState state = InitialLocalizationEkfState(params, kZeroTime, kStart);
  LocalizationEkfInput input;
  input.now = Milliseconds(50);
  input.imu.push_back({Milliseconds(50), 0.0, 0.0});
  StepLocalizationEkf(params, input, &state);
  input = {};
  input.now = Milliseconds(100);
  input.wheel_speed.push_back({Milliseconds(40), 0.25});  // arrived late over its transport
  const LocalizationEkfOutput out = StepLocalizationEkf(params, input, &state);
  EXPECT_EQ(out.fused, 1);
  EXPECT_EQ(out.late, 1);
  EXPECT_GT(out.speed_mps, 0.1);
  EXPECT_EQ(out.stamp, Milliseconds(50));  // not moved back
}

TEST(LocalizationEkfTest, SensorTimeoutPredictsToNow) {
  LocalizationEkfParams params;
  LocalizationEkfState state = InitialLocalizationEkfState(params, kZeroTime, kStart);
  LocalizationEkfInput input;
  input.now = Milliseconds(50);
  input.wheel_speed.push_back({Milliseconds(0), 0.25});
  input.wheel_speed.push_back({Milliseconds(50), 0.25});
  LocalizationEkfOutput out = StepLocalizationEkf(params, input, &state);
  EXPECT_EQ(out.stamp, Milliseconds(50));
  const double x50_m = out.X_odom_base.x_m;
  input = {};
  input.now = Milliseconds(100);  // 50 ms without a reading: below the 0.1 s timeout
  EXPECT_EQ(StepLocalizationEkf(params, input, &state).stamp, Milliseconds(50));
  input.now = Milliseconds(150);  // 100 ms: predict
  out = StepLocalizationEkf(params, input, &state);
  EXPECT_EQ(out.stamp, Milliseconds(150));
  EXPECT_NEAR(out.X_odom_base.x_m, x50_m + out.speed_mps * 0.1, 1e-12);
  EXPECT_GT(out.X_odom_base.x_m, x50_m + 0.02);
}

TEST(LocalizationEkfTest, RejectsOutOfOrderAndNonFiniteInput) {
  LocalizationEkfParams params;
  LocalizationEkfState state = InitialLocalizationEkfState(params, kZeroTime, kStart);
  LocalizationEkfInput input;
  input.now = Milliseconds(50);
  input.imu = {{Milliseconds(30), 0.0, 0.0}, {Milliseconds(20), 0.0, 0.0}};
  try {
    StepLocalizationEkf(params, input, &state);
    FAIL() << "accepted IMU stamps going backwards";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("IMU reading stamped 0.02 s is out of order"));
  }
  state = InitialLocalizationEkfState(params, kZeroTime, kStart);
  input.imu = {{Milliseconds(30), 0.0, 0.0}};
  StepLocalizationEkf(params, input, &state);
  input.now = Milliseconds(100);
  input.imu = {{Milliseconds(25), 0.0, 0.0}};  // older than the last IMU reading, across Steps
  EXPECT_THROW(StepLocalizationEkf(params, input, &state), std::invalid_argument);
  input.imu = {{Milliseconds(120), 0.0, 0.0}};  // after now
  EXPECT_THROW(StepLocalizationEkf(params, input, &state), std::invalid_argument);
  input.imu = {{Milliseconds(60), std::numeric_limits<double>::quiet_NaN(), 0.0}};
  EXPECT_THROW(StepLocalizationEkf(params, input, &state), std::invalid_argument);
  input.imu = {};
  input.wheel_speed = {{Milliseconds(60), std::numeric_limits<double>::infinity()}};
  EXPECT_THROW(StepLocalizationEkf(params, input, &state), std::invalid_argument);
  input.wheel_speed = {};
  input.now = Milliseconds(10);  // before the filter's time (30 ms)
  EXPECT_THROW(StepLocalizationEkf(params, input, &state), std::invalid_argument);

  // Pose fixes: only when enabled, and with a positive definite covariance.
  input = {};
  input.now = Milliseconds(100);
  input.pose_fixes.push_back(PoseFix{Milliseconds(90), kStart, Eigen::Matrix3d::Identity()});
  try {
    StepLocalizationEkf(params, input, &state);
    FAIL() << "accepted a pose fix with use_pose_fix off";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("use_pose_fix"));
  }
  params.use_pose_fix = true;
  input.pose_fixes[0].covariance(0, 0) = -1.0;
  EXPECT_THROW(StepLocalizationEkf(params, input, &state), std::invalid_argument);
}

TEST(LocalizationEkfTest, Deterministic) {
  auto run = [] {
    Truth truth;
    truth.yaw_rate_rad_per_s = 0.3;
    Drive drive(truth);
    const LocalizationEkfOutput out = drive.Run(3.0);
    return std::vector<double>{out.X_odom_base.x_m, out.X_odom_base.y_m, out.X_odom_base.yaw_rad,
                               out.covariance(0, 0)};
  };
  EXPECT_EQ(run(), run());
}

}  // namespace
}  // namespace autonomsim::stack
