// SPDX-License-Identifier: MIT
// A stepper axis and the 7I76 in the control API:
// `lbpkit sim --card 7I92T --machine FILE`
// with a stepper axis. GET /api/machine (and "machine" in GET /api/state)
// gives a stepper axis a "stepper" object (its StepGen's steps, the steps
// the motor lost, a stall) and no drives, a servo axis "stepper": null and
// its drives; GET /api/state lists the 7I76 after the 7I77 among
// the daughtercards, with its inputs, outputs, field voltage and spindle
// interface, and /api/input, /api/field and /api/output reach it by its
// connector. A host writes StepGen 0's registers and cycles the 7I76 over
// LBP16, as LinuxCNC's hostmot2 would.
#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <tuple>

#include "lbpkit/hostmot2.hpp"
#include "lbpkit/lbp16_transport.hpp"
#include "lbpkit/sserial.hpp"
#include "support/sim_child.hpp"
#include "support/wait.hpp"
#include "support/stepgen_registers.hpp"

namespace {

using namespace std::chrono_literals;
using nlohmann::json;

constexpr double kStepsPerMm = 800.0;
constexpr double kPullOut = 40000.0;  // steps/s, the file's max_step_rate

// X a servo axis, Z a stepper on StepGen 0 at -1000 mm.
const std::string kMachine = LBPKIT_TESTS_DIR "/machines/router_stepper.toml";

using test_support::waitFor;

class StepperAnd7I76Api : public testing::Test {
 protected:
  void SetUp() override {
    sim_ = std::make_unique<test_support::SimChild>(
        test_support::SimOptions{"127.0.0.1", 0, {}, true, {}, {"--card", "7I92T", "--machine", kMachine}});
    udp_ = sim_->udpPort();
    api_ = sim_->apiPort();
    ASSERT_GT(udp_, 0);
    ASSERT_GT(api_, 0);
  }
  void TearDown() override {
    if (sim_) {
      EXPECT_EQ(sim_->stopWithin(10s), 0);
    }
    sim_.reset();
  }
  json get(const std::string& path) { return sim_->get(path); }
  // The status and the answer.
  std::pair<int, json> post(const std::string& path, const json& body) {
    const auto r = sim_->post(path, body);
    return {r.status, r.body};
  }
  json z() { return get("/api/machine")["axes"][1]; }

  std::unique_ptr<test_support::SimChild> sim_;
  int udp_ = 0, api_ = 0;
};

// A host on LBP16: StepGen 0's registers, and the transport for a cycle.
class StepGenHost {
 public:
  explicit StepGenHost(int port)
      : t_("127.0.0.1", static_cast<std::uint16_t>(port)), info_(lbpkit::readCardInfo(t_)), stepGen_(t_, info_) {}
  void setStepRate(double stepsPerSecond) { stepGen_.setRate(stepsPerSecond); }
  lbpkit::Lbp16Transport& transport() { return t_; }
  const lbpkit::CardInfo& info() const { return info_; }

 private:
  lbpkit::Lbp16Transport t_;
  lbpkit::CardInfo info_;
  testing_stepgen::StepGenRegisters stepGen_;
};

TEST_F(StepperAnd7I76Api, AStepperAxisHasAStepperObjectAndNoDrives) {
  const auto m = get("/api/machine");
  ASSERT_TRUE(m.is_object());
  const auto& x = m["axes"][0];
  const auto& z = m["axes"][1];
  // The servo axis as without a stepper, "stepper": null.
  EXPECT_EQ(x["name"], "x");
  EXPECT_TRUE(x["stepper"].is_null()) << x.dump();
  ASSERT_EQ(x["drives"].size(), 1U);
  for (const char* key : {"analog_output", "command_volts", "ena", "enabled", "torque", "encoder_input",
                          "encoder_count", "true_counts", "encoder_broken"})
    EXPECT_TRUE(x["drives"][0].contains(key)) << key;
  // The stepper: no drives, its StepGen, nothing stepped yet.
  EXPECT_EQ(z["name"], "z");
  EXPECT_TRUE(z["drives"].is_array());
  EXPECT_TRUE(z["drives"].empty()) << z.dump();
  ASSERT_TRUE(z["stepper"].is_object()) << z.dump();
  EXPECT_EQ(z["stepper"]["stepgen"], 0);
  EXPECT_EQ(z["stepper"]["steps"], 0);
  EXPECT_EQ(z["stepper"]["lost_steps"], 0);
  EXPECT_EQ(z["stepper"]["stalled"], false);
  EXPECT_DOUBLE_EQ(z["stepper"]["commanded_position"].get<double>(), z["position"].get<double>());
  EXPECT_DOUBLE_EQ(z["position"].get<double>(), -1000.0);
  // GET /api/state's "machine" is the same document.
  const auto s = get("/api/state");
  ASSERT_TRUE(s["machine"].is_object());
  EXPECT_EQ(s["machine"]["axes"][1]["stepper"]["stepgen"], 0);
  EXPECT_TRUE(s["machine"]["axes"][0]["stepper"].is_null());
  // A stepper has no encoder to reverse and no amplifier to miswire; the
  // servo axis has both. The trace has no z_enabled.
  auto [code, body] = post("/api/machine", {{"action", "encoder"}, {"axis", "z"}, {"reversed", true}});
  EXPECT_EQ(code, 400);
  EXPECT_EQ(body["error"], "\"axis\": z is a stepper axis: it has no encoder");
  std::tie(code, body) = post("/api/machine", {{"action", "amplifier"}, {"axis", "z"}, {"enable_ignored", true}});
  EXPECT_EQ(code, 400);
  EXPECT_EQ(body["error"], "\"axis\": z is a stepper axis: it has no amplifier");
  std::tie(code, body) = post("/api/machine", {{"action", "amplifier"}, {"axis", "x"}, {"enable_ignored", true}});
  EXPECT_EQ(code, 200) << body.dump();
  EXPECT_TRUE(body["axes"][0]["drives"][0]["enable_ignored"].get<bool>());
  const auto columns = get("/api/machine/trace")["columns"];
  EXPECT_NE(std::find(columns.begin(), columns.end(), "x_enabled"), columns.end()) << columns.dump();
  EXPECT_EQ(std::find(columns.begin(), columns.end(), "z_enabled"), columns.end()) << columns.dump();
}

TEST_F(StepperAnd7I76Api, StepsLostStepsAndAStallShowAsTheStepGenRuns) {
  StepGenHost host(udp_);
  // Within the pull-out rate: every step moves Z, none lost.
  host.setStepRate(20000.0);
  ASSERT_TRUE(waitFor([&] { return z()["stepper"]["steps"].get<std::int64_t>() > 4000; })) << z().dump();
  host.setStepRate(0.0);
  std::this_thread::sleep_for(50ms);
  auto a = z();
  const auto steps = a["stepper"]["steps"].get<std::int64_t>();
  EXPECT_EQ(a["stepper"]["lost_steps"], 0) << a.dump();
  EXPECT_EQ(a["stepper"]["stalled"], false);
  EXPECT_NEAR(a["position"].get<double>(), -1000.0 + static_cast<double>(steps) / kStepsPerMm, 1e-9) << a.dump();
  EXPECT_NEAR(a["stepper"]["commanded_position"].get<double>(), a["position"].get<double>(), 1e-9);
  // Past it: the motor stalls, the steps made meanwhile are lost, and the
  // commanded position runs ahead of where Z is by exactly them.
  host.setStepRate(1.5 * kPullOut);
  ASSERT_TRUE(waitFor([&] {
    const auto b = z();
    return b["stepper"]["stalled"] == true && b["stepper"]["lost_steps"].get<std::int64_t>() > 2000;
  })) << z().dump();
  host.setStepRate(0.0);
  std::this_thread::sleep_for(50ms);
  a = z();
  const auto lost = a["stepper"]["lost_steps"].get<std::int64_t>();
  EXPECT_EQ(a["stepper"]["stalled"], false) << "stopped: in step again; " << a.dump();
  EXPECT_GT(a["stepper"]["steps"].get<std::int64_t>(), steps + lost - 1);
  EXPECT_NEAR(a["stepper"]["commanded_position"].get<double>() - a["position"].get<double>(),
              static_cast<double>(lost) / kStepsPerMm, 1e-9)
      << a.dump();
  EXPECT_NEAR(a["following_error"].get<double>(), static_cast<double>(lost) / kStepsPerMm, 1e-9);
}

TEST_F(StepperAnd7I76Api, The7I76IsListedAfterThe7I77AndTheApiReachesIt) {
  auto s = get("/api/state");
  ASSERT_EQ(s["daughtercards"].size(), 2U) << s["daughtercards"].dump();
  EXPECT_EQ(s["daughtercards"][0]["type"], "7I77");
  EXPECT_EQ(s["daughtercards"][0]["connector"], 0);
  EXPECT_TRUE(s["daughtercards"][0]["analog"].is_object());
  const auto d = s["daughtercards"][1];
  EXPECT_EQ(d["type"], "7I76");
  EXPECT_EQ(d["connector"], 1);
  EXPECT_EQ(d["connector_name"], "P1");
  EXPECT_EQ(d["channel"], 3);
  EXPECT_EQ(d["field_io"]["unit_number"], "0x10000AEE");
  EXPECT_EQ(d["field_io"]["powered"], true);
  EXPECT_DOUBLE_EQ(d["field_io"]["field_voltage"].get<double>(), 24.0);
  ASSERT_EQ(d["field_io"]["inputs"].size(), 32U);
  ASSERT_EQ(d["field_io"]["outputs"].size(), 16U);
  EXPECT_EQ(d["spindle"], (json{{"volts", 0.0}, {"enable", false}, {"direction", false}}));

  // An input, the field voltage and an output's load, by its connector.
  auto [code, body] = post("/api/input", {{"connector", 1}, {"input", 20}, {"on", true}});
  EXPECT_EQ(code, 200) << body.dump();
  EXPECT_EQ(body["daughtercards"][1]["field_io"]["inputs"][20]["on"], true);
  EXPECT_EQ(body["daughtercards"][1]["field_io"]["inputs"][19]["on"], false);
  EXPECT_EQ(body["daughtercards"][0]["field_io"]["inputs"][20]["on"], false) << "the 7I77's INPUT20 is another input";
  std::tie(code, body) = post("/api/field", {{"connector", 1}, {"volts", 12.0}});
  EXPECT_EQ(code, 200) << body.dump();
  EXPECT_DOUBLE_EQ(body["daughtercards"][1]["field_io"]["field_voltage"].get<double>(), 12.0);
  EXPECT_DOUBLE_EQ(body["daughtercards"][0]["field_io"]["field_voltage"].get<double>(), 24.0);
  std::tie(code, body) = post("/api/output", {{"connector", 1}, {"output", 3}, {"ohms", 1000}});
  EXPECT_EQ(code, 200) << body.dump();
  // What it cannot do is refused, naming why.
  std::tie(code, body) = post("/api/field", {{"connector", 1}, {"vin", 5.0}});
  EXPECT_EQ(code, 400);
  EXPECT_NE(body["error"].get<std::string>().find("7I76 has no VIN"), std::string::npos) << body.dump();
  std::tie(code, body) = post("/api/overtemp", {{"connector", 1}, {"chip", 0}, {"hot", true}});
  EXPECT_EQ(code, 400);
  EXPECT_NE(body["error"].get<std::string>().find("connector 1 carries the 7I76"), std::string::npos) << body.dump();
  std::tie(code, body) = post("/api/input", {{"connector", 1}, {"input", 32}, {"on", true}});
  EXPECT_EQ(code, 400) << body.dump();
  std::tie(code, body) = post("/api/field", {{"connector", 1}, {"volts", 24.0}});
  EXPECT_EQ(code, 200);

  // A host on channel 3: its outputs and spindle command reach the terminals.
  StepGenHost card(udp_);
  lbpkit::SmartSerial::Options o;
  o.channelMask = 1U << 3;
  lbpkit::SmartSerial ss(card.transport(), card.info(), o);
  ss.discover(1U << 3);
  ss.startNormal();
  const auto output = ss.find(3, "output"), spinOut = ss.find(3, "spinout"), spinEna = ss.find(3, "spinena"),
             spinDir = ss.find(3, "spindir"), input = ss.find(3, "input");
  ss.setRaw(output, 1U << 3);
  ss.set(spinOut, 2.5);
  ss.setRaw(spinEna, 1);
  ss.setRaw(spinDir, 1);
  // The state is read between cycles, well within the 7I76's watchdog.
  json i76;
  for (int i = 0; i < 2000; ++i) {
    (void)ss.cycle();
    card.transport().sleep(1ms);
    if (i % 10 != 9) continue;
    i76 = get("/api/state")["daughtercards"][1];
    if (i76["field_io"]["outputs"][3]["on"] == true && i76["spindle"]["enable"] == true) break;
  }
  EXPECT_TRUE(ss.bit(input, 20)) << "the host reads the input the API set";
  EXPECT_EQ(i76["field_io"]["outputs"][3]["on"], true) << i76["field_io"]["outputs"].dump();
  EXPECT_DOUBLE_EQ(i76["field_io"]["outputs"][3]["volts"].get<double>(), 24.0);
  EXPECT_NEAR(i76["field_io"]["outputs"][3]["amps"].get<double>(), 0.024, 1e-9);
  EXPECT_EQ(i76["field_io"]["outputs"][2]["on"], false);
  EXPECT_NEAR(i76["spindle"]["volts"].get<double>(), 2.5, 10.0 / 65535);
  EXPECT_EQ(i76["spindle"]["enable"], true);
  EXPECT_EQ(i76["spindle"]["direction"], true);
  EXPECT_EQ(i76["field_io"]["mode"], 0);
}

// Without a 7I76 (the 7I92's default firmware) the list is the 7I77s'.
TEST(StepperAnd7I76ApiWithout, AFirmwareWithoutA7I76ListsOnlyThe7I77s) {
  test_support::SimChild sim("127.0.0.1");
  ASSERT_GT(sim.apiPort(), 0);
  const auto s = sim.get("/api/state");
  ASSERT_TRUE(s.is_object());
  for (const auto& d : s["daughtercards"]) EXPECT_NE(d["type"], "7I76");
  const auto p = sim.post("/api/input", {{"connector", 1}, {"input", 2}, {"on", true}});
  EXPECT_EQ(p.status, 400);
  EXPECT_NE(p.body.dump().find("no 7I77 on connector 1"), std::string::npos) << p.body.dump();
  EXPECT_EQ(sim.stopWithin(10s), 0);
}

}  // namespace
