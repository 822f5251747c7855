// SPDX-License-Identifier: MIT
// What `lbpkit pins` and `lbpkit check-config` say of a card, against what
// LinuxCNC's hm2_eth creates on it as halcmd lists it (Debian's
// linuxcnc-uspace, installed by scripts/test), on every card of the
// catalogue and every firmware mode.
#include <arpa/inet.h>
#include <sys/socket.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>
#include <functional>
#include <set>
#include <sstream>

#include "support/interop.hpp"

namespace interop {
namespace {

using namespace std::chrono_literals;

std::set<std::string> halcmdItems(const std::string& pins, const std::string& params,
                                  const std::string& board = "hm2_7i92.0") {
  std::set<std::string> out;
  for (const auto& [text, kind] : {std::pair{pins, "pin"}, std::pair{params, "param"}}) {
    std::istringstream in(text);
    std::string line;
    while (std::getline(in, line)) {
      std::istringstream words(line);
      std::vector<std::string> w;
      for (std::string s; words >> s;) w.push_back(s);
      // Owner Type Dir Value Name [<== signal]
      if (w.size() < 5 || w[4].rfind(board + ".", 0) != 0) continue;
      out.insert(std::string(kind) + " " + w[4] + " " + w[1] + " " + w[2]);
    }
  }
  return out;
}

// `lbpkit pins --json`'s items in halcmdItems' form.
std::set<std::string> pinsItems(const json& j) {
  std::set<std::string> out;
  for (const auto& [key, kind] : {std::pair{"pins", "pin"}, std::pair{"params", "param"}})
    for (const auto& i : j[key])
      out.insert(std::string(kind) + " " + i["name"].get<std::string>() + " " + i["type"].get<std::string>() + " " +
                 i["dir"].get<std::string>());
  return out;
}

std::set<std::string> lbpkitPins(const std::string& cardIp, const std::string& config) {
  const auto r = test_support::run({"pins", "--addr", cardIp, "--config", config, "--json"});
  EXPECT_EQ(r.exit, 0) << r.err;
  const auto j = json::parse(r.out, nullptr, false);
  return j.is_discarded() ? std::set<std::string>{} : pinsItems(j);
}

std::string difference(const std::set<std::string>& a, const std::set<std::string>& b) {
  std::string out;
  for (const auto& x : a)
    if (!b.count(x)) out += "  " + x + "\n";
  return out;
}

// What LinuxCNC made that lbpkit pins did not predict, and the other way.
std::string mismatch(const std::set<std::string>& predicted, const std::set<std::string>& actual) {
  return "LinuxCNC created, lbpkit pins did not list:\n" + difference(actual, predicted) +
         "lbpkit pins listed, LinuxCNC did not create:\n" + difference(predicted, actual);
}

// A sim configuration with two 7I77s, and its removal (the second
// connector's EEPROM files, FILE.2 and FILE.analog.2, are in the sim's own
// folder and go with it).
std::string twoSevenI77s(const std::string& file) {
  std::ofstream(file) << "[card]\npinout = \"7I77x2\"\n[[daughtercard]]\ntype = \"7I77\"\n[[daughtercard]]\ntype = \"7I77\"\n";
  return file;
}
void removeTwoSevenI77s(const std::string& file) { std::filesystem::remove(file); }

// Removes a test's files at the end of its scope, however it ends.
struct Cleanup {
  std::function<void()> run;
  ~Cleanup() { run(); }
};

// `lbpkit pins` (run against the sim over the network, before
// LinuxCNC loads) names exactly the pins and parameters Debian's hm2_eth
// then creates: name, type and direction of every hm2_7i92.0.* item that
// `halcmd show pin` and `halcmd show param` list, for each field I/O mode
// with one 7I77, and for one and two 7I77s on channels 0..5.
TEST_F(LinuxCnc, PinsListsExactlyWhatHm2EthCreatesInEveryModeWithOneAndTwo7I77s) {
  struct Case {
    unsigned sevenI77s;
    std::string config;
  };
  const std::vector<Case> cases = {{1, "num_encoders=6 sserial_port_0=00xxxx"},
                                   {1, "num_encoders=6 sserial_port_0=10xxxx"},
                                   {1, "num_encoders=6 sserial_port_0=20xxxx"},
                                   {1, "num_encoders=6 sserial_port_0=30xxxx"},
                                   {1, "num_encoders=12 sserial_port_0=000000"},
                                   {1, "num_encoders=3 sserial_port_0=0x"},
                                   {2, "num_encoders=12 sserial_port_0=000000"},
                                   {2, "num_encoders=12 sserial_port_0=3x0200"}};
  const auto toml = twoSevenI77s(fifo_ + ".toml");
  const Cleanup cleanup{[&] {
    hal("halrun -U");
    sim_.reset();  // before its files go: it writes them as it stops
    removeTwoSevenI77s(toml);
  }};
  for (const auto& c : cases) {
    SCOPED_TRACE(std::to_string(c.sevenI77s) + " 7I77, " + c.config);
    sim_ = cardSim(c.sevenI77s == 2 ? std::vector<std::string>{"--config", toml}
                                                           : std::vector<std::string>{});
    ASSERT_TRUE(sim_->up());
    const auto predicted = lbpkitPins(cardIp_, c.config);
    const auto r = loadBoard("hm2_7i92.0", c.config);
    ASSERT_EQ(r.exit, 0) << r.out;
    const auto actual = halcmdItems(halcmd("show pin").out, halcmd("show param").out);
    EXPECT_GT(actual.size(), 300U);
    EXPECT_EQ(predicted, actual) << mismatch(predicted, actual);
    hal("halrun -U");
    sim_.reset();
  }
}

// What `lbpkit check-config` passes loads in LinuxCNC against the
// sim without a HAL error; and what it catches, halcmd refuses at the same
// line.
TEST_F(LinuxCnc, CheckConfigsVerdictsAreLinuxCncs) {
  const std::filesystem::path corpus = std::filesystem::path(LBPKIT_SOURCE_DIR) / "tests/check_config";
  const auto toml = twoSevenI77s(fifo_ + ".toml");
  const Cleanup cleanup{[&] {
    hal("halrun -U");
    sim_.reset();  // before its files go: it writes them as it stops
    removeTwoSevenI77s(toml);
  }};
  for (const char* name : {"field_io_mode3", "two_7i77s"}) {
    SCOPED_TRACE(name);
    const auto ini = corpus / "good" / (std::string(name) + ".ini");
    const auto checked = test_support::run({"check-config", ini.string()});
    ASSERT_EQ(checked.exit, 0) << checked.out << checked.err;
    sim_ = cardSim(std::string(name) == "two_7i77s" ? std::vector<std::string>{"--config", toml}
                                                                            : std::vector<std::string>{});
    ASSERT_TRUE(sim_->up());
    // The same INI with this test's card address.
    std::ifstream in(ini);
    std::ostringstream text;
    for (std::string line; std::getline(in, line);)
      text << (line.rfind("IPADDRESS", 0) == 0 ? "IPADDRESS = " + cardIp_ : line) << "\n";
    const auto ownIni = fifo_ + ".ini";
    std::ofstream(ownIni) << text.str();
    const auto command = "halcmd -i " + ownIni + " -f " + (corpus / "good" / (std::string(name) + ".hal")).string();
    const auto r = hal(command);
    std::filesystem::remove(ownIni);
    EXPECT_EQ(r.exit, 0) << r.out;
    EXPECT_EQ(r.out.find("rror"), std::string::npos) << r.out;
    hal("halrun -U");
    sim_.reset();
  }

  // Broken ones: halcmd stops at the line check-config names.
  startSim();
  for (const char* name : {"wrong_channel", "no_remote_on_channel", "wrong_remote_channel", "wrong_mode",
                           "channel_left_out", "read_only_parameter", "two_outputs", "encoder_not_enabled",
                           "misspelt_pin", "setp_output_pin", "parameter_on_signal", "gpio_used_by_module"}) {
    SCOPED_TRACE(name);
    const auto hal_file = corpus / "broken" / (std::string(name) + ".hal");
    const auto checked = test_support::run({"check-config", hal_file.string(), "--json"});
    ASSERT_EQ(checked.exit, 1) << checked.out;
    const auto findings = json::parse(checked.out)["findings"];
    ASSERT_FALSE(findings.empty());
    const auto line = findings[0]["line"].get<unsigned>();
    const auto own = ownCopy(hal_file, name);
    const auto r = hal("halcmd -f " + own);
    std::filesystem::remove(own);
    EXPECT_NE(r.exit, 0) << r.out;
    EXPECT_NE(r.out.find(own + ":" + std::to_string(line) + ":"), std::string::npos)
        << "check-config says line " << line << "; halcmd says:\n" << r.out;
    hal("halrun -U");
  }
}

// hm2_eth names each card of the catalogue as it does the
// real one and creates every module's pins; the 7I77 answers wherever its
// firmware puts it (on the 7I96S, P1) and the card runs without io_error.
TEST_F(LinuxCnc, Hm2EthCreatesEachCardsPinsForEveryModule) {
  struct Case {
    std::string card, board, config;
    std::vector<std::string> pins;
  };
  const std::vector<Case> cases = {
      {"7I92T", "hm2_7i92.0", "num_encoders=8 num_stepgens=5 sserial_port_0=00xxx",
       {"stepgen.00.position-cmd", "stepgen.04.step_type", "encoder.07.count", "dpll.01.timer-us",
        "dpll.base-freq-khz", "7i77.0.0.input-31", "7i77.0.1.analogout5", "watchdog.has_bit"}},
      {"7I96S", "hm2_7i96s.0", "num_encoders=8 num_stepgens=5 num_pwmgens=1 sserial_port_0=00xx",
       {"stepgen.04.position-cmd", "pwmgen.00.value", "encoder.06.count", "dpll.04.timer-us", "7i77.0.0.output-15",
        "7i77.0.1.analogena", "gpio.050.in", "led.CR01"}},
      {"7I80HD-25", "hm2_7i80.0", "num_encoders=6 sserial_port_0=00x",
       {"encoder.05.count", "7i77.0.0.input-00", "7i77.0.1.analogout0", "gpio.071.in"}},
  };
  const Cleanup cleanup{[&] {
    hal("halrun -U");
    sim_.reset();
  }};
  for (const auto& c : cases) {
    SCOPED_TRACE(c.card);
    sim_ = cardSim(std::vector<std::string>{"--card", c.card});
    ASSERT_TRUE(sim_->up());
    const auto r = loadBoard(c.board, c.config);
    ASSERT_EQ(r.exit, 0) << r.out;
    const auto pins = halcmd("show pin").out + halcmd("show param").out;
    for (const auto& p : c.pins) EXPECT_NE(pins.find(c.board + "." + p), std::string::npos) << p << "\n" << pins;
    EXPECT_EQ(pins.find("hm2_7i92.0.") != std::string::npos, c.board == "hm2_7i92.0");
    // Terminals -> HAL through the 7I77's field I/O processor.
    sim_->post("/api/input", {{"input", 6}, {"on", true}});
    EXPECT_TRUE(waitFor([&] { return getp(c.board + ".7i77.0.0.input-06") == "TRUE"; }, 1000ms));
    EXPECT_EQ(getp(c.board + ".io_error"), "FALSE")
        << "packet-error-total " << getp(c.board + ".packet-error-total") << "\nsim: " << sim_->get()["lbp16"].dump()
        << "\n" << sim_->get()["server"].dump() << "\n" << sim_->get()["access_counters"].dump();
    hal("halrun -U");
    sim_.reset();
  }
}

// On the 7I77+7I76 firmware the 7I76's field I/O processor
// answers on channel 3 (PIN_7I77_7I76_34.vhd) and hm2_eth makes its pins
// from what it reports (sserial(9)'s 7I76 names), mode 2 with the field
// voltage reading; its expansion port (channel 4) has nobody.
TEST_F(LinuxCnc, Hm2EthCreatesThe7I76sPinsOnChannel3) {
  const auto config = fifo_ + ".toml";
  std::ofstream(config) << "[card]\nname = \"7I92\"\npinout = \"7I77+7I76\"\n";
  const Cleanup cleanup{[&] {
    hal("halrun -U");
    sim_.reset();
    std::filesystem::remove(config);
  }};
  sim_ = cardSim(std::vector<std::string>{"--card", "7I92", "--config", config});
  ASSERT_TRUE(sim_->up());
  const auto r = loadBoard("hm2_7i92.0", "num_encoders=8 num_stepgens=5 sserial_port_0=00x20");
  ASSERT_EQ(r.exit, 0) << r.out;
  const auto pins = halcmd("show pin").out + halcmd("show param").out;
  for (const char* p : {"input-31", "input-00-not", "output-15", "spinout", "spinena", "spindir", "analog3",
                        "fieldvoltage", "spinout-scalemax", "spinena-invert", "nvunitnumber", "swrevision"})
    EXPECT_NE(pins.find(std::string("hm2_7i92.0.7i76.0.3.") + p), std::string::npos) << p << "\n" << pins;
  EXPECT_EQ(pins.find("hm2_7i92.0.7i76.0.4."), std::string::npos) << "nothing on channel 4";
  EXPECT_NE(pins.find("hm2_7i92.0.7i77.0.0.input-31"), std::string::npos);
  EXPECT_NE(pins.find("hm2_7i92.0.stepgen.04.position-cmd"), std::string::npos);
  // The 7I76's 24 V field supply, read through mode 2's FieldVoltage.
  EXPECT_TRUE(waitFor([&] { return std::atof(getp("hm2_7i92.0.7i76.0.3.fieldvoltage").c_str()) > 23.5; }, 1000ms))
      << getp("hm2_7i92.0.7i76.0.3.fieldvoltage");
  EXPECT_EQ(getp("hm2_7i92.0.io_error"), "FALSE");
}

// The 7I96S's TB3 as Mesa's 7I96S firmwares carry it (pncconf's
// 7i96s_d): hm2_eth makes InM's inputs IN0..IN10, SSR's OUT0..OUT3 and
// OutM's OUT4 and OUT5 from the pin descriptors (inm.c, ssr.c, outm.c), and
// what LinuxCNC writes lands in those modules' registers.
TEST_F(LinuxCnc, Hm2EthCreatesThe7I96SsTb3InmSsrAndOutmPins) {
  if (!test_support::haveClientProgram("mesaflash")) GTEST_SKIP() << "mesaflash is not installed (scripts/test installs it)";
  const Cleanup cleanup{[&] {
    hal("halrun -U");
    sim_.reset();
  }};
  sim_ = cardSim(std::vector<std::string>{"--card", "7I96S"});
  ASSERT_TRUE(sim_->up());
  const auto r = loadBoard("hm2_7i96s.0", "num_encoders=8 num_stepgens=5 num_pwmgens=1 sserial_port_0=00xx");
  ASSERT_EQ(r.exit, 0) << r.out;
  const auto pins = halcmd("show pin").out + halcmd("show param").out;
  const std::string b = "hm2_7i96s.0.";
  for (const char* p : {"inm.00.input-00", "inm.00.input-10", "inm.00.input-10-not", "inm.00.raw-input-05",
                        "inm.00.input-03-slow", "inm.00.enc0-count", "inm.00.enc3-reset", "inm.00.scan_rate",
                        "inm.00.enc1_4xmode", "ssr.00.rate", "ssr.00.out-00", "ssr.00.out-03", "ssr.00.invert-03",
                        "outm.00.out-04", "outm.00.out-05", "outm.00.invert-05", "stepgen.04.position-cmd"})
    EXPECT_NE(pins.find(b + p), std::string::npos) << p << "\n" << pins;
  for (const char* p : {"inm.00.input-11", "ssr.00.out-04", "outm.00.out-03", "outm.00.out-06"})
    EXPECT_EQ(pins.find(b + p + std::string(" ")), std::string::npos) << p;
  EXPECT_EQ(getp(b + "inm.00.scan_width"), "11");  // MaxBit + 1, read from the control register
  // Idle inputs: pins high, inverted to "off".
  EXPECT_TRUE(waitFor([&] { return getp(b + "inm.00.input-00-not") == "TRUE"; }, 1000ms));
  EXPECT_EQ(getp(b + "inm.00.raw-input-10"), "FALSE");
  halcmd("setp " + b + "ssr.00.out-02 1");
  halcmd("setp " + b + "outm.00.out-05 1");
  halcmd("setp " + b + "outm.00.invert-04 1");
  const std::string rpo = "timeout 30 " + onCardCpu() + test_support::inLinuxCncRoot() + "mesaflash --device 7i96s --addr " + cardIp_ + " --rpo ";
  auto reg = [&](const char* address) {
    auto v = sh(rpo + address).out;
    while (!v.empty() && v.back() == '\n') v.pop_back();
    return v;
  };
  EXPECT_TRUE(waitFor([&] { return reg("0x7D00") == "00000004"; }, 2000ms)) << reg("0x7D00");  // SSR data
  EXPECT_EQ(reg("0x7E00"), "00001030");  // 1 MHz: divisor 48, enable
  EXPECT_TRUE(waitFor([&] { return reg("0xB000") == "00000030"; }, 2000ms)) << reg("0xB000");  // OutM 4 (inverted), 5
  // inm.c's control word: invert, divisor 112 (20 kHz x 11 inputs), 5 and 500 scans; MaxBit 10.
  EXPECT_EQ(reg("0x8500"), "7D051C2A");
  // encoder.timer-number reaches the counters' DPLL timer register
  // (base + 5 strides: 0x3A00), (1 << 12) | 0x8000, and the card still keeps time.
  halcmd("setp " + b + "dpll.01.timer-us -100");
  halcmd("setp " + b + "encoder.timer-number 1");
  EXPECT_TRUE(waitFor([&] { return reg("0x3A00") == "00009000"; }, 2000ms)) << reg("0x3A00");
  std::this_thread::sleep_for(300ms);
  EXPECT_EQ(getp(b + "io_error"), "FALSE");
}

// `lbpkit sim` arguments for a card of the catalogue and one of its
// firmwares (none: its default), the firmware through a sim configuration
// written to `toml`.
std::vector<std::string> catalogueCard(const std::string& card, const std::string& pinout, const std::string& toml) {
  std::vector<std::string> args{"--card", card};
  if (pinout.empty()) return args;
  std::ofstream(toml) << "[card]\nname = \"" << card << "\"\npinout = \"" << pinout << "\"\n";
  args.insert(args.end(), {"--config", toml});
  return args;
}

// `lbpkit pins` knows every card of the catalogue with
// its modules (StepGen, PWMGen, HM2DPLL, the 7I96S's InM, SSR and OutM, the
// 7I76 on channel 3): what it lists from the card on the network (hm2_eth's
// board name from the LBP16 name) is what hm2_eth creates, pin for pin and
// parameter for parameter, for each card's default firmware and the 7I92's
// 7I77+7I76, with every module and with some left out (their IO pins become
// GPIO again).
TEST_F(LinuxCnc, PinsListsExactlyWhatHm2EthCreatesOnEveryCardOfTheCatalogue) {
  struct Case {
    std::string card, pinout, board, config;
  };
  const std::vector<Case> cases = {
      {"7I92", "", "hm2_7i92.0", "sserial_port_0=00xxxx"},
      {"7I92", "7I77+7I76", "hm2_7i92.0", "num_encoders=8 num_stepgens=5 sserial_port_0=00x0x"},
      {"7I92T", "", "hm2_7i92.0", "num_encoders=8 num_stepgens=5 sserial_port_0=00x2x"},
      {"7I92T", "", "hm2_7i92.0", "num_encoders=6 num_stepgens=2 num_dplls=0 sserial_port_0=00xxx"},
      {"7I96S", "", "hm2_7i96s.0", "num_encoders=8 num_stepgens=5 num_pwmgens=1 sserial_port_0=00xx"},
      {"7I96S", "", "hm2_7i96s.0",
       "num_encoders=2 num_stepgens=3 num_pwmgens=0 num_inms=0 num_ssrs=0 num_outms=0 sserial_port_0=0xxx"},
      {"7I80HD-25", "", "hm2_7i80.0", "num_encoders=6 sserial_port_0=00x"},
  };
  const auto toml = fifo_ + "-pinout.toml";
  const Cleanup cleanup{[&] {
    hal("halrun -U");
    sim_.reset();
    std::filesystem::remove(toml);
  }};
  for (const auto& c : cases) {
    SCOPED_TRACE(c.card + " " + c.pinout + ": " + c.config);
    sim_ = cardSim(catalogueCard(c.card, c.pinout, toml));
    ASSERT_TRUE(sim_->up());
    const auto listed = test_support::run({"pins", "--addr", cardIp_, "--config", c.config, "--json"});
    ASSERT_EQ(listed.exit, 0) << listed.err;
    const auto j = json::parse(listed.out, nullptr, false);
    ASSERT_FALSE(j.is_discarded()) << listed.out;
    EXPECT_EQ(j["board"], c.board);
    const auto predicted = pinsItems(j);
    const auto r = loadBoard(c.board, c.config);
    ASSERT_EQ(r.exit, 0) << r.out;
    const auto actual = halcmdItems(halcmd("show pin").out, halcmd("show param").out, c.board);
    EXPECT_GT(actual.size(), 200U);
    EXPECT_EQ(predicted, actual) << mismatch(predicted, actual);
    hal("halrun -U");
    sim_.reset();
  }
}

// check-config's verdicts on the catalogue's cards are
// LinuxCNC's. What it passes (a 7I92T with StepGens and the HM2DPLL, a
// 7I96S with every module, a 7I80HD-25) loads against `lbpkit sim` of that
// card; what it catches (a sixth StepGen, DPLL pins on a 7I92's firmware, a
// StepGen num_stepgens leaves out, more StepGens than the firmware has),
// halcmd refuses at the line check-config names.
TEST_F(LinuxCnc, CheckConfigsVerdictsOnEveryCardOfTheCatalogueAreLinuxCncs) {
  const std::filesystem::path corpus = std::filesystem::path(LBPKIT_SOURCE_DIR) / "tests/check_config";
  struct Case {
    std::string file, card, pinout;
    bool good;
  };
  const std::vector<Case> cases = {{"good/7i92t_stepgens_dpll", "7I92T", "", true},
                                   {"good/7i96s_modules", "7I96S", "", true},
                                   {"good/7i80hd_7i77", "7I80HD-25", "", true},
                                   {"broken/stepgen_not_in_firmware", "7I92T", "", false},
                                   {"broken/dpll_without_hm2dpll", "7I92", "7I77+7I76", false},
                                   {"broken/stepgen_left_out", "7I96S", "", false},
                                   {"broken/too_many_stepgens", "7I96S", "", false}};
  const auto toml = fifo_ + "-pinout.toml";
  const Cleanup cleanup{[&] {
    hal("halrun -U");
    sim_.reset();
    std::filesystem::remove(toml);
  }};
  for (const auto& c : cases) {
    SCOPED_TRACE(c.file);
    const auto file = corpus / (c.file + ".hal");
    std::vector<std::string> check{"check-config", file.string(), "--json"};
    if (!c.pinout.empty()) check.insert(check.end(), {"--card", c.card, "--pinout", c.pinout});
    const auto checked = test_support::run(check);
    ASSERT_EQ(checked.exit, c.good ? 0 : 1) << checked.out << checked.err;
    sim_ = cardSim(catalogueCard(c.card, c.pinout, toml));
    ASSERT_TRUE(sim_->up());
    const auto own = ownCopy(file, "catalogue");
    const auto r = hal("halcmd -f " + own);
    std::filesystem::remove(own);
    if (c.good) {
      EXPECT_EQ(r.exit, 0) << r.out;
      EXPECT_EQ(r.out.find("rror"), std::string::npos) << r.out;
    } else {
      const auto findings = json::parse(checked.out)["findings"];
      ASSERT_FALSE(findings.empty());
      const auto line = findings[0]["line"].get<unsigned>();
      EXPECT_NE(r.exit, 0) << r.out;
      EXPECT_NE(r.out.find(own + ":" + std::to_string(line) + ":"), std::string::npos)
          << "check-config says line " << line << " (" << findings[0]["reason"] << "); halcmd says:\n" << r.out;
    }
    hal("halrun -U");
    sim_.reset();
  }
}

}  // namespace
}  // namespace interop
