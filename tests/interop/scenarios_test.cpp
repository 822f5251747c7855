// SPDX-License-Identifier: MIT
// The scenarios in examples/scenarios/, each a fault script that replays a
// LinuxCNC user's report, run against Debian's LinuxCNC (hm2_eth at 1 kHz)
// as a developer runs them: `lbpkit sim --script FILE` on the host clock.
// Each test asserts what Debian's LinuxCNC does under its scenario and
// prints what it saw; examples/scenarios/README.md says how that compares
// with the report. Every scenario's first fault comes at 5 s of simulated
// time and a field input changes at 6 s; on the host clock a simulated
// second is a thousand of LinuxCNC's servo cycles, so what LinuxCNC counts
// does not depend on how this machine schedules it.
#include <gtest/gtest.h>
#include <sched.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <thread>

#include "process/process.hpp"
#include "support/interop.hpp"

namespace interop {
namespace {

using namespace std::chrono_literals;

class Scenario : public LinuxCnc {
 public:
  // What LinuxCNC showed across the scenario's first fault.
  struct Seen {
    long long packetErrors = 0;  // hm2_eth's packet-error-total, from 4.5 s to after the network's counts
    std::string ioError;         // hm2_eth's io_error at 6.5 s
    bool inputSeen = false;      // input 5, switched on at 6 s, read through the smart-serial port
    int faultCountMax = 0;       // the smart-serial port's highest fault-count of any cycle
    std::string portState;       // its port_state at 6.5 s (3: running)
    std::string messages;        // hostmot2's and hm2_eth's messages from loading on
    nlohmann::json network;      // /api/network's counts at 6.5 s, before packetErrors
  };

 protected:
  void TearDown() override {
    LinuxCnc::TearDown();
    std::filesystem::remove(messagesFile());
  }

  // Runs examples/scenarios/`file` against hm2_eth at 1 kHz on the host
  // clock until 6.5 s of simulated time; `extraHal` goes before the thread
  // starts.
  Seen run(const std::string& file, const std::string& extraHal = "") {
    Seen seen;
    sim_ = cardSim({"--script", std::string(LBPKIT_SOURCE_DIR) + "/examples/scenarios/" + file});
    EXPECT_TRUE(sim_->up());
    if (!sim_->up()) return seen;
    // The smart-serial fault-count falls by fault-dec each good cycle,
    // faster than a look through halcmd: minmax.0.max keeps its highest.
    const auto r = load("00xxxxxx", true, messagesFile(),
                        extraHal +
                            "loadrt conv_u32_float\nloadrt minmax\naddf conv-u32-float.0 servo\naddf minmax.0 servo\n"
                            "net fault-count hm2_7i92.0.sserial.port-0.fault-count conv-u32-float.0.in\n"
                            "net fault-count-f conv-u32-float.0.out minmax.0.in\n");
    EXPECT_EQ(r.exit, 0) << r.out << messages();
    if (r.exit != 0) return seen;
    const double loadedAt = simSeconds();
    EXPECT_LT(loadedAt, 4.5) << "LinuxCNC was not running before the scenario's first fault at 5 s";
    EXPECT_TRUE(untilSim(4.5));
    const long long before = packetErrors();
    EXPECT_EQ(getp("hm2_7i92.0.7i77.0.0.input-05"), "FALSE");
    EXPECT_TRUE(untilSim(6.5));
    // The card's counts first: a fault it made just now is in hm2_eth's
    // count once hm2_eth has finished that cycle, which on the host clock
    // is before simulated time has moved on two periods.
    seen.network = sim_->get("/api/network")["did"];
    EXPECT_TRUE(untilSim(simSeconds() + 0.005));
    seen.packetErrors = packetErrors() - before;
    seen.ioError = getp("hm2_7i92.0.io_error");
    seen.inputSeen = getp("hm2_7i92.0.7i77.0.0.input-05") == "TRUE";
    seen.faultCountMax = std::atoi(getp("minmax.0.max").c_str());
    seen.portState = getp("hm2_7i92.0.sserial.port-0.port_state");
    seen.messages = messages();
    std::printf("%s (LinuxCNC running from %.2f s): packet-error-total +%lld, io_error %s, input 5 %s, "
                "sserial fault-count up to %d, port_state %s, network %s\nmessages:\n%s\n",
                file.c_str(), loadedAt, seen.packetErrors, seen.ioError.c_str(), seen.inputSeen ? "seen" : "not seen",
                seen.faultCountMax, seen.portState.c_str(), seen.network.dump().c_str(), seen.messages.c_str());
    return seen;
  }
  long long packetErrors() { return std::atoll(getp("hm2_7i92.0.packet-error-total").c_str()); }
  double simSeconds() { return sim_->get()["time_s"].get<double>(); }
  bool untilSim(double seconds) { return waitFor([&] { return simSeconds() >= seconds; }, 30s); }
  std::string messagesFile() const { return fifo_ + ".messages"; }
  std::string messages() const {
    std::ifstream in(messagesFile());
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  }
};

bool says(const std::string& messages, const char* what) { return messages.find(what) != std::string::npos; }

// The smart-serial port ran on through the fault: input 5, switched on
// after it, reached HAL, the port is in its running state and hostmot2 did
// not stop it.
void expectThePortRanOn(const Scenario::Seen& seen) {
  EXPECT_TRUE(seen.inputSeen);
  EXPECT_EQ(seen.portState, "3");
  EXPECT_FALSE(says(seen.messages, "will be stopped")) << seen.messages;
}

// https://github.com/LinuxCNC/linuxcnc/issues/4525: one read timeout, then
// smart-serial stops ("error finishing read"). Debian's hm2_eth counts the
// one lost reply and goes on: the port keeps running and reads the input.
TEST_F(Scenario, ReadTimeoutIsOnePacketErrorAndTheSmartSerialPortRunsOn) {
  const auto seen = run("read-timeout.toml");
  EXPECT_EQ(seen.network["reply"]["dropped"], 1);
  EXPECT_GE(seen.packetErrors, 1);
  EXPECT_EQ(seen.ioError, "FALSE");
  expectThePortRanOn(seen);
  EXPECT_FALSE(says(seen.messages, "error finishing read")) << seen.messages;
}

// https://github.com/LinuxCNC/linuxcnc/issues/4236: reads answered 800 us
// late now and then. hm2_eth's default read timeout (80 % of the 1 ms
// period) is those same 800 us, so whether it counts a spike depends on
// microseconds of the wall clock (Debian 13's hm2_eth counted 5 of 6 in
// one run): the test gives it 400 us, half a spike, and each spike is then
// a packet error; the level falls back between spikes and the port runs
// on. The error limit is raised to 100, as a measurement of LinuxCNC
// without a real-time kernel needs (its own late cycles are errors at
// that timeout too, docs/faults.md).
TEST_F(Scenario, ReadLatencySpikesPastTheReadTimeoutAreEachAPacketError) {
  const auto seen = run("read-latency-spikes.toml",
                        "setp hm2_7i92.0.packet-read-timeout 400000\nsetp hm2_7i92.0.packet-error-limit 100\n");
  const long long spikes = seen.network["reply"]["delayed"].get<long long>();
  EXPECT_GE(spikes, 5);  // every 250th reply from 5 s to 6.5 s
  EXPECT_GE(seen.packetErrors, spikes);
  expectThePortRanOn(seen);
}

// https://github.com/LinuxCNC/linuxcnc/issues/27: smart-serial does not
// recover from a single transmission error. Debian's hostmot2 counts it
// once (fault-count up by fault-inc, 10, then down by fault-dec each
// cycle) and the port runs on, though SSLBP's error bits stay set until
// the channel is stopped (docs/faults.md).
TEST_F(Scenario, OneTransmissionErrorIsCountedOnceAndThePortRecovers) {
  const auto seen = run("one-transmission-error.toml");
  const auto link = sim_->get("/api/link")["channels"][0];
  EXPECT_EQ(link["did"]["breaks"], 1);
  EXPECT_EQ(link["sslbp"]["errors"]["serial_break"], 1);
  EXPECT_GE(seen.faultCountMax, 9);
  EXPECT_LT(seen.faultCountMax, 200);  // fault-lim: over it the port is stopped
  expectThePortRanOn(seen);
}

// https://github.com/LinuxCNC/linuxcnc/issues/412: "DoIt not cleared from
// previous servo thread". Debian's hostmot2 writes the DoIt after the
// cycle's data in the same datagram, and the card has done it before the
// next read: writes held back past the next read never bring the message.
// What hm2_eth shows instead is a packet error for each, from its count
// of the writes the card received.
TEST_F(Scenario, WritesHeldBackPastTheNextReadArePacketErrorsNotADoItMessage) {
  const auto seen = run("doit-not-cleared.toml");
  const long long late = seen.network["request"]["delayed"].get<long long>();
  EXPECT_GE(late, 2);  // every 500th write from 5 s to 6.5 s
  EXPECT_GE(seen.packetErrors, late);
  expectThePortRanOn(seen);
  EXPECT_FALSE(says(seen.messages, "DoIt not cleared")) << seen.messages;
}

// https://github.com/LinuxCNC/linuxcnc/issues/4322: packet-error-total is
// 1 on every start with another module loaded. One write the card never
// received is what hm2_eth counts so: +1 with every read answered.
TEST_F(Scenario, OneLostWriteIsOnePacketErrorWithoutAReadTimeout) {
  const auto seen = run("lost-write.toml");
  EXPECT_EQ(seen.network["request"]["dropped"], 1);
  EXPECT_EQ(seen.network["reply"]["dropped"], 0);
  EXPECT_GE(seen.packetErrors, 1);
  EXPECT_EQ(seen.ioError, "FALSE");
  expectThePortRanOn(seen);
}

// A PC without a real-time kernel keeps LinuxCNC's servo thread from its
// CPU now and then for longer than the 7I77's 50 ms watchdog: here a
// SCHED_FIFO task above it on its CPU (below the sim's card thread) spins
// for 150 ms, three times. The thread is late, not stopped: runnable all
// the while, which the host clock's watch on its process sees, so time
// waits for it as an on-time machine's would and no watchdog bites
// (docs/clocks.md). The 7I77's watchdog keeps its 50 ms.
TEST_F(Scenario, AServoThreadKeptFromItsCpuIsLateNotStopped) {
  startSim();
  const auto r = load("00xxxxxx", true, messagesFile());
  ASSERT_EQ(r.exit, 0) << r.out << messages();
  ASSERT_TRUE(untilSim(simSeconds() + 0.5));
  const auto before = sim_->get()["clock"];
  for (int i = 0; i < 3; ++i) {
    std::thread hog([] {
      lbpkit::process::pinToCpu(test_support::cardCpu());
      const sched_param p{20};
      if (::sched_setscheduler(0, SCHED_FIFO, &p) != 0) return;
      const auto until = std::chrono::steady_clock::now() + 150ms;
      while (std::chrono::steady_clock::now() < until) {
      }
    });
    hog.join();
    EXPECT_TRUE(untilSim(simSeconds() + 0.3));
  }
  const auto after = sim_->get();
  const auto& clock = after["clock"];
  std::printf("clock before %s\nafter %s\nmessages:\n%s\n", before.dump().c_str(), clock.dump().c_str(),
              messages().c_str());
  EXPECT_GE(clock["host_late_held"].get<int>() - before["host_late_held"].get<int>(), 3);
  EXPECT_EQ(clock["host_silences"], before["host_silences"]);
  EXPECT_GT(clock["host_pid"].get<int>(), 0);
  const auto& faults = after["daughtercards"][0]["field_io"]["faults"];
  EXPECT_EQ(std::find(faults.begin(), faults.end(), "WatchdogFault"), faults.end()) << faults;
  EXPECT_FALSE(says(messages(), "Watchdog Fault")) << messages();
  EXPECT_EQ(getp("hm2_7i92.0.watchdog.has_bit"), "FALSE");
  EXPECT_EQ(getp("hm2_7i92.0.sserial.port-0.port_state"), "3");
}

}  // namespace
}  // namespace interop
