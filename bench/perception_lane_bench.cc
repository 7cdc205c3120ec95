// Lane detection on a rendered lab-track frame (issue 5): the whole step, the plain OpenCV
// mask+warp stage (the reference) and LaneDetector's own mask+warp stage, all on the same frame.
// Runs with the repository root as working directory (it reads scenarios/tracks/lab.yaml).
#include <benchmark/benchmark.h>

#include "stack/lane_detection.h"
#include "stack/tests/track_frames.h"
#include "vehicle/camera_model.h"

namespace autonomsim::stack {
namespace {

struct LaneBenchFrame {
  LaneBenchFrame() {
    const auto& camera = frames.color_camera();
    calibration.K = camera.params().K;
    calibration.D = camera.params().D;
    calibration.X_base_camera = camera.X_base_camera();
    // outer lane, south straight: the yellow centre line and the white boundary in view
    frame = frames.Render(frames.PoseOnRoute("outer_loop", 2.5));
    image = cv::Mat(frame.color.height, frame.color.width, CV_8UC3, frame.color.bgr.data());
  }
  testing::TrackFrames frames;
  LaneCameraCalibration calibration;
  testing::RgbdFrame frame;
  cv::Mat image;
};

const LaneBenchFrame& Frame() {
  static const LaneBenchFrame frame;
  return frame;
}

void BM_LaneDetection(benchmark::State& state) {
  LaneDetector detector(LaneDetectionParams{}, Frame().calibration);
  for (auto _ : state) benchmark::DoNotOptimize(detector.Step(Frame().image));
}
BENCHMARK(BM_LaneDetection)->Unit(benchmark::kMicrosecond);

void BM_LaneMasksOpenCV(benchmark::State& state) {
  LaneDetector detector(LaneDetectionParams{}, Frame().calibration);
  BirdsEyeMasks masks;
  for (auto _ : state) {
    LaneMasksReference(Frame().image, detector.thresholds(), detector.image_to_birds_eye(), &masks);
    benchmark::DoNotOptimize(masks.yellow.data);
  }
}
BENCHMARK(BM_LaneMasksOpenCV)->Unit(benchmark::kMicrosecond);

void BM_LaneMasksFast(benchmark::State& state) {
  LaneDetector detector(LaneDetectionParams{}, Frame().calibration);
  BirdsEyeMasks masks;
  for (auto _ : state) {
    detector.ComputeMasks(Frame().image, &masks);
    benchmark::DoNotOptimize(masks.yellow.data);
  }
}
BENCHMARK(BM_LaneMasksFast)->Unit(benchmark::kMicrosecond);

// The same stage as the fit reads it (what lane_planner hands poly_fit): row sums, no masks.
void BM_LaneRowSums(benchmark::State& state) {
  LaneDetector detector(LaneDetectionParams{}, Frame().calibration);
  BirdsEyeRowSums sums;
  for (auto _ : state) {
    detector.ComputeRowSums(Frame().image, &sums);
    benchmark::DoNotOptimize(sums.yellow.data());
  }
}
BENCHMARK(BM_LaneRowSums)->Unit(benchmark::kMicrosecond);

// The renderer's part: each source pixel's line class (ClassOf of the frame's colours).
void WriteFrameClasses(LaneDetector& detector) {
  const cv::Mat& image = Frame().image;
  const ClassImageRegion classes = detector.MutableClassRegion();
  for (const LaneDetector::SourceSpan& span : classes.spans) {
    const std::uint8_t* bgr = image.ptr<std::uint8_t>(span.row);
    for (int c = span.col_begin; c < span.col_end; ++c) {
      classes.pixels[static_cast<std::size_t>(span.row * classes.stride + c)] =
          detector.ClassOf(bgr[3 * c], bgr[3 * c + 1], bgr[3 * c + 2]);
    }
  }
}

// The warp and row sums alone, as the loop runs them: the renderer has written each source
// pixel's line class (here ClassOf of the frame's colours), the detector sums the warped classes.
void BM_LaneRowSumsFromClasses(benchmark::State& state) {
  LaneDetector detector(LaneDetectionParams{}, Frame().calibration);
  WriteFrameClasses(detector);
  BirdsEyeRowSums sums;
  for (auto _ : state) {
    detector.ComputeRowSumsFromClasses(&sums);
    benchmark::DoNotOptimize(sums.yellow.data());
  }
}
BENCHMARK(BM_LaneRowSumsFromClasses)->Unit(benchmark::kMicrosecond);

// The same, counted as the lab's hardware counts (hw_pixel_classes exact: rt_polyfit's exact 255
// and 127 in the combined image's warp).
void BM_LaneRowSumsFromClassesExact(benchmark::State& state) {
  LaneDetector detector(LaneDetectionParams{}, Frame().calibration);
  WriteFrameClasses(detector);
  BirdsEyeRowSums sums;
  for (auto _ : state) {
    detector.ComputeRowSumsFromClasses(&sums, BirdsEyeClasses::kExact);
    benchmark::DoNotOptimize(sums.yellow.data());
  }
}
BENCHMARK(BM_LaneRowSumsFromClassesExact)->Unit(benchmark::kMicrosecond);

// The fit stage alone: ours (FitLanePoints), and rt_polyfit's with every lab option
// (FitLanePointsHardware: exact counts, truncation, the PnP projection in float, the overwrite).
void BM_LaneFit(benchmark::State& state) {
  LaneDetectionParams params;
  const bool lab = state.range(0) != 0;
  if (lab) {
    params.hw_pixel_classes = BirdsEyeClasses::kExact;
    params.hw_no_line = HwNoLine::kBothBelowMin;
    params.hw_truncate_points = true;
    params.hw_valid_overwrite = true;
    params.projection = LaneProjection::kPnpSwapped;
  }
  LaneDetector detector(params, Frame().calibration);
  BirdsEyeRowSums sums;
  detector.ComputeRowSums(Frame().image, &sums, params.hw_pixel_classes);
  for (auto _ : state) {
    const LanePoints lanes = lab ? FitLanePointsHardware(*detector.tables(), sums)
                                 : FitLanePoints(*detector.tables(), sums);
    benchmark::DoNotOptimize(lanes.valid);
  }
}
BENCHMARK(BM_LaneFit)->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace autonomsim::stack
