// The manual's DISCOVERY SEQUENCE (steps 5..29) at the LBP level, against
// both 7I77 processors in every software mode.
#include <gtest/gtest.h>

#include <bit>
#include <cstring>
#include <string>

#include "lbp/protocol.hpp"
#include "lbp_host.hpp"
#include "remote/analog.hpp"
#include "remote/field_io.hpp"

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
      // GTOC parameters (names as real boards report them, plus the manual's).
      for (const char* p : {"SwRevision", "NVBaudRate", "NVUnitNumber", "NVWatchDogTimeout", "UnitNumber",
                            "WatchDogTime", "Fault", "Output", "FieldVoltage", "EncMode0", "NVEncMode1"})
        EXPECT_NE(find(d.gtoc, p), nullptr) << p;
    }
  }
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
  EXPECT_NE(find(d.gtoc, "HwRevision"), nullptr);
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
    EXPECT_EQ(h.local(lbp::local_read::kCapability), 0x05);
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
