// SPDX-License-Identifier: MIT
// `lbpkit pins` and `lbpkit check-config`. The naming rules on a
// hand-made card (lbpkit_linuxcnc alone), then the checker on the corpus in
// tests/check_config/: every good configuration passes, every broken one is
// caught at the line its "# expect:" comment marks, with that reason and the
// nearest existing name. (tests/interop_test.cpp proves the names against
// LinuxCNC itself.)
#include <sys/stat.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <sstream>
#include <tuple>

#include "linuxcnc/config_check.hpp"
#include "linuxcnc/hm2_pins.hpp"
#include "lbpkit/wire/names.hpp"
#include "support/process.hpp"
#include "support/temp_dir.hpp"

namespace {

using namespace lbpkit;
using nlohmann::json;
namespace fs = std::filesystem;

const linuxcnc::Item* item(const std::vector<linuxcnc::Item>& items, const std::string& name) {
  for (const auto& i : items)
    if (i.name == name || i.alsoNamed == name) return &i;
  return nullptr;
}

TEST(Hm2Config, ParsesCountsAndSmartSerialModes) {
  std::vector<std::string> problems;
  const auto c = linuxcnc::parseHm2Config("num_encoders=6  num_pwmgens=0 sserial_port_0=30xx", &problems);
  EXPECT_TRUE(problems.empty());
  EXPECT_EQ(c.count("num_encoders"), 6);
  EXPECT_EQ(c.count("num_pwmgens"), 0);
  EXPECT_EQ(c.count("num_stepgens"), -1);
  EXPECT_EQ(c.mode(0, 0), '3');
  EXPECT_EQ(c.mode(0, 2), 'x');
  EXPECT_EQ(c.mode(0, 5), '0') << "channels past the string run in mode 0";
  EXPECT_EQ(c.channelMask(0), 0xF3);
  linuxcnc::parseHm2Config("num_encoder=6 sserial_port_7=0 num_leds=two", &problems);
  ASSERT_EQ(problems.size(), 3U);
  EXPECT_NE(problems[0].find("\"num_encoder\" is not a hostmot2 config= key"), std::string::npos) << problems[0];
  EXPECT_NE(problems[1].find("N 0..3"), std::string::npos) << problems[1];
  EXPECT_NE(problems[2].find("wants a number"), std::string::npos) << problems[2];
}

// A small card: 4 IO pins (an encoder select output, a TX, an RX, a plain
// one), 2 muxed encoders, one SSerial port with a remote on channel 0.
CardInfo smallCard() {
  CardInfo c;
  c.boardName = "MESA7I92";
  auto module = [&](std::uint8_t tag, std::uint8_t n) {
    ModuleInfo m;
    m.tag = tag;
    m.instances = n;
    c.modules.push_back(m);
  };
  module(wire::hm2::tag::kWatchdog, 1);
  module(wire::hm2::tag::kIoPort, 1);
  module(wire::hm2::tag::kMuxedQCount, 2);
  module(wire::hm2::tag::kMuxedQCountSel, 1);
  module(wire::hm2::tag::kSSerial, 1);
  module(wire::hm2::tag::kLed, 1);
  auto pin = [&](std::uint8_t tag, std::uint8_t unit, std::uint8_t code) {
    PinInfo p;
    p.io = static_cast<unsigned>(c.pins.size());
    p.secondaryTag = tag;
    p.secondaryUnit = unit;
    p.secondaryPin = code;
    c.pins.push_back(p);
  };
  pin(wire::hm2::tag::kMuxedQCountSel, 0, 0x81);  // sel0, out
  pin(wire::hm2::tag::kSSerial, 0, 0x81);         // tx0
  pin(wire::hm2::tag::kSSerial, 0, 0x01);         // rx0
  pin(0, 0, 0);                                   // GPIO
  return c;
}

linuxcnc::Remote smallRemote() {
  linuxcnc::Remote r;
  r.name = "7I77";
  auto element = [&](const char* name, DataType t, Direction d, unsigned bits) {
    ProcessDataElement e;
    e.name = name;
    e.type = t;
    e.direction = d;
    e.bits = bits;
    return e;
  };
  r.description.processData = {element("Input", DataType::Bits, Direction::Input, 4),
                               element("Output", DataType::Bits, Direction::Output, 2),
                               element("AnalogOut0", DataType::Signed, Direction::Output, 13),
                               element("AnalogIn0", DataType::Unsigned, Direction::Input, 16),
                               element("AnalogEna", DataType::Boolean, Direction::Output, 1),
                               element("Enc0", DataType::Encoder, Direction::Input, 16),
                               element("Pad", DataType::Pad, Direction::Input, 3)};
  r.description.parameters = {element("NVBaudRate", DataType::NonVolUnsigned, Direction::Input, 8),
                              element("WatchdogTime", DataType::Unsigned, Direction::Bidirectional, 16),
                              element("Gain", DataType::Signed, Direction::Output, 16),
                              element("Flags", DataType::Bits, Direction::Output, 8)};
  return r;
}

TEST(HalPins, FollowHostmot2sNamingRules) {
  const auto card = smallCard();
  const auto items = linuxcnc::hostmot2Items(card, linuxcnc::parseHm2Config("sserial_port_0=0"), {smallRemote()}, linuxcnc::Driver::Eth);
  ASSERT_TRUE(std::is_sorted(items.begin(), items.end(), [](auto& a, auto& b) { return a.name < b.name; }));
  auto check = [&](const std::string& name, linuxcnc::Kind k, linuxcnc::Type t, linuxcnc::Dir d) {
    const auto* i = item(items, "hm2_7i92.0." + name);
    ASSERT_NE(i, nullptr) << name;
    EXPECT_EQ(i->kind, k) << name;
    EXPECT_EQ(i->type, t) << name;
    EXPECT_EQ(i->dir, d) << name;
  };
  using K = linuxcnc::Kind;
  using T = linuxcnc::Type;
  using D = linuxcnc::Dir;
  // Remote: bits in (with -not), bits out (with -invert), numeric out (three
  // parameters), numeric in (scalemax only), boolean, encoder, GTOC params.
  check("7i77.0.0.input-03", K::Pin, T::Bit, D::Out);
  check("7i77.0.0.input-03-not", K::Pin, T::Bit, D::Out);
  check("7i77.0.0.output-01", K::Pin, T::Bit, D::In);
  check("7i77.0.0.output-01-invert", K::Param, T::Bit, D::RW);
  check("7i77.0.0.analogout0", K::Pin, T::Float, D::In);
  check("7i77.0.0.analogout0-minlim", K::Param, T::Float, D::RW);
  check("7i77.0.0.analogin0", K::Pin, T::Float, D::Out);
  check("7i77.0.0.analogin0-scalemax", K::Param, T::Float, D::RW);
  EXPECT_EQ(item(items, "hm2_7i92.0.7i77.0.0.analogin0-maxlim"), nullptr);
  check("7i77.0.0.analogena", K::Pin, T::Bit, D::In);
  check("7i77.0.0.analogena-invert", K::Param, T::Bit, D::RW);
  check("7i77.0.0.enc0.index-enable", K::Pin, T::Bit, D::IO);
  check("7i77.0.0.enc0.counts-per-rev", K::Param, T::U32, D::RW);
  check("7i77.0.0.nvbaudrate", K::Param, T::U32, D::RO);
  check("7i77.0.0.watchdogtime", K::Param, T::U32, D::RW);
  check("7i77.0.0.gain", K::Param, T::S32, D::RW);
  EXPECT_EQ(item(items, "hm2_7i92.0.7i77.0.0.flags"), nullptr) << "bits are no parameter";
  EXPECT_EQ(item(items, "hm2_7i92.0.7i77.0.0.pad"), nullptr);
  EXPECT_EQ(item(items, "hm2_7i92.0.7i77.0.0.input-04"), nullptr);
  // Card: encoders, the module's output pins under both names, GPIO.
  check("encoder.01.velocity-rpm", K::Pin, T::Float, D::Out);
  check("encoder.muxed-sample-frequency", K::Pin, T::U32, D::In);
  check("encoder.00.sel0.invert_output", K::Param, T::Bit, D::RW);
  EXPECT_EQ(item(items, "hm2_7i92.0.encoder.00.sel0.invert_output")->alsoNamed, "hm2_7i92.0.gpio.000.invert_output");
  check("sserial.00.tx0.is_opendrain", K::Param, T::Bit, D::RW);
  check("gpio.002.in_not", K::Pin, T::Bit, D::Out);
  EXPECT_EQ(item(items, "hm2_7i92.0.gpio.002.invert_output"), nullptr) << "an input of SSerial";
  check("gpio.003.out", K::Pin, T::Bit, D::In);
  check("gpio.003.is_output", K::Param, T::Bit, D::RW);
  check("led.CR04", K::Pin, T::Bit, D::In);
  check("read-request.time", K::Pin, T::S32, D::Out);
  check("packet-error-decrement", K::Param, T::S32, D::RO);
  check("sserial.port-0.fault-lim", K::Param, T::U32, D::RW);

  // Channel 0 left out: no remote pins, and its pins are plain GPIO again.
  const auto without = linuxcnc::hostmot2Items(card, linuxcnc::parseHm2Config("num_encoders=0 sserial_port_0=x"), {smallRemote()},
                                          linuxcnc::Driver::Pci);
  EXPECT_EQ(item(without, "hm2_7i92.0.7i77.0.0.input-00"), nullptr);
  EXPECT_NE(item(without, "hm2_7i92.0.gpio.001.out"), nullptr);
  EXPECT_NE(item(without, "hm2_7i92.0.gpio.000.out"), nullptr) << "no encoder takes the select pin";
  EXPECT_EQ(item(without, "hm2_7i92.0.encoder.00.count"), nullptr);
  EXPECT_NE(item(without, "hm2_7i92.0.read_gpio.time"), nullptr);
  EXPECT_EQ(item(without, "hm2_7i92.0.read-request.time"), nullptr);
  EXPECT_EQ(item(without, "hm2_7i92.0.packet-error"), nullptr);
}

TEST(HalPins, EditDistance) {
  EXPECT_EQ(lbpkit::wire::editDistance("output-01", "ouput-01"), 1U);
  EXPECT_EQ(lbpkit::wire::editDistance("", "abc"), 3U);
  EXPECT_EQ(lbpkit::wire::editDistance("7i77.0.4", "7i77.0.1"), 1U);
}

fs::path corpus() { return fs::path(LBPKIT_SOURCE_DIR) / "tests/check_config"; }

// The options a corpus file asks for on its "# check-config args: ..." line
// (--card, --pinout: the card it is to be checked as).
std::vector<std::string> argsOf(const fs::path& file) {
  std::ifstream in(file);
  std::vector<std::string> out;
  for (std::string line; std::getline(in, line);) {
    const std::string tag = "# check-config args: ";
    if (line.rfind(tag, 0) != 0) continue;
    std::istringstream words(line.substr(tag.size()));
    for (std::string w; words >> w;) out.push_back(w);
  }
  return out;
}

test_support::Result check(const fs::path& file, bool asJson = false, const std::vector<std::string>& extra = {}) {
  std::vector<std::string> args{"check-config", file.string()};
  if (asJson) args.emplace_back("--json");
  args.insert(args.end(), extra.begin(), extra.end());
  return test_support::run(args);
}

TEST(CheckConfig, TheExampleMillPasses) {
  const auto r = check(fs::path(LBPKIT_SOURCE_DIR) / "examples/linuxcnc/mill/mill.ini");
  EXPECT_EQ(r.exit, 0) << r.out << r.err;
  EXPECT_NE(r.out.find("hm2_7i92.0 by hm2_eth config=\"num_encoders=6 num_pwmgens=0 num_stepgens=0 sserial_port_0=00xxxx\""),
            std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("no problems"), std::string::npos) << r.out;
}

TEST(CheckConfig, EveryGoodConfigurationPasses) {
  int n = 0;
  for (const auto& e : fs::directory_iterator(corpus() / "good")) {
    const auto& p = e.path();
    // A HAL file that an INI names is checked through the INI.
    if (p.extension() == ".hal" && fs::exists(fs::path(p).replace_extension(".ini"))) continue;
    if (p.extension() != ".ini" && p.extension() != ".hal") continue;
    ++n;
    const auto r = check(p);
    EXPECT_EQ(r.exit, 0) << p << "\n" << r.out << r.err;
    EXPECT_NE(r.out.find("no problems"), std::string::npos) << p << "\n" << r.out;
  }
  EXPECT_GE(n, 3);
}

struct Expectation {
  unsigned line = 0;
  std::string reason;
  std::string nearest;
};

// Every line FILE marks: "# expect: REASON | NEAREST" at the end of a line
// (a HAL file), or the line after a "# expect next line: REASON" comment (an
// INI, whose values run to the end of the line).
std::vector<Expectation> expectations(const fs::path& file) {
  std::ifstream in(file);
  std::vector<Expectation> out;
  std::string line;
  unsigned n = 0;
  while (std::getline(in, line)) {
    ++n;
    const std::string next = "# expect next line: ";
    if (line.rfind(next, 0) == 0) {
      out.push_back({n + 1, line.substr(next.size()), {}});
      continue;
    }
    const auto at = line.find("# expect: ");
    if (at == std::string::npos || at == 0) continue;
    Expectation e{n, line.substr(at + 10), {}};
    if (const auto bar = e.reason.find(" | "); bar != std::string::npos) {
      e.nearest = e.reason.substr(bar + 3);
      e.reason.resize(bar);
    }
    out.push_back(e);
  }
  return out;
}

// Whether the findings of `j` hold one at `file`:`want.line` with that
// severity, saying want.reason (and naming want.nearest).
bool holds(const json& j, const std::string& file, const Expectation& want, const std::string& severity) {
  for (const auto& f : j["findings"]) {
    if (f["file"] != file || f["line"] != want.line) continue;
    if (f["reason"].get<std::string>().find(want.reason) == std::string::npos) continue;
    if (f["severity"] != severity) continue;
    if (!want.nearest.empty() && f.value("nearest", "") != want.nearest) continue;
    return true;
  }
  return false;
}

// Each configuration of broken/ (an INI with the HAL file of its name, or a
// HAL file alone) is refused at every line its files mark.
TEST(CheckConfig, EveryBrokenConfigurationIsCaughtWhereItsCommentSays) {
  int n = 0;
  for (const auto& e : fs::directory_iterator(corpus() / "broken")) {
    const auto& p = e.path();
    if (p.extension() != ".hal" && p.extension() != ".ini") continue;
    const auto hal = fs::path(p).replace_extension(".hal");
    if (p.extension() == ".hal" && fs::exists(fs::path(p).replace_extension(".ini"))) continue;  // through its INI
    std::vector<std::pair<fs::path, Expectation>> wanted;
    std::vector<fs::path> files{p};
    if (p != hal && fs::exists(hal)) files.push_back(hal);
    for (const auto& file : files)
      for (const auto& x : expectations(file)) wanted.emplace_back(file, x);
    ASSERT_FALSE(wanted.empty()) << p << " has no \"# expect:\" or \"# expect next line:\" line";
    ++n;
    const auto r = check(p, true, argsOf(fs::exists(hal) ? hal : p));
    EXPECT_EQ(r.exit, 1) << p << "\n" << r.out << r.err;
    const auto j = json::parse(r.out, nullptr, false);
    ASSERT_FALSE(j.is_discarded()) << r.out << r.err;
    EXPECT_EQ(j["ok"], false);
    for (const auto& [file, want] : wanted)
      EXPECT_TRUE(holds(j, file.filename().string(), want, "error"))
          << p << ": no error at " << file.filename().string() << ":" << want.line << " saying \"" << want.reason
          << "\"" << (want.nearest.empty() ? "" : " nearest " + want.nearest) << "\n"
          << j["findings"].dump(2);
  }
  EXPECT_GE(n, 25);
}

// board_ip=[HM2]IPADDRESS: an address that is no card's is reported at the
// INI's line that holds it, naming the HAL line that uses it. A loopback
// address is a warning: no card has it, but lbpkit sim on this PC answers
// there for a LinuxCNC whose hm2_eth takes it.
TEST(CheckConfig, ABoardAddressFromTheIniIsCheckedAtTheIniLine) {
  struct Case {
    const char* ini;
    unsigned line;
    const char* reason;
    const char* severity;
    int exit;
  };
  for (const Case& c : {Case{"injected.ini", 5,
                             "board_ip=[HM2]IPADDRESS at injected.hal:3: \"$(touch${IFS}/tmp/x/PWNED1)10.77.1.5\" is "
                             "not an IPv4 address (four numbers 0-255 joined by dots)",
                             "error", 1},
                        Case{"loopback.ini", 4,
                             "board_ip=[HM2](IPADDRESS) at loopback.hal:3: 127.0.0.1 is a loopback address "
                             "(127.0.0.0/8): no card can have it; only an lbpkit sim on this PC answers there",
                             "warning", 0},
                        Case{"trailing.ini", 4, "\"10.77.1.5 $(reboot)\" is not an IPv4 address", "error", 1}}) {
    const auto r = check(corpus() / "address" / c.ini, true);
    EXPECT_EQ(r.exit, c.exit) << c.ini << "\n" << r.out << r.err;
    const auto j = json::parse(r.out, nullptr, false);
    ASSERT_FALSE(j.is_discarded()) << r.out << r.err;
    int found = 0;
    for (const auto& f : j["findings"])
      if (f["name"] == "board_ip") {
        ++found;
        EXPECT_EQ(f["file"], c.ini) << f.dump();
        EXPECT_EQ(f["line"], c.line) << f.dump();
        EXPECT_EQ(f["severity"], c.severity) << f.dump();
        EXPECT_NE(f["reason"].get<std::string>().find(c.reason), std::string::npos) << f.dump();
      }
    EXPECT_EQ(found, 1) << j.dump(2);
  }
  // The text output: file:line, the value and the reason.
  const auto text = check(corpus() / "address/injected.ini");
  EXPECT_NE(text.out.find("injected.ini:5: error: board_ip=[HM2]IPADDRESS at injected.hal:3: \"$(touch"),
            std::string::npos)
      << text.out;
}

TEST(CheckConfig, ASignalWithNoWriterIsAWarningAsLinuxCncLoadsIt) {
  const auto r = check(corpus() / "warned/input_without_writer.hal", true);
  EXPECT_EQ(r.exit, 0) << r.out << r.err;
  const auto j = json::parse(r.out, nullptr, false);
  ASSERT_FALSE(j.is_discarded()) << r.out << r.err;
  ASSERT_EQ(j["findings"].size(), 1U) << j.dump(2);
  EXPECT_EQ(j["findings"][0]["severity"], "warning");
  EXPECT_EQ(j["findings"][0]["line"], 9);
  EXPECT_NE(j["findings"][0]["reason"].get<std::string>().find("signal coolant has no writer"), std::string::npos);
}

// What LinuxCNC's start-up check warns of, it starts with: warnings, at the
// lines marked, and no error.
TEST(CheckConfig, WhatLinuxCncsStartUpCheckWarnsOfIsAWarning) {
  const auto file = corpus() / "warned/startup_warnings.ini";
  const auto r = check(file, true);
  EXPECT_EQ(r.exit, 0) << r.out << r.err;
  const auto j = json::parse(r.out, nullptr, false);
  ASSERT_FALSE(j.is_discarded()) << r.out << r.err;
  const auto wanted = expectations(file);
  ASSERT_EQ(wanted.size(), 4U);
  for (const auto& want : wanted)
    EXPECT_TRUE(holds(j, file.filename().string(), want, "warning"))
        << "no warning at line " << want.line << " saying \"" << want.reason << "\"\n"
        << j["findings"].dump(2);
  for (const auto& f : j["findings"]) EXPECT_EQ(f["severity"], "warning") << f.dump();
}

// The five-axis router LinuxCNC refuses: the text output names the INI's
// line of each joint limit, and both values.
TEST(CheckConfig, AJointLimitOutsideItsAxissNamesTheLineAndBothValues) {
  const auto r = check(corpus() / "broken/five_axis_router.ini");
  EXPECT_EQ(r.exit, 1) << r.out << r.err;
  EXPECT_NE(r.out.find("five_axis_router.ini:89: error: [JOINT_4]MIN_LIMIT = -10 is above [AXIS_C]MIN_LIMIT = -99999 "
                       "(LinuxCNC's start-up check refuses it: a joint's limits must hold its axis's, and "
                       "[KINS]KINEMATICS coordinates=XYZAC makes joint 4 axis C)"),
            std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("five_axis_router.ini:91: error: [JOINT_4]MAX_LIMIT = 10 is below [AXIS_C]MAX_LIMIT = 99999"),
            std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("2 errors"), std::string::npos) << r.out;
}

// The start-up check's findings of `r` (check-config --json): those that
// say "LinuxCNC's start-up check", by severity.
std::pair<int, int> startupFindings(const test_support::Result& r) {
  const auto j = json::parse(r.out, nullptr, false);
  std::pair<int, int> n{0, 0};
  if (j.is_discarded()) return {-1, -1};
  for (const auto& f : j["findings"])
    if (f["reason"].get<std::string>().find("LinuxCNC's start-up check") != std::string::npos)
      ++(f["severity"] == "error" ? n.first : n.second);
  return n;
}

// An INI whose [EMC]VERSION is not 1.1 is converted by update_ini before
// LinuxCNC's start-up check reads it: check-config says nothing of it.
// Values the check reads oddly never hang or crash check-config.
TEST(CheckConfig, TheStartUpCheckReadsOnlyAVersion11IniAndNeverHangs) {
  test_support::TempDir dir("lbpkit-check-startup");
  std::ifstream in(corpus() / "broken/five_axis_router.ini");
  std::stringstream text;
  text << in.rdbuf();
  const auto router = text.str();
  auto with = [&](const std::string& name, const std::string& from, const std::string& to) {
    auto copy = router;
    const auto at = copy.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    if (at != std::string::npos) copy.replace(at, from.size(), to);
    const auto p = dir.path() / name;
    std::ofstream(p) << copy;
    return check(p, true);
  };
  const auto old = with("old.ini", "VERSION = 1.1", "VERSION = 1.0");
  EXPECT_EQ(startupFindings(old), std::make_pair(0, 0)) << old.out;
  const auto none = with("none.ini", "VERSION = 1.1", "");
  EXPECT_EQ(startupFindings(none), std::make_pair(0, 0)) << none.out;

  // A whole number of joints far past LinuxCNC's 16: counted, not hung on.
  const auto many = with("many.ini", "JOINTS = 5", "JOINTS = 1e9");
  EXPECT_EQ(startupFindings(many).first, 2) << many.out.substr(0, 3000);
  for (const auto& [name, from, to, says] :
       {std::tuple{"inf.ini", "JOINTS = 5", "JOINTS = inf", "never ends"},
        std::tuple{"empty.ini", "JOINTS = 5", "JOINTS =", "never ends"},
        std::tuple{"brace.ini", "KINEMATICS = trivkins", "KINEMATICS = trivkins {", "unmatched brace"},
        std::tuple{"extra.ini", "EMCMOT = motmod", "EMCMOT = motmod num_extrajoints=two", "Tcl error"}}) {
    const auto r = with(name, from, to);
    EXPECT_EQ(r.exit, 1) << name << "\n" << r.out;
    EXPECT_NE(r.out.find(says), std::string::npos) << name << "\n" << r.out;
  }
}

// The INI `ini` as the `linuxcnc` command hands it on: `ini` itself, or,
// when a line starts with #INCLUDE, the file LinuxCNC's own handle_includes
// (LinuxCNC: scripts/linuxcnc.in, installed as /usr/bin/linuxcnc) writes,
// run on a copy in `into` whose entries link to those of ini's folder (it
// writes next to the INI, and the source tree is left as it is). "" when
// it cannot be made.
fs::path expandedByLinuxCnc(const fs::path& ini, const fs::path& into) {
  std::ifstream in(ini);
  bool includes = false;
  for (std::string line; std::getline(in, line);) includes = includes || line.rfind("#INCLUDE", 0) == 0;
  if (!includes) return ini;
  if (!fs::exists("/usr/bin/linuxcnc")) return {};
  const auto dir = into / ini.parent_path().filename();
  fs::create_directories(dir);
  for (const auto& e : fs::directory_iterator(ini.parent_path()))
    if (!fs::exists(fs::symlink_status(dir / e.path().filename()))) fs::create_symlink(e.path(), dir / e.path().filename());
  const auto copy = dir / (ini.filename().string() + ".copy.ini");
  fs::copy_file(ini, copy, fs::copy_options::overwrite_existing);
  const auto command = "cd '" + dir.string() + "' && GREP=grep bash -c 'eval \"$(sed -n \"/^function handle_includes/,/^}/p\" "
                       "/usr/bin/linuxcnc)\"; handle_includes \"$0\"' '" + copy.string() + "' >/dev/null 2>&1";
  if (std::system(command.c_str()) != 0) return {};
  const auto out = fs::path(copy.string() + ".expanded");
  return fs::exists(out) ? out : fs::path();
}

// On every INI of the corpus, the public configurations and the examples
// that LinuxCNC checks as it is (VERSION 1.1), check-config's start-up
// errors are there exactly when LinuxCNC's own script refuses the file.
TEST(CheckConfig, StartUpErrorsAreExactlyWhatLinuxCncsOwnCheckRefuses) {
  const fs::path script = "/usr/share/linuxcnc/hallib/check_config.tcl";
  if (!fs::exists(script) || !fs::exists("/usr/bin/tclsh8.6")) GTEST_SKIP() << "LinuxCNC's check_config.tcl is not installed";
  int compared = 0, refused = 0;
  test_support::TempDir expanded("lbpkit-check-expanded");
  for (const char* folder : {"tests/check_config", "tests/public_configs", "tests/machine_from_config", "examples"})
    for (const auto& e : fs::recursive_directory_iterator(fs::path(LBPKIT_SOURCE_DIR) / folder)) {
      const auto& p = e.path();
      if (p.extension() != ".ini") continue;
      std::ifstream in(p);
      std::stringstream text;
      text << in.rdbuf();
      if (text.str().find("\nVERSION = 1.1\n") == std::string::npos) continue;
      // LinuxCNC's script counts joints without end on this one.
      if (p.filename() == "joints_not_a_number.ini") continue;
      // `linuxcnc` checks the INI with its #INCLUDEs expanded.
      const auto checked = expandedByLinuxCnc(p, expanded.path());
      ASSERT_FALSE(checked.empty()) << p;
      const auto command = "/usr/bin/tclsh8.6 " + script.string() + " '" + checked.string() + "' >/dev/null 2>&1";
      const int status = std::system(command.c_str());
      ASSERT_TRUE(WIFEXITED(status)) << command;
      const bool linuxcncRefuses = WEXITSTATUS(status) != 0;
      const auto r = check(p, true);
      const bool weRefuse = startupFindings(r).first > 0;
      EXPECT_EQ(weRefuse, linuxcncRefuses) << p << "\n" << r.out;
      ++compared;
      refused += linuxcncRefuses ? 1 : 0;
    }
  EXPECT_GE(compared, 15);
  EXPECT_GE(refused, 7);
}

// What LinuxCNC cannot load never passes, and nothing read crashes or hangs
// the check: only regular files are read, lines and files are bounded, and
// [SECTION]KEY is found by a scan, not a recursive regular expression.
TEST(CheckConfig, FilesLinuxCncCannotLoadAreRefusedAndNothingCrashesOrHangs) {
  test_support::TempDir dir("lbpkit-check-hostile");
  auto ini = [&](const std::string& name, const std::string& halfile) {
    const auto p = dir.path() / (name + ".ini");
    std::ofstream(p) << "[HAL]\nHALFILE = " << halfile << "\n";
    return p;
  };
  auto refused = [&](const fs::path& p, const std::string& why) {
    const auto r = test_support::run({"check-config", p.string()}, std::chrono::seconds(20));
    EXPECT_EQ(r.exit, 1) << p << "\n" << r.out << r.err;
    EXPECT_NE((r.out + r.err).find(why), std::string::npos) << p << "\n" << r.out << r.err;
  };
  refused(ini("directory", dir.path().string()), "a directory, not a file");
  refused(ini("zero", "/dev/zero"), "not a regular file");
  refused(ini("random", "/dev/urandom"), "not a regular file");
  const auto fifo = dir.path() / "fifo.hal";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  refused(ini("fifo", fifo.string()), "not a regular file");
  refused(fifo, "not a regular file");
  refused(dir.path(), "a directory, not a file");

  // Long words: a substitution whose key runs on, and one left open.
  const std::string letters(50'000, 'B');
  std::ofstream(dir.path() / "long.ini") << "[A]\nB = 1\n[HAL]\nHALFILE = long.hal\n";
  std::ofstream(dir.path() / "long.hal") << "setp [A]" << letters << " 1\nsetp x [A](" << letters << "\n"
                                          << "net " << letters << " hm2_7i92.0.7i77.0.0.output-00\n";
  auto r = test_support::run({"check-config", (dir.path() / "long.ini").string()}, std::chrono::seconds(20));
  EXPECT_EQ(r.exit, 1) << r.out << r.err;
  EXPECT_NE(r.out.find("the INI file has no [A]BBBB"), std::string::npos) << r.out.substr(0, 2000);
  // A line past the bound: reported, not read.
  std::ofstream(dir.path() / "wide.hal") << "# " << std::string(100'000, 'x') << "\nloadrt threads\n";
  r = test_support::run({"check-config", (dir.path() / "wide.hal").string()}, std::chrono::seconds(20));
  EXPECT_EQ(r.exit, 1) << r.out << r.err;
  EXPECT_NE(r.out.find("wide.hal:1: error: a line of more than 65536 characters"), std::string::npos)
      << r.out.substr(0, 2000);
}

// halcmd's `source FILE` reads FILE where the command stands, relative to
// the INI's folder (where linuxcnc runs halcmd): a configuration split into
// files joined by source is checked whole, a missing file is an error at
// its source line, and a file that sources itself ends with an error.
TEST(CheckConfig, SourcedHalFilesAreReadWhereTheySourceCommandStands) {
  test_support::TempDir dir("lbpkit-check-source");
  fs::create_directories(dir.path() / "parts");
  std::ofstream(dir.path() / "machine.ini") << "[HAL]\nHALFILE = machine.hal\n";
  std::ofstream(dir.path() / "parts/load.hal")
      << "loadrt hostmot2\nloadrt hm2_eth board_ip=10.10.10.10 config=\"num_encoders=6 sserial_port_0=00xxxx\"\n";
  std::ofstream(dir.path() / "machine.hal") << "source parts/load.hal\n"
                                            << "loadrt threads name1=servo-thread period1=1000000\n"
                                            << "addf hm2_7i92.0.read servo-thread\n"
                                            << "net lube => hm2_7i92.0.7i77.0.0.ouput-01\n";
  auto r = check(dir.path() / "machine.ini");
  EXPECT_EQ(r.exit, 1) << r.out << r.err;
  EXPECT_NE(r.out.find("hm2_7i92.0 by hm2_eth config=\"num_encoders=6 sserial_port_0=00xxxx\" (parts/load.hal:2)"),
            std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("machine.hal:4: error: the 7I77 on port 0 channel 0 has no ouput-01"), std::string::npos) << r.out;

  std::ofstream(dir.path() / "missing.ini") << "[HAL]\nHALFILE = missing.hal\n";
  std::ofstream(dir.path() / "missing.hal") << "# the second line\nsource no-such.hal\n";
  r = check(dir.path() / "missing.ini");
  EXPECT_EQ(r.exit, 1) << r.out << r.err;
  EXPECT_NE(r.out.find("missing.hal:2: error: source no-such.hal: no such file"), std::string::npos) << r.out;

  std::ofstream(dir.path() / "loop.ini") << "[HAL]\nHALFILE = loop.hal\n";
  std::ofstream(dir.path() / "loop.hal") << "source loop.hal\n";
  r = check(dir.path() / "loop.ini");
  EXPECT_EQ(r.exit, 1) << r.out << r.err;
  EXPECT_NE(r.out.find("loop.hal:1: error: source loop.hal: files sourced 16 deep"), std::string::npos) << r.out;
}

// #INCLUDE FILE in an INI: the linuxcnc command replaces the line by FILE's
// content, one level deep, before anything reads the INI. Every finding
// about an included value names the included file and its line.
TEST(CheckConfig, IncludedIniFilesAreReadAndFindingsNameTheirLines) {
  const auto r = check(corpus() / "include/mill.ini", true);
  EXPECT_EQ(r.exit, 1) << r.out << r.err;
  const auto j = json::parse(r.out, nullptr, false);
  ASSERT_FALSE(j.is_discarded()) << r.out << r.err;
  for (const auto& file : {"hm2.inc", "joint_0.inc"})
    for (const auto& want : expectations(corpus() / "include/parts" / file))
      EXPECT_TRUE(holds(j, std::string("parts/") + file, want, "error"))
          << file << ":" << want.line << " " << want.reason << "\n" << j["findings"].dump(2);
  // [HAL] comes from parts/hal.inc; the #INCLUDE in it is a comment.
  EXPECT_EQ(j["hal_files"].size(), 1U) << r.out;
  EXPECT_TRUE(holds(j, "parts/hal.inc", {3, "in a file the INI includes: linuxcnc expands one level", {}}, "warning"))
      << j["findings"].dump(2);
  EXPECT_EQ(r.out.find("not-there.hal"), std::string::npos) << r.out;
  unsigned errors = 0;
  for (const auto& f : j["findings"]) errors += f["severity"] == "error" ? 1U : 0U;
  EXPECT_EQ(errors, 2U) << j["findings"].dump(2);
  // machine --from-config reads the same values where they are written.
  test_support::TempDir dir("lbpkit-check-include-machine");
  const auto m = test_support::run(
      {"machine", "--from-config", (corpus() / "include/mill.ini").string(), "-o", (dir.path() / "m.toml").string()});
  EXPECT_EQ(m.out.find("mill.ini:0: warning: [HAL] names no HALFILE"), std::string::npos) << m.out << m.err;
}

// An #INCLUDE of a file that cannot be read is an error at the INI's line:
// linuxcnc goes on without it, and what it held is missing. Names are
// expanded as the shell's `eval echo` would for ~ and $VARIABLE; anything
// else is refused, never run.
TEST(CheckConfig, AnIncludeThatCannotBeReadIsAnErrorAtTheIniLine) {
  test_support::TempDir dir("lbpkit-check-include");
  auto write = [&](const std::string& name, const std::string& text) {
    std::ofstream(dir.path() / name, std::ios::binary) << text;
    return dir.path() / name;
  };
  write("load.hal", "loadrt hostmot2\nloadrt hm2_eth board_ip=10.10.10.10 config=\"num_encoders=6\"\n"
                    "setp hm2_7i92.0.encoder.00.scale 100\n");
  write("hal.inc", "HALFILE = load.hal\n");

  auto r = check(write("missing.ini", "[EMC]\nMACHINE = m\n\n[HAL]\n#INCLUDE no-such.inc\n"));
  EXPECT_EQ(r.exit, 1) << r.out << r.err;
  EXPECT_NE(r.out.find("missing.ini:5: error: #INCLUDE no-such.inc: no such file: linuxcnc reports it and starts "
                       "without that file, so whatever it holds (here, under [HAL]) is missing from the INI"),
            std::string::npos)
      << r.out;

  r = check(write("directory.ini", "[HAL]\n#INCLUDE " + dir.path().string() + "\n"));
  EXPECT_EQ(r.exit, 1) << r.out << r.err;
  EXPECT_NE(r.out.find("directory.ini:2: error: #INCLUDE " + dir.path().string() + ": a directory, not a file"),
            std::string::npos)
      << r.out;

  // ~ and $VARIABLE, as the shell expands them.
  ::setenv("LBPKIT_TEST_INCLUDE_DIR", dir.path().c_str(), 1);
  r = check(write("variable.ini", "[HAL]\n#INCLUDE ${LBPKIT_TEST_INCLUDE_DIR}/hal.inc\n"));
  EXPECT_EQ(r.exit, 0) << r.out << r.err;
  EXPECT_NE(r.out.find("checked in 1 HAL file: no problems"), std::string::npos) << r.out;
  r = check(write("relative.ini", "[HAL]\n#INCLUDE $LBPKIT_TEST_INCLUDE_DIR/../" + dir.path().filename().string() +
                                      "/hal.inc\n"));
  EXPECT_EQ(r.exit, 0) << r.out << r.err;

  // What the shell would run or expand otherwise is not: an error, no file made.
  for (const std::string& name : std::vector<std::string>{"$(touch made)", "`touch made`", "hal.inc;touch made", "h*.inc", "'hal.inc'",
                                  "~nobody/hal.inc", "$1", "hal.inc\r"}) {
    r = check(write("refused.ini", "[HAL]\n#INCLUDE " + name + "\n"));
    EXPECT_EQ(r.exit, 1) << name << "\n" << r.out << r.err;
    EXPECT_NE(r.out.find("refused.ini:2: error: #INCLUDE "), std::string::npos) << name << "\n" << r.out;
  }
  EXPECT_FALSE(fs::exists(dir.path() / "made"));

  // No name: a warning (linuxcnc says so and goes on). An indented #INCLUDE
  // in an INI with no line that starts with one is a comment.
  r = check(write("noname.ini", "[HAL]\nHALFILE = load.hal\n#INCLUDE\n"));
  EXPECT_EQ(r.exit, 0) << r.out << r.err;
  EXPECT_NE(r.out.find("noname.ini:3: warning: #INCLUDE names no file"), std::string::npos) << r.out;
  r = check(write("indented.ini", "[HAL]\nHALFILE = load.hal\n  #INCLUDE hal.inc\n"));
  EXPECT_NE(r.out.find("indented.ini:3: warning: #INCLUDE hal.inc: linuxcnc expands #INCLUDE only"),
            std::string::npos)
      << r.out;

  // With an #INCLUDE, a last line with no newline is lost (the shell's read).
  r = check(write("unended.ini", "[HAL]\n#INCLUDE hal.inc\nPOSTGUI_HALFILE = load.hal"));
  EXPECT_NE(r.out.find("unended.ini:3: warning: the INI's last line has no newline"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("checked in 1 HAL file"), std::string::npos) << r.out;
}

// A Tcl HAL file is read as far as lbpkit can: its HAL commands with the
// INI's values ($::SECTION(KEY), [lindex $::SECTION(KEY) 0]); other Tcl is
// a warning naming the file. An INI whose HAL files give lbpkit nothing to
// check is no pass.
TEST(CheckConfig, TclHalFilesAreReadAsFarAsLbpkitCan) {
  test_support::TempDir dir("lbpkit-check-tcl");
  auto write = [&](const std::string& name, const std::string& text) {
    std::ofstream(dir.path() / name) << text;
    return dir.path() / name;
  };
  write("load.tcl", "# the card\nloadrt hostmot2\n"
                    "loadrt [lindex $::HM2(DRIVER) 0] board_ip=$::HM2(IPADDRESS) config=[lindex $::HM2(CONFIG) 0]\n"
                    "set scale 100 ;# Tcl lbpkit does not read\n"
                    "hal setp hm2_7i92.0.encoder.00.scale $::JOINT_0(SCALE)\n"
                    "net lube => hm2_7i92.0.7i77.0.0.ouput-01\n");
  auto r = check(write("tcl.ini", "[HM2]\nDRIVER = hm2_eth\nIPADDRESS = 10.10.10.10\n"
                                  "CONFIG = \"num_encoders=6 sserial_port_0=00xxxx\"\n"
                                  "[JOINT_0]\nSCALE = 100\n[HAL]\nHALFILE = load.tcl\n"));
  EXPECT_EQ(r.exit, 1) << r.out << r.err;
  EXPECT_NE(r.out.find("hm2_7i92.0 by hm2_eth config=\"num_encoders=6 sserial_port_0=00xxxx\" (load.tcl:3)"),
            std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("load.tcl:6: error: the 7I77 on port 0 channel 0 has no ouput-01"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("load.tcl:4: warning: load.tcl: 1 Tcl command lbpkit does not read"), std::string::npos) << r.out;

  write("procedural.tcl", "foreach n {0 1} {\n  setp hm2_7i92.0.encoder.0$n.scale 100\n}\n");
  r = check(write("procedural.ini", "[HAL]\nHALFILE = procedural.tcl\n"));
  EXPECT_EQ(r.exit, 1) << r.out << r.err;
  EXPECT_NE(r.out.find("procedural.tcl:1: warning: procedural.tcl: 1 Tcl command lbpkit does not read"),
            std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("procedural.ini:2: error: lbpkit read no HAL command in the 1 HAL file the INI names"),
            std::string::npos)
      << r.out;
}

// A servo joint whose 7I77 analog output's maxlim/minlim hold its PID's
// output under what MAX_VELOCITY needs (FF1 x MAX_VELOCITY): hostmot2 holds
// the value to [minlim, maxlim] before it scales it, so every faster move
// ends in a following error. LinuxCNC starts: a warning, naming the setp of
// the limit and the INI's MAX_VELOCITY, and the exit status stays 0. With
// limits that reach MAX_VELOCITY, or FF1 0 (no feed-forward to size the
// output by), nothing is said.
TEST(CheckConfig, AnAnalogOutputsLimitUnderMaxVelocityIsAWarning) {
  test_support::TempDir dir("lbpkit-check-output-limit");
  // One X servo: [JOINT_0] at lines 19-28 (MAX_VELOCITY at 21), the HAL's
  // limits at lines 9 (minlim) and 10 (maxlim) when `limits`.
  auto servo = [&](const std::string& name, const std::string& ff1, const std::string& minlim,
                   const std::string& maxlim, bool limits = true) {
    std::ofstream(dir.path() / (name + ".ini"))
        << "[EMC]\nVERSION = 1.1\nMACHINE = servo\n\n[KINS]\nKINEMATICS = trivkins coordinates=X\nJOINTS = 1\n\n"
        << "[TRAJ]\nCOORDINATES = X\nLINEAR_UNITS = mm\n\n"
        << "[AXIS_X]\nMAX_VELOCITY = 50\nMAX_ACCELERATION = 500\nMIN_LIMIT = -100\nMAX_LIMIT = 100\n\n"
        << "[JOINT_0]\nTYPE = LINEAR\nMAX_VELOCITY = 50.0\nMAX_ACCELERATION = 500\nMIN_LIMIT = -100\nMAX_LIMIT = 100\n"
        << "FF1 = " << ff1 << "\nOUTPUT_SCALE = 250\nOUTPUT_MIN_LIMIT = " << minlim << "\nOUTPUT_MAX_LIMIT = " << maxlim
        << "\n\n[HAL]\nHALFILE = " << name << ".hal\n";
    std::ofstream hal(dir.path() / (name + ".hal"));
    hal << "loadrt hostmot2\n"
        << "loadrt hm2_eth board_ip=10.10.10.10 config=\"num_encoders=6 num_pwmgens=0 num_stepgens=0 "
           "sserial_port_0=00xxxx\"\n"
        << "loadrt pid names=pid.x\n"
        << "setp pid.x.FF1 [JOINT_0]FF1\n"
        << "net x-pos-cmd joint.0.motor-pos-cmd => pid.x.command\n"
        << "net x-pos-fb hm2_7i92.0.encoder.00.position => pid.x.feedback joint.0.motor-pos-fb\n"
        << "net x-output pid.x.output => hm2_7i92.0.7i77.0.1.analogout0\n"
        << "setp hm2_7i92.0.7i77.0.1.analogout0-scalemax [JOINT_0]OUTPUT_SCALE\n";
    if (limits)
      hal << "setp hm2_7i92.0.7i77.0.1.analogout0-minlim [JOINT_0]OUTPUT_MIN_LIMIT\n"
          << "setp hm2_7i92.0.7i77.0.1.analogout0-maxlim [JOINT_0]OUTPUT_MAX_LIMIT\n";
    return dir.path() / (name + ".ini");
  };

  // Each configuration warned of, and the line check-config prints.
  struct Warned {
    const char* name;
    const char* ff1;
    const char* minlim;
    const char* maxlim;
    bool limits;
    std::string line;
  };
  for (const auto& w : {
           // PNCconf's +-10 with OUTPUT_SCALE 250: 10 mm/s of the 50 the INI allows.
           Warned{"held", "1.0", "-10.0", "10.0", true,
                  "held.hal:10: warning: joint 0: hm2_7i92.0.7i77.0.1.analogout0-maxlim 10 holds its PID's output to "
                  "10 (10 units/s at FF1 1), under [JOINT_0]MAX_VELOCITY 50 (held.ini:21): a move faster than that "
                  "ends in a following error; PNCconf's default limits of +-10 suit an OUTPUT_SCALE of 10 only"},
           // The limit nearer 0 holds it, here minlim; FF1 2 halves the velocity.
           Warned{"held_below", "2", "-20", "250", true,
                  "held_below.hal:9: warning: joint 0: hm2_7i92.0.7i77.0.1.analogout0-minlim -20 holds its PID's "
                  "output to -20 (10 units/s at FF1 2), under [JOINT_0]MAX_VELOCITY 50 (held_below.ini:21): a move "
                  "faster than that ends in a following error"},
           // No setp of the limits: hostmot2's own, the 7I77's +-10, at the
           // line that nets the output.
           Warned{"unset", "1", "-250", "250", false,
                  "unset.hal:7: warning: joint 0: hm2_7i92.0.7i77.0.1.analogout0-maxlim 10 (hostmot2's default: none "
                  "set) holds its PID's output to 10 (10 units/s at FF1 1), under [JOINT_0]MAX_VELOCITY 50 "
                  "(unset.ini:21): a move faster than that ends in a following error; hostmot2's default limits of "
                  "+-10 suit a scalemax of 10 only"}}) {
    const auto r = check(servo(w.name, w.ff1, w.minlim, w.maxlim, w.limits));
    EXPECT_EQ(r.exit, 0) << w.name << "\n" << r.out << r.err;
    EXPECT_NE(r.out.find(w.line + "\n"), std::string::npos) << w.line << "\n" << r.out;
    EXPECT_NE(r.out.find(": no errors, 1 warning\n"), std::string::npos) << r.out;
  }
  const auto warned = check(dir.path() / "held.ini", true);
  EXPECT_EQ(warned.exit, 0) << warned.out << warned.err;
  const auto j = json::parse(warned.out, nullptr, false);
  ASSERT_FALSE(j.is_discarded()) << warned.out << warned.err;
  EXPECT_EQ(j["ok"], true);
  ASSERT_EQ(j["findings"].size(), 1U) << j.dump(2);
  EXPECT_EQ(j["findings"][0]["severity"], "warning");
  EXPECT_EQ(j["findings"][0]["name"], "hm2_7i92.0.7i77.0.1.analogout0-maxlim");

  // Limits of +-OUTPUT_SCALE reach 250 mm/s; exactly MAX_VELOCITY is reached.
  for (const auto& [name, ff1, minlim, maxlim] :
       {std::tuple{"reaches", "1", "-250", "250"}, std::tuple{"reaches_exactly", "5", "-250", "250"},
        std::tuple{"no_ff1", "0", "-10", "10"}}) {
    const auto r = check(servo(name, ff1, minlim, maxlim));
    EXPECT_EQ(r.exit, 0) << name << "\n" << r.out << r.err;
    EXPECT_EQ(r.out.find("following error"), std::string::npos) << name << "\n" << r.out;
    EXPECT_NE(r.out.find(": no problems\n"), std::string::npos) << name << "\n" << r.out;
  }
}

TEST(CheckConfig, TextOutputSaysFileLineReasonAndNearestName) {
  const auto r = check(corpus() / "broken/wrong_channel.hal");
  EXPECT_EQ(r.exit, 1);
  EXPECT_NE(r.out.find("wrong_channel.hal:9: error: smart-serial port 0 channel 4 is left out: 'x' in sserial_port_0=00xxxx"),
            std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("    nearest existing name: hm2_7i92.0.7i77.0.1.analogout0"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("1 error"), std::string::npos) << r.out;
  const auto missing = check(corpus() / "no-such-file.ini");
  EXPECT_EQ(missing.exit, 1);
  EXPECT_NE(missing.out.find("no such file"), std::string::npos) << missing.out;
}

TEST(Pins, ListsEachModesPinsForTheVirtualCard) {
  auto pins = [](const std::string& config, const std::string& cards = "1") {
    const auto r = test_support::run({"pins", "--config", config, "--7i77s", cards, "--json"});
    EXPECT_EQ(r.exit, 0) << r.err;
    std::set<std::string> names;
    const auto j = json::parse(r.out, nullptr, false);
    for (const char* kind : {"pins", "params"})
      for (const auto& i : j[kind]) names.insert(i["name"].get<std::string>() + " " + i["type"].get<std::string>() + " " +
                                                 i["dir"].get<std::string>());
    return names;
  };
  const auto mode0 = pins("num_encoders=6 sserial_port_0=00xxxx");
  const auto mode3 = pins("num_encoders=6 sserial_port_0=30xxxx");
  EXPECT_TRUE(mode0.count("hm2_7i92.0.7i77.0.0.input-31 bit OUT"));
  EXPECT_TRUE(mode0.count("hm2_7i92.0.7i77.0.1.analogout5 float IN"));
  EXPECT_TRUE(mode0.count("hm2_7i92.0.7i77.0.0.nvwatchdogtimeout u32 RO"));
  EXPECT_FALSE(mode0.count("hm2_7i92.0.7i77.0.0.fieldvoltage float OUT"));
  EXPECT_TRUE(mode3.count("hm2_7i92.0.7i77.0.0.fieldvoltage float OUT"));
  EXPECT_TRUE(mode3.count("hm2_7i92.0.7i77.0.0.enc1.reset bit I/O"));
  const auto two = pins("num_encoders=12 sserial_port_0=000000", "2");
  EXPECT_TRUE(two.count("hm2_7i92.0.7i77.0.4.analogout0 float IN"));
  EXPECT_TRUE(two.count("hm2_7i92.0.encoder.11.count s32 OUT"));
  EXPECT_FALSE(mode0.count("hm2_7i92.0.7i77.0.4.analogout0 float IN"));
}

// A board name stands for every card of the catalogue
// hm2_eth gives it (hm2_7i92: the 7I92 and the 7I92T) with each of their
// firmwares; check-config takes the one under which the configuration has
// the fewest errors (the first on a tie) and says which; --card and
// --pinout choose instead.
TEST(CheckConfig, PicksTheCardAndFirmwareWithTheFewestErrors) {
  const auto mill = check(fs::path(LBPKIT_SOURCE_DIR) / "examples/linuxcnc/mill/mill.ini");
  EXPECT_EQ(mill.exit, 0) << mill.out << mill.err;
  EXPECT_NE(mill.out.find("(mill.hal:9): 7I92 (7I77x2 firmware), 7I77 on channel 0 (mode 0)"), std::string::npos)
      << mill.out;
  const auto stepper = corpus() / "good/7i92t_stepgens_dpll.hal";
  const auto picked = check(stepper, true);
  EXPECT_EQ(picked.exit, 0) << picked.out << picked.err;
  const auto j = json::parse(picked.out, nullptr, false);
  ASSERT_FALSE(j.is_discarded()) << picked.out;
  EXPECT_EQ(j["boards"][0]["model"].get<std::string>().rfind("7I92T (7I77+7I76 firmware), 7I77 on channel 0", 0), 0U)
      << j.dump(2);
  EXPECT_EQ(j["boards"][0]["candidates"], 5) << "the 7I92's three firmwares and the 7I92T's two";
  // Forced to the plain 7I92's firmware without the HM2DPLL: every DPLL
  // timer name is an error.
  const auto forced = check(stepper, false, {"--card", "7I92", "--pinout", "7I77+7I76"});
  EXPECT_EQ(forced.exit, 1) << forced.out;
  EXPECT_NE(forced.out.find("7I92 (7I77+7I76 firmware), 7I77 on channel 0"), std::string::npos) << forced.out;
  EXPECT_NE(forced.out.find("7i92t_stepgens_dpll.hal:14: error: the 7I92 (7I77+7I76 firmware) has no HM2DPLL"),
            std::string::npos)
      << forced.out;
  EXPECT_NE(forced.out.find("stepgen.timer-number exists only on a firmware with an HM2DPLL"), std::string::npos)
      << forced.out;
  EXPECT_NE(forced.out.find("3 errors"), std::string::npos) << forced.out;
  // A card of another LinuxCNC name, or a firmware it does not have.
  const auto other = check(stepper, false, {"--card", "7I96S"});
  EXPECT_EQ(other.exit, 1);
  EXPECT_NE(other.out.find("no card 7I96S of the catalogue is hm2_7i92.0"), std::string::npos) << other.out;
  const auto none = test_support::run({"check-config", stepper.string(), "--card", "7I99"});
  EXPECT_NE(none.exit, 0);
  EXPECT_NE((none.out + none.err).find("7I92, 7I92T, 7I96S, 7I80HD-25"), std::string::npos) << none.out << none.err;
}

// The 7I76 mill (a 7I92T + 7I77 + 7I76, a stepper on StepGen 0 timed by the
// HM2DPLL, Z's switches and the spindle on the 7I76) passes as the 7I92T with
// its 7I77+7I76 firmware.
TEST(CheckConfig, TheStepperZMillPasses) {
  const auto ini = fs::path(LBPKIT_SOURCE_DIR) / "examples/linuxcnc/mill-7i76/mill.ini";
  const auto r = check(ini);
  EXPECT_EQ(r.exit, 0) << r.out << r.err;
  EXPECT_NE(r.out.find("7I92T (7I77+7I76 firmware), 7I77 on channel 0 (mode 0)"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("7I76 on channel 3 (mode 0)"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("no problems"), std::string::npos) << r.out;
}

TEST(Pins, ListsEachCardsModules) {
  auto pins = [](const std::vector<std::string>& extra, const std::string& config) {
    std::vector<std::string> args{"pins", "--config", config, "--json"};
    args.insert(args.end(), extra.begin(), extra.end());
    const auto r = test_support::run(args);
    EXPECT_EQ(r.exit, 0) << r.err;
    return json::parse(r.out, nullptr, false);
  };
  auto has = [](const json& j, const std::string& name, const std::string& type, const std::string& dir) {
    for (const char* kind : {"pins", "params"})
      for (const auto& i : j[kind])
        if (i["name"] == name) return i["type"] == type && i["dir"] == dir;
    return false;
  };
  const auto s96 = pins({"--card", "7I96S"}, "num_encoders=8 num_stepgens=5 num_pwmgens=1 sserial_port_0=00xx");
  EXPECT_EQ(s96["board"], "hm2_7i96s.0");
  EXPECT_TRUE(has(s96, "hm2_7i96s.0.stepgen.04.position-cmd", "float", "IN"));
  EXPECT_TRUE(has(s96, "hm2_7i96s.0.stepgen.00.counts", "s32", "OUT"));
  EXPECT_TRUE(has(s96, "hm2_7i96s.0.stepgen.00.dirsetup", "u32", "RW"));
  EXPECT_TRUE(has(s96, "hm2_7i96s.0.stepgen.timer-number", "s32", "IN"));
  EXPECT_TRUE(has(s96, "hm2_7i96s.0.encoder.timer-number", "s32", "IN"));
  EXPECT_TRUE(has(s96, "hm2_7i96s.0.pwmgen.00.value", "float", "IN"));
  EXPECT_TRUE(has(s96, "hm2_7i96s.0.pwmgen.pwm_frequency", "u32", "RW"));
  EXPECT_TRUE(has(s96, "hm2_7i96s.0.dpll.01.timer-us", "float", "IN"));
  EXPECT_TRUE(has(s96, "hm2_7i96s.0.dpll.phase-error-us", "float", "OUT"));
  EXPECT_TRUE(has(s96, "hm2_7i96s.0.stepgen.00.step.invert_output", "bit", "RW"));
  EXPECT_TRUE(has(s96, "hm2_7i96s.0.pwmgen.00.out0.is_opendrain", "bit", "RW"));
  const auto few = pins({"--card", "7I96S"}, "num_stepgens=1 num_pwmgens=0 num_dplls=0 sserial_port_0=00xx");
  EXPECT_TRUE(has(few, "hm2_7i96s.0.stepgen.00.enable", "bit", "IN"));
  EXPECT_FALSE(has(few, "hm2_7i96s.0.stepgen.01.enable", "bit", "IN"));
  EXPECT_FALSE(has(few, "hm2_7i96s.0.pwmgen.00.value", "float", "IN"));
  EXPECT_FALSE(has(few, "hm2_7i96s.0.dpll.01.timer-us", "float", "IN"));
  EXPECT_TRUE(has(few, "hm2_7i96s.0.stepgen.timer-number", "s32", "IN")) << "the DPLL is there, num_dplls or not";
  EXPECT_TRUE(has(few, "hm2_7i96s.0.gpio.019.out", "bit", "IN")) << "StepGen 1's Step is GPIO again";
  const auto plain = pins({}, "sserial_port_0=00xxxx");
  EXPECT_EQ(plain["board"], "hm2_7i92.0");
  EXPECT_FALSE(has(plain, "hm2_7i92.0.stepgen.timer-number", "s32", "IN"));
  const auto i76 = pins({"--card", "7I92", "--pinout", "7I77+7I76"}, "num_stepgens=5 sserial_port_0=00x0x");
  EXPECT_TRUE(has(i76, "hm2_7i92.0.stepgen.04.position-cmd", "float", "IN"));
  EXPECT_TRUE(has(i76, "hm2_7i92.0.7i76.0.3.spinout", "float", "IN"));
  EXPECT_FALSE(has(i76, "hm2_7i92.0.stepgen.timer-number", "s32", "IN")) << "no HM2DPLL on a 7I92";
  EXPECT_EQ(pins({"--card", "7I80HD-25"}, "sserial_port_0=00x")["board"], "hm2_7i80.0");
  const auto bad = test_support::run({"pins", "--card", "7I92T", "--pinout", "7I77x9"});
  EXPECT_NE(bad.exit, 0);
  EXPECT_NE((bad.out + bad.err).find("\"7I77+7I76\", \"7I77x2\""), std::string::npos) << bad.out << bad.err;
}

}  // namespace
