// SPDX-License-Identifier: MIT
// lbpkit rehearse as a user runs it (`sudo lbpkit rehearse CONFIG.ini`, the
// report in the folder it is run from): the example mill
// (examples/linuxcnc/mill) through every check, each verdict and the
// figures that make it asserted; and copies of it with one thing wrong, each
// caught by the check that is about it: FERROR raised to 50 mm (a runaway
// travels past the room the machine has beyond its soft limits before
// LinuxCNC disables the drive), the E-stop input unwired (no field input
// reaches iocontrol.0.emc-enable-in) and the hm2 watchdog at 1 s on a
// stepper with nothing else to stop it (a dead host leaves its StepGen
// stepping). Needs root and linuxcnc-uspace (scripts/test installs it).
#include <unistd.h>

#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <nlohmann/json.hpp>

#include "support/interop.hpp"
#include "support/process.hpp"
#include "support/temp_dir.hpp"

namespace {

namespace fs = std::filesystem;
using nlohmann::json;

class Rehearse : public ::testing::Test {
 protected:
  void SetUp() override {
    if (::geteuid() != 0) GTEST_SKIP() << "lbpkit rehearse needs root";
    if (!test_support::haveClientProgram("linuxcnc") || !interop::have("ip"))
      GTEST_SKIP() << "linuxcnc-uspace or iproute2 is not installed";
    // LinuxCNC runs as nobody (root ran lbpkit): the configuration readable.
    fs::permissions(dir_.path(), fs::perms::owner_all | fs::perms::group_read | fs::perms::group_exec |
                                     fs::perms::others_read | fs::perms::others_exec);
    fs::copy(fs::path(LBPKIT_SOURCE_DIR) / "examples/linuxcnc/mill", config_, fs::copy_options::recursive);
    ::setenv("HOME", dir_.path().c_str(), 1);  // LinuxCNC's and the sim's files in the user's home
    ::unsetenv("DISPLAY");
  }
  // Every line of `file` holding `text` replaced by `with`.
  void change(const std::string& file, const std::string& text, const std::string& with) {
    std::ifstream in(config_ / file);
    std::string out, line;
    unsigned n = 0;
    while (std::getline(in, line)) {
      if (line.find(text) != std::string::npos) {
        line = with;
        ++n;
      }
      out += line + "\n";
    }
    in.close();
    ASSERT_GT(n, 0U) << file << " has no line with " << text;
    std::ofstream(config_ / file, std::ios::trunc) << out;
  }
  // lbpkit rehearse on the copy, from the test's folder (the report goes
  // to rehearse-mill/ there, as it does for a user): its status and output;
  // the report in report_.
  test_support::Result rehearse(std::vector<std::string> more = {}) {
    const auto here = fs::current_path();
    fs::current_path(dir_.path());
    std::vector<std::string> args = {"rehearse", (config_ / "mill.ini").string()};
    args.insert(args.end(), more.begin(), more.end());
    auto r = test_support::run(args, std::chrono::seconds(600));
    fs::current_path(here);
    std::ifstream in(dir_.path() / "rehearse-mill/report.json");
    report_ = json::parse(in, nullptr, false);
    return r;
  }
  const json& check(const std::string& id) const {
    static const json none;
    for (const auto& c : report_["checks"])
      if (c["id"] == id) return c;
    return none;
  }

  test_support::TempDir dir_;
  fs::path config_ = dir_.path() / "config";
  json report_;
};

// The example mill through a check of every kind, in the four LinuxCNC
// sessions a rehearsal makes (the field power's, the network cut's and the
// stopped host's each start from a LinuxCNC of their own).
TEST_F(Rehearse, TheExampleMillThroughEveryKindOfCheck) {
  const auto r = rehearse({"--only",
                           "runaway.x.reversed-encoder.moving,runaway.x.broken-a.holding,runaway.y.jammed,estop,"
                           "limits.x,spindle,field,host"});
  ASSERT_FALSE(report_.is_discarded()) << r.out << r.err;
  ASSERT_FALSE(report_.contains("stopped")) << report_["stopped"] << r.out << r.err;
  std::printf("%s", r.out.c_str());        // a line per check: what was measured
  EXPECT_EQ(r.exit, 1) << r.out << r.err;  // the broken encoder at rest and the field power fail
  EXPECT_TRUE(fs::exists(dir_.path() / "rehearse-mill/report.html"));

  // A reversed encoder at MAX_VELOCITY: FERROR is 10 mm at 200 mm/s,
  // MIN_FERROR 1 mm at rest (mill.ini). X goes at least MIN_FERROR before
  // LinuxCNC takes the machine off, and less than the 21 mm the machine has
  // past its soft limits.
  const auto& reversed = check("runaway.x.reversed-encoder.moving");
  EXPECT_EQ(reversed["verdict"], "pass") << reversed.dump().substr(0, 700);
  const auto& f = reversed["figures"];
  EXPECT_GT(f["distance_to_disable"].get<double>(), 1.0) << f.dump();
  EXPECT_LT(f["distance_to_disable"].get<double>(), 21.0) << f.dump();
  EXPECT_DOUBLE_EQ(f["bound"].get<double>(), 21.0) << f.dump();
  EXPECT_GT(f["time_to_disable_s"].get<double>(), 0.0) << f.dump();
  EXPECT_FALSE(f["hit_hard_stop"].get<bool>());
  EXPECT_NE(r.out.find("pass  X: reversed encoder while moving"), std::string::npos) << r.out;

  // A broken A channel while the axis holds still: the count stands, so
  // LinuxCNC sees the small error it last had and no more; its PID's
  // integrator (I = 1000, DEADBAND = 0: mill.ini) winds up on it and the
  // axis creeps away, unseen: more than MIN_FERROR (1 mm) in the 3 s
  // watched, however far (that depends on where in a servo period the wire
  // broke).
  const auto& broken = check("runaway.x.broken-a.holding");
  EXPECT_EQ(broken["verdict"], "fail") << broken.dump().substr(0, 700);
  EXPECT_NE(broken["reason"].get<std::string>().find("LinuxCNC never took the machine off"), std::string::npos);
  EXPECT_GT(broken["figures"]["distance"].get<double>(), 1.0) << broken["figures"].dump();
  EXPECT_NE(r.out.find("FAIL  X: broken encoder A channel while holding position"), std::string::npos) << r.out;

  // A jammed axis does not move: moving, LinuxCNC takes the machine off;
  // holding, it needs not.
  EXPECT_EQ(check("runaway.y.jammed.moving")["verdict"], "pass");
  EXPECT_EQ(check("runaway.y.jammed.holding")["verdict"], "pass");
  EXPECT_LT(check("runaway.y.jammed.moving")["figures"]["distance"].get<double>(), 0.5);
  EXPECT_LT(check("runaway.y.jammed.holding")["figures"]["distance"].get<double>(), 0.01);

  // The E-stop input (field input 9): ENA drops once LinuxCNC's iocontrol
  // and task have seen it, and Machine On is refused while it is open. Its
  // verdict varies from run to run: those programs run on the wall clock
  // beside a machine on the servo thread's, and X travels 200 mm/s times
  // their 10 to 120 ms (against a 21 mm bound).
  const auto& estop = check("estop.estop")["figures"];
  EXPECT_GT(estop["time_to_ena_off_s"].get<double>(), 0.0) << estop.dump();
  EXPECT_LT(estop["time_to_ena_off_s"].get<double>(), 0.5) << estop.dump();
  EXPECT_TRUE(estop["machine_on_refused_while_open"].get<bool>());
  EXPECT_TRUE(estop["machine_on_after_release"].get<bool>());

  // Limits on X: homed within one count (1/1600 mm), MDI past either soft
  // limit refused, and each limit switch (its NC contact on a -not input)
  // stops a 20 mm/s jog (DEFAULT_LINEAR_VELOCITY) well inside the room
  // before the hard stop.
  EXPECT_EQ(check("limits.x.home")["verdict"], "pass") << check("limits.x.home").dump();
  EXPECT_LE(check("limits.x.home")["figures"]["difference"].get<double>(), 1.0 / 1600);
  EXPECT_EQ(check("limits.x.soft")["verdict"], "pass") << check("limits.x.soft").dump();
  for (const char* sw : {"limits.x.x-min", "limits.x.x-max"}) {
    const auto& c = check(sw);
    EXPECT_EQ(c["verdict"], "pass") << c.dump().substr(0, 700);
    EXPECT_DOUBLE_EQ(c["figures"]["jog_velocity"].get<double>(), 20.0) << c.dump().substr(0, 700);
    EXPECT_LT(c["figures"]["distance_past_switch"].get<double>(), 2.0) << c.dump().substr(0, 700);
    EXPECT_NE(c["figures"]["linuxcnc_limit_mask"].get<int>(), 0) << c.dump().substr(0, 700);
  }

  // The spindle: at half of its VFD's 24000 rpm, at-speed comes, and the
  // E-stop drops its run input.
  EXPECT_EQ(check("spindle.at-speed")["verdict"], "pass") << check("spindle.at-speed").dump();
  EXPECT_EQ(check("spindle.estop")["verdict"], "pass") << check("spindle.estop").dump();
  EXPECT_LT(check("spindle.estop")["figures"]["time_to_enable_off_s"].get<double>(), 0.5);

  // Field power: the 7I77's field I/O processor runs from it (W1 as
  // shipped), so hostmot2 loses the processor and stops the smart-serial
  // port, and nothing in the example mill takes the machine off.
  const auto& field = check("field.0");
  EXPECT_EQ(field["verdict"], "fail") << field.dump();
  EXPECT_TRUE(field["figures"]["smart_serial_port_stopped"].get<bool>()) << field.dump();
  EXPECT_TRUE(field["figures"]["smart_serial_port_restarted"].get<bool>()) << field.dump();

  // The host stopped, and the network cut: the 7I77's own watchdog (50 ms)
  // drops ENA and makes the analog outputs 0 V (the figures count from the
  // rehearsal's request, a few milliseconds before the host fell silent).
  for (const char* id : {"host.stopped", "host.network"}) {
    const auto& host = check(id);
    EXPECT_EQ(host["verdict"], "pass") << host.dump().substr(0, 700);
    EXPECT_GE(host["figures"]["time_to_ena_off_s"].get<double>(), 0.045) << host.dump();
    EXPECT_LE(host["figures"]["time_to_ena_off_s"].get<double>(), 0.12) << host.dump();
    EXPECT_DOUBLE_EQ(host["figures"]["seven_i77_watchdog_s"].get<double>(), 0.05) << host.dump();
  }
}

TEST_F(Rehearse, AFerrorOf50mmFailsTheRunaway) {
  change("mill.ini", "FERROR = 10", "FERROR = 50");
  const auto r = rehearse({"--only", "runaway.x.reversed-encoder.moving"});
  ASSERT_FALSE(report_.is_discarded()) << r.out << r.err;
  EXPECT_EQ(r.exit, 1) << r.out;
  const auto& c = check("runaway.x.reversed-encoder.moving");
  EXPECT_EQ(c["verdict"], "fail") << c.dump();
  EXPECT_GT(c["figures"]["distance_to_disable"].get<double>(), 21.0) << c.dump();
}

TEST_F(Rehearse, AnUnwiredEstopFailsTheChain) {
  // The chain looped back in software, as a simulated configuration has it.
  change("mill.hal", "net estop-ext     =>  iocontrol.0.emc-enable-in",
         "net estop-out     =>  iocontrol.0.emc-enable-in");
  const auto r = rehearse({"--only", "estop"});
  ASSERT_FALSE(report_.is_discarded()) << r.out << r.err;
  EXPECT_EQ(r.exit, 1) << r.out;
  const auto& c = check("estop");
  EXPECT_EQ(c["verdict"], "fail") << report_.dump(1);
  EXPECT_NE(c["reason"].get<std::string>().find("iocontrol.0.emc-enable-in"), std::string::npos);
}

// The hm2 watchdog at 1 s on the example mill on a 7I77 and a 7I76, whose
// Z is a stepper on the 7I92T's StepGen (the machine and card its own test
// gives it: lbpkit machine --from-config does not derive a 7I76). A dead
// host leaves the StepGen stepping at Z's last rate until the FPGA card's
// watchdog stops it. As the machine file wires it, the 7I76's own watchdog
// turns its field outputs off at 50 ms, the brake-release among them, and
// Z's brake stops the axis: the check passes however long the hm2 watchdog
// is. Without the brake, Z steps on for the whole second, until the bite
// makes the StepGen's step pin an input: the check fails.
TEST_F(Rehearse, AOneSecondHm2WatchdogFailsLosingTheHostWhereNothingElseStopsAStepper) {
  fs::remove_all(config_);
  fs::copy(fs::path(LBPKIT_SOURCE_DIR) / "examples/linuxcnc/mill-7i76", config_, fs::copy_options::recursive);
  change("mill.ini", "WATCHDOG_NS = 50000000", "WATCHDOG_NS = 1000000000");
  const auto braked = dir_.path() / "mill-7i76.toml";
  fs::copy_file(fs::path(LBPKIT_SOURCE_DIR) / "examples/machines/mill-7i76.toml", braked);
  {
    const auto r = rehearse({"--only", "host.stopped", "--card", "7I92T", "--machine", braked.string()});
    ASSERT_FALSE(report_.is_discarded()) << r.out << r.err;
    EXPECT_EQ(r.exit, 0) << r.out;
    const auto& c = check("host.stopped");
    EXPECT_EQ(c["verdict"], "pass") << c.dump();
    EXPECT_DOUBLE_EQ(c["figures"]["hm2_watchdog_s"].get<double>(), 1.0);
    EXPECT_LT(c["figures"]["time_to_steps_stopped_s"].get<double>(), 0.2) << c.dump();
  }
  // The same Z without its brake.
  std::ifstream in(braked);
  std::string text, line;
  while (std::getline(in, line))
    if (line.rfind("brake_", 0) != 0) text += line + "\n";
  in.close();
  const auto free = dir_.path() / "mill-7i76-no-brake.toml";
  std::ofstream(free) << text;
  const auto r = rehearse({"--only", "host.stopped", "--card", "7I92T", "--machine", free.string()});
  ASSERT_FALSE(report_.is_discarded()) << r.out << r.err;
  std::printf("%s", r.out.c_str());  // what was measured
  EXPECT_EQ(r.exit, 1) << r.out;
  const auto& c = check("host.stopped");
  EXPECT_EQ(c["verdict"], "fail") << c.dump();
  // Z steps on at its speed for the hm2 watchdog's second (and the few tens
  // of milliseconds between the rehearsal's last look and the stop),
  // further than the room past its soft limits.
  EXPECT_GE(c["figures"]["time_to_steps_stopped_s"].get<double>(), 0.95) << c.dump();
  EXPECT_LE(c["figures"]["time_to_steps_stopped_s"].get<double>(), 1.2) << c.dump();
  EXPECT_GT(c["figures"]["distance_to_disable"].get<double>(), c["figures"]["bound"].get<double>()) << c.dump();
  EXPECT_NE(c["reason"].get<std::string>().find("before its StepGen stopped"), std::string::npos) << c.dump();
}

}  // namespace
