// SPDX-License-Identifier: MIT
// The field I/O processor's numbered behaviours (manual: FIELD I/O).
#include <gtest/gtest.h>

#include <filesystem>
#include <vector>

#include "support/lbp_host.hpp"
#include "support/temp_dir.hpp"
#include "remote/field_io.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace remote = lbpkit::model::remote;
namespace lbp = lbpkit::model::lbp;

namespace {

using remote::FieldIoProcessor;
using testing_lbp::Bytes;
using testing_lbp::Host;
namespace fault = remote::fault;
using namespace std::chrono_literals;

// What SSLBP does at START (firmware sequence): clear status, set the mode,
// discovery, one zero-output transfer, clear faults.
void start(Host& h, std::uint8_t mode = 0) {
  ASSERT_TRUE(h.setLocal(lbp::local_write::kStatus, 0));
  ASSERT_TRUE(h.setLocal(lbp::local_write::kRemoteSwMode, mode));
  ASSERT_TRUE(h.transact({lbp::special_rpc::kDiscovery}, 6).has_value());
  h.processData(Bytes(h.dev.discovery().txSize, 0));
  ASSERT_TRUE(h.setLocal(lbp::local_write::kClearFault, 0xFF));
  EXPECT_EQ(h.local(lbp::local_read::kClearFault), 0);
  EXPECT_EQ(h.local(lbp::local_read::kFaultStatus), 0);
}

// W1 right: VIN from its own 12 V supply, so field supply faults show.
FieldIoProcessor::Options separateVin() {
  FieldIoProcessor::Options o;
  o.vinFromField = false;
  o.vin = 12.0;
  return o;
}

std::uint32_t inputsOf(const Bytes& reply) {
  return std::uint32_t{reply.at(1)} | (std::uint32_t{reply.at(2)} << 8) | (std::uint32_t{reply.at(3)} << 16) |
         (std::uint32_t{reply.at(4)} << 24);
}

TEST(FieldIo, StartsWithAWatchdogFaultAndNoOutputs) {
  FieldIoProcessor io;
  EXPECT_EQ(io.faults(), fault::kWatchdog);
  EXPECT_TRUE(io.faultLed());
  Host h(io);
  auto r = h.processData({0xFF, 0xFF});
  EXPECT_EQ(r.at(0), fault::kWatchdog);
  EXPECT_EQ(io.outputs(), 0);  // outputs cannot be set while faulted
  start(h);
  h.processData({0xFF, 0xFF});
  EXPECT_EQ(io.outputs(), 0xFFFF);
  EXPECT_FALSE(io.faultLed());
}

TEST(FieldIo, OutputsReachTheTerminalsSourcingAndSinking) {
  for (auto type : {remote::OutputType::Sourcing, remote::OutputType::Sinking}) {
    FieldIoProcessor::Options o;
    o.outputs = type;
    FieldIoProcessor io(o);
    Host h(io);
    start(h);
    h.processData({0x05, 0x80});  // outputs 0, 2 and 15
    EXPECT_EQ(io.outputs(), 0x8005);
    const bool sourcing = type == remote::OutputType::Sourcing;
    EXPECT_DOUBLE_EQ(io.outputVoltage(0), sourcing ? 24.0 : 0.0);
    EXPECT_DOUBLE_EQ(io.outputVoltage(1), sourcing ? 0.0 : 24.0);
    EXPECT_DOUBLE_EQ(io.outputVoltage(15), sourcing ? 24.0 : 0.0);
  }
}

TEST(FieldIo, InputThresholdsAreSixtyAndFortyPercentWithHysteresis) {
  FieldIoProcessor io;  // 24 V field: on at 14.4 V, off at 9.6 V
  Host h(io);
  start(h);
  auto in0 = [&]() { return inputsOf(h.processData({0, 0})) & 1U; };
  io.setInputVoltage(0, 14.3);
  EXPECT_EQ(in0(), 0U);
  io.setInputVoltage(0, 14.4);
  EXPECT_EQ(in0(), 1U);
  io.setInputVoltage(0, 9.7);  // inside the hysteresis band: stays on
  EXPECT_EQ(in0(), 1U);
  io.setInputVoltage(0, 9.6);
  EXPECT_EQ(in0(), 0U);
  io.setInputVoltage(0, 12.0);  // inside the band from below: stays off
  EXPECT_EQ(in0(), 0U);
  // Thresholds follow the field voltage: at 12 V, 7.2 V is on.
  io.setFieldVoltage(12.0, h.now);
  io.setInputVoltage(31, 7.2);
  EXPECT_EQ(inputsOf(h.processData({0, 0})) >> 31, 1U);
}

TEST(FieldIo, AnalogModesReportEightBitReadingsAt36_3VoltsFullScale) {
  EXPECT_EQ(FieldIoProcessor::analogReading(0.0), 0);
  EXPECT_EQ(FieldIoProcessor::analogReading(36.3), 255);
  EXPECT_EQ(FieldIoProcessor::analogReading(50.0), 255);
  EXPECT_EQ(FieldIoProcessor::analogReading(18.15), 128);
  FieldIoProcessor io;
  Host h(io);
  start(h, 2);
  io.setInputVoltage(0, 10.0);
  io.setInputVoltage(3, 36.3);
  const auto r = h.processData({0, 0});
  ASSERT_EQ(r.size(), 10U);
  EXPECT_EQ(r[5], FieldIoProcessor::analogReading(10.0));
  EXPECT_EQ(r[8], 255);
  EXPECT_EQ(r[9], FieldIoProcessor::analogReading(24.0));  // field voltage
}

// MPG INPUTS: mode 3 counts two MPGs on inputs 16..19, A and B as
// pncconf's 7I77 mode-3 table assigns them (input 16 MPG 0 B, 17 MPG 0 A,
// 18 MPG 1 B, 19 MPG 1 A), 1X by default.
TEST(FieldIo, Mode3CountsTwoMpgsOnInputs16To19At1X) {
  FieldIoProcessor io;
  Host h(io);
  start(h, 3);
  // 5 V encoder signals: the 2.5 V threshold applies, not 60 % of 24 V.
  auto step = [&](unsigned first, unsigned second, int cycles) {
    const double hi = 5.0;
    for (int i = 0; i < cycles; ++i) {  // `first` leads
      io.setInputVoltage(first, hi);
      io.setInputVoltage(second, hi);
      io.setInputVoltage(first, 0);
      io.setInputVoltage(second, 0);
    }
  };
  step(17, 16, 10);  // A leads B on MPG 0: up
  step(18, 19, 3);   // B leads A on MPG 1: down
  const auto r = h.processData({0, 0});
  ASSERT_EQ(r.size(), 12U);
  EXPECT_EQ(r[10], 10);                      // 1X: one count per cycle
  EXPECT_EQ(r[11], static_cast<std::uint8_t>(-3));
  EXPECT_EQ(inputsOf(r) & (1U << 16), 0U);
}

TEST(FieldIo, Mode3MpgAIsInput17And19AndNVEncModeSetsTheCountMode) {
  FieldIoProcessor io;  // its EEPROM in memory, kept across a power cycle
  Host h(io);
  start(h, 3);
  // Pulses on A alone (B low): 1X counts each rising edge of A, up.
  for (int i = 0; i < 4; ++i) {
    io.setInputVoltage(17, 5.0);
    io.setInputVoltage(17, 0.0);
    io.setInputVoltage(19, 5.0);
    io.setInputVoltage(19, 0.0);
  }
  auto r = h.processData({0, 0});
  EXPECT_EQ(r[10], 4);
  EXPECT_EQ(r[11], 4);
  // Pulses on B alone count nothing at 1X.
  io.setInputVoltage(16, 5.0);
  io.setInputVoltage(16, 0.0);
  EXPECT_EQ(h.processData({0, 0})[10], 4);
  // NVEncMode0 = 2 (4X), read at the next power-up (NON-VOLATILE FIELD I/O PARAMETERS).
  std::uint16_t nv = 0;
  for (std::size_t id = 0; id < io.elementCount(); ++id)
    if (io.descriptor(static_cast<remote::ElementId>(id)).name == "NVEncMode0")
      nv = io.address(static_cast<remote::ElementId>(id));
  ASSERT_NE(nv, 0);
  ASSERT_TRUE(h.setLocal(lbp::local_write::kNonVolatile, lbp::nonvolatile::kEeprom));
  ASSERT_TRUE(h.write(nv, 1, 2));
  ASSERT_TRUE(h.setLocal(lbp::local_write::kNonVolatile, lbp::nonvolatile::kNone));
  io.powerCycle(h.now);
  start(h, 3);
  for (int i = 0; i < 2; ++i) {  // one full quadrature cycle, A leading: 4 edges
    io.setInputVoltage(17, 5.0);
    io.setInputVoltage(16, 5.0);
    io.setInputVoltage(17, 0.0);
    io.setInputVoltage(16, 0.0);
  }
  r = h.processData({0, 0});
  EXPECT_EQ(r[10], 8);
}

TEST(FieldIo, WatchdogBitesAfter50msAndTheHostMustClearIt) {
  FieldIoProcessor io;
  Host h(io);
  start(h);
  h.processData({0xFF, 0x00});
  EXPECT_EQ(io.outputs(), 0x00FF);
  h.wait(49ms);
  EXPECT_EQ(io.faults(), 0);
  h.processData({0xFF, 0x00});
  h.wait(50ms + 1us);
  EXPECT_EQ(io.faults(), fault::kWatchdog);
  EXPECT_EQ(io.outputs(), 0);
  EXPECT_TRUE(io.lbpStatus() & lbp::status::kWatchdogTimeout);
  // Communication alone does not bring the outputs back.
  auto r = h.processData({0xFF, 0x00});
  EXPECT_EQ(r[0], fault::kWatchdog);
  EXPECT_EQ(io.outputs(), 0);
  ASSERT_TRUE(h.setLocal(lbp::local_write::kClearFault, 0xFF));
  h.processData({0xFF, 0x00});
  EXPECT_EQ(io.outputs(), 0x00FF);
}

// FIELD I/O WATCHDOG AND FAULTS: "When a fault flag is set, outputs can not
// longer be set and the host must first clear the fault". Outputs written
// while the watchdog fault is set are not set: the clear alone turns
// nothing on; the host's next write does.
TEST(FieldIo, OutputsWrittenWhileTheWatchdogFaultIsSetAreNotSet) {
  FieldIoProcessor io;
  Host h(io);
  start(h);
  h.processData({0x0F, 0x00});
  h.wait(51ms);
  ASSERT_EQ(io.faults(), fault::kWatchdog);
  EXPECT_EQ(io.outputs(), 0);
  h.processData({0xFF, 0xFF});
  EXPECT_EQ(io.outputs(), 0);
  ASSERT_TRUE(h.setLocal(lbp::local_write::kClearFault, 0xFF));
  EXPECT_EQ(io.faults(), 0);
  EXPECT_EQ(io.outputs(), 0);  // neither what was set before the bite nor what came after
  h.processData({0xFF, 0xFF});
  EXPECT_EQ(io.outputs(), 0xFFFF);
}

// SHORT CIRCUIT PROTECTION ("disable the affected output and indicate a
// fault") and OVER-TEMPERATURE PROTECTION ("disable the affected chip and
// indicate a fault"): those fault flags do not stop the host setting the
// other outputs; only the watchdog's flag does (FIELD I/O WATCHDOG AND
// FAULTS). Field supply faults block nothing either.
TEST(FieldIo, OnlyTheWatchdogFaultStopsOutputsBeingSet) {
  FieldIoProcessor io(separateVin());
  Host h(io);
  start(h);
  io.setOutputLoad(3, 0.0);  // a dead short on output 3
  h.processData({0x08, 0x00});
  ASSERT_TRUE(io.faults() & fault::kOverCurrent);
  h.processData({0x38, 0x01});  // with OverCurrent set, set outputs 4, 5 and 8
  EXPECT_EQ(io.outputs(), 0x0130);
  io.setDriverOverTemperature(1, true);
  ASSERT_TRUE(io.faults() & fault::kOverTemp);
  h.processData({0x78, 0x01});  // chip 1 is off; chip 0 still takes new outputs
  EXPECT_EQ(io.outputs(), 0x0070);
  io.setFieldVoltage(4.0, h.now);
  ASSERT_TRUE(io.faults() & fault::kLowVoltage);
  h.processData({0x03, 0x00});
  EXPECT_EQ(io.outputs(), 0x0003);
}

TEST(FieldIo, WatchdogTimeZeroDisablesIt) {
  FieldIoProcessor io;
  Host h(io);
  start(h);
  const auto wd = io.address(io.standard(remote::Standard::WatchdogTime));
  ASSERT_TRUE(h.write(wd, 2, 0));
  h.processData({0x01, 0x00});
  h.wait(10s);
  EXPECT_EQ(io.faults(), 0);
  EXPECT_EQ(io.outputs(), 1);
  ASSERT_TRUE(h.write(wd, 2, 100));  // WPD WATCHDOGTIME 100
  h.wait(99ms);
  EXPECT_EQ(io.faults(), 0);
  h.wait(2ms);
  EXPECT_EQ(io.faults(), fault::kWatchdog);
}

TEST(FieldIo, ShortCircuitDisablesThatOutputOnly) {
  FieldIoProcessor io;
  Host h(io);
  start(h);
  io.setOutputLoad(3, 24.0 / 0.3);  // 300 mA: fine
  h.processData({0x0F, 0x00});
  EXPECT_EQ(io.outputs(), 0x000F);
  EXPECT_NEAR(io.outputCurrent(3), 0.3, 1e-9);
  io.setOutputLoad(3, 10.0);  // 2.4 A: short
  EXPECT_EQ(io.outputs(), 0x0007);
  EXPECT_TRUE(io.outputTripped(3));
  EXPECT_EQ(h.processData({0x0F, 0x00})[0], fault::kOverCurrent);
  io.setOutputLoad(3, 1e9);  // short removed: still off until cleared
  h.processData({0x0F, 0x00});
  EXPECT_EQ(io.outputs(), 0x0007);
  ASSERT_TRUE(h.setLocal(lbp::local_write::kClearFault, 0xFF));
  h.processData({0x0F, 0x00});
  EXPECT_EQ(io.outputs(), 0x000F);
  EXPECT_EQ(io.faults(), 0);
}

TEST(FieldIo, OverTemperatureAndChipCurrentDisableAWholeChip) {
  FieldIoProcessor io;
  Host h(io);
  start(h);
  h.processData({0xFF, 0xFF});
  io.setDriverOverTemperature(1, true);
  EXPECT_EQ(io.outputs(), 0x00FF);
  EXPECT_TRUE(io.chipShutdown(1));
  EXPECT_EQ(h.processData({0xFF, 0xFF})[0], fault::kOverTemp);
  ASSERT_TRUE(h.setLocal(lbp::local_write::kClearFault, 0xFF));
  EXPECT_EQ(io.faults(), fault::kOverTemp);  // still hot
  io.setDriverOverTemperature(1, false);
  ASSERT_TRUE(h.setLocal(lbp::local_write::kClearFault, 0xFF));
  h.processData({0xFF, 0xFF});
  EXPECT_EQ(io.outputs(), 0xFFFF);
  // Five 300 mA loads on chip 0 = 1.5 A > 1.4 A per chip.
  for (unsigned i = 0; i < 5; ++i) io.setOutputLoad(i, 80.0);
  EXPECT_TRUE(io.chipShutdown(0));
  EXPECT_EQ(io.outputs(), 0xFF00);
  EXPECT_TRUE(io.faults() & fault::kOverTemp);
}

TEST(FieldIo, FieldAndVinSupply) {
  // W1 left: VIN is field power; below 8 V the processor is off.
  FieldIoProcessor io;
  io.setFieldVoltage(7.0, lbp::SimTime{1ms});
  EXPECT_FALSE(io.powered());
  Host h(io, lbp::SimTime{2ms});
  EXPECT_TRUE(h.send({0xDF}).empty());
  io.setFieldVoltage(24.0, lbp::SimTime{3ms});
  EXPECT_TRUE(io.powered());
  EXPECT_EQ(io.faults(), fault::kWatchdog);  // a fresh power-up
  // W1 right: separate VIN; a field supply failure is reported.
  FieldIoProcessor sep(separateVin());
  Host hs(sep);
  start(hs);
  sep.setFieldVoltage(3.0, hs.now);
  EXPECT_TRUE(sep.powered());
  EXPECT_EQ(hs.processData({0, 0})[0], fault::kLowVoltage);
  EXPECT_FALSE(sep.fieldVoltageLed());
  sep.setFieldVoltage(33.0, hs.now);
  EXPECT_TRUE(sep.faults() & fault::kHighVoltage);
  sep.setFieldVoltage(24.0, hs.now);
  ASSERT_TRUE(hs.setLocal(lbp::local_write::kClearFault, 0xFF));
  EXPECT_EQ(sep.faults(), 0);
}

TEST(FieldIo, NonVolatileValuesTakeEffectOnlyAfterAPowerCycle) {
  const auto file = std::filesystem::temp_directory_path() / ("lbpkit-fio-" + std::to_string(::getpid()));
  std::filesystem::remove(file);
  FieldIoProcessor::Options o;
  o.nvFile = file;
  {
    FieldIoProcessor io(o);
    Host h(io);
    const auto nvwd = io.address(io.standard(remote::Standard::NvWatchdogTimeout));
    EXPECT_EQ(h.read(nvwd, 2), 50U);
    EXPECT_FALSE(h.write(nvwd, 2, 100) && io.lbpStatus() == 0);  // NV access off: invalid write
    EXPECT_TRUE(io.lbpStatus() & lbp::status::kInvalidWrite);
    EXPECT_EQ(h.read(nvwd, 2), 50U);
    ASSERT_TRUE(h.setLocal(lbp::local_write::kNonVolatile, lbp::nonvolatile::kEeprom));
    ASSERT_TRUE(h.write(nvwd, 2, 100));  // WPD NVWATCHDOGTIME 100
    ASSERT_TRUE(h.setLocal(lbp::local_write::kNonVolatile, 0));
    EXPECT_EQ(h.read(nvwd, 2), 100U);
    EXPECT_EQ(io.watchdogTimeMs(), 50);  // working copy unchanged until power-up
    // Baud rate index: 4 = 115200, effective after the power cycle too.
    ASSERT_TRUE(h.setLocal(lbp::local_write::kNonVolatile, lbp::nonvolatile::kEeprom));
    ASSERT_TRUE(h.write(io.address(io.standard(remote::Standard::NvBaudRate)), 2, 4));
    EXPECT_EQ(io.baud(), 2500000U);
    io.setFieldVoltage(0.0, h.now);  // power cycle
    io.setFieldVoltage(24.0, h.now);
    EXPECT_EQ(io.watchdogTimeMs(), 100);
    EXPECT_EQ(io.baud(), 115200U);
  }
  FieldIoProcessor again(o);  // the file keeps it across runs
  EXPECT_EQ(again.watchdogTimeMs(), 100);
  test_support::removeStateFiles(file.string());
}

TEST(FieldIo, PowerCutDuringAnNvWriteLeavesTheOldOrNewValue) {
  FieldIoProcessor probe;
  const std::size_t slot = probe.nvStore().slotBytes();
  for (std::size_t cut = 0; cut <= slot; cut += 7) {
    FieldIoProcessor io;
    Host h(io);
    const auto nvunit = io.address(io.standard(remote::Standard::NvUnitNumber));
    ASSERT_TRUE(h.setLocal(lbp::local_write::kNonVolatile, lbp::nonvolatile::kEeprom));
    ASSERT_TRUE(h.write(nvunit, 4, 0x12000001));
    io.nvStore().cutPowerAfter(cut);
    h.write(nvunit, 4, 0x12ABCDEF);
    if (io.powered()) {
      EXPECT_GE(cut, slot);
    }
    io.setFieldVoltage(0.0, h.now);
    io.setFieldVoltage(24.0, h.now);
    const auto unit = io.unitNumber();
    EXPECT_TRUE(unit == 0x12000001U || unit == 0x12ABCDEFU) << std::hex << unit << " cut " << std::dec << cut;
  }
}

TEST(FieldIo, AnEepromFileThatCannotBeWrittenDoesNotKillTheProcessor) {
  FieldIoProcessor::Options o;
  o.nvFile = "/nonexistent-lbpkit-dir/eeprom";
  FieldIoProcessor io(o);
  Host h(io);
  const auto nvwd = io.address(io.standard(remote::Standard::NvWatchdogTimeout));
  ASSERT_TRUE(h.setLocal(lbp::local_write::kNonVolatile, lbp::nonvolatile::kEeprom));
  ASSERT_TRUE(h.setLocal(lbp::local_write::kStatus, 0));
  EXPECT_TRUE(h.write(nvwd, 2, 100));
  EXPECT_TRUE(io.powered());
  EXPECT_TRUE(io.lbpStatus() & lbp::status::kInvalidWrite);  // it did not take
  EXPECT_EQ(h.read(nvwd, 2), 50U);
}

// An NV write the EEPROM did not save is refused to the host
// (Invalid write) and told to whoever runs the model, every time.
TEST(FieldIo, AnNvWriteTheEepromDidNotSaveIsRefusedAndReported) {
  std::vector<remote::NvEvent> events;
  FieldIoProcessor::Options o;
  o.nvFile = "/dev/full";  // a device, not an EEPROM image: never written
  o.nvReport = [&](const remote::NvEvent& e) { events.push_back(e); };
  FieldIoProcessor io(o);
  ASSERT_FALSE(events.empty());
  EXPECT_EQ(events.front().kind, remote::NvEvent::Kind::Refused);
  EXPECT_NE(events.front().message.find("/dev/full: is a character device"), std::string::npos)
      << events.front().message;
  Host h(io);
  const auto nvwd = io.address(io.standard(remote::Standard::NvWatchdogTimeout));
  ASSERT_TRUE(h.setLocal(lbp::local_write::kNonVolatile, lbp::nonvolatile::kEeprom));
  for (int write = 0; write < 2; ++write) {  // each write fails alike
    ASSERT_TRUE(h.setLocal(lbp::local_write::kStatus, 0));
    const auto before = events.size();
    EXPECT_TRUE(h.write(nvwd, 2, 100));
    EXPECT_TRUE(io.lbpStatus() & lbp::status::kInvalidWrite);
    ASSERT_EQ(events.size(), before + 1);
    EXPECT_EQ(events.back().kind, remote::NvEvent::Kind::WriteFailed);
    EXPECT_NE(events.back().message.find("not saved"), std::string::npos) << events.back().message;
  }
  EXPECT_EQ(h.read(nvwd, 2), 50U);
}

TEST(FieldIo, WritesToReadOnlyOrUnmappedMemoryChangeNothing) {
  FieldIoProcessor io;
  Host h(io);
  start(h);
  const auto input = io.address(0);  // Input is read only
  EXPECT_TRUE(h.write(input, 4, 0xFFFFFFFF));
  EXPECT_TRUE(io.lbpStatus() & lbp::status::kInvalidWrite);
  EXPECT_EQ(h.read(input, 4), 0U);
  EXPECT_TRUE(h.write(remote::memory::kRom, 1, 0x00));  // discovery ROM
  EXPECT_EQ(h.read(remote::memory::kRom, 1), lbp::kProcessDataRecord);
  EXPECT_TRUE(h.write(0xF000, 8, ~0ULL));  // unmapped
  EXPECT_EQ(h.read(0xF000, 8), 0U);
  // WPD OUTPUT by address works (with the fault cleared), like the manual's example.
  ASSERT_TRUE(h.write(io.address(1), 2, 0xAAAA));
  EXPECT_EQ(io.outputs(), 0xAAAA);
}

}  // namespace
