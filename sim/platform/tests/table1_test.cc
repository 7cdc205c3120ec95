// The platform model on the paper's Table I test setup, with the ZCU104 profile.
//
// A row's CPU is the sum of the processes the lab's sheet lists for its run (benchmark/
// Benchmark.ods, reference §8: row 3 = AstraSDK + ReconROS, row 7 = lane node + Cam2Image, ...);
// the rate probe (`ros2 topic hz`) is in no row.
// Rows 3-8 (zero-copy) are what the compute costs were fitted to: every cell, and every process
// beside the sheet's range, must be in range.
// Rows 1-2 (without Iceoryx) are the held-out check, computed from the DDS transport model whose
// figures were set before these rows were run (Cyclone's defaults, sim/platform/dds_link.h):
// their point clouds overflow the reader's socket buffer and are repaired on Cyclone's 100 ms
// cycles, so the probe gets fewer than the camera's 30 fps (reliable: 22 and 27 fps; best
// effort: none). The paper measured 9-12 and 13-14 fps and 180-220 % CPU; the model's CPU stays
// at 135-173 %. The gaps are recorded by the disabled tests at the end, so that they stay visible
// instead of being tuned away.
#include "sim/platform/table1.h"

#include <gtest/gtest.h>

#include <set>

#include "sim/platform/platform_profile.h"

namespace autonomsim::sim {
namespace {

class Table1 : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    profile_ = new PlatformProfile(LoadPlatformProfile("scenarios/platforms/zcu104.yaml"));
    rows_ = new std::vector<Table1Result>(RunTable1(*profile_));
  }
  static void TearDownTestSuite() {
    delete rows_;
    delete profile_;
  }
  static PlatformProfile* profile_;
  static std::vector<Table1Result>* rows_;
};
PlatformProfile* Table1::profile_ = nullptr;
std::vector<Table1Result>* Table1::rows_ = nullptr;

TEST_F(Table1, EightRowsInThePapersOrder) {
  ASSERT_EQ(rows_->size(), 8u);
  EXPECT_EQ((*rows_)[0].row.configuration, "SW, without Iceoryx");
  EXPECT_TRUE((*rows_)[0].row.held_out);
  EXPECT_TRUE((*rows_)[1].row.held_out);
  for (std::size_t i = 2; i < rows_->size(); ++i) EXPECT_FALSE((*rows_)[i].row.held_out);
}

TEST_F(Table1, EveryZeroCopyCellIsInThePapersRange) {
  for (const Table1Result& r : *rows_) {
    if (r.row.held_out) continue;
    SCOPED_TRACE(r.row.component + " / " + r.row.configuration);
    EXPECT_TRUE(r.in_cpu) << r.cpu_percent;
    EXPECT_TRUE(r.in_fps) << r.fps;
    EXPECT_TRUE(r.in_turnaround) << r.turnaround_ms;
  }
}

// The processes of a row's run, found by the sheet's name (or a node's, for one the sheet does
// not list); null if the row has none of that name.
const ProcessResult* FindProcess(const Table1Result& r, const std::string& name) {
  for (const ProcessResult& p : r.processes) {
    if (p.name == name) return &p;
  }
  return nullptr;
}

TEST_F(Table1, EveryZeroCopyRowsProcessesAreInTheSheetsRanges) {
  for (const Table1Result& r : *rows_) {
    if (r.row.held_out) continue;
    SCOPED_TRACE(r.row.component + " / " + r.row.configuration);
    ASSERT_FALSE(r.row.sheet.empty());
    for (const ProcessResult& p : r.processes) {
      if (p.sheet) {
        EXPECT_TRUE(p.in_range) << p.name << ": " << p.cpu_percent;
      }
    }
  }
  // The camera drivers and the delegates, as the sheet measured them (reference §8)
  EXPECT_NEAR(FindProcess((*rows_)[2], "AstraSDK")->cpu_percent, 65.0, 0.5);
  EXPECT_NEAR(FindProcess((*rows_)[6], "Cam2Image")->cpu_percent, 25.0, 0.5);
  for (std::size_t row : {3, 5, 7}) {
    const ProcessResult* delegates = FindProcess((*rows_)[row], "ReconROS");
    ASSERT_NE(delegates, nullptr);
    EXPECT_NEAR(delegates->cpu_percent, 6.0, 0.5) << row;  // 4-8 %
  }
}

TEST_F(Table1, ARowsCpuIsTheSumOfTheSheetsProcessesAndNeverTheProbes) {
  for (const Table1Result& r : *rows_) {
    SCOPED_TRACE(r.row.configuration);
    ASSERT_EQ(r.processes.size() >= r.row.sheet.size(), true);
    double sum = 0.0;
    double others = 0.0;
    for (std::size_t i = 0; i < r.processes.size(); ++i) {
      const ProcessResult& p = r.processes[i];
      EXPECT_EQ(p.sheet.has_value(), i < r.row.sheet.size()) << p.name;  // the sheet's first
      (p.sheet ? sum : others) += p.cpu_percent;
    }
    EXPECT_DOUBLE_EQ(r.cpu_percent, sum);
    EXPECT_NEAR(r.board_cpu_percent, sum + others, 1e-6);
    const ProcessResult* probe = FindProcess(r, "fps_probe");
    ASSERT_NE(probe, nullptr);
    EXPECT_FALSE(probe->sheet.has_value());
  }
  // Rows 5 and 6 are the ReconROS process alone: their sources run outside the sum.
  EXPECT_FALSE(FindProcess((*rows_)[4], "camera_publisher")->sheet.has_value());
  EXPECT_FALSE(FindProcess((*rows_)[5], "astra_sdk")->sheet.has_value());
}

TEST_F(Table1, TheRateProbeCostsItsCopyingTakeAndItsCallbackOnly) {
  // Row 3's probe takes each 4,915,200-byte cloud by copy (20 us take + the copy at 1.5 GB/s) and
  // runs a 20 us callback, 30 times a second: no fitted per-byte work.
  const ProcessResult* probe = FindProcess((*rows_)[2], "fps_probe");
  ASSERT_NE(probe, nullptr);
  const double per_frame_s = 20e-6 + 4915200.0 / profile_->cpu.memcpy_bytes_per_s + 20e-6;
  EXPECT_NEAR(probe->cpu_percent, 100.0 * 30.0 * per_frame_s, 0.1);
  EXPECT_EQ(profile_->Component("fps_probe").sw->work_ns_per_input_byte, 0.0);
}

TEST_F(Table1, HeldOutRowsPrintTheirSplitBesideTheSheetsAndCostMoreThanZeroCopy) {
  for (int i : {0, 1}) {
    const Table1Result& dds = (*rows_)[static_cast<std::size_t>(i)];
    const Table1Result& zc = (*rows_)[static_cast<std::size_t>(i + 2)];
    SCOPED_TRACE(dds.row.configuration);
    const ProcessResult* astra = FindProcess(dds, "AstraSDK");
    const ProcessResult* recon = FindProcess(dds, "ReconROS");
    ASSERT_NE(astra, nullptr);
    ASSERT_NE(recon, nullptr);
    EXPECT_EQ(astra->sheet->lo, 80.0);  // the sheet: 80-100 % without Iceoryx, 60-70 % with
    EXPECT_GT(astra->cpu_percent, FindProcess(zc, "AstraSDK")->cpu_percent);
    EXPECT_GT(recon->cpu_percent, FindProcess(zc, "ReconROS")->cpu_percent);
  }
}

TEST_F(Table1, TheTextShowsEachRowsProcessesBesideTheSheets) {
  const std::string text = Table1Text(*rows_, {}, "zcu104", {});
  for (const char* expected :
       {"AstraSDK             astra_sdk", "Cam2Image            cam2image",
        "ReconROS             lane_planner+poly_fit", "(60-70) in", "fps_probe",
        "(not in the sheet: outside the row's sum)", "processes in the sheet's"}) {
    EXPECT_NE(text.find(expected), std::string::npos) << expected;
  }
}

TEST_F(Table1, DdsCostsMoreThanZeroCopyInEveryRespect) {
  // Per output frame, the held-out (DDS) rows spend more CPU and more time than their zero-copy
  // counterparts (rows 3 and 4), which is the paper's direction.
  for (int i : {0, 1}) {
    const Table1Result& dds = (*rows_)[static_cast<std::size_t>(i)];
    const Table1Result& zc = (*rows_)[static_cast<std::size_t>(i + 2)];
    EXPECT_GT(dds.cpu_percent / dds.fps, 1.5 * zc.cpu_percent / zc.fps);
    EXPECT_GT(dds.turnaround_ms, zc.turnaround_ms + 10.0);
    EXPECT_LE(dds.fps, zc.fps);
  }
}

TEST_F(Table1, TheSameRunGivesTheSameNumbers) {
  const std::vector<Table1Result> again = RunTable1(*profile_);
  for (std::size_t i = 0; i < again.size(); ++i) {
    EXPECT_EQ(again[i].cpu_percent, (*rows_)[i].cpu_percent);  // bit for bit
    EXPECT_EQ(again[i].fps, (*rows_)[i].fps);
    EXPECT_EQ(again[i].turnaround_ms, (*rows_)[i].turnaround_ms);
  }
}

TEST_F(Table1, JsonHasTheAgreedShape) {
  const std::vector<WholeUnitResult> whole = {RunWholeUnit(*profile_)};
  const nlohmann::json j = Table1Json(*rows_, whole);
  ASSERT_EQ(j["rows"].size(), 8u);
  for (const auto& row : j["rows"]) {
    std::set<std::string> keys;
    for (const auto& [key, unused] : row.items()) keys.insert(key);
    std::set<std::string> expected = {
        "component",     "configuration", "cpu_percent", "board_cpu_percent", "fps",
        "turnaround_ms", "paper",         "in_range",    "processes"};
    if (row.contains("alternative")) expected.insert("alternative");  // the held-out rows
    EXPECT_EQ(keys, expected);
    EXPECT_EQ(row["paper"]["fps"].size(), 2u);
    EXPECT_TRUE(row["in_range"]["turnaround_ms"].is_boolean());
  }
  EXPECT_EQ(j["held_out"], nlohmann::json::array({0, 1}));
  for (int i : {0, 1}) {
    EXPECT_EQ(j["rows"][i]["alternative"]["reliability"], "best_effort");
    EXPECT_TRUE(j["rows"][i]["alternative"].contains("fps"));
  }
  EXPECT_FALSE(j["rows"][2].contains("alternative"));
  EXPECT_TRUE(j["whole_unit"]["zero_copy"].contains("demand_percent"));
  EXPECT_EQ(j["whole_unit"]["zero_copy"]["sheet_percent"], nlohmann::json::array({310, 360}));
  EXPECT_EQ(j["rows"][2]["paper"]["cpu_percent"], nlohmann::json::array({90, 110}));
  const nlohmann::json& astra = j["rows"][2]["processes"][0];
  EXPECT_EQ(astra["process"], "AstraSDK");
  EXPECT_EQ(astra["nodes"], nlohmann::json::array({"astra_sdk"}));
  EXPECT_EQ(astra["sheet"], nlohmann::json::array({60, 70}));
  EXPECT_EQ(astra["in_range"], true);
  const nlohmann::json& probe = j["rows"][2]["processes"][2];
  EXPECT_EQ(probe["process"], "fps_probe");
  EXPECT_TRUE(probe["sheet"].is_null());
  EXPECT_TRUE(probe["in_range"].is_null());
}

TEST_F(Table1, WholeUnitInSoftwareDemandsWhatTheSheetsProcessesSumToAndFallsBehind) {
  const WholeUnitResult zc = RunWholeUnit(*profile_);
  EXPECT_EQ(zc.capacity_percent, 400.0);
  // The camera drivers and the components as the sheet measured them, plus the background loads:
  // inside the sheet's sum for the same processes (310-360 %) plus those loads, below 400 %.
  EXPECT_GE(zc.demand_percent, zc.sheet_percent.lo + zc.background_percent);
  EXPECT_LE(zc.demand_percent, zc.sheet_percent.hi + zc.background_percent);
  EXPECT_LT(zc.demand_percent, 400.0);
  // Yet it does not keep up: while the others run, the lane node's share of the cores stretches
  // its job past the frame period, and its queue overflows. Every other node keeps up.
  const NodeReport* zc_lane = zc.report.FindNode("lane_detection");
  ASSERT_NE(zc_lane, nullptr);
  EXPECT_GT(zc_lane->turnaround_ms.p50, 1000.0 / 30.0);
  EXPECT_GT(zc_lane->drops, 0u);
  EXPECT_LT(zc_lane->rate_hz, 29.0);
  for (const NodeReport& n : zc.report.nodes) {
    if (n.name != "lane_detection") {
      EXPECT_EQ(n.drops, 0u) << n.name;
    }
  }

  const WholeUnitResult dds = RunWholeUnit(*profile_, {}, Transport::kDds);
  EXPECT_GT(dds.demand_percent, 400.0);
  EXPECT_LE(dds.cpu_percent, 400.0 + 1e-6);  // the cores cannot deliver more
  EXPECT_GT(dds.cpu_percent, 390.0);
  const NodeReport* lane = dds.report.FindNode("lane_detection");
  ASSERT_NE(lane, nullptr);
  EXPECT_GT(lane->drops, 0u);  // keep-last queues overflow
  EXPECT_LT(lane->rate_hz, 25.0);
  EXPECT_GT(lane->turnaround_ms.p50, zc.report.FindNode("lane_detection")->turnaround_ms.p50);
}

// The held-out rows come from the DDS mechanism, not from a fitted cost: a 4.9 MB point cloud is
// 366 datagrams against a 416 KiB socket buffer (2 x rmem_max 212 992 B), so it overflows and
// waits for repair; a reliable topic delivers fewer than the camera's 30 fps, a best-effort one
// loses every cloud (reference §10: ddsperf on one host, best effort: nothing arrives). The
// turnaround of these rows is the period, as the paper's figure there is (reference §8).
TEST_F(Table1, TheRowsWithoutIceoryxLoseFramesToTheSocketBufferAndItsRepair) {
  for (int i : {0, 1}) {
    const Table1Result& r = (*rows_)[static_cast<std::size_t>(i)];
    ASSERT_TRUE(r.row.held_out);
    EXPECT_GT(r.fps, 1.0) << r.row.configuration;
    EXPECT_LT(r.fps, 29.0) << r.row.configuration;
    EXPECT_DOUBLE_EQ(r.turnaround_ms, 1000.0 / r.fps);
    ASSERT_TRUE(r.alternative.has_value());
    EXPECT_EQ(r.alternative->reliability, Reliability::kBestEffort);
    EXPECT_EQ(r.alternative->fps, 0.0) << r.row.configuration;
  }
  // the zero-copy rows keep the camera's rate, and their turnaround is the node's own
  for (std::size_t i = 2; i < rows_->size(); ++i) {
    const Table1Result& r = (*rows_)[i];
    EXPECT_GE(r.fps, 29.0) << r.row.configuration;
    EXPECT_LT(r.turnaround_ms, 1000.0 / 30.0) << r.row.configuration;
    EXPECT_FALSE(r.alternative.has_value());
  }
}

// The paper's held-out CPU, as the sheet's processes sum it. Not reached: see the top of this file.
TEST_F(Table1, DISABLED_HeldOutCpuInRange) {
  for (int i : {0, 1}) {
    const Table1Result& r = (*rows_)[static_cast<std::size_t>(i)];
    EXPECT_TRUE(r.in_cpu) << r.row.configuration << ": " << r.cpu_percent;
    for (const ProcessResult& p : r.processes) {
      if (p.sheet) {
        EXPECT_TRUE(p.in_range) << r.row.configuration << ", " << p.name;
      }
    }
  }
}

// The paper's held-out FPS and turnaround. Not reached: see the top of this file and the profile.
TEST_F(Table1, DISABLED_HeldOutFpsAndTurnaroundInRange) {
  for (int i : {0, 1}) {
    const Table1Result& r = (*rows_)[static_cast<std::size_t>(i)];
    EXPECT_TRUE(r.in_fps) << r.row.configuration << ": " << r.fps;
    EXPECT_TRUE(r.in_turnaround) << r.row.configuration << ": " << r.turnaround_ms;
  }
}

}  // namespace
}  // namespace autonomsim::sim
