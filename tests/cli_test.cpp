// The lbpkit tools as a user runs them.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "process.hpp"

namespace {

using testing_process::Daemon;
using testing_process::run;

std::string tempPath(const std::string& name) {
  auto p = std::filesystem::temp_directory_path() / ("lbpkit-cli-" + name + "-" + std::to_string(::getpid()));
  std::filesystem::remove(p);
  return p.string();
}

std::string trim(std::string s) {
  while (!s.empty() && (s.back() == '\n' || s.back() == ' ')) s.pop_back();
  return s;
}

TEST(Cli, DiscoverJsonListsBothChannelsInEveryFieldIoMode) {
  for (int mode = 0; mode < 4; ++mode) {
    const auto r = run({"discover", "--json", "--modes", std::to_string(mode) + "0x"});  // TB6 skipped
    ASSERT_EQ(r.exit, 0) << r.err;
    const auto j = nlohmann::json::parse(r.out);
    EXPECT_EQ(j["card"], "MESA7I92");
    EXPECT_GT(j["discovery"]["doits"].get<int>(), 10);
    ASSERT_EQ(j["channels"].size(), 2U);
    const auto& io = j["channels"][0];
    const auto& an = j["channels"][1];
    EXPECT_EQ(io["name"], "7I77");
    EXPECT_EQ(io["function"], "field I/O");
    EXPECT_EQ(io["mode"], mode);
    EXPECT_EQ(an["function"], "analog");
    std::map<std::string, nlohmann::json> pd;
    for (const auto& e : io["process_data"]) pd[e["name"]] = e;
    EXPECT_EQ(pd.at("Input")["bits"], 32);
    EXPECT_EQ(pd.at("Output")["direction"], "out");
    EXPECT_EQ(pd.count("AnalogIn3"), mode >= 1 ? 1U : 0U);
    EXPECT_EQ(pd.count("FieldVoltage"), mode >= 2 ? 1U : 0U);
    EXPECT_EQ(pd.count("Enc1"), mode >= 3 ? 1U : 0U);
    if (mode >= 1) {
      EXPECT_EQ(pd.at("AnalogIn0")["unit"], "V");
      EXPECT_NEAR(pd.at("AnalogIn0")["max"].get<double>(), 36.3, 1e-4);
    }
    std::map<std::string, nlohmann::json> apd;
    for (const auto& e : an["process_data"]) apd[e["name"]] = e;
    EXPECT_EQ(apd.at("AnalogOut5")["bits"], 13);
    EXPECT_EQ(apd.at("AnalogOut5")["min"], -10.0);
    EXPECT_EQ(apd.at("AnalogOut5")["max"], 10.0);
    EXPECT_EQ(apd.at("AnalogOut5")["unit"], "V");
    EXPECT_EQ(apd.at("SpinEna")["type"], "BOOLEAN");
  }
}

TEST(Cli, DiscoverByDefaultTriesEveryChannelAsLinuxCncDoes) {
  const auto r = run({"discover", "--json"});
  ASSERT_EQ(r.exit, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  ASSERT_EQ(j["channels"].size(), 3U);
  EXPECT_EQ(j["channels"][2]["present"], false);  // TB6: nothing attached
  EXPECT_NE(j["channels"][2]["status"].get<std::string>().find("TimeoutError"), std::string::npos);
}

TEST(Cli, RpdWpdOnTheVirtualCard) {
  const auto state = tempPath("state");
  EXPECT_EQ(trim(run({"rpd", "WATCHDOGTIME", "--state", state}).out), "50");
  auto w = run({"wpd", "WATCHDOGTIME", "0", "--state", state});
  EXPECT_EQ(w.exit, 0) << w.err;
  EXPECT_EQ(trim(w.out), "WatchDogTime = 0");
  // Every --sim run powers the virtual card up: working values start from NV.
  EXPECT_EQ(trim(run({"rpd", "WATCHDOGTIME", "--state", state}).out), "50");
  w = run({"wpd", "NVWATCHDOGTIME", "100", "--state", state});
  EXPECT_EQ(w.exit, 0) << w.err;
  EXPECT_NE(w.out.find("after a power cycle"), std::string::npos);
  EXPECT_EQ(trim(run({"rpd", "NVWATCHDOGTIME", "--state", state}).out), "100");
  EXPECT_EQ(trim(run({"rpd", "watchdogtime", "--state", state}).out), "100");  // after the power cycle
  EXPECT_EQ(trim(run({"rpd", "FAULT", "H", "--state", state}).out), "01");      // watchdog fault at power-up
  EXPECT_EQ(trim(run({"rpd", "nvunitnumber", "H", "--channel", "1"}).out), "11000AEE");
  std::filesystem::remove(state);
}

TEST(Cli, RpdWpdOverSerialToThePtyRemote) {
  const auto state = tempPath("pty");
  {
    Daemon d({"remote", "--pty", "--setup", "--state", state});
    const auto pty = d.value("serial device: ");
    ASSERT_FALSE(pty.empty());
    EXPECT_EQ(trim(run({"rpd", "WATCHDOGTIME", "--serial", pty}).out), "50");
    auto w = run({"wpd", "WATCHDOGTIME", "0", "--serial", pty});
    EXPECT_EQ(w.exit, 0) << w.err;
    EXPECT_EQ(trim(run({"rpd", "WATCHDOGTIME", "--serial", pty}).out), "0");
    w = run({"wpd", "NVWATCHDOGTIME", "100", "--serial", pty});
    EXPECT_EQ(w.exit, 0) << w.err;
    EXPECT_EQ(trim(run({"rpd", "NVWATCHDOGTIME", "--serial", pty}).out), "100");
    EXPECT_EQ(trim(run({"rpd", "WATCHDOGTIME", "--serial", pty}).out), "0");  // until a power cycle
    const auto bad = run({"wpd", "SwRevision", "3", "--serial", pty});
    EXPECT_EQ(bad.exit, 1);
    EXPECT_NE(bad.err.find("read only"), std::string::npos) << bad.err;
    EXPECT_EQ(d.stop(), 0);
  }
  {
    Daemon d({"remote", "--pty", "--setup", "--state", state});  // power cycle
    const auto pty = d.value("serial device: ");
    EXPECT_EQ(trim(run({"rpd", "WATCHDOGTIME", "--serial", pty}).out), "100");
    EXPECT_EQ(d.stop(), 0);
  }
  std::filesystem::remove(state);
}

TEST(Cli, ErrorsSayWhatFailed) {
  auto r = run({"rpd", "NOSUCH"});
  EXPECT_EQ(r.exit, 1);
  EXPECT_NE(r.err.find("has no parameter \"NOSUCH\""), std::string::npos) << r.err;
  r = run({"discover", "--modes", "0z"});
  EXPECT_EQ(r.exit, 1);
  EXPECT_NE(r.err.find("neither a mode digit nor x"), std::string::npos) << r.err;
  r = run({"rpd", "FAULT", "--serial", "/nonexistent/tty"});
  EXPECT_EQ(r.exit, 1);
  EXPECT_NE(r.err.find("cannot open /nonexistent/tty"), std::string::npos) << r.err;
  r = run({"wpd", "WATCHDOGTIME", "70000"});
  EXPECT_EQ(r.exit, 1);
  EXPECT_NE(r.err.find("does not fit"), std::string::npos) << r.err;
}

TEST(Cli, SimRefusesBadConfigurationsClearly) {
  const auto bad = tempPath("bad.toml");
  {
    std::ofstream(bad) << "[[daughtercard]]\ntype = \"7I88\"\n";
  }
  auto r = run({"sim", "--config", bad, "--api", "0"});
  EXPECT_EQ(r.exit, 1);
  EXPECT_NE(r.err.find("daughtercard 0: type \"7I88\""), std::string::npos) << r.err;
  {
    std::ofstream(bad) << "[[daughtercard\n";
  }
  r = run({"sim", "--config", bad, "--api", "0"});
  EXPECT_EQ(r.exit, 1);
  EXPECT_NE(r.err.find("line 1"), std::string::npos) << r.err;
  r = run({"sim", "--bind", "127.0.0.1:70000", "--api", "0"});
  EXPECT_EQ(r.exit, 1);
  EXPECT_NE(r.err.find("not a port number"), std::string::npos) << r.err;
  std::filesystem::remove(bad);
}

TEST(Cli, InfoAndMonitor) {
  auto r = run({"info"});
  ASSERT_EQ(r.exit, 0) << r.err;
  EXPECT_NE(r.out.find("SSerial 0 TX0 (out)"), std::string::npos);
  EXPECT_NE(r.out.find("MuxedQCount"), std::string::npos);
  r = run({"monitor", "--frames", "2", "--plain", "--demo", "--display", "20"});
  ASSERT_EQ(r.exit, 0) << r.err;
  EXPECT_NE(r.out.find("channel 0: 7I77 field I/O"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("CS: ok"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("AnalogOut0"), std::string::npos);
}

}  // namespace
