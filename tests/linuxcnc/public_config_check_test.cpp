// SPDX-License-Identifier: MIT
// Every public configuration under tests/public_configs/ (each folder with
// its SOURCE.md) through the user's two commands, `lbpkit check-config INI`
// and `lbpkit machine --from-config INI -o M.toml`: each gives what the
// table below says, success or exactly these errors (file:line: error:
// reason), each entry with why. What lbpkit learns to derive or check shows
// up here as an entry to update; a folder without an entry fails.
#include <gtest/gtest.h>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <filesystem>
#include <ostream>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "support/process.hpp"
#include "support/temp_dir.hpp"

namespace {

namespace fs = std::filesystem;

const fs::path kPublic = fs::path(LBPKIT_SOURCE_DIR) / "tests/public_configs";

struct Expected {
  std::string folder;  // under tests/public_configs/
  std::string ini;     // the INI a user starts, in that folder
  // The lines "file:line: error: reason" each command prints; none: it passes.
  std::vector<std::string> checkErrors;
  std::vector<std::string> machineErrors;
  // Further lines (a warning) check-config prints that say why.
  std::vector<std::string> checkNotes;
};

// gtest names a failing case by its folder.
void PrintTo(const Expected& x, std::ostream* os) { *os << x.folder << "/" << x.ini; }

// check-config's reason for a pin on a smart-serial channel where the
// firmware's two 7I77 channels (0 and 1) leave no remote.
std::string noRemoteOnChannel2(const std::string& where) {
  return where +
         ": error: no remote answers on smart-serial port 0 channel 2 (found: 7I77 on smart-serial port 0 channel 0 "
         "(mode 0); 7I77 on smart-serial port 0 channel 1 (mode 0))";
}

std::string noHomeSwitch(const std::string& where, int joint, const std::string& velocity, const std::string& axis,
                         int halLine, int megaInput) {
  const auto j = std::to_string(joint);
  return where + ": error: joint " + j + ": HOME_SEARCH_VEL is " + velocity + " but axis." + j +
         ".home-sw-in reaches no 7I77, 7I76 or card input (signal input-" + axis + "-axis-limit (tree_4024.hal:" +
         std::to_string(halLine) + "), with mega2560.input-" + std::to_string(megaInput) + ", axis." + j +
         ".neg-lim-sw-in, axis." + j + ".pos-lim-sw-in): there is no home switch to place";
}

const std::vector<Expected>& table() {
  static const std::vector<Expected> t = {
      // A 5I25 + 7I77 mill split into modules: [HAL] and each [AXIS_N] come
      // from other files by LinuxCNC's #INCLUDE (the linuxcnc script expands
      // it before anything reads the INI, and so does lbpkit), and its HAL
      // files source Tcl files ([HAL]TWOPASS) whose HAL commands lbpkit reads
      // with the INI's values ([lindex $::AXIS_0(P) 0]). Z's Tcl file drives
      // hm2_5i25.0.7i77.0.2.analogout1: channel 2, where the 7I77x2 firmware
      // has no remote (its 7I77s answer on channels 0-1 and 3-4), and
      // machine --from-config, whose machine sits behind the first 7I77
      // (analog outputs on channel 1), says Z's drive is on no 7I77's
      // analog outputs rather than taking it as the first 7I77's analogout1
      // (Y's). The configuration's own wiring as lbpkit's 5I25 firmware
      // sees it.
      {"5i25-7i77-mill-evgeniident",
       "DCS-M4.ini",
       {noRemoteOnChannel2("Devices/mesanet.com/7i77.0/axis-2.tcl:29"),
        noRemoteOnChannel2("Devices/mesanet.com/7i77.0/axis-2.tcl:30"),
        noRemoteOnChannel2("Devices/mesanet.com/7i77.0/axis-2.tcl:31"),
        noRemoteOnChannel2("Devices/mesanet.com/7i77.0/axis-2.tcl:33")},
       {"LinuxCNC/axis-2.hal:5: error: joint 2: its PID drives hm2_5i25.0.7i77.0.2.analogout1 "
        "(Devices/mesanet.com/7i77.0/axis-2.tcl:33), on smart-serial port 0 channel 2, where no 7I77 has its analog "
        "outputs (the first 7I77's are on channel 1, a second's on 4), so this joint cannot be derived"},
       {"60 hostmot2 names checked in 16 HAL files"}},
      // PNCconf for LinuxCNC 2.7: `addf hm2_5i25.0.pet_watchdog`, a function
      // 2.9's hostmot2 no longer exports (LinuxCNC refuses the line too: the
      // configuration's age, which tests/e2e/public_config_test.cpp leaves out).
      // The machine derives.
      {"5i25-7i77-mill-floppydisk525",
       "7i77v7.ini",
       {"7i77v7.hal:21: error: no function hm2_5i25.0.pet_watchdog: hm2_5i25.0 exports hm2_5i25.0.read "
        "hm2_5i25.0.read_gpio hm2_5i25.0.write hm2_5i25.0.write_gpio"},
       {},
       {}},
      // Home switches on an Arduino read by a Python component
      // (mega2560_hal_io_pins.py, in the repository, not staged): no 7I77 or
      // card input to place a switch on. The configuration's own hardware.
      {"5i25-7i77-vmc-bendemott",
       "tree_4024.ini",
       {},
       {noHomeSwitch("tree_4024.ini:128", 0, "-5.0", "x", 68, 18),
        noHomeSwitch("tree_4024.ini:217", 1, "-5.0", "y", 69, 19),
        noHomeSwitch("tree_4024.ini:291", 2, "5.0", "z", 70, 20)},
       {}},
      // Y is an STMBL drive on smart-serial channel 2 (hm2_7i80.0.stbl.0.2),
      // a remote lbpkit does not model, behind a custom component (lin2rev);
      // io.hal:141 puts motion.digital-in-07 on a second signal, which halcmd
      // refuses as well (the configuration's own mistake).
      {"7i80-7i77-router-shulter",
       "justinbieber.ini",
       {noRemoteOnChannel2("justinbieber.hal:87"), noRemoteOnChannel2("justinbieber.hal:88"),
        noRemoteOnChannel2("justinbieber.hal:90"), noRemoteOnChannel2("justinbieber.hal:91"),
        "io.hal:141: error: motion.digital-in-07 is already on signal 3d-probe-in: a pin joins one signal (halcmd "
        "refuses)"},
       {"justinbieber.hal:89: error: joint 1: neither a PID whose output reaches a 7I77 analogoutN nor a StepGen "
        "takes its command (signal yposcmd): lbpkit cannot tell what moves it"},
       {}},
      // A 7I73 pendant on smart-serial channel 2 (panel.hal, its post-GUI
      // file): a remote lbpkit does not model. X and Z derive.
      {"7i92-7i77-lathe-dowerna",
       "padovani.ini",
       {noRemoteOnChannel2("panel.hal:1"), noRemoteOnChannel2("panel.hal:182"), noRemoteOnChannel2("panel.hal:198"),
        noRemoteOnChannel2("panel.hal:199"), noRemoteOnChannel2("panel.hal:200"), noRemoteOnChannel2("panel.hal:201"),
        noRemoteOnChannel2("panel.hal:202"), noRemoteOnChannel2("panel.hal:399")},
       {},
       {}},
      // The HAL loads a 7I96S but adds hm2_7i94.0.read and .write, a board it
      // never loads (halcmd refuses the addf: the configuration's own
      // leftover). The machine derives.
      {"7i96s-7i77-router-wrhammer",
       "Rover13s.ini",
       {"Rover13s.hal:23: error: lbpkit does not know the board hm2_7i94.0: lbpkit knows hm2_7i92.0 (7I92), "
        "hm2_7i92.0 (7I92T), hm2_7i96s.0 (7I96S), hm2_7i80.0 (7I80HD-25) (hm2_eth) and the 5I25 and 6I25 with the "
        "7I77x2 firmware (hm2_pci)"},
       {},
       {}},
      // A 7I96S + 7I77 gantry (two servos on one axis): passes both.
      {"gtec-gantry-7i96s", "citic_gantry_robot.ini", {}, {}, {}},
      // A 7I96S + 7I77 testbed (a closed-loop stepper and a servo): passes both.
      {"gtec-testbed-7i96s-xy", "mesa_7i96s_7i77_xy.ini", {}, {}, {}},
      // The same testbed as X (the servo, a home switch on the 7I96S's
      // input 1) and C, the closed-loop stepper as a wrapped rotary axis
      // homed on its encoder's index. check-config passes; C has no
      // MIN_LIMIT or MAX_LIMIT (LinuxCNC leaves such a joint unbounded),
      // and machine --from-config needs them for the axis's travel. The
      // configuration's own rotary axis.
      {"gtec-testbed-7i96s-xc",
       "mesa_7i96s_7i77_xc.ini",
       {},
       {"mesa_7i96s_7i77_xc.ini:130: error: [JOINT_1] needs MIN_LIMIT below MAX_LIMIT: they give the axis its travel"},
       {}},
      // The same testbed's two motors both on X (coordinates=XX: the
      // closed-loop stepper and the servo as a gantry pair, no switches,
      // homed in place together): passes both.
      {"gtec-testbed-7i96s-xx", "mesa_7i96s_7i77_xx.ini", {}, {}, {}},
  };
  return t;
}

// The "file:line: error: reason" lines of a command's output, sorted (the
// two streams are read apart).
std::vector<std::string> errorLines(const test_support::Result& r) {
  std::vector<std::string> lines;
  std::istringstream in(r.out + "\n" + r.err);
  for (std::string line; std::getline(in, line);)
    if (line.find(": error: ") != std::string::npos) lines.push_back(line);
  std::sort(lines.begin(), lines.end());
  return lines;
}

std::vector<std::string> sorted(std::vector<std::string> v) {
  std::sort(v.begin(), v.end());
  return v;
}

std::string joined(const std::vector<std::string>& v) {
  std::string s;
  for (const auto& l : v) s += "  " + l + "\n";
  return s;
}

class PublicConfigCheck : public ::testing::TestWithParam<Expected> {};

TEST(PublicConfigCorpus, EveryFolderHasAnEntryWithItsSourceAndIni) {
  std::set<std::string> folders, entries;
  for (const auto& e : fs::directory_iterator(kPublic))
    if (e.is_directory()) folders.insert(e.path().filename().string());
  for (const auto& x : table()) {
    entries.insert(x.folder);
    EXPECT_TRUE(fs::is_regular_file(kPublic / x.folder / "SOURCE.md")) << x.folder;
    EXPECT_TRUE(fs::is_regular_file(kPublic / x.folder / x.ini)) << x.folder << "/" << x.ini;
  }
  EXPECT_EQ(folders, entries) << "each folder of tests/public_configs/ needs its entry in the table";
  EXPECT_GE(folders.size(), 8U);
}

TEST_P(PublicConfigCheck, CheckConfigAndMachineFromConfigGiveWhatTheTableSays) {
  const auto& x = GetParam();
  const auto ini = (kPublic / x.folder / x.ini).string();

  const auto check = test_support::run({"check-config", ini}, std::chrono::seconds(20));
  EXPECT_EQ(check.exit, x.checkErrors.empty() ? 0 : 1) << check.out << check.err;
  EXPECT_EQ(errorLines(check), sorted(x.checkErrors))
      << "check-config " << ini << " printed:\n" << check.out << check.err << "expected:\n" << joined(x.checkErrors);
  for (const auto& note : x.checkNotes)
    EXPECT_NE((check.out + check.err).find(note), std::string::npos) << note << "\n" << check.out << check.err;

  test_support::TempDir dir("lbpkit-public-check");
  const auto toml = dir.path() / "machine.toml";
  const auto machine =
      test_support::run({"machine", "--from-config", ini, "-o", toml.string()}, std::chrono::seconds(20));
  EXPECT_EQ(machine.exit, x.machineErrors.empty() ? 0 : 1) << machine.out << machine.err;
  EXPECT_EQ(errorLines(machine), sorted(x.machineErrors))
      << "machine --from-config " << ini << " printed:\n"
      << machine.out << machine.err << "expected:\n"
      << joined(x.machineErrors);
  if (x.machineErrors.empty()) {
    EXPECT_TRUE(fs::is_regular_file(toml)) << machine.out << machine.err;
    EXPECT_GT(fs::file_size(toml), 0U);
  } else {
    EXPECT_FALSE(fs::exists(toml)) << "an error leaves no machine file";
  }
}

std::string folderName(const ::testing::TestParamInfo<Expected>& info) {
  std::string name;
  for (const char c : info.param.folder)
    if (std::isalnum(static_cast<unsigned char>(c)) != 0) name += c;
  return name;
}

INSTANTIATE_TEST_SUITE_P(Public, PublicConfigCheck, ::testing::ValuesIn(table()), folderName);

}  // namespace
