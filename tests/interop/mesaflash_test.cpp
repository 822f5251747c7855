// SPDX-License-Identifier: MIT
// Mesa's mesaflash (Debian's package, installed by scripts/test) against
// `lbpkit sim`: it reads every card of the catalogue, writes and verifies
// the configuration flash, lists both 7I77 remotes' modes. Each test starts
// its own virtual card and stops it.
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

#include "support/interop.hpp"
#include "support/temp_dir.hpp"

namespace interop {
namespace {

using namespace std::chrono_literals;

TEST(Mesaflash, ReadsTheVirtualCard) {
  if (!test_support::haveClientProgram("mesaflash")) GTEST_SKIP() << "mesaflash is not installed (scripts/test installs it)";
  Sim sim(loopback());
  ASSERT_TRUE(sim.up());
  const std::string card = "timeout 30 " + onCardCpu() + test_support::inLinuxCncRoot() + "mesaflash --device 7i92 --addr " + loopback();
  auto r = sh(card + " --readhmid");
  ASSERT_EQ(r.exit, 0) << r.out;
  EXPECT_NE(r.out.find("BoardName : MESA7I92"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("Module: SSerial"), std::string::npos);
  EXPECT_NE(r.out.find("Module: MuxedQCount"), std::string::npos);
  EXPECT_NE(r.out.find("TXData0"), std::string::npos);   // IO5 SS0TX
  EXPECT_NE(r.out.find("MuxSel0"), std::string::npos);   // IO7 ENCMUX
  EXPECT_NE(r.out.find("MuxQ-IDX"), std::string::npos);  // IO10 QCMUXI01
  r = sh(card + " --sserial");
  ASSERT_EQ(r.exit, 0) << r.out;
  EXPECT_NE(r.out.find("channel 0: 7I77 GPIO (unit 0x12000AEE)"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("channel 1: 7I77 ANALOG (unit 0x11000AEE)"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("NVWatchDogTimeout = 50ms"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("channel 2:"), std::string::npos) << "nothing on TB6: " << r.out;
  EXPECT_EQ(sh(card + " --rpo 0x100").out, "55AACAFE\n");
  sh(card + " --wpo 0x1400=0x5");  // IOPort output invert: a plain register
  EXPECT_EQ(sh(card + " --rpo 0x1400").out, "00000005\n");
  r = sh(card + " --verbose");
  EXPECT_NE(r.out.find("7I92"), std::string::npos) << r.out;
  EXPECT_EQ(sim.stop(), 0);
}

// A file of this process's own, in a folder that goes when the process
// ends, however a test ended.
std::string scratch(const std::string& name) {
  static const test_support::TempDir folder("lbpkit-mesaflash");
  return folder / name;
}

// A Xilinx .bit file (header fields a..e, then the data) with made-up data.
std::string fakeBitfile() {
  const auto path = scratch("fake.bit");
  std::ofstream f(path, std::ios::binary);
  const unsigned char magic[] = {0x00, 0x09, 0x0f, 0xf0, 0x0f, 0xf0, 0x0f, 0xf0, 0x0f, 0xf0, 0x00, 0x00, 0x01};
  f.write(reinterpret_cast<const char*>(magic), sizeof magic);
  auto field = [&](char tag, const std::string& text) {
    f.put(tag);
    f.put(static_cast<char>((text.size() + 1) >> 8));
    f.put(static_cast<char>(text.size() + 1));
    f.write(text.c_str(), static_cast<std::streamsize>(text.size() + 1));
  };
  field('a', "lbpkit_test.ncd");
  field('b', "6slx9tqg144");
  field('c', "2026/11/21");
  field('d', "12:00:00");
  const std::uint32_t n = 40000;
  f.put('e');
  for (int shift = 24; shift >= 0; shift -= 8) f.put(static_cast<char>(n >> shift));
  std::uint32_t x = 1;
  for (std::uint32_t i = 0; i < n; ++i) f.put(static_cast<char>((x = x * 1664525U + 1013904223U) >> 24));
  return path;
}

TEST(Mesaflash, WritesAndVerifiesTheVirtualFlash) {
  if (!test_support::haveClientProgram("mesaflash")) GTEST_SKIP() << "mesaflash is not installed (scripts/test installs it)";
  Sim sim(loopback());
  ASSERT_TRUE(sim.up());
  const auto bit = fakeBitfile();
  const std::string card = "timeout 120 " + onCardCpu() + test_support::inLinuxCncRoot() + "mesaflash --device 7i92 --addr " + loopback();
  auto r = sh(card + " --verify " + bit);  // a blank part has no boot block
  EXPECT_NE(r.out.find("BootSector is invalid"), std::string::npos) << r.out;
  r = sh(card + " --write " + bit + " --fix-boot-block");
  EXPECT_EQ(r.exit, 0) << r.out;
  EXPECT_NE(r.out.find("verified successfully"), std::string::npos) << r.out;
  r = sh(card + " --verify " + bit);
  EXPECT_EQ(r.exit, 0) << r.out;
  EXPECT_NE(r.out.find("Boot sector OK"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("verified successfully"), std::string::npos) << r.out;
  std::filesystem::remove(bit);
}

// mesaflash --sserial --verbose collects every software mode record of each
// remote's GTOC and walks each one (mesaflash: sserial_module.c): both 7I77
// processors list all their modes there, whatever the current one. Its
// verbose parameter list shows UNSIGNED parameters whose unit reads "None".
TEST(Mesaflash, ShowsEverySoftwareModeOfBothRemotes) {
  if (!test_support::haveClientProgram("mesaflash")) GTEST_SKIP() << "mesaflash is not installed (scripts/test installs it)";
  Sim sim(loopback());
  ASSERT_TRUE(sim.up());
  const auto r = sh("timeout 60 " + onCardCpu() + test_support::inLinuxCncRoot() + "mesaflash --device 7i92 --addr " + loopback() + " --sserial --verbose");
  ASSERT_EQ(r.exit, 0) << r.out;
  const auto field = r.out.find("channel 0: 7I77 GPIO");
  const auto analog = r.out.find("channel 1: 7I77 ANALOG");
  ASSERT_NE(field, std::string::npos) << r.out;
  ASSERT_NE(analog, std::string::npos) << r.out;
  ASSERT_LT(field, analog) << r.out;
  const std::string fieldPart = r.out.substr(field, analog - field);
  const std::string analogPart = r.out.substr(analog);
  for (const char* mode : {"SOFTWARE MODE IO [index 00]", "SOFTWARE MODE IO+AnalogIn [index 01]",
                           "SOFTWARE MODE IO+AnalogIn+FieldVoltage [index 02]",
                           "SOFTWARE MODE IO+AnalogIn+FieldVoltage+MPG [index 03]"})
    EXPECT_NE(fieldPart.find(mode), std::string::npos) << mode << "\n" << r.out;
  EXPECT_NE(analogPart.find("SOFTWARE MODE Analog [index 00]"), std::string::npos) << r.out;
  EXPECT_EQ(analogPart.find("[index 01]"), std::string::npos) << r.out;
  EXPECT_NE(fieldPart.find("UnitNumber = 12000AEE [32 bits UNSIGNED IO | UNIT: None"), std::string::npos) << r.out;
  EXPECT_NE(analogPart.find("UnitNumber = 11000AEE"), std::string::npos) << r.out;
  EXPECT_NE(fieldPart.find("NVEncMode0 [8 bits NV UNSIGNED IN | UNIT: None"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("HwRevision"), std::string::npos) << "no sibling reports one: " << r.out;
  // The SSLBP local space above 0x200 (sserialwa.vhd: the
  // interface clock at 0x230..0x233, the channel count at 0x234).
  EXPECT_NE(r.out.find("SSLBP Clock: 100 MHz"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("SSLBP Channels: 6"), std::string::npos) << r.out;
  EXPECT_EQ(sim.stop(), 0);
}

// What mesaflash --write programmed is in the flash file
// next to the EEPROM, and a sim started again on the same state verifies.
TEST(Mesaflash, TheFlashIsKeptAcrossRestarts) {
  if (!test_support::haveClientProgram("mesaflash")) GTEST_SKIP() << "mesaflash is not installed (scripts/test installs it)";
  const auto state = (std::filesystem::temp_directory_path() / ("lbpkit-interop-flash-" + std::to_string(::getpid()))).string();
  auto clean = [&] {
    test_support::removeStateFiles(state);
  };
  clean();
  auto start = [&] {
    auto d = std::make_unique<Daemon>(std::vector<std::string>{"sim", "--bind", loopback(), "--no-api", "--state", state});
    d->readUntil("point LinuxCNC at it");
    return d;
  };
  const auto bit = fakeBitfile();
  const std::string card = "timeout 120 " + onCardCpu() + test_support::inLinuxCncRoot() + "mesaflash --device 7i92 --addr " + loopback();
  auto first = start();
  auto r = sh(card + " --write " + bit + " --fix-boot-block");
  EXPECT_EQ(r.exit, 0) << r.out;
  EXPECT_NE(r.out.find("verified successfully"), std::string::npos) << r.out;
  EXPECT_EQ(first->stop(), 0);
  EXPECT_TRUE(std::filesystem::exists(state + ".flash"));
  EXPECT_FALSE(std::filesystem::exists(state + ".flash.tmp"));
  auto second = start();
  r = sh(card + " --verify " + bit);
  EXPECT_EQ(r.exit, 0) << r.out;
  EXPECT_NE(r.out.find("Boot sector OK"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("verified successfully"), std::string::npos) << r.out;
  EXPECT_EQ(second->stop(), 0);
  std::filesystem::remove(bit);
  clean();
}

// Every card of the catalogue as mesaflash reads it (its
// board-name table decides --device): the IDROM's name, ports, the
// firmware's modules and pins.
TEST(Mesaflash, ReadsEveryCardOfTheCatalogue) {
  if (!test_support::haveClientProgram("mesaflash")) GTEST_SKIP() << "mesaflash is not installed (scripts/test installs it)";
  struct Case {
    std::string card, device;
    std::vector<std::string> lines;  // each must appear in --readhmid
    std::vector<std::string> absent;
  };
  const std::vector<Case> cases = {
      {"7I92T", "7i92t",
       {"BoardName : MESA7I92", "FPGA Size: 20 KGates", "FPGA Pins: 256", "Number of IO Ports: 2",
        "Module: DPLL", "Module: StepGen", "There are 5 of StepGen in configuration",
        "There are 8 of MuxedQCount in configuration", "Module: SSerial", "Step/Table1", "Dir/Table2", "TXData3",
        "RXData4", "MuxSel0"},
       {"Module: PWM"}},
      {"7I96S", "7i96s",
       {"BoardName : MESA7I96", "FPGA Size: 20 KGates", "Number of IO Ports: 3", "Width of one I/O port: 17",
        "Clock Low frequency: 100.0000 MHz", "Clock High frequency: 200.0000 MHz", "Module: DPLL",
        "There are 5 of StepGen in configuration", "Module: PWM", "There are 8 of MuxedQCount in configuration",
        "Step/Table1", "TXEn3", "TXData0", "MuxSel0", "IO Connections for P1"},
       {"Module: QCount"}},
      {"7I80HD-25", "7i80hd-25",
       {"BoardName : MESA7I80", "FPGA Size: 25 KGates", "Number of IO Ports: 3", "Width of one I/O port: 24",
        "There are 6 of MuxedQCount in configuration", "Module: SSerial", "TXData0", "MuxQ-IDX"},
       {"Module: StepGen", "Module: DPLL"}},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.card);
    Sim sim(loopback(), {"--card", c.card});
    ASSERT_TRUE(sim.up());
    EXPECT_EQ(sim.get()["card"]["name"], c.card);
    const std::string card = "timeout 30 " + onCardCpu() + test_support::inLinuxCncRoot() + "mesaflash --device " + c.device + " --addr " + loopback();
    auto r = sh(card + " --readhmid");
    ASSERT_EQ(r.exit, 0) << r.out;
    for (const auto& line : c.lines) EXPECT_NE(r.out.find(line), std::string::npos) << line << "\n" << r.out;
    for (const auto& line : c.absent) EXPECT_EQ(r.out.find(line), std::string::npos) << line << "\n" << r.out;
    // The 7I96S's TB3 inputs (its InM module): mesaflash 3.4.9 names each
    // by the encoder input it can also be (Input0_EncA0 .. Input7_EncB3:
    // the InM entry of the pin-name table in mesaflash's hostmot2.c); 3.4.6
    // (Debian 12) named them Input0 .. Input7.
    if (c.card == "7I96S") {
      const bool encoderNames = test_support::releaseOf("mesaflash").atLeast(3, 4, 9);
      EXPECT_NE(r.out.find(encoderNames ? "InM              0        Input0_EncA0    (In)"
                                        : "InM              0        Input0          (In)"),
                std::string::npos)
          << r.out;
    }
    // The 7I77 wherever the firmware puts it: both processors on channels 0 and 1.
    r = sh(card + " --sserial");
    ASSERT_EQ(r.exit, 0) << r.out;
    EXPECT_NE(r.out.find("channel 0: 7I77 GPIO (unit 0x12000AEE)"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("channel 1: 7I77 ANALOG (unit 0x11000AEE)"), std::string::npos) << r.out;
    // Another card's name is not this one: mesaflash finds no 7I92 here.
    EXPECT_EQ(sh("timeout 30 " + onCardCpu() + test_support::inLinuxCncRoot() + "mesaflash --device 7i92 --addr " + loopback() + " --readhmid").out.find("MESA"),
              std::string::npos);
    EXPECT_EQ(sim.stop(), 0);
  }
}

// An Efinix .bin as mesaflash's bitfile.c reads one: text lines, the 7th
// naming the part after a blank, then (made-up) data.
std::string fakeEfinixBin() {
  const auto path = scratch("fake.bin");
  std::ofstream f(path, std::ios::binary);
  f << "Version: lbpkit\nDate: 2026-12-02\nMode: active\nWidth: 4\nFamily: Trion\nFPGA: T20\n"
    << "Device: T20F256\nProject: lbpkit_test\nPadded: yes\nEnd: 1\n";
  std::uint32_t x = 7;
  for (int i = 0; i < 70000; ++i) f.put(static_cast<char>((x = x * 1664525U + 1013904223U) >> 24));
  return path;
}

// Each card's LBP16 face as mesaflash --verbose prints it (its
// name in the board-info space and the EEPROM, its flash), where mesaflash
// programs it (the user area of a 16 Mbit part: 0x100000; an Efinix card
// without the Xilinx boot block) and that --reload reloads its FPGA the way
// its family does (Xilinx ICAP IPROG, Efinix configuration register): the
// modules come back at power-up.
TEST(Mesaflash, EachCardAnswersWithItsOwnLbp16DetailsAndReloads) {
  if (!test_support::haveClientProgram("mesaflash")) GTEST_SKIP() << "mesaflash is not installed (scripts/test installs it)";
  struct Case {
    std::string card, device, part;
    bool efinix;
  };
  const std::vector<Case> cases = {{"7I92", "7i92", "6slx9tqg144", false},
                                   {"7I92T", "7i92t", "T20F256", true},
                                   {"7I96S", "7i96s", "T20F256", true},
                                   {"7I80HD-25", "7i80hd-25", "6slx25ftg256", false}};
  const auto bin = fakeEfinixBin();
  for (const auto& c : cases) {
    SCOPED_TRACE(c.card);
    Sim sim(loopback(), {"--card", c.card});
    ASSERT_TRUE(sim.up());
    const std::string card = "timeout 120 " + onCardCpu() + test_support::inLinuxCncRoot() + "mesaflash --device " + c.device + " --addr " + loopback();
    auto r = sh(card + " --verbose");
    ASSERT_EQ(r.exit, 0) << r.out;
    for (const auto& line : {"ETH device " + c.card + " at ip=", "    board name: " + c.card + "\n  " + "  user leds",
                             "[space 7] LBP16 info:\n    board name: " + c.card + "\n", "FPGA type: " + c.part,
                             std::string("flash size: 16Mb (id: 0x164014)"),
                             std::string("3: FPGAFlsh (flash, RW, 32-bit) [size=2M], page size: 256, erase size: 65536"),
                             std::string("LBP16 protocol version 3")})
      EXPECT_NE(r.out.find(line), std::string::npos) << line << "\n" << r.out;
    if (c.efinix) {
      r = sh(card + " --write " + bin);
      EXPECT_EQ(r.exit, 0) << r.out;
      EXPECT_NE(r.out.find("File type: Efinix bin file"), std::string::npos) << r.out;
      EXPECT_NE(r.out.find("sectors starting from 0x100000"), std::string::npos) << r.out;
      EXPECT_EQ(r.out.find("Boot"), std::string::npos) << "no boot block on an Efinix card: " << r.out;
      r = sh(card + " --verify " + bin);
      EXPECT_EQ(r.exit, 0) << r.out;
      EXPECT_NE(r.out.find("verified successfully"), std::string::npos) << r.out;
    }
    // A register the FPGA's reload puts back to power-up: IOPort output invert.
    r = sh(card + " --wpo 0x1400=0x5");
    ASSERT_EQ(r.exit, 0) << r.out;
    ASSERT_EQ(sh(card + " --rpo 0x1400").out, "00000005\n");
    r = sh(card + " --reload");
    EXPECT_EQ(r.exit, 0) << r.out;
    EXPECT_TRUE(waitFor([&] { return sh(card + " --rpo 0x1400").out == "00000000\n"; }, 3000ms))
        << sh(card + " --rpo 0x1400").out;
    EXPECT_EQ(sh(card + " --rpo 0x100").out, "55AACAFE\n");  // and answers again
    EXPECT_EQ(sim.stop(), 0);
  }
  std::filesystem::remove(bin);
}

}  // namespace
}  // namespace interop
