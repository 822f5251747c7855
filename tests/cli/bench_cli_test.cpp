// SPDX-License-Identifier: MIT
// `lbpkit bench` as a user runs it: the in-process and replies parts' JSON
// has the figures docs/performance.md quotes, and bad options are refused by name.
// No timing is asserted here (benchmarks/ and the command itself measure).
#include <gtest/gtest.h>

#include <array>

#include <nlohmann/json.hpp>

#include "support/process.hpp"

namespace {

using nlohmann::json;

TEST(BenchCli, InProcessJsonHasEveryFigure) {
  const auto r = test_support::run({"bench", "--only", "inprocess", "--seconds", "1", "--json"});
  ASSERT_EQ(r.exit, 0) << r.err;
  const auto j = json::parse(r.out, nullptr, false);
  ASSERT_FALSE(j.is_discarded()) << r.out;
  ASSERT_TRUE(j.contains("machine")) << j;
  EXPECT_TRUE(j["machine"].contains("cpu"));
  EXPECT_GE(j["machine"]["cpus"].get<unsigned>(), 1U);
  EXPECT_FALSE(j.contains("network")) << "only the part asked for runs";
  EXPECT_FALSE(j.contains("boards"));
  const auto& in = j["inprocess"];
  ASSERT_TRUE(in["rows"].is_array()) << j;
  ASSERT_EQ(in["rows"].size(), 2U) << "the board alone and the board with the mill, side by side";
  EXPECT_EQ(in["rows"][0]["name"], "board alone");
  EXPECT_EQ(in["rows"][1]["name"], "board + mill");
  for (const auto& row : in["rows"]) {
    EXPECT_NEAR(row["simulated_s"].get<double>(), 1.0, 1e-6) << row;
    EXPECT_GT(row["x_real_time"].get<double>(), 0.0) << row;
    EXPECT_GT(row["cpu_us_per_sim_ms"].get<double>(), 0.0) << row;
    EXPECT_GT(row["cpu_s"].get<double>(), 0.0) << row;
  }
  EXPECT_EQ(in["goal"]["x_real_time"], 2000);
}

TEST(BenchCli, TextOutputNamesTheComparison) {
  const auto r = test_support::run({"bench", "--only", "inprocess", "--seconds", "0.2"});
  ASSERT_EQ(r.exit, 0) << r.err;
  EXPECT_NE(r.out.find("board alone"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("board + mill"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("x real time"), std::string::npos) << r.out;
}

// The replies part: the same client's round trips to the Python echo
// server and to the sim, on any CPU and on one, idle and loaded: eight
// points, each with one datagram sent a millisecond.
TEST(BenchCli, RepliesPutTheSimBesideAnEchoServer) {
  const auto r = test_support::run({"bench", "--only", "replies", "--seconds", "0.2", "--json"});
  ASSERT_EQ(r.exit, 0) << r.err;
  const auto j = json::parse(r.out, nullptr, false);
  ASSERT_FALSE(j.is_discarded()) << r.out;
  const auto& points = j["replies"]["points"];
  // Per CPUs and load: the echo server, the sim, the sim holding the CPUs'
  // wake-up latency at 0 us (--cpu-latency, the default row).
  ASSERT_EQ(points.size(), 12U) << j;
  constexpr std::array<const char*, 3> kServers{"echo", "sim", "sim L0"};
  for (std::size_t i = 0; i < points.size(); ++i) {
    const auto& p = points[i];
    EXPECT_EQ(p["server"], kServers[i % 3]) << p;
    EXPECT_EQ(p["load"], (i / 3) % 2 == 0 ? "idle" : "loaded") << p;
    EXPECT_EQ(p["cpus"], i < 6 ? "any" : "one") << p;
    EXPECT_EQ(p["sent"].get<unsigned>(), 200U) << p;
    EXPECT_LE(p["late"].get<unsigned>() + p["lost"].get<unsigned>(), 200U) << p;
    EXPECT_LE(p["us"]["median"].get<double>(), p["us"]["max"].get<double>()) << p;
    EXPECT_GT(p["server_cpu_percent"].get<double>(), 0.0) << p;  // answering 200 datagrams takes some
  }
  EXPECT_NE(j["replies"]["goal"].get<std::string>().find("echo server"), std::string::npos);
  // Without the latency rows: echo and sim alone.
  const auto plain = test_support::run({"bench", "--only", "replies", "--seconds", "0.2", "--cpu-latency", "-1", "--json"});
  ASSERT_EQ(plain.exit, 0) << plain.err;
  EXPECT_EQ(json::parse(plain.out)["replies"]["points"].size(), 8U);
}

TEST(BenchCli, RefusesUnknownPartsAndBadDurations) {
  auto r = test_support::run({"bench", "--only", "inprocess,warp"});
  EXPECT_NE(r.exit, 0);
  EXPECT_NE(r.err.find("\"warp\" is not a part"), std::string::npos) << r.err;
  r = test_support::run({"bench", "--only", "inprocess", "--seconds", "0"});
  EXPECT_NE(r.exit, 0);
  EXPECT_NE(r.err.find("--seconds"), std::string::npos) << r.err;
  r = test_support::run({"bench", "--only", "boards", "--boards", "1,x"});
  EXPECT_NE(r.exit, 0);
  EXPECT_NE(r.err.find("--boards: \"x\""), std::string::npos) << r.err;
}

}  // namespace
