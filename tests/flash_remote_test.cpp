// `lbpkit flash-remote`: a 7I77 processor's firmware updated over the
// network through SSLBP in setup mode, each block read back, and the new
// image running after a power cycle; refused where a real remote refuses.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "remote/gtoc_parameters.hpp"
#include "remote/program_flash.hpp"
#include "support/process.hpp"
#include "support/remote_image.hpp"
#include "support/sim_child.hpp"
#include "support/temp_dir.hpp"

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

}  // namespace
