// SPDX-License-Identifier: MIT
#include "lbpkit/hostmot2.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>

#include "lbpkit/error.hpp"
#include "lbpkit/wire/hostmot2.hpp"

namespace lbpkit {

namespace {
using namespace wire::hm2::idrom;
namespace tag = wire::hm2::tag;
namespace pin = wire::hm2::pin;
constexpr unsigned kMaxModules = 48;   // as LinuxCNC's driver
constexpr unsigned kMaxPins = 1000;

std::string chars(std::uint32_t w) {
  std::string s;
  for (int i = 0; i < 4; ++i) {
    const char c = static_cast<char>((w >> (8 * i)) & 0xFF);
    if (c) s.push_back(c);
  }
  return s;
}
}  // namespace

std::string moduleName(std::uint8_t t) {
  const std::string_view name = wire::hm2::moduleName(t);
  return name.empty() ? fmt::format("unknown-0x{:02X}", t) : std::string(name);
}

std::string PinInfo::function() const {
  if (secondaryTag == 0) return "GPIO";
  const std::string dir = output() ? "out" : "in";
  const unsigned code = secondaryPin & pin::kCodeMask;
  switch (secondaryTag) {
    case tag::kSSerial: {
      const unsigned channel = (secondaryPin & pin::kSSerialChannelMask) - 1U;
      const char* kind = (secondaryPin & pin::kSSerialKindMask) == pin::kSSerialTxEn ? "TXEN" : output() ? "TX" : "RX";
      return fmt::format("SSerial {} {}{} ({})", secondaryUnit, kind, channel, dir);
    }
    case tag::kMuxedQCount: {
      const char* kind = code == pin::kQCountA           ? "A"
                         : code == pin::kQCountB         ? "B"
                         : code == pin::kQCountIndex     ? "IDX"
                         : code == pin::kQCountIndexMask ? "IDXMASK"
                                                         : "?";
      return fmt::format("MuxedQCount {} {} ({})", secondaryUnit, kind, dir);
    }
    case tag::kMuxedQCountSel:
      return fmt::format("MuxedQCountSel {} SEL{} ({})", secondaryUnit, code - pin::kQCountSel0, dir);
    default: return fmt::format("{} {} pin {} ({})", moduleName(secondaryTag), secondaryUnit, code, dir);
  }
}

const ModuleInfo* CardInfo::module(std::uint8_t tag) const {
  for (const auto& m : modules)
    if (m.tag == tag) return &m;
  return nullptr;
}

unsigned CardInfo::sserialChannels() const {
  unsigned n = 0;
  for (const auto& p : pins)
    if (p.secondaryTag == tag::kSSerial && p.secondaryUnit == 0)
      n = std::max(n, static_cast<unsigned>(p.secondaryPin & pin::kSSerialChannelMask));
  return n;
}

CardInfo readCardInfo(Transport& t) {
  CardInfo info;
  std::uint32_t cookie = 0, name[2] = {}, pointer = 0;
  t.queueRead(kCookieAddress, &cookie);
  t.queueRead(kConfigName, name, 2);
  t.queueRead(kIdromPointer, &pointer);
  t.flush();
  if (cookie != kCookie)
    throw Error(fmt::format("no HostMot2 card at {}: cookie at 0x{:04X} reads 0x{:08X}, not 0x{:08X} "
                            "(is the FPGA configured, and is this the right address?)",
                            t.describe(), kCookieAddress, cookie, kCookie));
  info.configName = chars(name[0]) + chars(name[1]);
  if (info.configName != "HOSTMOT2")
    throw Error(fmt::format("configuration name at 0x{:04X} is \"{}\", not HOSTMOT2", kConfigName, info.configName));
  const auto idrom = static_cast<std::uint16_t>(pointer & 0xFFFF);
  std::array<std::uint32_t, 16> h{};
  t.queueRead(idrom, h.data(), h.size());
  t.flush();
  auto field = [&](unsigned offset) { return h[offset / 4]; };
  info.idromType = field(kType);
  if (info.idromType != 2 && info.idromType != kIdromType)
    throw Error(fmt::format("IDROM at 0x{:04X} has type {}, expected 2 or 3", idrom, info.idromType));
  info.boardName = chars(field(kBoardNameLow)) + chars(field(kBoardNameHigh));
  info.fpgaSize = field(kFpgaSize);
  info.fpgaPins = field(kFpgaPins);
  info.ioPorts = field(kIoPorts);
  info.ioWidth = field(kIoWidth);
  info.portWidth = field(kPortWidth);
  info.clockLow = field(kClockLow);
  info.clockHigh = field(kClockHigh);
  const std::uint32_t instStride[2] = {field(kInstanceStride0), field(kInstanceStride1)};
  const std::uint32_t regStride[2] = {field(kRegisterStride0), field(kRegisterStride1)};
  if (info.portWidth == 0 || info.ioWidth != info.ioPorts * info.portWidth)
    throw Error(fmt::format("IDROM: IOWidth {} is not IOPorts {} x PortWidth {}", info.ioWidth, info.ioPorts,
                            info.portWidth));
  if (info.ioWidth > kMaxPins) throw Error(fmt::format("IDROM: IOWidth {} is more than {} pins", info.ioWidth, kMaxPins));
  if (info.clockLow < 1'000'000 || info.clockHigh < 1'000'000)
    throw Error(fmt::format("IDROM: clocks {} / {} Hz are below 1 MHz", info.clockLow, info.clockHigh));

  // Module descriptors until a zero tag.
  std::array<std::uint32_t, 3 * kMaxModules> md{};
  t.queueRead(static_cast<std::uint16_t>(idrom + field(kOffsetToModulesField)), md.data(), 3 * 32);
  t.flush();
  for (unsigned i = 0; i < 32; ++i) {
    const auto w0 = md[3 * i], w1 = md[3 * i + 1], w2 = md[3 * i + 2];
    if ((w0 & 0xFF) == 0) break;
    ModuleInfo m;
    m.tag = static_cast<std::uint8_t>(w0);
    m.name = moduleName(m.tag);
    m.version = static_cast<std::uint8_t>(w0 >> 8);
    m.clockTag = static_cast<std::uint8_t>(w0 >> 16);
    m.instances = static_cast<std::uint8_t>(w0 >> 24);
    m.baseAddress = static_cast<std::uint16_t>(w1);
    m.registers = static_cast<std::uint8_t>(w1 >> 16);
    const unsigned rs = (w1 >> 24) & 0xF, is = (w1 >> 28) & 0xF;
    if (m.clockTag != wire::hm2::kClockLow && m.clockTag != wire::hm2::kClockHigh)
      throw Error(fmt::format("module descriptor {} ({}): clock tag {} is neither 1 nor 2", i, m.name, m.clockTag));
    if (rs > 1 || is > 1)
      throw Error(fmt::format("module descriptor {} ({}): stride selectors {}/{} are not 0 or 1", i, m.name, rs, is));
    m.clockHz = m.clockTag == wire::hm2::kClockLow ? info.clockLow : info.clockHigh;
    m.registerStride = regStride[rs];
    m.instanceStride = instStride[is];
    m.multipleRegisters = w2;
    info.modules.push_back(m);
  }
  // Pin descriptors.
  std::vector<std::uint32_t> pins(info.ioWidth);
  for (std::size_t at = 0; at < pins.size(); at += 127) {
    const std::size_t n = std::min<std::size_t>(127, pins.size() - at);
    t.queueRead(static_cast<std::uint16_t>(idrom + field(kOffsetToPinsField) + kPinDescriptorBytes * at),
                pins.data() + at, n);
  }
  t.flush();
  for (unsigned i = 0; i < info.ioWidth; ++i) {
    const auto w = pins[i];
    if ((w >> 24) != tag::kIoPort)
      throw Error(fmt::format("pin descriptor {}: primary function 0x{:02X} is not IOPort", i, w >> 24));
    info.pins.push_back(PinInfo{i, i / info.portWidth, i % info.portWidth, static_cast<std::uint8_t>(w >> 8),
                                static_cast<std::uint8_t>(w >> 16), static_cast<std::uint8_t>(w)});
  }
  return info;
}

}  // namespace lbpkit
