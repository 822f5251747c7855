// SPDX-License-Identifier: MIT
// LinuxCNC's own tool for a smart-serial remote's firmware and parameters,
// setsserial (Debian's linuxcnc-uspace: setsserial(9)), through hm2_eth
// against `lbpkit sim` with the 7I77's field I/O processor in setup mode
// (W12), as the manual wants for a firmware update: `flash` programs the
// processor's flash (docs/protocol-facts.md#the-program-flash), which then
// runs the new image after a power cycle; `set` writes a non-volatile
// parameter.
#include <unistd.h>

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "remote/gtoc_parameters.hpp"
#include "remote/program_flash.hpp"
#include "support/interop.hpp"
#include "support/remote_image.hpp"
#include "support/temp_dir.hpp"

namespace interop {
namespace {

using namespace std::chrono_literals;

class Setsserial : public LinuxCnc {
 protected:
  void SetUp() override {
    LinuxCnc::SetUp();
    if (IsSkipped() || HasFatalFailure()) return;
    std::filesystem::create_directories(firmware_.parent_path());
    for (const bool setup : {true, false})
      std::ofstream(setup ? setupConfig_ : operateConfig_)
          << "[card]\nname = \"7I92\"\n[[daughtercard]]\ntype = \"7I77\"\nw12_setup = " << (setup ? "true" : "false")
          << "\n";
  }
  void TearDown() override {
    card_.reset();
    LinuxCnc::TearDown();
    std::filesystem::remove(firmware_);
  }
  // The sim on the test's state (the EEPROM and the program flash beside
  // it), the field I/O processor's W12 in setup mode or not, on the wall
  // clock: setsserial runs no servo thread.
  bool startCard(bool setup) {
    card_.reset();
    const auto& config = setup ? setupConfig_ : operateConfig_;
    card_ = std::make_unique<test_support::SimChild>(test_support::SimOptions{
        cardIp_, -1, "127.0.0.1", false, state_.string(), withCardCpu({"--config", config.string()})});
    return card_->up();
  }
  // hostmot2 (at setup mode's 115.2 kBaud for a flash, as setsserial
  // demands), hm2_eth, then setsserial with `command`, and LinuxCNC
  // stopped: halcmd's output with rtapi_app's, where setsserial prints (its
  // standard output reaches the file when it exits, so the stop is part of
  // the same command). Standard output (rtapi_print: setsserial's progress)
  // and error (its verdict) go to files of their own: rtapi_app flushes the
  // first in blocks, and a line of the second would land inside one.
  struct Run {
    int exit = -1;
    std::string out, err;
  };
  Run setsserial(const std::string& command, bool setupBaud) {
    const auto file = fifo_ + ".hal";
    std::ofstream(file) << (setupBaud ? "loadrt hostmot2 sserial_baudrate=115200\n" : "loadrt hostmot2\n")
                        << "loadrt hm2_eth board_ip=" << cardIp_ << " config=\"num_encoders=6 sserial_port_0=0xxxxx\"\n"
                        // hm2_eth's wait for each reply, as the other tests give it
                        // (support/interop.hpp: patientDeadlines), before setsserial's
                        // thousands of reads.
                        << "setp hm2_7i92.0.packet-read-timeout 20000000\n"
                        << "loadrt setsserial cmd=\"" << command << "\"\n";
    const auto errors = fifo_ + ".err";
    const auto r = hal("sh -c 'halcmd -f " + file + " 2>" + errors + "; status=$?; halrun -U 2>>" + errors +
                       "; exit $status'");
    std::ifstream in(errors);
    Run run{r.exit, r.out, std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>())};
    std::filesystem::remove(file);
    std::filesystem::remove(errors);
    return run;
  }
  test_support::TempDir dir_{"lbpkit-setsserial"};
  std::filesystem::path setupConfig_ = dir_.path() / "setup.toml";
  std::filesystem::path operateConfig_ = dir_.path() / "operate.toml";
  std::filesystem::path state_ = dir_.path() / "7i77.eeprom";
  // Where setsserial's request_firmware looks (/lib/firmware, the
  // release's own when the test runs one: support/linuxcnc_release.hpp),
  // under a name of this test's own.
  std::filesystem::path firmware_ =
      test_support::linuxCncRoot() + "/lib/firmware/lbpkit-test-" + std::to_string(::getpid()) + ".BIN";
  // W12 back to operate mode and the power cycled (the sim started again
  // on the same files): the processor boots the flash's image and reports
  // its software revision, `hex`.
  void expectRunningRevision(const std::string& hex) {
    ASSERT_TRUE(startCard(false));
    const auto rev = test_support::run({"rpd", "swrevision", "H", "--addr", cardIp_});
    EXPECT_EQ(rev.exit, 0) << rev.err;
    EXPECT_NE(rev.out.find(hex), std::string::npos) << rev.out;
  }
  std::unique_ptr<test_support::SimChild> card_;
};

// setsserial's own lines, as a figure of what it printed.
void printSetsserialLines(const std::string& out, const std::string& err) {
  std::istringstream in(out + err);
  for (std::string line; std::getline(in, line);)
    if (line.find("Size =") != std::string::npos || line.find("block") != std::string::npos ||
        line.find("Firmware") != std::string::npos || line.find("Synch") != std::string::npos)
      std::printf("setsserial: %s\n", line.c_str());
}

TEST_F(Setsserial, FlashProgramsTheFieldIoProcessorWhichRunsItAfterAPowerCycle) {
  if (!std::filesystem::is_directory("/lib/firmware")) GTEST_SKIP() << "no /lib/firmware";
  test_support::writeRemoteImage(firmware_, 3000, 0x2A);
  ASSERT_TRUE(startCard(true));
  const auto r = setsserial("flash hm2_7i92.0.7i77.0.0 " + firmware_.filename().string(), true);
  printSetsserialLines(r.out, r.err);
  EXPECT_EQ(r.exit, 0);
  // Whose lateness a failed flash was: the sim's slowest answer (a card
  // thread held back past the 7I77's 50 ms watchdog breaks an update in
  // flight, where a real card is never late) and the links' errors.
  if (r.err.find("Firmware Flash Success") == std::string::npos)
    std::printf("the sim: %s\nits links: %s\n", card_->get()["server"].dump().c_str(),
                card_->get("/api/link").dump().c_str());
  // What setsserial prints on real hardware: the geometry the remote
  // reports, each block erased and written (block 0, the boot block, never),
  // and success.
  EXPECT_NE(r.out.find("Write Size = 40, Erase Size = 200"), std::string::npos) << r.out;
  for (int block = 1; block <= 6; ++block) {
    EXPECT_NE(r.out.find("Erased block " + std::to_string(block) + "\n"), std::string::npos) << block << r.out;
    EXPECT_NE(r.out.find("Wrote block " + std::to_string(block) + "\n"), std::string::npos) << block << r.out;
  }
  EXPECT_EQ(r.out.find("block 0\n"), std::string::npos) << r.out;
  EXPECT_NE(r.err.find("Firmware Flash Success"), std::string::npos) << r.err;
  expectRunningRevision("2A");
}

// The sim killed in the middle of an update (the power cut while a block
// is erased or written), then the update run again: the remote works and
// runs the new image, whenever the cut came (the flash file keeps every
// block as it was before or after the commit in progress).
TEST_F(Setsserial, AnUpdateCutByKillingTheSimThenRepeatedEndsWithAWorkingRemote) {
  if (!std::filesystem::is_directory("/lib/firmware")) GTEST_SKIP() << "no /lib/firmware";
  test_support::writeRemoteImage(firmware_, 16000, 0x33);
  ASSERT_TRUE(startCard(true));
  const std::string command = "flash hm2_7i92.0.7i77.0.0 " + firmware_.filename().string();
  Run cut;
  std::thread update([&] { cut = setsserial(command, true); });
  std::this_thread::sleep_for(700ms);
  card_->stop(SIGKILL);
  update.join();
  printSetsserialLines(cut.out, cut.err);
  ASSERT_TRUE(startCard(true));
  const auto again = setsserial(command, true);
  printSetsserialLines(again.out, again.err);
  EXPECT_NE(again.err.find("Firmware Flash Success"), std::string::npos) << again.err;
  expectRunningRevision("33");
}

// `set` needs the parameter list hostmot2 reads in operate mode (in setup
// mode it reads none), and puts the channel in setup mode itself.
TEST_F(Setsserial, SetWritesANonVolatileParameter) {
  ASSERT_TRUE(startCard(false));
  // setsserial finds the parameter by its name as the remote reports it.
  const auto r = setsserial("set hm2_7i92.0.7i77.0.0.nvwatchdogtimeout 120", false);
  EXPECT_NE(r.err.find("Parameter setting success"), std::string::npos) << r.err;
  const auto nv = test_support::run({"rpd", "nvwatchdogtimeout", "--addr", cardIp_});
  EXPECT_EQ(nv.exit, 0) << nv.err;
  EXPECT_NE(nv.out.find("120"), std::string::npos) << nv.out;
}

}  // namespace
}  // namespace interop
