// SPDX-License-Identifier: MIT
// A 7I77 processor's program flash over LBP, driven with exactly the
// accesses LinuxCNC's setsserial makes to update its firmware
// (docs/protocol-facts.md#the-program-flash), and read back through the
// page buffer.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <vector>

#include "remote/field_io.hpp"
#include "remote/program_flash.hpp"
#include "support/lbp_host.hpp"
#include "support/remote_image.hpp"
#include "support/temp_dir.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace remote = lbpkit::model::remote;
namespace lbp = lbpkit::model::lbp;

namespace {

using remote::FieldIoProcessor;
using remote::ProgramFlash;
using testing_lbp::Bytes;
using testing_lbp::Host;
namespace flash = lbp::flash;

FieldIoProcessor::Options setupMode(const std::filesystem::path& nvFile = {}) {
  FieldIoProcessor::Options o;
  o.setupMode = true;  // W12
  o.nvFile = nvFile;
  return o;
}

bool invalidWrite(remote::RemoteDevice& d) { return (d.lbpStatus() & lbp::status::kInvalidWrite) != 0; }

// setsserial's sslbp_flash: block 0 skipped, all-zero blocks skipped, each
// other block erased and written page by page in 8-byte writes, the cookie
// read after each commit. `blocks`: stop after erasing this many (an update
// cut short between an erase and its writes).
void flashLikeSetsserial(Host& h, std::span<const std::uint8_t> file, std::size_t blocks = SIZE_MAX) {
  ASSERT_TRUE(h.setLocal(lbp::local_write::kNonVolatile, lbp::nonvolatile::kFlash));
  const std::size_t writeSize = std::size_t{1} << h.read(flash::kWriteSize, 1);
  const std::size_t eraseSize = std::size_t{1} << h.read(flash::kEraseSize, 1);
  ASSERT_TRUE(h.setLocal(lbp::local_write::kNonVolatile, lbp::nonvolatile::kNone));
  for (std::size_t block = 1; block * eraseSize < file.size(); ++block) {
    const std::size_t start = block * eraseSize;
    bool zero = true;
    for (std::size_t t = 0; t < eraseSize; ++t) zero = zero && file[start + t] == 0;
    if (zero) continue;
    ASSERT_TRUE(h.setLocal(lbp::local_write::kNonVolatile, lbp::nonvolatile::kFlash));
    ASSERT_TRUE(h.write(flash::kOffset, 4, start));
    ASSERT_TRUE(h.write(flash::kCommit, 1, flash::kErase));
    ASSERT_EQ(h.local(lbp::local_read::kCookie), lbp::kCookie);
    ASSERT_TRUE(h.setLocal(lbp::local_write::kNonVolatile, lbp::nonvolatile::kNone));
    if (--blocks == 0) return;
    ASSERT_TRUE(h.setLocal(lbp::local_write::kNonVolatile, lbp::nonvolatile::kFlash));
    for (std::size_t i = 0; i < eraseSize; i += writeSize) {
      ASSERT_TRUE(h.write(flash::kOffset, 4, start + i));
      for (std::size_t j = 0; j < writeSize; j += 8) {
        std::uint64_t v = 0;
        for (std::size_t k = 0; k < 8; ++k) v |= std::uint64_t{file[start + i + j + k]} << (8 * k);
        ASSERT_TRUE(h.write(static_cast<std::uint16_t>(j), 8, v));
      }
      ASSERT_TRUE(h.write(flash::kCommit, 1, flash::kWrite));
      ASSERT_EQ(h.local(lbp::local_read::kCookie), lbp::kCookie);
    }
    ASSERT_TRUE(h.setLocal(lbp::local_write::kNonVolatile, lbp::nonvolatile::kNone));
  }
}

// The flash read back page by page: offset, then the page buffer's addresses.
std::vector<std::uint8_t> readBack(Host& h) {
  std::vector<std::uint8_t> out;
  EXPECT_TRUE(h.setLocal(lbp::local_write::kNonVolatile, lbp::nonvolatile::kFlash));
  for (std::size_t at = 0; at < ProgramFlash::kSize; at += ProgramFlash::kWriteBytes) {
    EXPECT_TRUE(h.write(flash::kOffset, 4, at));
    for (std::size_t j = 0; j < ProgramFlash::kWriteBytes; j += 8) {
      const std::uint64_t v = h.read(static_cast<std::uint16_t>(j), 8);
      for (std::size_t k = 0; k < 8; ++k) out.push_back(static_cast<std::uint8_t>(v >> (8 * k)));
    }
  }
  EXPECT_TRUE(h.setLocal(lbp::local_write::kNonVolatile, lbp::nonvolatile::kNone));
  return out;
}

void powerCycle(FieldIoProcessor& io, Host& h) {
  io.setFieldVoltage(0.0, h.now);
  io.setFieldVoltage(24.0, h.now);
}

TEST(ProgramFlash, OperateModeRefusesFlashAccess) {
  FieldIoProcessor io;  // W12 left: operate mode
  Host h(io);
  EXPECT_EQ(h.local(lbp::local_read::kCapability) & lbp::capability::kFlash, lbp::capability::kFlash);
  ASSERT_TRUE(h.setLocal(lbp::local_write::kNonVolatile, lbp::nonvolatile::kFlash));
  EXPECT_TRUE(invalidWrite(io));
  EXPECT_EQ(h.local(lbp::local_read::kNonVolatile), lbp::nonvolatile::kNone);
  // The low addresses stay the protected RPC table.
  ASSERT_TRUE(h.setLocal(lbp::local_write::kStatus, 0));
  h.write(0, 8, 0x1122334455667788ULL);
  EXPECT_TRUE(invalidWrite(io));
}

TEST(ProgramFlash, SetsserialsUpdateIsKeptAndReadsBackAsTheFile) {
  test_support::TempDir dir("lbpkit-flash");
  const auto eeprom = dir.path() / "7i77.eeprom";
  const auto file = ProgramFlash::image("7I77", remote::kFieldIoProcessor, 0x2A, test_support::remoteProgram(3000, 7));
  {
    FieldIoProcessor io(setupMode(eeprom));
    Host h(io);
    EXPECT_EQ(h.local(lbp::local_read::kSwRevision), io.identity().swRevision);  // the factory program
    ASSERT_TRUE(h.setLocal(lbp::local_write::kNonVolatile, lbp::nonvolatile::kFlash));
    EXPECT_EQ(h.read(flash::kWriteSize, 1), ProgramFlash::kWriteLog2);
    EXPECT_EQ(h.read(flash::kEraseSize, 1), ProgramFlash::kEraseLog2);
    ASSERT_TRUE(h.setLocal(lbp::local_write::kNonVolatile, lbp::nonvolatile::kNone));
    flashLikeSetsserial(h, file);
    EXPECT_EQ(io.lbpStatus() & lbp::status::kInvalidWrite, 0);
    // 3016 bytes after block 0: blocks 1..6, each erased and written in 8 pages.
    EXPECT_EQ(io.programFlash().erases(), 6U);
    EXPECT_EQ(io.programFlash().pageWrites(), 48U);
    const auto back = readBack(h);
    ASSERT_EQ(back.size(), ProgramFlash::kSize);
    ASSERT_EQ(file.size(), 7 * ProgramFlash::kEraseBytes);
    EXPECT_TRUE(std::equal(file.begin() + ProgramFlash::kEraseBytes, file.end(), back.begin() + ProgramFlash::kEraseBytes));
    // Still the old program until it boots again.
    EXPECT_EQ(h.local(lbp::local_read::kSwRevision), io.identity().swRevision);
    powerCycle(io, h);
    EXPECT_TRUE(io.programRuns());
    EXPECT_EQ(h.local(lbp::local_read::kSwRevision), 0x2A);
    EXPECT_EQ(h.read(io.address(io.standard(remote::Standard::SwRevision)), 1), 0x2AU);
  }
  // The flash file keeps it: a processor started on the same files runs it.
  FieldIoProcessor again(setupMode(eeprom));
  EXPECT_TRUE(again.programRuns());
  EXPECT_EQ(again.softwareRevision(), 0x2A);
}

TEST(ProgramFlash, AnUpdateCutShortLeavesTheBootBlockAndASecondUpdateRestoresIt) {
  FieldIoProcessor io(setupMode());
  Host h(io);
  const auto file = ProgramFlash::image("7I77", remote::kFieldIoProcessor, 0x31, test_support::remoteProgram(5000, 3));
  flashLikeSetsserial(h, file, 1);  // block 1 erased, never written: the header is gone
  powerCycle(io, h);
  EXPECT_FALSE(io.programRuns());
  // The boot block answers LBP but has no process data to start.
  EXPECT_EQ(h.local(lbp::local_read::kCookie), lbp::kCookie);
  EXPECT_FALSE(h.transact({lbp::special_rpc::kDiscovery}, 6).has_value());
  // It still takes a whole update, and then runs it.
  flashLikeSetsserial(h, file);
  powerCycle(io, h);
  EXPECT_TRUE(io.programRuns());
  EXPECT_EQ(h.local(lbp::local_read::kSwRevision), 0x31);
  EXPECT_TRUE(h.transact({lbp::special_rpc::kDiscovery}, 6).has_value());
}

TEST(ProgramFlash, APowerUpWithoutAValidProgramSaysSoNamingTheFile) {
  test_support::TempDir dir("lbpkit-flash");
  const auto eeprom = dir.path() / "7i77.eeprom";
  std::vector<remote::NvEvent> events;
  auto o = setupMode(eeprom);
  o.nvReport = [&](const remote::NvEvent& e) { events.push_back(e); };
  auto noProgram = [&] {
    return std::count_if(events.begin(), events.end(),
                         [](const remote::NvEvent& e) { return e.kind == remote::NvEvent::Kind::NoProgram; });
  };
  FieldIoProcessor io(o);
  Host h(io);
  EXPECT_EQ(noProgram(), 0);  // the factory program
  const auto file = ProgramFlash::image("7I77", remote::kFieldIoProcessor, 0x33, test_support::remoteProgram(5000, 4));
  flashLikeSetsserial(h, file, 3);  // cut after block 3's erase
  powerCycle(io, h);
  ASSERT_FALSE(io.programRuns());
  ASSERT_EQ(noProgram(), 1);
  const auto& said = events.back().message;
  EXPECT_NE(said.find("the 7I77 field I/O processor's program in " + eeprom.string() + ".program is not valid"),
            std::string::npos)
      << said;
  EXPECT_NE(said.find("boot block"), std::string::npos) << said;
  EXPECT_NE(said.find("lbpkit flash-remote"), std::string::npos) << said;
  // The boot block takes the whole image again; the next power-up is quiet.
  flashLikeSetsserial(h, file);
  powerCycle(io, h);
  EXPECT_TRUE(io.programRuns());
  EXPECT_EQ(noProgram(), 1);
}

TEST(ProgramFlash, APowerCutDuringACommitLeavesTheFlashAsBeforeOrAfterIt) {
  test_support::TempDir dir("lbpkit-flash");
  const auto eeprom = dir.path() / "7i77.eeprom";
  const auto file = ProgramFlash::image("7I77", remote::kFieldIoProcessor, 0x34, test_support::remoteProgram(900, 5));
  std::vector<std::uint8_t> before;
  {
    FieldIoProcessor io(setupMode(eeprom));
    Host h(io);
    flashLikeSetsserial(h, file);
    before.assign(io.programFlash().contents().begin(), io.programFlash().contents().end());
  }
  const std::size_t slot = [&] {
    FieldIoProcessor io(setupMode(eeprom));
    return io.programFlash().store().slotBytes();
  }();
  for (const std::size_t cut : {std::size_t{0}, std::size_t{1}, slot / 2, slot - 1}) {
    {
      FieldIoProcessor io(setupMode(eeprom));
      Host h(io);
      ASSERT_TRUE(io.programRuns());
      // Power goes mid-way through the erase of block 1 (the header's).
      io.programFlash().store().cutPowerAfter(cut);
      ASSERT_TRUE(h.setLocal(lbp::local_write::kNonVolatile, lbp::nonvolatile::kFlash));
      ASSERT_TRUE(h.setLocal(lbp::local_write::kStatus, 0));
      ASSERT_TRUE(h.write(flash::kOffset, 4, ProgramFlash::kEraseBytes));
      h.write(flash::kCommit, 1, flash::kErase);
      EXPECT_TRUE(invalidWrite(io)) << cut;
    }
    FieldIoProcessor again(setupMode(eeprom));
    EXPECT_TRUE(again.programRuns()) << cut;
    EXPECT_TRUE(std::equal(before.begin(), before.end(), again.programFlash().contents().begin())) << cut;
  }
}

TEST(ProgramFlash, AnImageForAnotherProcessorOrCardDoesNotRun) {
  for (const auto& file : {ProgramFlash::image("7I77", remote::kAnalogProcessor, 0x10, test_support::remoteProgram(700, 1)),
                           ProgramFlash::image("7I76", remote::kFieldIoProcessor, 0x10, test_support::remoteProgram(700, 1))}) {
    FieldIoProcessor io(setupMode());
    Host h(io);
    flashLikeSetsserial(h, file);
    powerCycle(io, h);
    EXPECT_FALSE(io.programRuns());
  }
}

TEST(ProgramFlash, TheBootBlockUnalignedAndOutOfRangeCommitsAreRefused) {
  FieldIoProcessor io(setupMode());
  Host h(io);
  ASSERT_TRUE(h.setLocal(lbp::local_write::kNonVolatile, lbp::nonvolatile::kFlash));
  for (const std::uint32_t offset : {0U, 0x10U, static_cast<std::uint32_t>(ProgramFlash::kSize)}) {
    ASSERT_TRUE(h.setLocal(lbp::local_write::kStatus, 0));
    ASSERT_TRUE(h.write(flash::kOffset, 4, offset));
    h.write(flash::kCommit, 1, flash::kErase);
    EXPECT_TRUE(invalidWrite(io)) << offset;
  }
  ASSERT_TRUE(h.setLocal(lbp::local_write::kStatus, 0));
  ASSERT_TRUE(h.write(flash::kOffset, 4, ProgramFlash::kEraseBytes));
  h.write(flash::kCommit, 1, 0x42);  // neither erase nor write
  EXPECT_TRUE(invalidWrite(io));
  EXPECT_EQ(io.programFlash().erases(), 0U);
  const auto factory = ProgramFlash::image("7I77", remote::kFieldIoProcessor, io.identity().swRevision, {});
  EXPECT_TRUE(std::equal(factory.begin(), factory.end(), io.programFlash().contents().begin()));
}

}  // namespace

