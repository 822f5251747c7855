// SPDX-License-Identifier: MIT
// Configurations nobody here wrote, from their own files to homed and moved
// with the user's commands alone, with their defaults: the public ones
// (tests/public_configs/, each with its SOURCE.md) and PNCconf's corpus
// (tests/pncconf/configs/, made by PNCconf's own writer). `lbpkit
// check-config` finds no error, `lbpkit machine --from-config` writes the
// machine, and `lbpkit linuxcnc INI --display tests/e2e/config_display.py`
// runs LinuxCNC against the sim with the machine it derives, on the clock it
// chooses for this PC (docs/linuxcnc.md#on-a-pc-without-a-real-time-kernel),
// from a desktop of the test's own (Xvfb: the configuration's own windows,
// such as hal_manualtoolchange, open there) and the user's home in the
// test's folder. The headless display homes every joint, makes G53 MDI
// moves across each axis' travel and runs a short program. Every joint must
// end within one count of LinuxCNC's command, and LinuxCNC report no error
// in any step. What a configuration needs that Debian's LinuxCNC lacks (a
// custom component, a GUI panel) is left out, line by line, each with its
// reason. Needs root, linuxcnc-uspace and xvfb (scripts/test installs them).
#include <sys/stat.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "support/interop.hpp"
#include "support/process.hpp"
#include "support/temp_dir.hpp"
#include "support/xvfb.hpp"

namespace {

namespace fs = std::filesystem;

// Lines a configuration's file has that Debian's LinuxCNC cannot load:
// each line of `file` holding `text` is commented out.
struct LeftOut {
  std::string file;
  std::string text;
  std::string why;
};

struct PublicConfig {
  std::string folder;  // under tests/public_configs/ or tests/pncconf/configs/
  std::string ini;
  std::vector<LeftOut> leftOut;
};

std::ostream& operator<<(std::ostream& o, const PublicConfig& c) { return o << c.folder; }

void leaveOut(const fs::path& config, const LeftOut& l) {
  const auto file = config / l.file;
  std::ifstream in(file);
  ASSERT_TRUE(in) << file;
  std::string text, line;
  unsigned changed = 0;
  while (std::getline(in, line)) {
    if (line.find(l.text) != std::string::npos) {
      line = "# left out by lbpkit's test (" + l.why + "): " + line;
      ++changed;
    }
    text += line + "\n";
  }
  in.close();
  ASSERT_GT(changed, 0U) << l.file << " has no line with " << l.text;
  std::ofstream(file, std::ios::trunc) << text;
}

class PublicConfigRun : public ::testing::TestWithParam<PublicConfig> {
 protected:
  void SetUp() override {
    if (::geteuid() != 0) GTEST_SKIP() << "lbpkit linuxcnc needs root";
    if (!test_support::haveClientProgram("linuxcnc") || !interop::have("ip") || !interop::have("Xvfb"))
      GTEST_SKIP() << "linuxcnc-uspace, iproute2 or xvfb is not installed";
  }
};

// The folder a configuration is in: PNCconf's corpus, or a public one.
fs::path source(const PublicConfig& c) {
  const auto pncconf = fs::path(LBPKIT_SOURCE_DIR) / "tests/pncconf/configs" / c.folder;
  return fs::exists(pncconf) ? pncconf : fs::path(LBPKIT_SOURCE_DIR) / "tests/public_configs" / c.folder;
}

TEST_P(PublicConfigRun, HomesMovesAndRunsAProgram) {
  const auto& c = GetParam();
  test_support::TempDir dir;
  // LinuxCNC runs as nobody (rtapi_app's RTAPI_UID): the folder is readable,
  // the results file writable.
  fs::permissions(dir.path(), fs::perms::owner_all | fs::perms::group_read | fs::perms::group_exec |
                                  fs::perms::others_read | fs::perms::others_exec);
  const auto config = dir.path() / "config";
  fs::copy(source(c), config, fs::copy_options::recursive);
  for (const auto& l : c.leftOut) leaveOut(config, l);
  fs::create_directories(dir.path() / "e2e");
  // The displays and the driver of lbpkit rehearse's they build on.
  for (const char* script : {"tests/e2e/config_display.py", "tests/e2e/display.py", "apps/lbpkit/rehearse_driver.py"}) {
    fs::copy_file(fs::path(LBPKIT_SOURCE_DIR) / script, dir.path() / "e2e" / fs::path(script).filename());
    fs::permissions(dir.path() / "e2e" / fs::path(script).filename(),
                    fs::perms::owner_all | fs::perms::group_read | fs::perms::group_exec | fs::perms::others_read |
                        fs::perms::others_exec);
  }
  const auto results = dir.path() / "results.jsonl";
  std::ofstream(results).close();
  fs::permissions(results, fs::perms::all);

  // The README's three commands, as a user types them.
  const auto ini = (config / c.ini).string();
  const auto checked = test_support::run({"check-config", ini});
  ASSERT_EQ(checked.exit, 0) << checked.out << checked.err;
  const auto machine = (dir.path() / "machine.toml").string();
  const auto derived = test_support::run({"machine", "--from-config", ini, "-o", machine});
  ASSERT_EQ(derived.exit, 0) << derived.err;

  const auto display = (dir.path() / "e2e/config_display.py").string() + " --out " + results.string();
  // The user's desktop and home: LinuxCNC's files in its user's home
  // (linuxcnc_debug.txt, the sim's EEPROM state) go to the test's folder.
  test_support::Xvfb desktop;
  ASSERT_TRUE(desktop.up()) << "Xvfb did not start";
  const auto userHome = dir.path() / "home";
  fs::create_directories(userHome);
  ::setenv("HOME", userHome.c_str(), 1);
  ::setenv("DISPLAY", desktop.display().c_str(), 1);
  // The machine is lbpkit linuxcnc's own (--machine auto, derived as
  // above); the sim's clock and CPU are the ones it chooses for this PC.
  // Should LinuxCNC fail, its error dialog waits on the desktop: the run
  // is stopped after 240 s, and what LinuxCNC said is in its log.
  // Another release's LinuxCNC where the test runs one
  // (support/linuxcnc_release.hpp): lbpkit linuxcnc's --linuxcnc-root.
  std::vector<std::string> command = {"linuxcnc", ini, "--display", display};
  if (!test_support::linuxCncRoot().empty()) command.insert(command.end(), {"--linuxcnc-root", test_support::linuxCncRoot()});
  const auto r = test_support::run(command, std::chrono::seconds(240));
  const std::string log = r.out + r.err;
  EXPECT_EQ(r.exit, 0) << log;

  std::ifstream in(results);
  std::map<std::string, std::vector<nlohmann::json>> steps;
  std::string done;  // the display's steps, for a run that did not finish
  for (std::string line; std::getline(in, line);)
    if (!line.empty()) {
      const auto j = nlohmann::json::parse(line);
      steps[j["step"].get<std::string>()].push_back(j);
      done += line + "\n";
    }
  ASSERT_EQ(steps.count("exception"), 0U) << steps["exception"][0].dump(2) << log;
  ASSERT_EQ(steps.count("finished"), 1U) << log << "the display's steps:\n" << done;
  EXPECT_TRUE(steps["machine_on"].at(0)["ok"].get<bool>()) << steps["machine_on"][0].dump();
  const auto& home = steps["home"].at(0);
  EXPECT_TRUE(home["ok"].get<bool>()) << home.dump();
  EXPECT_TRUE(home["within_one_count"].get<bool>()) << home.dump();
  EXPECT_TRUE(home["messages"].empty()) << home.dump();
  ASSERT_EQ(steps["mdi"].size(), 3U);
  for (const auto& m : steps["mdi"]) {
    EXPECT_TRUE(m["ok"].get<bool>()) << m.dump();
    EXPECT_TRUE(m["within_one_count"].get<bool>()) << m.dump();
    EXPECT_TRUE(m["messages"].empty()) << m.dump();
  }
  const auto& program = steps["program"].at(0);
  EXPECT_TRUE(program["ok"].get<bool>()) << program.dump();
  EXPECT_TRUE(program["within_one_count"].get<bool>()) << program.dump();
  // What LinuxCNC said after the last step (a watchdog bite when its servo
  // thread stalls past the host clock's 40 ms silence is LinuxCNC's
  // lateness), printed for the record.
  std::printf("%s: homed in %.1f s; after the steps LinuxCNC said: %s\n", c.folder.c_str(),
              home["seconds"].get<double>(), steps["finished"][0]["all_messages"].dump().c_str());
}

// gtest's name for a configuration: its folder's letters and digits.
std::string configName(const ::testing::TestParamInfo<PublicConfig>& i) {
  std::string name;
  for (char ch : i.param.folder)
    if (std::isalnum(static_cast<unsigned char>(ch))) name += ch;
  return name;
}

INSTANTIATE_TEST_SUITE_P(
    Public, PublicConfigRun,
    ::testing::Values(
        // A 7I96S + 7I77 testbed by hand (LinuxCNC 2.9, mm): X a closed-loop
        // stepper (a StepGen in velocity mode, an encoder's feedback), Y a
        // servo, their home switches on the 7I96S's own inputs, a
        // classicladder program (Debian's LinuxCNC has it). Nothing left out.
        PublicConfig{"gtec-testbed-7i96s-xy", "mesa_7i96s_7i77_xy.ini", {}},
        // The same testbed with both joints on X (a closed-loop stepper
        // and a servo, homed in place together), as published.
        PublicConfig{"gtec-testbed-7i96s-xx", "mesa_7i96s_7i77_xx.ini", {}},
        // A 5I25 + 7I77 mill by PNCconf for LinuxCNC 2.7, in inches: run as
        // a copy on a 7I92 (hm2_pci) converted by update_ini.
        PublicConfig{"5i25-7i77-mill-floppydisk525",
                     "7i77v7.ini",
                     {{"7i77v7.hal", "probe_parport", "a PC parallel port: no such module in LinuxCNC's uspace build"},
                      {"7i77v7.hal", "pet_watchdog",
                       "LinuxCNC 2.9's hostmot2 exports no pet_watchdog function (lbpkit check-config says so)"},
                      {"custom.hal", "spindle-vfd", "gs2_vfd talks to a VFD on a serial port"},
                      {"7i77v7.ini", "POSTGUI_HALFILE", "its PyVCP panel's pins exist only with AXIS"}}},
        // A 7I92 + 7I77 lathe (X and Z servos, a spindle with an encoder),
        // PNCconf-made then split by hand into files joined by `source`,
        // mm. Its spindle goes through a custom component of the
        // repository's own (gearchange32, built with halcompile), which
        // Debian's LinuxCNC does not have: left out, and the spindle's
        // analog output with it.
        PublicConfig{"7i92-7i77-lathe-dowerna",
                     "padovani.ini",
                     {{"load.hal", "loadrt gearchange32", "a custom component: not in Debian's LinuxCNC"},
                      {"load.hal", "addf gear", "the custom component's function"},
                      {"padovani.hal", "gear.", "the custom component's pins"},
                      {"inout.hal", "gear.", "the custom component's pins (its gear selector inputs)"},
                      {"padovani.ini", "POSTGUI_HALFILE",
                       "gmoccapy's pins and a 7I73 pendant on channel 2 (lbpkit has no 7I73)"}}}),
    configName);

// PNCconf's corpus (tests/pncconf/README.md), each configuration as its
// writer made it: nothing left out. hal_manualtoolchange's window opens on
// the test's desktop.
INSTANTIATE_TEST_SUITE_P(Pncconf, PublicConfigRun,
                         ::testing::Values(PublicConfig{"5i25-xyz-mm-switch", "5i25_xyz_mm_switch.ini", {}},
                                           PublicConfig{"5i25-xyza-inch-index", "5i25_xyza_inch_index.ini", {}},
                                           PublicConfig{"5i25-xyyz-mm-shared", "5i25_xyyz_mm_shared.ini", {}},
                                           PublicConfig{"7i92-xyz-inch-in-place", "7i92_xyz_inch_in_place.ini", {}},
                                           PublicConfig{"7i92-xyyz-mm-index-shared", "7i92_xyyz_mm_index_shared.ini", {}},
                                           PublicConfig{"7i92-xyyza-mm-switch", "7i92_xyyza_mm_switch.ini", {}},
                                           PublicConfig{"7i96s-xyz-mm-switch", "7i96s_xyz_mm_switch.ini", {}},
                                           PublicConfig{"7i96s-xyza-inch-shared", "7i96s_xyza_inch_shared.ini", {}},
                                           PublicConfig{"7i80hd-xyz-inch-index", "7i80hd_xyz_inch_index.ini", {}},
                                           PublicConfig{"7i80hd-xyyza-mm-in-place", "7i80hd_xyyza_mm_in_place.ini", {}}),
                         configName);

}  // namespace
