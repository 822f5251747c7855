// SPDX-License-Identifier: MIT
// `lbpkit flash-remote`: a 7I77 processor's firmware updated over the
// network through SSLBP in setup mode, each block read back, and the new
// image running after a power cycle; refused where a real remote refuses.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <stdexcept>
#include <string>
#include <vector>

#include "lbpkit/error.hpp"
#include "lbpkit/hostmot2.hpp"
#include "lbpkit/remote_flash.hpp"
#include "lbpkit/sserial.hpp"
#include "lbpkit/wire/seven_i77.hpp"
#include "remote/gtoc_parameters.hpp"
#include "remote/program_flash.hpp"
#include "sim_card/sim_transport.hpp"
#include "support/process.hpp"
#include "support/remote_image.hpp"
#include "support/sim_child.hpp"
#include "support/temp_dir.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace hm2 = lbpkit::model::hm2;
namespace remote = lbpkit::model::remote;

namespace {

using namespace std::chrono_literals;

std::string loopback(int n) { return "127.94." + std::to_string(::getpid() % 250) + "." + std::to_string(n); }

struct Files {
  test_support::TempDir dir{"lbpkit-flash-remote"};
  std::filesystem::path setup = dir.path() / "setup.toml";
  std::filesystem::path operate = dir.path() / "operate.toml";
  std::filesystem::path state = dir.path() / "7i77.eeprom";
  std::filesystem::path image = dir.path() / "7I77.BIN";
  Files() {
    for (const bool w12 : {true, false})
      std::ofstream(w12 ? setup : operate) << "[card]\nname = \"7I92\"\n[[daughtercard]]\ntype = \"7I77\"\nw12_setup = "
                                           << (w12 ? "true" : "false") << "\n";
    test_support::writeRemoteImage(image, 2500, 0x3C);
  }
  test_support::SimOptions sim(const std::string& address, bool w12) const {
    return {address, 0, {}, true, state.string(), {"--config", (w12 ? setup : operate).string()}};
  }
};

std::string at(const test_support::SimChild& sim) { return sim.address() + ":" + std::to_string(sim.udpPort()); }

std::vector<char> bytesOf(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// The in-process card with its first 7I77 in setup mode (W12, W4) on
// `state`: a power-up of both processors on those files.
hm2::HostMot2Card::Options setupCard(const std::filesystem::path& state) {
  hm2::HostMot2Card::Options o;
  o.first.fieldIo.setupMode = true;
  o.first.fieldIo.nvFile = state;
  o.first.analog.setupMode = true;
  o.first.analog.nvFile = state.string() + ".analog";
  return o;
}

// lbpkit flash-remote's steps through the library: channel 0 at 115200
// baud, setup START, the update. `stopAfter`: the host goes away once this
// block is written.
void flashInProcess(lbpkit::SimTransport& t, std::span<const std::uint8_t> image, std::size_t stopAfter = SIZE_MAX) {
  const auto info = lbpkit::readCardInfo(t);
  lbpkit::SmartSerial::Options options;
  options.channelMask = 0x01;
  lbpkit::SmartSerial ss(t, info, options);
  ss.setBaudRate(0, lbpkit::wire::i7i77::kSetupBaud);
  ss.stopAll();
  ASSERT_EQ(ss.start(0x01, true), 0);
  auto remote = ss.remote(0);
  lbpkit::flashRemote(*remote, image, true, [&](const lbpkit::FlashProgress& p) {
    if (p.step == lbpkit::FlashProgress::Step::Written && p.block == stopAfter) throw std::runtime_error("host gone");
  });
}

TEST(FlashRemote, UpdatesTheFieldIoProcessorInSetupModeAndReadsItBack) {
  Files f;
  {
    test_support::SimChild sim(f.sim(loopback(1), true));
    ASSERT_TRUE(sim.up());
    const auto r = test_support::run({"flash-remote", f.image.string(), "--addr", at(sim)});
    ASSERT_EQ(r.exit, 0) << r.err;
    // 2500 bytes of program after the boot block and the header: blocks 1..5.
    EXPECT_NE(r.out.find("flash of 512-byte blocks in 64-byte pages"), std::string::npos) << r.out;
    for (int block = 1; block <= 5; ++block) {
      EXPECT_NE(r.out.find("block " + std::to_string(block) + "/5 written"), std::string::npos) << r.out;
      EXPECT_NE(r.out.find("block " + std::to_string(block) + "/5 verified"), std::string::npos) << r.out;
    }
    EXPECT_NE(r.out.find("5 blocks written and read back as the file"), std::string::npos) << r.out;
  }
  // W12 back and the power cycled: the new image runs.
  test_support::SimChild sim(f.sim(loopback(1), false));
  ASSERT_TRUE(sim.up());
  const auto rev = test_support::run({"rpd", "swrevision", "H", "--addr", at(sim)});
  EXPECT_EQ(rev.exit, 0) << rev.err;
  EXPECT_NE(rev.out.find("3C"), std::string::npos) << rev.out;
}

TEST(FlashRemote, AProcessorInOperateModeOrAMissingFileIsRefusedByName) {
  Files f;
  test_support::SimChild sim(f.sim(loopback(2), false));
  ASSERT_TRUE(sim.up());
  // At 115200 baud nothing answers a processor in operate mode...
  auto r = test_support::run({"flash-remote", f.image.string(), "--addr", at(sim)});
  EXPECT_NE(r.exit, 0);
  EXPECT_NE(r.err.find("setup START failed at 115200 baud: is the remote in setup mode, W12 or W4?"),
            std::string::npos)
      << r.err;
  r = test_support::run({"flash-remote", (f.dir.path() / "none.BIN").string(), "--addr", at(sim)});
  EXPECT_NE(r.exit, 0);
  EXPECT_NE(r.err.find("none.BIN: cannot read it"), std::string::npos) << r.err;
  // ... and its firmware is as it was.
  const auto rev = test_support::run({"rpd", "swrevision", "H", "--addr", at(sim)});
  EXPECT_EQ(rev.exit, 0) << rev.err;
  EXPECT_EQ(rev.out.find("3C"), std::string::npos) << rev.out;
}

TEST(FlashRemote, TheLibraryUpdatesAProcessorWhoseUpdateWasCut) {
  test_support::TempDir dir("lbpkit-flash-remote");
  const auto state = dir.path() / "7i77.eeprom";
  const auto image =
      remote::ProgramFlash::image("7I77", remote::kFieldIoProcessor, 0x4B, test_support::remoteProgram(6000, 0x4B));
  {
    lbpkit::SimTransport t(setupCard(state));
    EXPECT_THROW(flashInProcess(t, image, 3), std::runtime_error);
  }
  {
    // Power-up on the cut flash: the boot block alone, which SETUP START
    // finds without its special RPCs, and which takes the whole image.
    lbpkit::SimTransport t(setupCard(state));
    ASSERT_FALSE(t.card().daughtercard(0).fieldIo.programRuns());
    flashInProcess(t, image);
  }
  lbpkit::SimTransport t(setupCard(state));
  EXPECT_TRUE(t.card().daughtercard(0).fieldIo.programRuns());
  EXPECT_EQ(t.card().daughtercard(0).fieldIo.softwareRevision(), 0x4B);
}

TEST(FlashRemote, TheLibraryRefusesAnImageLargerThanTheFlashBeforeAnyErase) {
  test_support::TempDir dir("lbpkit-flash-remote");
  lbpkit::SimTransport t(setupCard(dir.path() / "7i77.eeprom"));
  std::vector<std::uint8_t> image(lbpkit::wire::i7i77::kProgramFlashBytes + 1, 0x5A);
  try {
    flashInProcess(t, image);
    FAIL() << "an image larger than the flash was taken";
  } catch (const lbpkit::Error& e) {
    EXPECT_NE(std::string(e.what()).find("an image of 32769 bytes is larger than the 32768-byte (32 KiB) program "
                                         "flash: nothing was erased"),
              std::string::npos)
        << e.what();
  }
  EXPECT_EQ(t.card().daughtercard(0).fieldIo.programFlash().erases(), 0U);
  EXPECT_EQ(t.card().daughtercard(0).fieldIo.programFlash().pageWrites(), 0U);
}

TEST(FlashRemote, AnUpdateCutByKillingTheSimIsToldAtPowerUpAndTheNextUpdateTakes) {
  Files f;
  const auto image = f.dir.path() / "7I77-30K.BIN";
  test_support::writeRemoteImage(image, 30000, 0x5D);  // blocks 1..59
  const auto address = loopback(3);
  {
    test_support::SimChild sim(f.sim(address, true));
    ASSERT_TRUE(sim.up());
    int out = -1, err = -1;
    const pid_t flash = test_support::spawn({"flash-remote", image.string(), "--addr", at(sim)}, out, err);
    std::string said, failed;
    test_support::readUntil(out, said, "block 4/59 written", 60s);
    const bool started = said.find("block 4/59 written") != std::string::npos;
    sim.stop(SIGKILL);  // power gone in the middle of the update
    test_support::readUntil(err, failed, "lbpkit: ", 60s);
    int status = 0;
    ::waitpid(flash, &status, 0);
    ::close(out);
    ::close(err);
    ASSERT_TRUE(started) << said << failed;
    EXPECT_FALSE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << said << failed;
    EXPECT_EQ(said.find("blocks written"), std::string::npos) << said;
  }
  {
    // The next power-up: the sim says which processor holds no valid program
    // and where, and a new update in setup mode takes.
    test_support::SimChild sim(f.sim(address, true));
    ASSERT_TRUE(sim.up());
    const std::string warned = sim.daemon().readErrUntil("is not valid");
    EXPECT_NE(warned.find("lbpkit sim: warning: channel 0: the 7I77 field I/O processor's program in " +
                          f.state.string() + ".program is not valid (an update was cut?): it stays in its boot block"),
              std::string::npos)
        << warned;
    EXPECT_NE(warned.find("lbpkit flash-remote puts a new image in it"), std::string::npos) << warned;
    const auto r = test_support::run({"flash-remote", image.string(), "--addr", at(sim)});
    ASSERT_EQ(r.exit, 0) << r.out << r.err;
    EXPECT_NE(r.out.find("59 blocks written and read back as the file"), std::string::npos) << r.out;
  }
  // W12 back and the power cycled: the new program runs and is discovered.
  test_support::SimChild sim(f.sim(address, false));
  ASSERT_TRUE(sim.up());
  const auto d = test_support::run({"discover", "--addr", at(sim)});
  EXPECT_EQ(d.exit, 0) << d.out << d.err;
  EXPECT_NE(d.out.find("field I/O"), std::string::npos) << d.out;
  const auto rev = test_support::run({"rpd", "swrevision", "H", "--addr", at(sim)});
  EXPECT_EQ(rev.exit, 0) << rev.err;
  EXPECT_NE(rev.out.find("5D"), std::string::npos) << rev.out;
}

TEST(FlashRemote, AnImageLargerThanTheFlashOrNotARegularFileIsRefusedBeforeAnyErase) {
  Files f;
  test_support::SimChild sim(f.sim(loopback(4), true));
  ASSERT_TRUE(sim.up());
  ASSERT_EQ(test_support::run({"flash-remote", f.image.string(), "--addr", at(sim)}).exit, 0);
  const auto program = f.state.string() + ".program";
  const auto flashed = bytesOf(program);
  ASSERT_FALSE(flashed.empty());
  // A good image with more after it, and a sparse 64 MiB file.
  const auto big = f.dir.path() / "40K.BIN";
  const auto huge = f.dir.path() / "64M.BIN";
  test_support::writeRemoteImage(big, 8000, 0x61);
  test_support::writeRemoteImage(huge, 8000, 0x61);
  std::filesystem::resize_file(big, 40 * 1024);
  std::filesystem::resize_file(huge, 64 * 1024 * 1024);
  for (const auto& [file, bytes] : {std::pair{big, "40960"}, {huge, "67108864"}}) {
    const auto r = test_support::run({"flash-remote", file.string(), "--addr", at(sim)});
    EXPECT_NE(r.exit, 0);
    EXPECT_NE(r.err.find(file.string() + ": " + bytes +
                         " bytes, larger than the 7I77 processor's 32768-byte (32 KiB) program flash"),
              std::string::npos)
        << r.err;
    EXPECT_NE(r.err.find("nothing was erased"), std::string::npos) << r.err;
    EXPECT_EQ(r.out.find("block"), std::string::npos) << r.out;
  }
  // A FIFO no one writes (not waited on), a folder, a device.
  const auto fifo = f.dir.path() / "fifo.BIN";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  for (const auto& [file, kind] : {std::pair{fifo.string(), "a FIFO"}, {f.dir.path().string(), "a folder"},
                                   {std::string("/dev/zero"), "a character device"}}) {
    const auto r = test_support::run({"flash-remote", file, "--addr", at(sim)}, 30s);
    EXPECT_NE(r.exit, 0) << file;
    EXPECT_NE(r.err.find(file + ": is " + kind + ", not a firmware image file"), std::string::npos) << r.err;
  }
  EXPECT_EQ(bytesOf(program), flashed);
}

}  // namespace
