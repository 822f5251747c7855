// SPDX-License-Identifier: MIT
// The manual's DISCOVERY SEQUENCE (steps 5..29) at the LBP level, against
// both 7I77 processors in every software mode.
#include <gtest/gtest.h>

#include <bit>
#include <cstring>
#include <string>

#include "lbp/protocol.hpp"
#include "support/lbp_host.hpp"
#include "lbpkit/discovery.hpp"
#include "remote/analog.hpp"
#include "remote/field_io.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace remote = lbpkit::model::remote;
namespace lbp = lbpkit::model::lbp;

namespace {

using testing_lbp::Bytes;
using testing_lbp::Host;

struct Record {
  std::uint8_t type = 0;
  std::uint8_t bits = 0, dataType = 0, direction = 0;
  float min = 0, max = 0;
  std::uint16_t address = 0;
  std::string unit, name;
  std::uint8_t modeIndex = 0, modeType = 0;
};

std::string readString(Host& h, std::uint16_t& p) {
  std::string s;
  for (int i = 0; i < 64; ++i) {
    const auto c = static_cast<char>(h.read(p++, 1));
    if (c == 0) return s;
    s.push_back(c);
  }
  ADD_FAILURE() << "unterminated string";
  return s;
}

// Steps 6..10 (PTOC) or the same walk over the GTOC, then 11..28 per record.
std::vector<Record> readTable(Host& h, std::uint16_t toc) {
  std::vector<std::uint16_t> pointers;
  for (std::uint16_t p = toc;; p += 2) {
    const auto entry = static_cast<std::uint16_t>(h.read(p, 2));  // remote read word
    if (entry == 0) break;
    pointers.push_back(entry);
    if (pointers.size() > 64) {
      ADD_FAILURE() << "table does not end";
      break;
    }
  }
  std::vector<Record> records;
  for (std::uint16_t at : pointers) {
    Record r;
    r.type = static_cast<std::uint8_t>(h.read(at, 1));
    if (r.type == lbp::kProcessDataRecord) {
      r.bits = static_cast<std::uint8_t>(h.read(at + 1, 1));
      r.dataType = static_cast<std::uint8_t>(h.read(at + 2, 1));
      r.direction = static_cast<std::uint8_t>(h.read(at + 3, 1));
      r.min = std::bit_cast<float>(static_cast<std::uint32_t>(h.read(at + 4, 4)));
      r.max = std::bit_cast<float>(static_cast<std::uint32_t>(h.read(at + 8, 4)));
      r.address = static_cast<std::uint16_t>(h.read(at + 12, 2));  // the table's offsets (docs/protocol-facts.md#discovery-records)
      std::uint16_t p = static_cast<std::uint16_t>(at + 14);
      r.unit = readString(h, p);
      r.name = readString(h, p);
    } else if (r.type == lbp::kModeRecord) {
      r.modeIndex = static_cast<std::uint8_t>(h.read(at + 1, 1));
      r.modeType = static_cast<std::uint8_t>(h.read(at + 2, 1));
      std::uint16_t p = static_cast<std::uint16_t>(at + 4);
      r.name = readString(h, p);
    } else {
      ADD_FAILURE() << "record type " << int(r.type) << " at " << at;
    }
    records.push_back(r);
  }
  return records;
}

struct Discovered {
  std::uint8_t rx = 0, tx = 0;
  std::vector<Record> ptoc, gtoc;
};

Discovered discover(Host& h, std::uint8_t mode) {
  // What SSLBP's setup START does before the host walks the tables.
  EXPECT_EQ(h.local(lbp::local_read::kCookie), 0x5A);
  EXPECT_TRUE(h.setLocal(lbp::local_write::kRemoteSwMode, mode));
  auto d = h.transact({lbp::special_rpc::kDiscovery}, 6);
  EXPECT_TRUE(d.has_value());
  Discovered out;
  if (!d) return out;
  out.rx = (*d)[0];
  out.tx = (*d)[1];
  const auto ptoc = static_cast<std::uint16_t>((*d)[2] | ((*d)[3] << 8));
  const auto gtoc = static_cast<std::uint16_t>((*d)[4] | ((*d)[5] << 8));
  EXPECT_NE(ptoc, 0);  // LinuxCNC takes a zero PTOC pointer for "no remote"
  out.ptoc = readTable(h, ptoc);
  out.gtoc = readTable(h, gtoc);
  return out;
}

void checkConsistent(const Discovered& d, std::uint8_t mode) {
  unsigned inBits = 0, outBits = 0, modeRecords = 0;
  for (const auto& r : d.ptoc) {
    if (r.type == lbp::kModeRecord) {
      ++modeRecords;
      if (r.modeType == lbp::kSwMode) {
        EXPECT_EQ(r.modeIndex, mode);
      }
      continue;
    }
    EXPECT_GE(r.bits, 1);
    EXPECT_FALSE(r.name.empty());
    EXPECT_FALSE(lbp::isNonVolatile(static_cast<lbp::DataType>(r.dataType))) << r.name << " NV in PTOC";
    if (r.direction != 0x80) inBits += r.bits;
    if (r.direction != 0x00) outBits += r.bits;
  }
  EXPECT_EQ(modeRecords, 2U);  // hardware and software mode
  EXPECT_LE(inBits, 96U);      // three interface registers
  EXPECT_LE(outBits, 96U);
  EXPECT_EQ(d.rx, 1 + (inBits + 7) / 8) << "fault byte plus inputs";
  EXPECT_EQ(d.tx, (outBits + 7) / 8);
  // Every PTOC record is also in the GTOC (same PARAM_ADD).
  for (const auto& r : d.ptoc) {
    if (r.type != lbp::kProcessDataRecord) continue;
    bool found = false;
    for (const auto& g : d.gtoc) found |= g.type == r.type && g.address == r.address && g.name == r.name;
    EXPECT_TRUE(found) << r.name;
  }
}

// GTOC entries that are not process data of the current PTOC (same
// PARAM_ADD, as LinuxCNC decides), by name: what hosts make parameters of.
std::vector<std::string> parametersOf(const Discovered& d) {
  std::vector<std::string> out;
  for (const auto& g : d.gtoc) {
    if (g.type != lbp::kProcessDataRecord) continue;
    bool inPtoc = false;
    for (const auto& p : d.ptoc) inPtoc |= p.type == lbp::kProcessDataRecord && p.address == g.address;
    if (!inPtoc) out.push_back(g.name);
  }
  return out;
}

const Record* find(const std::vector<Record>& t, const std::string& name) {
  for (const auto& r : t)
    if (r.name == name) return &r;
  return nullptr;
}

TEST(Discovery, FieldIoEveryModeSetupAndOperate) {
  for (bool setup : {true, false}) {
    for (std::uint8_t mode = 0; mode < 4; ++mode) {
      SCOPED_TRACE(testing::Message() << "mode " << int(mode) << (setup ? " setup" : " operate"));
      remote::FieldIoProcessor::Options o;
      o.setupMode = setup;
      remote::FieldIoProcessor io(o);
      EXPECT_EQ(io.baud(), setup ? 115200U : 2500000U);
      Host h(io);
      const auto d = discover(h, mode);
      checkConsistent(d, mode);
      static constexpr std::uint8_t kRx[] = {5, 9, 10, 12};
      EXPECT_EQ(d.rx, kRx[mode]);
      EXPECT_EQ(d.tx, 2);
      const Record* in = find(d.ptoc, "Input");
      ASSERT_NE(in, nullptr);
      EXPECT_EQ(in->bits, 32);
      EXPECT_EQ(in->dataType, 0x01);
      const Record* out = find(d.ptoc, "Output");
      ASSERT_NE(out, nullptr);
      EXPECT_EQ(out->bits, 16);
      EXPECT_EQ(out->direction, 0x80);
      EXPECT_EQ(find(d.ptoc, "AnalogIn0") != nullptr, mode >= 1);
      EXPECT_EQ(find(d.ptoc, "FieldVoltage") != nullptr, mode >= 2);
      EXPECT_EQ(find(d.ptoc, "Enc0") != nullptr, mode >= 3);
      if (mode >= 1) {
        EXPECT_FLOAT_EQ(find(d.ptoc, "AnalogIn0")->max, 36.3F);
      }
      // GTOC parameters: the table's rows for this processor, in every mode.
      EXPECT_EQ(parametersOf(d), (std::vector<std::string>{"NVEncMode0", "NVEncMode1", "SwRevision", "NVBaudRate",
                                                           "NVUnitNumber", "NVWatchDogTimeout", "UnitNumber",
                                                           "WatchDogTime", "Fault"}));
    }
  }
}

// mesaflash collects every software mode record in the GTOC and walks each
// (mesaflash: sserial_module.c); LinuxCNC prints them ("Board ... Software
// Mode i = name") and makes pins from the PTOC alone (LinuxCNC: sserial.c).
// So the GTOC lists all of a processor's software modes whatever the current
// one; the PTOC only the current hardware and software modes (MODE DESCRIPTOR).
TEST(Discovery, TheGtocListsEverySoftwareModeThePtocOnlyTheCurrentOne) {
  const std::vector<std::string> names = {"IO", "IO+AnalogIn", "IO+AnalogIn+FieldVoltage",
                                          "IO+AnalogIn+FieldVoltage+MPG"};
  for (std::uint8_t mode = 0; mode < 4; ++mode) {
    SCOPED_TRACE(testing::Message() << "mode " << int(mode));
    remote::FieldIoProcessor io;
    Host h(io);
    const auto d = discover(h, mode);
    std::vector<std::string> gtocModes;
    unsigned hardware = 0;
    for (const auto& r : d.gtoc) {
      if (r.type != lbp::kModeRecord) continue;
      if (r.modeType == lbp::kHwMode) {
        ++hardware;
        continue;
      }
      EXPECT_EQ(r.modeIndex, gtocModes.size());
      gtocModes.push_back(r.name);
    }
    EXPECT_EQ(hardware, 1U);
    EXPECT_EQ(gtocModes, names);
    std::vector<std::string> ptocModes;
    for (const auto& r : d.ptoc)
      if (r.type == lbp::kModeRecord && r.modeType == lbp::kSwMode) ptocModes.push_back(r.name);
    EXPECT_EQ(ptocModes, std::vector<std::string>{names[mode]});
  }
  remote::AnalogProcessor a;
  Host h(a);
  const auto d = discover(h, 0);
  unsigned software = 0;
  for (const auto& r : d.gtoc) software += r.type == lbp::kModeRecord && r.modeType == lbp::kSwMode;
  EXPECT_EQ(software, 1U);  // the analog processor has one mode
}

// --state files keep working across versions: the NV parameters sit where
// earlier lbpkit versions put them in the EEPROM image.
TEST(Discovery, NonVolatileParametersKeepTheirEepromPlaces) {
  remote::FieldIoProcessor io;
  remote::AnalogProcessor an;
  auto at = [](const remote::RemoteDevice& d, const std::string& name) {
    for (std::size_t id = 0; id < d.elementCount(); ++id)
      if (d.descriptor(static_cast<remote::ElementId>(id)).name == name) return d.address(static_cast<remote::ElementId>(id));
    return std::uint16_t{0};
  };
  EXPECT_EQ(at(io, "NVEncMode0"), 0x0300);
  EXPECT_EQ(at(io, "NVEncMode1"), 0x0301);
  EXPECT_EQ(at(io, "NVBaudRate"), 0x0302);
  EXPECT_EQ(at(io, "NVUnitNumber"), 0x0304);
  EXPECT_EQ(at(io, "NVWatchDogTimeout"), 0x0308);
  EXPECT_EQ(at(an, "NVBaudRate"), 0x0300);
  EXPECT_EQ(at(an, "NVUnitNumber"), 0x0302);
  EXPECT_EQ(at(an, "NVWatchDogTimeout"), 0x0306);
}

// The host library over plain LBP: what it makes of a GTOC holding every
// software mode (lbpkit discover counts and shows them).
class LbpAccess : public lbpkit::RemoteAccess {
 public:
  explicit LbpAccess(Host& h) : h_(h) {}
  std::uint64_t read(std::uint16_t address, unsigned size) override {
    ++n_;
    return h_.read(address, static_cast<std::uint8_t>(size));
  }
  void write(std::uint16_t address, unsigned size, std::uint64_t value) override {
    ++n_;
    h_.write(address, static_cast<std::uint8_t>(size), value);
  }
  std::uint8_t localRead(std::uint8_t command) override {
    ++n_;
    return h_.local(command);
  }
  void localWrite(std::uint8_t command, std::uint8_t value) override {
    ++n_;
    h_.setLocal(command, value);
  }
  [[nodiscard]] std::uint64_t transactions() const override { return n_; }
  [[nodiscard]] std::string where() const override { return "LBP"; }

 private:
  Host& h_;
  std::uint64_t n_ = 0;
};

TEST(Discovery, TheHostLibraryKeepsTheGtocsModesApartFromTheCurrentOnes) {
  remote::FieldIoProcessor io;
  Host h(io);
  const auto tables = discover(h, 2);
  ASSERT_TRUE(h.setLocal(lbp::local_write::kRemoteSwMode, 2));
  const auto rpc = h.transact({lbp::special_rpc::kDiscovery}, 6);
  ASSERT_TRUE(rpc.has_value());
  LbpAccess access(h);
  const auto d = lbpkit::discover(access, static_cast<std::uint16_t>((*rpc)[2] | ((*rpc)[3] << 8)),
                                  static_cast<std::uint16_t>((*rpc)[4] | ((*rpc)[5] << 8)), (*rpc)[0], (*rpc)[1]);
  ASSERT_EQ(d.modes.size(), 2U);  // the PTOC's: hardware and the current software mode
  EXPECT_EQ(d.modes[1].name, "IO+AnalogIn+FieldVoltage");
  std::vector<std::string> software;
  for (const auto& m : d.gtocModes)
    if (m.type == lbp::kSwMode) software.push_back(m.name);
  EXPECT_EQ(software, (std::vector<std::string>{"IO", "IO+AnalogIn", "IO+AnalogIn+FieldVoltage",
                                                "IO+AnalogIn+FieldVoltage+MPG"}));
  std::vector<std::string> params;
  for (const auto& e : d.parameters) params.push_back(e.name);
  EXPECT_EQ(params, parametersOf(tables));
  // One DOIT per byte, as LinuxCNC reads: both tables and their sentinels,
  // and every record once (the GTOC's mode records include the PTOC's).
  EXPECT_EQ(d.gtocEntries, tables.gtoc.size());
  std::size_t bytes = 2 * (tables.ptoc.size() + 1) + 2 * (tables.gtoc.size() + 1);
  for (const auto& r : tables.gtoc)
    bytes += r.type == lbp::kModeRecord ? 4 + r.name.size() + 1 : 14 + r.unit.size() + 1 + r.name.size() + 1;
  EXPECT_EQ(d.bytewiseReads(), bytes);
}

// No source shows a real 7I77's GTOC: its parameters follow the manual's
// FIELD I/O PARAMETERS table and, where that is silent, the siblings in
// LinuxCNC's sserial(9): nvbaudrate, nvunitnumber, nvwatchdogtimeout,
// swrevision "(u32 ro)" (7I76, 7I69, 7I70, 7I71), nvencmodeN ro (7I73).
// LinuxCNC makes a parameter read only when its direction is Input. No
// sibling lists a working encmode, hwrevision or its analog inputs as
// parameters. Dimensionless units read "None", the spelling mesaflash
// compares (mesaflash: sserial_module.c).
TEST(Discovery, GtocParametersAreTheSiblingsWithTheirReadOnlyChoice) {
  remote::FieldIoProcessor io;
  Host h(io);
  const auto d = discover(h, 0);
  for (const char* name : {"SwRevision", "NVBaudRate", "NVUnitNumber", "NVWatchDogTimeout", "NVEncMode0", "NVEncMode1",
                           "Fault"}) {
    const Record* r = find(d.gtoc, name);
    ASSERT_NE(r, nullptr) << name;
    EXPECT_EQ(r->direction, 0x00) << name << " is read only to LinuxCNC";
    EXPECT_EQ(r->unit, std::string(name) == "NVWatchDogTimeout" ? "mS" : "None") << name;
  }
  for (const char* name : {"UnitNumber", "WatchDogTime"}) {  // the manual's "user settable" working values
    const Record* r = find(d.gtoc, name);
    ASSERT_NE(r, nullptr) << name;
    EXPECT_EQ(r->direction, 0x40) << name;
  }
  EXPECT_EQ(find(d.gtoc, "UnitNumber")->unit, "None");
  for (const char* absent : {"EncMode0", "EncMode1", "HwRevision", "AnalogIn0", "FieldVoltage", "Enc0"})
    EXPECT_EQ(find(d.gtoc, absent), nullptr) << absent << " in the mode 0 GTOC";
  EXPECT_EQ(find(d.ptoc, "Input")->unit, "None");
  EXPECT_EQ(find(d.ptoc, "Output")->unit, "None");
}

TEST(Discovery, AnalogProcessor) {
  remote::AnalogProcessor a;
  Host h(a);
  const auto d = discover(h, 0);
  checkConsistent(d, 0);
  EXPECT_EQ(d.tx, 10);
  EXPECT_EQ(d.rx, 1);
  for (int i = 0; i < 6; ++i) {
    const Record* r = find(d.ptoc, "AnalogOut" + std::to_string(i));
    ASSERT_NE(r, nullptr);
    EXPECT_EQ(r->bits, 13);
    EXPECT_EQ(r->dataType, 0x03);
    EXPECT_FLOAT_EQ(r->min, -10.0F);
    EXPECT_FLOAT_EQ(r->max, 10.0F);
    EXPECT_EQ(r->unit, "V");
  }
  EXPECT_EQ(find(d.ptoc, "AnalogEna")->dataType, 0x07);
  EXPECT_EQ(find(d.ptoc, "SpinEna")->dataType, 0x07);
  EXPECT_EQ(find(d.ptoc, "AnalogEna")->unit, "None");
  EXPECT_EQ(find(d.gtoc, "HwRevision"), nullptr);  // no sibling reports it
  EXPECT_EQ(parametersOf(d), (std::vector<std::string>{"SwRevision", "NVBaudRate", "NVUnitNumber",
                                                       "NVWatchDogTimeout", "UnitNumber", "WatchDogTime", "Fault"}));
}

TEST(Discovery, IllegalModeIsAFaultAndFallsBackToModeZeroTables) {
  remote::FieldIoProcessor io;
  Host h(io);
  ASSERT_TRUE(h.setLocal(lbp::local_write::kRemoteSwMode, 7));
  EXPECT_TRUE(io.faults() & remote::fault::kIllegalMode);
  EXPECT_EQ(h.transact({lbp::special_rpc::kDiscovery}, 6)->at(0), 5);
  ASSERT_TRUE(h.setLocal(lbp::local_write::kClearFault, 0xFF));
  EXPECT_TRUE(io.faults() & remote::fault::kIllegalMode);  // still illegal
  ASSERT_TRUE(h.setLocal(lbp::local_write::kRemoteSwMode, 0));
  ASSERT_TRUE(h.setLocal(lbp::local_write::kClearFault, 0xFF));
  EXPECT_EQ(io.faults(), 0);
}

TEST(Discovery, IdentityLocalsAndSpecialRpcs) {
  remote::FieldIoProcessor io;
  remote::AnalogProcessor an;
  for (remote::RemoteDevice* d : {static_cast<remote::RemoteDevice*>(&io), static_cast<remote::RemoteDevice*>(&an)}) {
    Host h(*d);
    std::string name;
    for (std::uint8_t c = 0xD0; c <= 0xD3; ++c) name.push_back(static_cast<char>(h.local(c)));
    EXPECT_EQ(name, "7I77");
    // CRC, EEPROM and flash: the firmware is updated over LBP (manual: UFLBP).
    EXPECT_EQ(h.local(lbp::local_read::kCapability), 0x0D);
    auto unit = h.transact({lbp::special_rpc::kUnitNumber}, 4);
    ASSERT_TRUE(unit.has_value());
    const std::uint32_t u = std::uint32_t{(*unit)[0]} | (std::uint32_t{(*unit)[1]} << 8) |
                            (std::uint32_t{(*unit)[2]} << 16) | (std::uint32_t{(*unit)[3]} << 24);
    EXPECT_EQ(u, d->unitNumber());
  }
  EXPECT_EQ(io.unitNumber() >> 24, 0x12U);  // field I/O
  EXPECT_EQ(an.unitNumber() >> 24, 0x11U);  // analog
}

}  // namespace
