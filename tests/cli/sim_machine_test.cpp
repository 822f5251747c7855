// SPDX-License-Identifier: MIT
// The machine behind the 7I77 in `lbpkit sim --machine`: GET and POST
// /api/machine, its trace in the API and in --record's CSV file, the
// mistakes the API and the CLI refuse, and the files --trace and --record
// may write. Each test starts its own sim on a loopback address of its own
// and stops it before it ends.
#include <sys/stat.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cstddef>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "support/process.hpp"
#include "support/sim_api.hpp"
#include "support/sim_child.hpp"

namespace {

using namespace std::chrono_literals;
using namespace test_support::sim_api;
using nlohmann::json;
using Clock = std::chrono::steady_clock;

// --- The machine behind the 7I77 ---------------------------------------

json axisNamed(const json& machine, const std::string& name) {
  for (const auto& a : machine["axes"])
    if (a["name"] == name) return a;
  return {};
}

// Polls GET /api/machine until `done` says so (5 s at most); the last answer.
template <typename Done>
json machineWhen(Sim& sim, Done done) {
  json m;
  const auto end = Clock::now() + 5s;
  do {
    m = sim.get("/api/machine").body;
    if (done(m)) break;
    std::this_thread::sleep_for(20ms);
  } while (Clock::now() < end);
  return m;
}

TEST(SimMachine, WithoutAMachineTheMachineRoutesAnswer404) {
  Sim sim(loopback(13));
  ASSERT_TRUE(sim.up());
  for (const auto* path : {"/api/machine", "/api/machine/trace"}) {
    const auto r = sim.get(path);
    EXPECT_EQ(r.status, 404) << path;
    EXPECT_NE(r.body.value("error", "").find("--machine"), std::string::npos) << r.raw;
  }
  EXPECT_EQ(sim.post("/api/machine", {{"action", "estop"}, {"pressed", true}}).status, 404);
  const auto r = sim.get();
  ASSERT_EQ(r.status, 200);
  ASSERT_TRUE(r.body.contains("machine"));
  EXPECT_TRUE(r.body["machine"].is_null());
  EXPECT_EQ(sim.stopWithin(2000ms), 0);
}

TEST(SimMachine, GetMachineShowsTheMillAndItsActionsWork) {
  Sim sim(loopback(14), {"--machine", "mill"});
  ASSERT_TRUE(sim.up());
  EXPECT_NE(sim.daemon().readUntil("machine: mill").find("machine: mill (built-in mill)"), std::string::npos);
  auto r = sim.get("/api/machine");
  ASSERT_EQ(r.status, 200) << r.raw;
  auto m = r.body;
  EXPECT_EQ(m["name"], "mill");
  ASSERT_EQ(m["axes"].size(), 3U);
  EXPECT_EQ(m["axes"][0]["name"], "x");
  EXPECT_EQ(m["axes"][0]["position"].get<double>(), 200.0);
  EXPECT_EQ(m["axes"][1]["position"].get<double>(), 150.0);
  EXPECT_EQ(m["axes"][2]["position"].get<double>(), -75.0);
  const auto& drive = m["axes"][0]["drives"][0];
  for (const auto* key : {"analog_output", "command_volts", "ena", "enabled", "torque", "encoder_input",
                          "encoder_count", "true_counts", "encoder_broken", "encoder_reversed", "enable_ignored"})
    EXPECT_TRUE(drive.contains(key)) << key;
  EXPECT_FALSE(drive["encoder_reversed"].get<bool>());
  EXPECT_FALSE(drive["enable_ignored"].get<bool>());
  EXPECT_EQ(m["axes"][0]["switches"].size(), 3U);
  EXPECT_EQ(m["axes"][0]["switches"][2]["name"], "x-max");
  EXPECT_EQ(m["axes"][0]["switches"][2]["kind"], "max_limit");
  EXPECT_TRUE(m["axes"][0]["switches"][2]["input_on"].get<bool>());  // normally closed, inside the travel
  EXPECT_TRUE(m["estop_ok"].get<bool>());
  EXPECT_FALSE(m["probe"].get<bool>());
  EXPECT_EQ(m["switches"].size(), 11U);
  EXPECT_EQ(m["outputs"][0]["name"], "coolant");
  EXPECT_TRUE(m["spindle"].is_object());
  // The same in /api/state.
  r = sim.get();
  ASSERT_EQ(r.status, 200);
  EXPECT_EQ(r.body["machine"]["name"], "mill");

  // E-stop: the chain's input (9) goes off, in the machine and at the 7I77.
  r = sim.post("/api/machine", {{"action", "estop"}, {"pressed", true}});
  ASSERT_EQ(r.status, 200) << r.raw;
  EXPECT_FALSE(r.body["estop_ok"].get<bool>());
  r = sim.get();
  EXPECT_FALSE(r.body["daughtercards"][0]["field_io"]["inputs"][9]["on"].get<bool>());
  r = sim.post("/api/machine", {{"action", "estop"}, {"pressed", false}});
  EXPECT_TRUE(r.body["estop_ok"].get<bool>());
  r = sim.post("/api/machine", {{"action", "probe"}, {"touching", true}});
  EXPECT_TRUE(r.body["probe"].get<bool>());
  r = sim.post("/api/machine", {{"action", "switch"}, {"name", "y-min"}, {"tripped", true}});
  ASSERT_EQ(r.status, 200);
  EXPECT_TRUE(axisNamed(r.body, "y")["switches"][1]["tripped"].get<bool>());
  EXPECT_FALSE(axisNamed(r.body, "y")["switches"][1]["input_on"].get<bool>());

  // A push moves Y by 3 mm (the drives are off: nothing pushes back).
  r = sim.post("/api/machine", {{"action", "push"}, {"axis", "y"}, {"distance", 3.0}, {"speed", 100.0}});
  ASSERT_EQ(r.status, 200) << r.raw;
  m = machineWhen(sim, [](const json& j) { return !axisNamed(j, "y")["pushing"].get<bool>(); });
  EXPECT_NEAR(axisNamed(m, "y")["position"].get<double>(), 153.0, 1e-6);
  EXPECT_NEAR(axisNamed(m, "y")["drives"][0]["true_counts"].get<double>(), 153.0 * 1600.0, 1e-3);
  // Jammed, a push waits.
  r = sim.post("/api/machine", {{"action", "jam"}, {"axis", "x"}, {"jammed", true}});
  EXPECT_TRUE(axisNamed(r.body, "x")["jammed"].get<bool>());
  r = sim.post("/api/machine", {{"action", "push"}, {"axis", "x"}, {"distance", -1.0}});
  EXPECT_TRUE(axisNamed(r.body, "x")["pushing"].get<bool>());
  std::this_thread::sleep_for(100ms);
  EXPECT_EQ(axisNamed(sim.get("/api/machine").body, "x")["position"].get<double>(), 200.0);
  sim.post("/api/machine", {{"action", "jam"}, {"axis", "x"}, {"jammed", false}});
  m = machineWhen(sim, [](const json& j) { return !axisNamed(j, "x")["pushing"].get<bool>(); });
  EXPECT_NEAR(axisNamed(m, "x")["position"].get<double>(), 199.0, 1e-6);
  // Encoder channels, the spindle's too.
  r = sim.post("/api/machine", {{"action", "encoder"}, {"axis", "z"}, {"channel", "A"}, {"broken", true}});
  ASSERT_EQ(r.status, 200);
  EXPECT_EQ(axisNamed(r.body, "z")["drives"][0]["encoder_broken"], json::array({"A"}));
  r = sim.post("/api/machine", {{"action", "encoder"}, {"axis", "spindle"}, {"channel", "index"}, {"broken", true}});
  ASSERT_EQ(r.status, 200) << r.raw;
  EXPECT_EQ(r.body["spindle"]["encoder_broken"], json::array({"index"}));
  r = sim.get();
  EXPECT_EQ(r.body["daughtercards"][0]["encoders"][5]["counts_per_rev"].get<int>(), 0);  // no index pulses
  // A and B swapped, and put right; the spindle's too.
  r = sim.post("/api/machine", {{"action", "encoder"}, {"axis", "x"}, {"reversed", true}});
  ASSERT_EQ(r.status, 200) << r.raw;
  EXPECT_TRUE(axisNamed(r.body, "x")["drives"][0]["encoder_reversed"].get<bool>());
  EXPECT_FALSE(axisNamed(r.body, "y")["drives"][0]["encoder_reversed"].get<bool>());
  EXPECT_EQ(axisNamed(r.body, "x")["drives"][0]["encoder_broken"], json::array());
  r = sim.post("/api/machine", {{"action", "encoder"}, {"axis", "spindle"}, {"reversed", true}});
  ASSERT_EQ(r.status, 200) << r.raw;
  EXPECT_TRUE(r.body["spindle"]["encoder_reversed"].get<bool>());
  r = sim.post("/api/machine", {{"action", "encoder"}, {"axis", "x"}, {"drive", 0}, {"reversed", false}});
  ASSERT_EQ(r.status, 200) << r.raw;
  EXPECT_FALSE(axisNamed(r.body, "x")["drives"][0]["encoder_reversed"].get<bool>());
  // An amplifier deaf to its enable: enabled with ENA off; put right, off.
  r = sim.post("/api/machine", {{"action", "amplifier"}, {"axis", "y"}, {"enable_ignored", true}});
  ASSERT_EQ(r.status, 200) << r.raw;
  auto y = axisNamed(r.body, "y")["drives"][0];
  EXPECT_TRUE(y["enable_ignored"].get<bool>());
  EXPECT_FALSE(y["ena"].get<bool>());
  EXPECT_TRUE(y["enabled"].get<bool>());
  EXPECT_FALSE(axisNamed(r.body, "x")["drives"][0]["enable_ignored"].get<bool>());
  r = sim.post("/api/machine", {{"action", "amplifier"}, {"axis", "y"}, {"drive", 0}, {"enable_ignored", false}});
  ASSERT_EQ(r.status, 200) << r.raw;
  y = axisNamed(r.body, "y")["drives"][0];
  EXPECT_FALSE(y["enable_ignored"].get<bool>());
  EXPECT_FALSE(y["enabled"].get<bool>());
  EXPECT_EQ(sim.stopWithin(2000ms), 0);
}

TEST(SimMachine, BadMachineActionsAreRefusedNamingTheField) {
  Sim sim(loopback(15), {"--machine", "lathe"});
  ASSERT_TRUE(sim.up());
  struct Case {
    json body;
    const char* says;
  };
  const std::vector<Case> cases = {
      {json::object(), "missing \"action\""},
      {{{"action", 3}}, "\"action\" must be a string"},
      {{{"action", "fly"}}, "\"action\" must be one of push, jam, encoder, amplifier, estop, probe, switch"},
      {{{"action", "push"}, {"distance", 1.0}}, "missing \"axis\""},
      {{{"action", "push"}, {"axis", "y"}, {"distance", 1.0}}, "this machine has no axis \"y\" (it has x, z)"},
      {{{"action", "push"}, {"axis", "x"}}, "missing \"distance\""},
      {{{"action", "push"}, {"axis", "x"}, {"distance", "far"}}, "\"distance\" must be a number"},
      {{{"action", "push"}, {"axis", "x"}, {"distance", 1e9}}, "\"distance\" must be a number"},
      {{{"action", "push"}, {"axis", "x"}, {"distance", 1.0}, {"speed", 0}}, "\"speed\" must be a number above 0"},
      {{{"action", "push"}, {"axis", "x"}, {"distance", 1.0}, {"speed", -5}}, "\"speed\" must be a number above 0"},
      {{{"action", "jam"}, {"axis", "x"}}, "missing \"jammed\""},
      {{{"action", "jam"}, {"axis", "x"}, {"jammed", 1}}, "\"jammed\" must be true or false"},
      {{{"action", "encoder"}, {"axis", "q"}, {"channel", "A"}, {"broken", true}}, "no axis \"q\""},
      {{{"action", "encoder"}, {"axis", "x"}, {"channel", "Z"}, {"broken", true}},
       "\"channel\" must be \"A\", \"B\" or \"index\""},
      {{{"action", "encoder"}, {"axis", "x"}, {"drive", 1}, {"channel", "A"}, {"broken", true}},
       "\"drive\" must be a whole number below 1"},
      {{{"action", "encoder"}, {"axis", "x"}, {"channel", "A"}}, "missing \"broken\""},
      {{{"action", "encoder"}, {"axis", "x"}}, "missing \"channel\" and \"broken\" (a broken wire) or \"reversed\""},
      {{{"action", "encoder"}, {"axis", "x"}, {"channel", "A"}, {"broken", true}, {"reversed", true}},
       "\"reversed\" goes alone: give either \"channel\" and \"broken\""},
      {{{"action", "encoder"}, {"axis", "x"}, {"broken", false}, {"reversed", true}}, "\"reversed\" goes alone"},
      {{{"action", "encoder"}, {"axis", "x"}, {"reversed", "yes"}}, "\"reversed\" must be true or false"},
      {{{"action", "encoder"}, {"axis", "x"}, {"drive", 1}, {"reversed", true}},
       "\"drive\" must be a whole number below 1"},
      {{{"action", "encoder"}, {"axis", "q"}, {"reversed", true}}, "no axis \"q\""},
      {{{"action", "amplifier"}, {"axis", "x"}}, "missing \"enable_ignored\""},
      {{{"action", "amplifier"}, {"axis", "x"}, {"enable_ignored", 1}}, "\"enable_ignored\" must be true or false"},
      {{{"action", "amplifier"}, {"axis", "spindle"}, {"enable_ignored", true}},
       "this machine has no axis \"spindle\""},
      {{{"action", "amplifier"}, {"axis", "z"}, {"drive", 1}, {"enable_ignored", true}},
       "\"drive\" must be a whole number below 1"},
      {{{"action", "amplifier"}, {"axis", "x"}, {"reversed", true}}, "unknown key \"reversed\""},
      {{{"action", "estop"}}, "missing \"pressed\""},
      {{{"action", "probe"}, {"touching", "yes"}}, "\"touching\" must be true or false"},
      {{{"action", "switch"}, {"name", "nope"}, {"tripped", true}}, "this machine has no switch \"nope\""},
      {{{"action", "switch"}, {"tripped", true}}, "missing \"name\""},
      {{{"action", "push"}, {"axis", "x"}, {"distance", 1.0}, {"sped", 2}}, "unknown key \"sped\""},
      {{{"action", "estop"}, {"pressed", true}, {"axis", "x"}}, "unknown key \"axis\""},
  };
  for (const auto& c : cases) {
    const auto r = sim.post("/api/machine", c.body);
    EXPECT_EQ(r.status, 400) << c.body.dump() << " " << r.raw;
    EXPECT_NE(r.body.value("error", "").find(c.says), std::string::npos) << c.body.dump() << " " << r.raw;
  }
  for (const auto* q : {"since=x", "since=", "since=1e400", "since=5s"}) {
    const auto r = sim.get(std::string("/api/machine/trace?") + q);
    EXPECT_EQ(r.status, 400) << q << " " << r.raw;
    EXPECT_NE(r.body.value("error", "").find("\"since\" must be a number"), std::string::npos) << r.raw;
  }
  // Nothing changed.
  const auto m = sim.get("/api/machine").body;
  EXPECT_EQ(axisNamed(m, "x")["position"].get<double>(), 50.0);
  EXPECT_FALSE(axisNamed(m, "x")["jammed"].get<bool>());
  EXPECT_FALSE(axisNamed(m, "x")["drives"][0]["encoder_reversed"].get<bool>());
  EXPECT_EQ(axisNamed(m, "x")["drives"][0]["encoder_broken"], json::array());
  EXPECT_FALSE(axisNamed(m, "z")["drives"][0]["enable_ignored"].get<bool>());
  EXPECT_TRUE(m["estop_ok"].get<bool>());
  EXPECT_EQ(sim.stopWithin(2000ms), 0);
}

TEST(SimMachine, TheCliRefusesMachineMistakes) {
  const auto state = tempPath("machine-cli");
  auto r = test_support::run({"sim", "--machine", "mill", "--demo", "--no-realtime", "--state", state},
                                std::chrono::seconds(5));
  EXPECT_NE(r.exit, 0);
  EXPECT_NE((r.out + r.err).find("--demo"), std::string::npos) << r.out << r.err;
  r = test_support::run({"sim", "--record", tempPath("orphan.csv"), "--no-realtime", "--state", state},
                           std::chrono::seconds(5));
  EXPECT_NE(r.exit, 0);
  EXPECT_NE(r.err.find("--record needs --machine"), std::string::npos) << r.err;
  r = test_support::run({"sim", "--machine", tempPath("no-such-machine.toml"), "--no-realtime", "--state", state},
                           std::chrono::seconds(5));
  EXPECT_NE(r.exit, 0);
  EXPECT_NE(r.err.find("no-such-machine.toml"), std::string::npos) << r.err;
  r = test_support::run({"sim", "--machine", "mill", "--record", "/nonexistent-dir/trace.csv", "--bind",
                            loopback(16) + ":0", "--api", loopback(16) + ":0", "--no-realtime", "--state", state},
                           std::chrono::seconds(5));
  EXPECT_NE(r.exit, 0);
  EXPECT_NE(r.err.find("--record /nonexistent-dir/trace.csv: No such file or directory"), std::string::npos) << r.err;
  test_support::removeStateFiles(state);
}

// --trace and --record write only what the user named as output: never
// through a link, never a FIFO, never the sim's own EEPROM, and an existing
// file only when it is the output of an earlier run.
TEST(SimOutputFiles, TraceAndRecordNeverWriteOverWhatTheUserDidNotName) {
  namespace fs = std::filesystem;
  auto slurp = [](const std::string& p) {
    std::ifstream in(p, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  };
  const auto state = tempPath("outputs.eeprom");
  {
    Sim first(test_support::SimOptions{loopback(19), 0, {}, true, state, {}});
    ASSERT_TRUE(first.up());
    EXPECT_EQ(first.stop(), 0);
  }
  const auto eeprom = slurp(state);
  ASSERT_FALSE(eeprom.empty());
  auto refused = [&](const std::vector<std::string>& extra, const std::string& why) {
    std::vector<std::string> args{"sim", "--bind", loopback(19) + ":0", "--api", loopback(19) + ":0", "--no-realtime",
                                  "--state", state};
    args.insert(args.end(), extra.begin(), extra.end());
    const auto r = test_support::run(args, std::chrono::seconds(10));
    EXPECT_NE(r.exit, 0) << r.out << r.err;
    EXPECT_NE(r.err.find(why), std::string::npos) << r.out << r.err;
  };
  // The sim's own EEPROM, by its own path and through another name for it.
  refused({"--trace", state}, "is the sim's own");
  const auto hard = tempPath("hard.pcap");
  fs::create_hard_link(state, hard);
  refused({"--trace", hard}, "is the sim's own");
  EXPECT_EQ(slurp(state), eeprom) << "the EEPROM is untouched";
  // A link, and what it points at untouched.
  const auto precious = tempPath("precious.txt");
  std::ofstream(precious) << "a file of the user's\n";
  const auto link = tempPath("link.pcap");
  fs::create_symlink(precious, link);
  refused({"--trace", link}, "a symbolic link");
  EXPECT_EQ(slurp(precious), "a file of the user's\n");
  // A file that is not a capture or a record.
  refused({"--trace", precious}, "exists and is not what this option writes");
  refused({"--machine", "mill", "--record", precious}, "exists and is not what this option writes");
  EXPECT_EQ(slurp(precious), "a file of the user's\n");
  // A FIFO: refused at once, not waited on.
  const auto fifo = tempPath("trace.fifo");
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  refused({"--trace", fifo}, "a FIFO");
  // The same file for both.
  const auto both = tempPath("both.pcap");
  refused({"--machine", "mill", "--record", both, "--trace", both}, "exists and is not what this option writes");
  // An earlier run's capture and record are replaced.
  const auto pcap = tempPath("earlier.pcap");
  const auto csv = tempPath("earlier.csv");
  for (int run = 0; run < 2; ++run) {
    Sim sim(test_support::SimOptions{loopback(19), 0, {}, true, state, {"--machine", "mill", "--trace", pcap, "--record", csv}});
    ASSERT_TRUE(sim.up()) << "run " << run;
    EXPECT_EQ(sim.stop(), 0);
  }
  EXPECT_EQ(slurp(pcap).substr(0, 4), std::string("\x4D\x3C\xB2\xA1", 4)) << "a nanosecond pcap, little-endian";
  EXPECT_EQ(slurp(csv).rfind("time_s,", 0), 0U);
  EXPECT_EQ(slurp(state).size(), eeprom.size());
}

// A host cycling the mill over UDP: every servo cycle is a row of the trace,
// in GET /api/machine/trace and in the --record CSV file.
TEST(SimMachine, RecordsEveryServoCycle) {
  const auto csv = tempPath("trace.csv");
  std::size_t cycles = 0;
  json trace;
  {
    Sim sim(loopback(17), {"--machine", "mill", "--record", csv});
    ASSERT_TRUE(sim.up());
    EXPECT_NE(sim.daemon().readUntil("recording:").find("recording: every servo cycle to " + csv), std::string::npos);
    // Not about the 7I77's watchdog: a held-back test is not a stalled host.
    ASSERT_EQ(test_support::patient7i77Watchdogs(sim.address() + ":" + std::to_string(sim.udpPort()), {0, 1}), "");
    HostOnSim host(sim);
    auto& t = host.t;
    auto& ss = host.ss;
    const auto a0 = ss.find(1, "analogout0");
    const auto ena = ss.find(1, "analogena");
    ss.setRaw(ena, 1);
    ss.set(a0, 2.0);  // X at 50 mm/s
    const auto start = sim.get("/api/machine/trace").body["rows"].size();
    for (; cycles < 400; ++cycles) {
      ASSERT_TRUE(ss.cycle().ok);
      t.sleep(1ms);
    }
    const auto m = sim.get("/api/machine").body;
    EXPECT_TRUE(axisNamed(m, "x")["drives"][0]["enabled"].get<bool>());
    EXPECT_NEAR(axisNamed(m, "x")["velocity"].get<double>(), 50.0, 1.0);
    trace = sim.get("/api/machine/trace").body;
    ASSERT_TRUE(trace["rows"].is_array()) << trace.dump().substr(0, 300);
    EXPECT_GE(trace["rows"].size(), start + cycles);
    EXPECT_LE(trace["rows"].size(), start + cycles + 20);
    // The row's time as the API gave it (to the nanosecond: the plant's
    // spans end where the host's datagrams came).
    const std::string since = trace["rows"][trace["rows"].size() - 10][0].dump();
    EXPECT_EQ(sim.get("/api/machine/trace?since=" + since).body["rows"].size(), 9U);
    ss.set(a0, 0.0);
    ss.setRaw(ena, 0);
    ASSERT_TRUE(ss.cycle().ok);
    EXPECT_EQ(sim.stopWithin(2000ms), 0);
  }
  const std::vector<std::string> columns{"time_s",     "x_command_volts",   "x_command_velocity", "x_position",
                                         "x_velocity", "x_following_error", "x_enabled",          "y_command_volts"};
  for (std::size_t i = 0; i < columns.size(); ++i) EXPECT_EQ(trace["columns"][i], columns[i]);
  EXPECT_EQ(trace["columns"].back(), "spindle_rpm");
  // The CSV: the same columns, a row per cycle, numbers that make sense.
  std::ifstream in(csv);
  std::string line;
  ASSERT_TRUE(std::getline(in, line));
  std::string header;
  for (const auto& c : trace["columns"]) header += (header.empty() ? "" : ",") + c.get<std::string>();
  EXPECT_EQ(line, header);
  std::vector<std::vector<double>> rows;
  while (std::getline(in, line)) {
    std::vector<double> row;
    std::stringstream fields(line);
    std::string f;
    while (std::getline(fields, f, ',')) row.push_back(std::stod(f));
    ASSERT_EQ(row.size(), trace["columns"].size()) << line;
    rows.push_back(row);
  }
  std::filesystem::remove(csv);
  ASSERT_GE(rows.size(), cycles);
  EXPECT_LE(rows.size(), cycles + 30);
  for (std::size_t i = 1; i < rows.size(); ++i) ASSERT_GT(rows[i][0], rows[i - 1][0]) << "row " << i;
  std::size_t moving = 0;
  for (const auto& row : rows) {
    if (row[1] < 1.99) continue;  // before the 2 V came
    ++moving;
    EXPECT_NEAR(row[1], 2.0, 0.01);
    EXPECT_NEAR(row[2], 50.0, 0.5);  // 2 V at 25 mm/s per volt
    EXPECT_GE(row[3], 200.0);
    EXPECT_LE(row[4], 60.0);  // the drive's velocity loop overshoots a little, then settles
    EXPECT_GT(row[5], -0.05);  // it lags its command, a little, and catches up
    EXPECT_LT(row[5], 0.5);
    EXPECT_EQ(row[6], 1.0);  // ENA on: the drive enabled
  }
  EXPECT_GE(moving, cycles - 5);
  // The last row at 2 V (the rows after it follow the 0 V that ended the
  // test, and how far X has slowed by then depends on when they were taken).
  const auto lastMoving = std::find_if(rows.rbegin(), rows.rend(), [](const auto& row) { return row[1] >= 1.99; });
  ASSERT_NE(lastMoving, rows.rend());
  // The rows after it that have the 0 V have ENA off with it (one process
  // data write carries both): the drive disabled.
  for (auto row = rows.rbegin(); row != lastMoving; ++row) {
    if ((*row)[1] == 0.0) {
      EXPECT_EQ((*row)[6], 0.0);
    }
  }
  EXPECT_NEAR((*lastMoving)[4], 50.0, 0.5);
  EXPECT_GT((*lastMoving)[3], 210.0);  // 400 ms at up to 50 mm/s
  EXPECT_NEAR(rows.back()[9], 150.0, 1e-9);  // Y stayed
}

}  // namespace
