// SPDX-License-Identifier: MIT
// The lbpkit tools as a user runs them.
#include <gtest/gtest.h>

#include <sys/resource.h>
#include <sys/stat.h>

#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <memory>
#include <nlohmann/json.hpp>
#include <thread>

#include "config/fault_script.hpp"
#include "support/process.hpp"
#include "support/sim_child.hpp"
#include "support/temp_dir.hpp"
#include "remote/nv_store.hpp"
#include "remote/remote_device.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace remote = lbpkit::model::remote;
namespace config = lbpkit::config;

namespace {

using test_support::Daemon;
using test_support::run;

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
    const auto r = run({"discover", "--json", "--modes", std::to_string(mode) + "0xxxx"});  // TB6, channels 3..5 skipped
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
  // Mesa's two-7I77 firmware has six channels: TB6 (2) and the second
  // connector's (3..5) have nothing attached.
  ASSERT_EQ(j["channels"].size(), 6U);
  for (unsigned ch = 2; ch < 6; ++ch) {
    EXPECT_EQ(j["channels"][ch]["present"], false) << ch;
    EXPECT_NE(j["channels"][ch]["status"].get<std::string>().find("TimeoutError"), std::string::npos) << ch;
  }
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
  test_support::removeStateFiles(state);
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
  test_support::removeStateFiles(state);
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
  EXPECT_NE(r.err.find(bad + ":2:8: daughtercard[0].type: \"7I88\" is not one of \"7I77\", \"7I77D\", \"none\""),
            std::string::npos)
      << r.err;
  {
    std::ofstream(bad) << "[[daughtercard\n";
  }
  r = run({"sim", "--config", bad, "--api", "0"});
  EXPECT_EQ(r.exit, 1);
  EXPECT_NE(r.err.find(bad + ":1:"), std::string::npos) << r.err;
  r = run({"sim", "--bind", "127.0.0.1:70000", "--api", "0"});
  EXPECT_EQ(r.exit, 1);
  EXPECT_NE(r.err.find("not a port number"), std::string::npos) << r.err;
  std::filesystem::remove(bad);
}

// The TOML chooses the firmware's pinout; a second 7I77
// needs Mesa's two-7I77 one.
TEST(Cli, SimConfigChoosesThePinout) {
  const auto bad = tempPath("pinout.toml");
  std::ofstream(bad) << "[card]\npinout = \"7I77x3\"\n";
  auto r = run({"sim", "--config", bad, "--api", "0"});
  EXPECT_EQ(r.exit, 1);
  EXPECT_NE(r.err.find(bad + ":2:10: card.pinout: \"7I77x3\" is not one of \"7I77x2\", \"7I77+GPIO\""), std::string::npos)
      << r.err;
  std::ofstream(bad) << "[card]\npinout = \"7I77+GPIO\"\n[[daughtercard]]\ntype = \"7I77\"\n[[daughtercard]]\ntype = \"7I77D\"\n";
  r = run({"sim", "--config", bad, "--api", "0"});
  EXPECT_EQ(r.exit, 1);
  EXPECT_NE(r.err.find(bad + ":6:8: daughtercard[1].type: the 7I77+GPIO pinout has GPIO on the second connector"),
            std::string::npos)
      << r.err;
  std::filesystem::remove(bad);
}

// `--script FILE` is a fault script of its own: [[fault]] entries and
// nothing else, checked like --config's, so a scenario file cannot carry a
// card that the user's --config does not have.
TEST(Cli, SimScriptHoldsFaultEntriesOnly) {
  const auto bad = tempPath("script.toml");
  std::ofstream(bad) << "[card]\npinout = \"7I77x2\"\n";
  auto r = run({"sim", "--script", bad, "--bind", "127.0.0.1:0", "--no-api"});
  EXPECT_EQ(r.exit, 1);
  EXPECT_NE(r.err.find(bad + ":"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("card: unknown key (known here: fault)"), std::string::npos) << r.err;
  std::ofstream(bad) << "[[fault]]\nat = 1\nfault = \"lightning\"\n";
  r = run({"sim", "--script", bad, "--bind", "127.0.0.1:0", "--no-api"});
  EXPECT_EQ(r.exit, 1);
  EXPECT_NE(r.err.find(bad + ":3:9: fault[0].fault"), std::string::npos) << r.err;
  std::filesystem::remove(bad);
  // Every scenario shipped in examples/scenarios/ is such a file.
  int scenarios = 0;
  for (const auto& e : std::filesystem::directory_iterator(std::string(LBPKIT_EXAMPLES_DIR) + "/scenarios")) {
    if (e.path().extension() != ".toml") continue;
    ++scenarios;
    EXPECT_FALSE(config::loadFaultScript(e.path().string(), true).empty()) << e.path();
  }
  EXPECT_GE(scenarios, 5);
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

// --- Data loss and security ----------------------------------------------

std::string fileText(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
}

// Starts lbpkit with regular files limited to `bytes` (SIGXFSZ ignored, so a
// write past it fails with EFBIG): a state file that stops taking writes,
// like a full disk, even for root.
std::unique_ptr<Daemon> daemonWithFileLimit(const std::vector<std::string>& args, rlim_t bytes) {
  rlimit old{};
  ::getrlimit(RLIMIT_FSIZE, &old);
  rlimit small = old;
  small.rlim_cur = bytes;
  auto* oldHandler = ::signal(SIGXFSZ, SIG_IGN);
  ::setrlimit(RLIMIT_FSIZE, &small);
  auto d = std::make_unique<Daemon>(args, true);  // its greeting on descriptor 3 (--ready-fd 3)
  ::setrlimit(RLIMIT_FSIZE, &old);
  ::signal(SIGXFSZ, oldHandler);
  return d;
}

// --state never writes over what is not an lbpkit EEPROM image.
TEST(Cli, SimRefusesAStateFileThatIsNotAnEepromImage) {
  const auto toml = tempPath("state.toml");
  const std::string text = "[[daughtercard]]\ntype = \"7I77\"\n";
  { std::ofstream(toml) << text; }
  auto r = run({"sim", "--bind", "127.0.0.1:0", "--api", "0", "--state", toml}, std::chrono::seconds(10));
  EXPECT_EQ(r.exit, 1);
  EXPECT_NE(r.err.find(toml + ": is not an lbpkit EEPROM image (" + std::to_string(text.size()) +
                       " bytes of something else); refusing to overwrite it"),
            std::string::npos)
      << r.err;
  EXPECT_EQ(fileText(toml), text);

  const auto link = tempPath("state.link");
  std::filesystem::create_symlink(toml, link);
  r = run({"sim", "--bind", "127.0.0.1:0", "--api", "0", "--state", link}, std::chrono::seconds(10));
  EXPECT_EQ(r.exit, 1);
  EXPECT_NE(r.err.find(link + ": is a symbolic link; lbpkit will not follow it"), std::string::npos) << r.err;
  EXPECT_EQ(fileText(toml), text);

  const auto fifo = tempPath("state.fifo");
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  r = run({"sim", "--bind", "127.0.0.1:0", "--api", "0", "--state", fifo}, std::chrono::seconds(10));
  EXPECT_EQ(r.exit, 1) << "a FIFO as --state hung the start";
  EXPECT_NE(r.err.find(fifo + ": is a FIFO"), std::string::npos) << r.err;

  const auto dir = tempPath("state.dir");
  r = run({"sim", "--bind", "127.0.0.1:0", "--api", "0", "--state", dir + "/sub/eeprom"}, std::chrono::seconds(10));
  EXPECT_EQ(r.exit, 1);
  EXPECT_NE(r.err.find("directory " + dir + "/sub does not exist"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir));
  std::filesystem::remove_all(dir);
  for (const auto& p : {toml, link, fifo}) {
    std::filesystem::remove(p);
    std::filesystem::remove(p + ".analog");  // none, unless a sim started after all
  }
}

// A write the EEPROM did not keep is an error, not "written to the EEPROM".
TEST(Cli, WpdFailsWhenTheEepromCannotSaveTheValue) {
  auto w = run({"wpd", "NVWATCHDOGTIME", "100", "--state", "/dev/full"});
  EXPECT_EQ(w.exit, 1) << w.out;
  EXPECT_EQ(w.out.find("written to the EEPROM"), std::string::npos) << w.out;
  EXPECT_NE(w.err.find("EEPROM"), std::string::npos) << w.err;
}

TEST(Cli, WpdToASimThatCannotSaveTheValueFails) {
  const auto state = tempPath("full");
  // Room for the factory image in the first slot, none for a second write.
  const auto limit = remote::NvStore(remote::memory::kEepromSize).slotBytes();
  auto d = daemonWithFileLimit({"sim", "--bind", "127.0.0.1:0", "--api", "0", "--state", state, "--ready-fd", "3"},
                               limit);
  const auto where = test_support::lbp16Address(*d);
  ASSERT_FALSE(where.empty());
  auto w = run({"wpd", "NVWATCHDOGTIME", "100", "--addr", where});
  EXPECT_EQ(w.exit, 1) << w.out;
  EXPECT_EQ(w.out.find("written to the EEPROM"), std::string::npos) << w.out;
  EXPECT_NE(w.err.find("EEPROM"), std::string::npos) << w.err;
  EXPECT_EQ(trim(run({"rpd", "NVWATCHDOGTIME", "--addr", where}).out), "50");
  EXPECT_EQ(d->stop(), 0);
  test_support::removeStateFiles(state);
}

TEST(Cli, WpdOverSerialFailsWhenTheRemoteCannotSaveTheValue) {
  const auto state = tempPath("fullpty");
  const auto limit = remote::NvStore(remote::memory::kEepromSize).slotBytes();
  auto d = daemonWithFileLimit({"remote", "--pty", "--setup", "--state", state}, limit);
  const auto pty = d->value("serial device: ");
  ASSERT_FALSE(pty.empty());
  auto w = run({"wpd", "NVWATCHDOGTIME", "100", "--serial", pty});
  EXPECT_EQ(w.exit, 1) << w.out;
  EXPECT_NE(w.err.find("EEPROM"), std::string::npos) << w.err;
  EXPECT_EQ(trim(run({"rpd", "NVWATCHDOGTIME", "--serial", pty}).out), "50");
  EXPECT_EQ(d->stop(), 0);
  test_support::removeStateFiles(state);
}

// Two sims on one EEPROM file would lose each other's writes.
TEST(Cli, ASecondSimOnTheSameStateFileIsRefused) {
  const auto state = tempPath("shared");
  Daemon first({"sim", "--bind", "127.0.0.1:0", "--api", "0", "--state", state, "--ready-fd", "3"}, true);
  ASSERT_FALSE(test_support::lbp16Address(first).empty());
  auto r = run({"sim", "--bind", "127.0.0.1:0", "--api", "0", "--state", state}, std::chrono::seconds(10));
  EXPECT_EQ(r.exit, 1);
  EXPECT_NE(r.err.find(state + ": in use by another lbpkit"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("lbpkit sim on 127.0.0.1:0"), std::string::npos) << r.err;  // who holds it
  EXPECT_EQ(first.stop(), 0);
  test_support::removeStateFiles(state);
}

TEST(Cli, SimsSideBySideEachHaveTheirOwnDefaultStateFile) {
  const auto home = tempPath("xdg");
  std::filesystem::create_directory(home);
  const char* old = std::getenv("XDG_STATE_HOME");
  const std::string saved = old ? old : "";
  ::setenv("XDG_STATE_HOME", home.c_str(), 1);
  Daemon a({"sim", "--bind", "127.0.0.1:0", "--api", "0", "--ready-fd", "3"}, true);
  Daemon b({"sim", "--bind", "127.0.0.2:0", "--api", "0", "--ready-fd", "3"}, true);
  if (old) ::setenv("XDG_STATE_HOME", saved.c_str(), 1);
  else ::unsetenv("XDG_STATE_HOME");
  const auto fileA = test_support::greeting(a)["cards"][0].value("state", "");
  const auto fileB = test_support::greeting(b)["cards"][0].value("state", "");
  EXPECT_EQ(fileA, home + "/lbpkit/7i77-127.0.0.1-0.eeprom");
  EXPECT_EQ(fileB, home + "/lbpkit/7i77-127.0.0.2-0.eeprom");
  EXPECT_EQ(a.stop(), 0);
  EXPECT_EQ(b.stop(), 0);
  std::filesystem::remove_all(home);
}

// --serial talks only to a terminal, never into a file.
TEST(Cli, SerialRefusesWhatIsNotATerminal) {
  const auto file = tempPath("notatty");
  { std::ofstream{file}; }
  auto r = run({"wpd", "WATCHDOGTIME", "0", "--serial", file});
  EXPECT_EQ(r.exit, 1);
  EXPECT_NE(r.err.find(file + ": is a regular file, not a serial device"), std::string::npos) << r.err;
  EXPECT_EQ(std::filesystem::file_size(file), 0U);  // no LBP bytes written into it
  r = run({"rpd", "FAULT", "--serial", "/dev/null"});
  EXPECT_EQ(r.exit, 1);
  EXPECT_NE(r.err.find("/dev/null: is not a serial device"), std::string::npos) << r.err;
  std::filesystem::remove(file);
}

TEST(Cli, MonitorRefusesRatesItCannotRun) {
  auto r = run({"monitor", "--rate", "1e9"}, std::chrono::seconds(10));
  EXPECT_NE(r.exit, 0);
  EXPECT_NE(r.err.find("--rate"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("1 to 20000 Hz"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("10 kHz"), std::string::npos) << r.err;  // and why
  EXPECT_EQ(r.out.find("lbpkit monitor:"), std::string::npos) << "it ran: " << r.out;
  r = run({"monitor", "--rate", "fast"}, std::chrono::seconds(10));
  EXPECT_NE(r.exit, 0);
  EXPECT_NE(r.err.find("--rate"), std::string::npos) << r.err;
  r = run({"monitor", "--display", "0"}, std::chrono::seconds(10));
  EXPECT_NE(r.exit, 0);
  EXPECT_NE(r.err.find("--display"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("0.1 to 100"), std::string::npos) << r.err;
  r = run({"monitor", "--frames", "-1"}, std::chrono::seconds(10));
  EXPECT_NE(r.exit, 0);
  EXPECT_NE(r.err.find("--frames"), std::string::npos) << r.err;
  r = run({"monitor", "--reply-timeout", "0"}, std::chrono::seconds(10));
  EXPECT_NE(r.exit, 0);
  EXPECT_NE(r.err.find("--reply-timeout"), std::string::npos) << r.err;
}

// A frame here is four seconds of wall clock (and 80 000 cycles): SIGTERM,
// sent just after a frame, must not wait for the next one. Three seconds
// leave an ASan build's exit on a loaded machine its time and still tell a
// monitor that waits for the frame's end.
TEST(Cli, MonitorStopsPromptlyOnSigterm) {
  int outFd = -1, errFd = -1;
  const pid_t pid = test_support::spawn({"monitor", "--sim", "--plain", "--rate", "20000", "--display", "0.25"},
                                           outFd, errFd);
  // Whatever happens below, no monitor is left behind.
  struct Reaper {
    pid_t pid;
    int out, err;
    ~Reaper() {
      if (pid > 0) {
        ::kill(pid, SIGKILL);
        ::waitpid(pid, nullptr, 0);
      }
      ::close(out);
      ::close(err);
    }
  } reaper{pid, outFd, errFd};
  std::string out;
  test_support::readUntil(outFd, out, "encoders:", std::chrono::seconds(30));
  ASSERT_NE(out.find("encoders:"), std::string::npos) << "no first frame: " << out;
  EXPECT_NE(out.find("0 lost replies"), std::string::npos) << out;
  EXPECT_NE(out.find("link: 0 cycles lost a reply"), std::string::npos) << out;

  const auto stopAt = std::chrono::steady_clock::now();
  ASSERT_EQ(::kill(pid, SIGTERM), 0);
  int status = 0;
  pid_t done = 0;
  while ((done = ::waitpid(pid, &status, WNOHANG)) == 0 &&
         std::chrono::steady_clock::now() - stopAt < std::chrono::seconds(10))
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  const auto took = std::chrono::steady_clock::now() - stopAt;
  ASSERT_EQ(done, pid) << "still running 10 s after SIGTERM";
  reaper.pid = -1;
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << "status " << status;
  EXPECT_LT(took, std::chrono::milliseconds(3000))
      << std::chrono::duration_cast<std::chrono::milliseconds>(took).count() << " ms";
}

// Every mistake in a configuration file is an error naming file, line and
// key: nothing is ignored or silently replaced by a default.
TEST(Cli, SimConfigurationMistakesNameFileLineAndKey) {
  const auto path = tempPath("mistakes.toml");
  const auto state = tempPath("mistakes.eeprom");
  struct Case {
    std::string line;
    std::string expected;
  };
  const Case cases[] = {
      {"feild_voltage = 24.0", ":3:17: daughtercard[0].feild_voltage: unknown key; did you mean field_voltage?"},
      {"field_voltage = nan", ":3:17: daughtercard[0].field_voltage: nan is out of range: 0 to 36 V"},
      {"field_voltage = inf", ":3:17: daughtercard[0].field_voltage: inf is out of range: 0 to 36 V"},
      {"field_voltage = -5", ":3:17: daughtercard[0].field_voltage: -5 is out of range: 0 to 36 V"},
      {"field_voltage = \"24\"", ":3:17: daughtercard[0].field_voltage: expected a number (V), not a string"},
      {"field_io_unit = 0x112000AEE",
       ":3:17: daughtercard[0].field_io_unit: 0x112000AEE is out of range: 0x12000000 to 0x12FFFFFF"},
      {"w12_setup = 1", ":3:13: daughtercard[0].w12_setup: expected true or false, not an integer"},
  };
  for (const auto& c : cases) {
    std::ofstream(path) << "[[daughtercard]]\ntype = \"7I77\"\n" << c.line << "\n";
    const auto r = run({"sim", "--config", path, "--bind", "127.0.0.1:0", "--no-api", "--state", state},
                       std::chrono::seconds(10));
    EXPECT_EQ(r.exit, 1) << c.line;
    EXPECT_NE(r.err.find(path + c.expected), std::string::npos) << c.line << "\n" << r.err;
  }
  const auto dir = tempPath("config.dir");
  std::filesystem::create_directories(dir);
  const auto r = run({"sim", "--config", dir, "--bind", "127.0.0.1:0", "--no-api", "--state", state},
                     std::chrono::seconds(10));
  EXPECT_EQ(r.exit, 1);
  EXPECT_NE(r.err.find(dir + ": is not a regular file"), std::string::npos) << r.err;
  std::filesystem::remove(dir);
  std::filesystem::remove(path);
  test_support::removeStateFiles(state);
}

}  // namespace
