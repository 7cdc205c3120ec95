// The platform model on the paper's Table I test setup, with the ZCU104 profile.
//
// Rows 3-8 (zero-copy) are what the compute costs were fitted to: every cell must be in range.
// Rows 1-2 (without Iceoryx) are the held-out check, computed from the DDS transport model whose
// figures were set before these rows were run: their CPU cells come out in range, their FPS and
// turnaround do not (the model's node keeps up at 30 fps with a 29-33 ms turnaround; the paper
// measured 9-14 fps and 71-111 ms while the CPU matches). That gap is recorded by the disabled
// test at the end, so that it stays visible instead of being tuned away.
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

TEST_F(Table1, HeldOutRowsCpuComesOutOfTheDdsModelInRange) {
  for (int i : {0, 1}) {
    const Table1Result& r = (*rows_)[static_cast<std::size_t>(i)];
    SCOPED_TRACE(r.row.configuration);
    EXPECT_TRUE(r.in_cpu) << r.cpu_percent;
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
    EXPECT_EQ(keys, (std::set<std::string>{"component", "configuration", "cpu_percent", "fps",
                                           "turnaround_ms", "paper", "in_range"}));
    EXPECT_EQ(row["paper"]["fps"].size(), 2u);
    EXPECT_TRUE(row["in_range"]["turnaround_ms"].is_boolean());
  }
  EXPECT_EQ(j["held_out"], nlohmann::json::array({0, 1}));
  EXPECT_TRUE(j["whole_unit"]["zero_copy"].contains("demand_percent"));
  EXPECT_EQ(j["rows"][2]["paper"]["cpu_percent"], nlohmann::json::array({90, 110}));
}

TEST_F(Table1, WholeUnitInSoftwareWithZeroCopyFitsTheCoresButNotWithDds) {
  const WholeUnitResult zc = RunWholeUnit(*profile_);
  EXPECT_EQ(zc.capacity_percent, 400.0);
  // The components' own work (Table I minus the rate probe) plus the background loads.
  EXPECT_LT(zc.demand_percent, 400.0);
  EXPECT_GT(zc.demand_percent, 300.0);
  for (const NodeReport& n : zc.report.nodes) EXPECT_EQ(n.drops, 0u) << n.name;

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
