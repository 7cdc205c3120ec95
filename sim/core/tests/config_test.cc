// The one reader and writer of config structs (sim/core/config.h), on small structs of its own.
#include "sim/core/config.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

namespace autonomsim::sim {
namespace {

using ::testing::HasSubstr;

struct Inner {
  double gain{1.0};
  Duration period{std::chrono::milliseconds(100)};
  template <class V>
  void Describe(V& v) {
    v("gain", gain);
    v("period_s", period);
  }
  void Validate() const {
    if (gain < 0) throw std::invalid_argument("gain must be >= 0, got " + std::to_string(gain));
  }
};

struct Outer {
  std::string name{"x"};
  std::uint64_t seed{1};
  bool flag{false};
  std::vector<Inner> items;
  std::array<int, 3> rgb{0, 0, 0};
  std::map<std::string, Inner> named;
  std::optional<int> maybe;
  Inner inner;
  template <class V>
  void Describe(V& v) {
    v("name", name);
    v("seed", seed);
    v("flag", flag);
    v("items", items);
    v("rgb", rgb);
    v("named", named);
    v("maybe", maybe);
    v("inner", inner);
  }
  void Validate() const {}
};

Outer Read(const std::string& yaml, const std::vector<std::string>& overrides = {}) {
  YAML::Node root = YAML::Load(yaml);
  ConfigSource source{"test.yaml", {}};
  BreakAliases(root);  // as the scenario and profile loaders do
  for (const std::string& o : overrides) ApplyOverride(root, o, &source);
  return ReadConfig<Outer>(root, source);
}

std::string ErrorOf(const std::string& yaml, const std::vector<std::string>& overrides = {}) {
  try {
    Read(yaml, overrides);
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(ConfigTest, ReadsEveryKindOfFieldAndKeepsDefaults) {
  const Outer o = Read(R"(
seed: 18446744073709551615
flag: true
items: [{gain: 2}, {period_s: 0.25}]
rgb: [1, 2, 3]
named: {a: {gain: 3}}
maybe: 4
inner:
)");
  EXPECT_EQ(o.name, "x");
  EXPECT_EQ(o.seed, 18446744073709551615u);
  EXPECT_TRUE(o.flag);
  ASSERT_EQ(o.items.size(), 2u);
  EXPECT_EQ(o.items[0].gain, 2.0);
  EXPECT_EQ(o.items[0].period, std::chrono::milliseconds(100));
  EXPECT_EQ(o.items[1].period, std::chrono::milliseconds(250));
  EXPECT_EQ(o.rgb, (std::array<int, 3>{1, 2, 3}));
  EXPECT_EQ(o.named.at("a").gain, 3.0);
  EXPECT_EQ(o.maybe, 4);
  EXPECT_EQ(o.inner.gain, 1.0);
}

TEST(ConfigTest, ErrorsNameLineColumnAndKeyPath) {
  EXPECT_THAT(ErrorOf("items:\n  - {gain: x}\n"),
              HasSubstr("test.yaml:2:12: items[0].gain: expected a number, got 'x'"));
  EXPECT_THAT(ErrorOf("items:\n  - {gain: -1}\n"),
              HasSubstr("test.yaml:2:12: items[0].gain: gain must be >= 0, got -1"));  // its line
  EXPECT_THAT(ErrorOf("inner: {gian: 1}\n"),
              HasSubstr("test.yaml:1:9: inner.gian: unknown key 'gian' (did you mean 'gain'?)"));
  EXPECT_THAT(ErrorOf("inner: {zzzzzzzz: 1}\n"), HasSubstr("(known keys: gain, period_s)"));
  EXPECT_THAT(ErrorOf("rgb: [1, 2]\n"), HasSubstr("rgb: expected a list of 3 values"));
  EXPECT_THAT(ErrorOf("seed: -1\n"), HasSubstr("seed: expected a non-negative integer"));
  EXPECT_THAT(ErrorOf("flag: maybe\n"), HasSubstr("flag: expected true or false"));
  EXPECT_THAT(ErrorOf("items: {gain: 1}\n"), HasSubstr("items: expected a list"));
  EXPECT_THAT(ErrorOf("inner: {gain: .nan}\n"), HasSubstr("expected a finite number"));
  EXPECT_THAT(ErrorOf("maybe: 1.5\n"), HasSubstr("maybe: expected an integer"));
  // issue 15 (fuzzing): a key that is a list or a mapping escaped as yaml-cpp's BadConversion
  EXPECT_THAT(ErrorOf("named: {[a, b]: {gain: 1}}\n"),
              HasSubstr("test.yaml:1:9: named: expected a name as key, got a list"));
  EXPECT_THAT(ErrorOf("named:\n  ? {a: 1}\n"),
              HasSubstr("test.yaml:2:5: named: expected a name as key, got a mapping"));
}

// Issue 33, item 3: a fault's `for_s: 1e12` was accepted and failed mid-run ("time value out of
// range", no location); every key in seconds is now checked where it is read.
TEST(ConfigTest, ATimeBeyondTheNanosecondRangeIsRefusedAtItsKey) {
  EXPECT_THAT(ErrorOf("inner: {period_s: 1.0e12}\n"),
              HasSubstr("test.yaml:1:19: inner.period_s: a time must be within ±9.2e+09 s"));
  EXPECT_THAT(ErrorOf("inner: {period_s: -1.0e10}\n"), HasSubstr("a time must be within"));
  EXPECT_THAT(ErrorOf("{}\n", {"inner.period_s=1e20"}),
              HasSubstr("--set inner.period_s: a time must be within ±9.2e+09 s"));
  EXPECT_EQ(Read("inner: {period_s: 9.0e9}\n").inner.period, FromSeconds(9.0e9));  // allowed
  // only keys in seconds (or ms): a gain of 1e12 is not a time
  EXPECT_EQ(Read("inner: {gain: 1.0e12}\n").inner.gain, 1.0e12);
}

TEST(ConfigTest, AKeysUnitComesFromTheWordsAtItsEnd) {
  EXPECT_EQ(UnitOfKey("lease_s"), "s");
  EXPECT_EQ(UnitOfKey("latency_ms"), "ms");
  EXPECT_EQ(UnitOfKey("q_position_m2_per_s"), "m²/s");
  EXPECT_EQ(UnitOfKey("speed_gain_per_mps"), "1/(m/s)");
  EXPECT_EQ(UnitOfKey("gyro_bias_rad_per_s"), "rad/s");
  EXPECT_EQ(UnitOfKey("gain"), "");
  EXPECT_EQ(UnitOfKey("imu_yaw_rate_variance_rad2_per_s2"), "rad²/s²");
  EXPECT_EQ(UnitOfKey("start_s_m"), "m");  // arc length s, in metres (was "s·m")
  EXPECT_EQ(UnitOfKey("s"), "");           // a key needs a word before its unit
}

TEST(ConfigTest, OverridesCreateKeysAndIndexLists) {
  const Outer o = Read("items: [{gain: 2}]\n", {"items[0].gain=5", "inner.period_s=0.5",
                                                "named.b.gain=7", "rgb=[4, 5, 6]"});
  EXPECT_EQ(o.items[0].gain, 5.0);
  EXPECT_EQ(o.inner.period, std::chrono::milliseconds(500));
  EXPECT_EQ(o.named.at("b").gain, 7.0);
  EXPECT_EQ(o.rgb, (std::array<int, 3>{4, 5, 6}));
  EXPECT_THAT(ErrorOf("{}", {"inner.gian=1"}), HasSubstr("--set inner.gian: unknown key 'gian'"));
  EXPECT_THAT(ErrorOf("{}", {"inner.gain=-2"}), HasSubstr("--set inner.gain: gain must be >= 0"));
  EXPECT_THAT(ErrorOf("items: []\n", {"items[0].gain=1"}), HasSubstr("index 0 is out of range"));
  EXPECT_THAT(ErrorOf("{}", {"flag.x=1"}), HasSubstr("--set flag.x: flag: expected true or false"));
  EXPECT_THAT(ErrorOf("flag: true\n", {"flag.x=1"}), HasSubstr("'flag' is not a mapping"));
}

// Issue 16: yaml-cpp shares an anchored node with its aliases; an override of one alias (a sweep's
// cars[1].stack...) changed every car that used the anchor.
TEST(ConfigTest, AnOverrideOfOneAliasLeavesTheAnchorAndTheOtherAliasesAlone) {
  const std::string text = "items: [&i {gain: 2}, *i, *i]\nnamed: {a: &n {gain: 3}, b: *n}\n";
  const Outer o = Read(text, {"items[1].gain=5", "named.b.gain=7"});
  ASSERT_EQ(o.items.size(), 3u);
  EXPECT_EQ(o.items[0].gain, 2.0);
  EXPECT_EQ(o.items[1].gain, 5.0);
  EXPECT_EQ(o.items[2].gain, 2.0);
  EXPECT_EQ(o.named.at("a").gain, 3.0);
  EXPECT_EQ(o.named.at("b").gain, 7.0);
  // and a bad value in the anchor is still reported at its line
  EXPECT_THAT(ErrorOf("items: [&i {gain: -1}, *i]\n"), HasSubstr("test.yaml:1:"));
}

// Issue 15: paths the override parser once let through, or answered with a library's message.
TEST(ConfigTest, MalformedOverridePathsAreRefusedNamingTheKey) {
  for (const char* key : {"items[0.gain", "items[0]]gain", "items.0.gain", ".seed", "seed.",
                          "items[-1].gain", "items[x].gain", "a..b", "items[]", "se ed"}) {
    const std::string error = ErrorOf("items: [{gain: 2}]\n", {std::string(key) + "=1"});
    EXPECT_THAT(error, HasSubstr(std::string("--set ") + key + ": ")) << key;
    EXPECT_THAT(error, HasSubstr("e.g. cars[0].oracle.speed_mps")) << key;
  }
  EXPECT_THAT(ErrorOf("items: []\n", {"items[99999999999999999999].gain=1"}),
              HasSubstr("list index 99999999999999999999 is out of range"));
  EXPECT_THAT(ErrorOf("- 1\n- 2\n", {"seed=1"}), HasSubstr("'(top level)' is not a mapping"));
  EXPECT_THAT(ErrorOf("{}", {"items[0]=1"}), HasSubstr("is not a list"));
  EXPECT_THAT(ErrorOf("{}", {"inner=&a {gain: *a}"}),
              HasSubstr("--set inner (value):1:1: an alias refers to a value that contains it"));
}

TEST(ConfigTest, DuplicateKeysNonUtf8TextAndFoldersAreErrorsNamingFileAndLine) {
  const std::filesystem::path dir =
      std::filesystem::path(::testing::TempDir()) / "config_test_load_yaml";
  std::filesystem::create_directories(dir);
  const auto error_of_file = [&](const std::string& name, const std::string& text) {
    std::ofstream(dir / name, std::ios::binary) << text;
    try {
      LoadYamlFile(dir / name);
    } catch (const ConfigError& e) {
      return std::string(e.what());
    }
    return std::string("(no error)");
  };
  EXPECT_THAT(error_of_file("dup.yaml", "seed: 1\nduration_s: 3\nduration_s: 5\n"),
              HasSubstr("dup.yaml:3:1: duration_s: duplicate key (first at line 2)"));
  EXPECT_THAT(error_of_file("nested.yaml", "a:\n  b: 1\n  b: 2\n"),
              HasSubstr("nested.yaml:3:3: b: duplicate key"));
  EXPECT_THAT(error_of_file("latin1.yaml", "seed: 1\nname: caf\xE9\n"),
              HasSubstr("latin1.yaml:2:10: not UTF-8 text (byte 0xE9)"));
  EXPECT_EQ(error_of_file("utf8.yaml", "name: caf\xC3\xA9 \xF0\x9F\x9A\x97\n"), "(no error)");
  // byte sequences shaped like UTF-8 that RFC 3629 forbids (they reached the JSON writer)
  EXPECT_THAT(error_of_file("overlong.yaml", "name: a\xC0\xAF\n"),
              HasSubstr("overlong.yaml:1:8: not UTF-8 text (byte 0xC0)"));
  EXPECT_THAT(error_of_file("surrogate.yaml", "name: \xED\xA0\x80\n"),
              HasSubstr("surrogate.yaml:1:7: not UTF-8 text (byte 0xED)"));
  EXPECT_THAT(error_of_file("too_high.yaml", "name: \xF4\x90\x80\x80\n"),
              HasSubstr("too_high.yaml:1:7: not UTF-8 text (byte 0xF4)"));
  // an alias inside what it names is a cycle every reader would follow forever (it crashed)
  EXPECT_THAT(error_of_file("cycle.yaml", "name: x\nseed: &a [*a]\n"),
              HasSubstr("cycle.yaml:2:7: an alias refers to a value that contains it"));
  EXPECT_THAT(error_of_file("cycle_map.yaml", "a: &a {b: *a}\n"),
              HasSubstr("cycle_map.yaml:1:4: an alias refers to a value that contains it"));
  // aliases that double at every level: 2^21 values from a few lines
  std::string laughs = "l0: &l0 [x, x]\n";
  for (int i = 1; i <= 21; ++i) {
    laughs += "l" + std::to_string(i) + ": &l" + std::to_string(i) + " [*l" +
              std::to_string(i - 1) + ", *l" + std::to_string(i - 1) + "]\n";
  }
  EXPECT_THAT(error_of_file("laughs.yaml", laughs), HasSubstr("values through its aliases"));
  EXPECT_EQ(error_of_file("shared.yaml", "a: &a {b: 1}\nc: *a\nd: [*a, *a]\n"), "(no error)");
  EXPECT_THAT(error_of_file("map_key.yaml", "a:\n  {k: v}: 42\n"),
              HasSubstr("map_key.yaml:2:3: a key must be a plain name, got a mapping"));
  EXPECT_THAT(error_of_file("dup_alias.yaml", "a: &m {k: 1, k: 2}\nb: *m\n"),
              HasSubstr("dup_alias.yaml:1:14: k: duplicate key"));
  std::filesystem::create_directories(dir / "folder.yaml");
  try {
    LoadYamlFile(dir / "folder.yaml");
    ADD_FAILURE() << "a folder was read as YAML";
  } catch (const ConfigError& e) {
    EXPECT_THAT(e.what(), HasSubstr("folder.yaml: is a folder, not a file"));
  }
}

// Issue 15 (fuzzing the loaders): `track: /dev/zero` in a scenario read until the memory ran out.
// Since issue 33 a device is refused before it is opened; a regular file is read up to 16 MiB.
TEST(ConfigTest, AFileThatNeverEndsIsRefusedBeforeItFillsTheMemory) {
  try {
    LoadYamlFile("/dev/zero");
    ADD_FAILURE() << "/dev/zero was read as YAML";
  } catch (const ConfigError& e) {
    EXPECT_THAT(e.what(), HasSubstr("/dev/zero: is a device, not a file"));
  }
  const std::filesystem::path big =
      std::filesystem::temp_directory_path() / ("big-" + std::to_string(::getpid()) + ".yaml");
  std::ofstream(big) << "a: 1\n";
  std::filesystem::resize_file(big, 17u << 20);  // sparse: 17 MiB of zeros after the first line
  try {
    LoadYamlFile(big);
    ADD_FAILURE() << "a 17 MiB file was read as YAML";
  } catch (const ConfigError& e) {
    EXPECT_THAT(e.what(), HasSubstr("larger than 16 MiB, not a config file"));
  }
  std::filesystem::remove(big);
}

TEST(ConfigTest, JsonHasEveryKeyAndRoundTripsThroughTheReader) {
  const Outer o = Read("items: [{gain: 2}]\nmaybe: 3\n");
  const nlohmann::json j = ToJson(o);
  EXPECT_EQ(j["inner"]["period_s"].get<double>(), 0.1);
  EXPECT_EQ(j["items"][0]["gain"].get<double>(), 2.0);
  EXPECT_EQ(j["maybe"].get<int>(), 3);
  // JSON is YAML: reading the JSON back gives the same JSON
  const Outer again = Read(j.dump());
  EXPECT_EQ(ToJson(again), j);
  // an empty optional is left out
  EXPECT_FALSE(ToJson(Outer{}).contains("maybe"));
}

}  // namespace
}  // namespace autonomsim::sim
