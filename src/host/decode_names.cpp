// SPDX-License-Identifier: MIT
// Register names for `lbpkit decode`: HostMot2 registers from the IDROM's
// module descriptors (docs/protocol-facts.md#module-and-pin-descriptors),
// the remote's local LBP registers (manual: LOCAL LBP READ/WRITE COMMANDS),
// and an IDROM rebuilt from the registers a capture shows being read.
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <map>
#include <string_view>
#include <vector>

#include "lbpkit/decode.hpp"
#include "lbpkit/error.hpp"
#include "lbpkit/transport.hpp"
#include "lbpkit/wire/hostmot2.hpp"
#include "lbpkit/wire/lbp.hpp"
#include "lbpkit/wire/names.hpp"

namespace lbpkit::decode {

namespace {
namespace tag = wire::hm2::tag;
namespace idr = wire::hm2::idrom;

// The IDROM header's fields by byte offset (firmware: idrom.vhd).
constexpr std::array<std::string_view, 16> kHeaderFields = {
    "type",       "offset_to_modules", "offset_to_pins", "board_name_low",    "board_name_high",   "fpga_size",
    "fpga_pins",  "io_ports",          "io_width",       "port_width",        "clock_low",         "clock_high",
    "instance_stride0", "instance_stride1", "register_stride0", "register_stride1"};
constexpr unsigned kMaxModuleDescriptors = 32;  // firmware: IDROMConst.vhd

// The name of register `index` of a module (the module map's; "regN"
// where the map has none).
std::string registerName(std::uint8_t t, unsigned index) {
  const wire::hm2::ModuleKind* kind = wire::hm2::moduleKind(t);
  const wire::hm2::Register* r = kind != nullptr ? kind->at(index) : nullptr;
  return r != nullptr ? std::string(r->name) : fmt::format("reg{}", index);
}

// LinuxCNC's words for the modules (hostmot2 names its pins so); the
// IDROM's name in lower case for a module the map does not know.
std::string moduleWord(std::uint8_t t) {
  if (const wire::hm2::ModuleKind* kind = wire::hm2::moduleKind(t)) return std::string(kind->halWord);
  return wire::asciiLower(moduleName(t));
}

// The registers of a capture as a card: reads answered from what the
// capture shows, so readCardInfo() parses the IDROM as it does a real card's.
class CapturedRegisters final : public Transport {
 public:
  explicit CapturedRegisters(const std::map<std::uint16_t, std::uint32_t>& r) : registers_(r) {}
  void queueRead(std::uint16_t address, std::uint32_t* into, std::size_t count) override {
    reads_.push_back({address, into, count});
  }
  void queueWrite(std::uint16_t, const std::uint32_t*, std::size_t) override {}
  void flush() override {
    for (const auto& r : reads_)
      for (std::size_t i = 0; i < r.count; ++i) {
        const auto address = static_cast<std::uint16_t>(r.address + 4 * i);
        const auto it = registers_.find(address);
        if (it != registers_.end()) {
          r.into[i] = it->second;
        } else if (pastLastModule(address)) {
          r.into[i] = 0;  // LinuxCNC reads the descriptors only up to the zero tag
        } else {
          throw Error(fmt::format("the capture has no read of HostMot2 register 0x{:04X}", address));
        }
      }
    reads_.clear();
  }
  bool tryFlush() override {
    flush();
    return true;
  }
  [[nodiscard]] LinkCounters linkCounters() const override { return {}; }
  Nanoseconds now() override { return Nanoseconds{0}; }
  void sleep(Nanoseconds) override {}
  [[nodiscard]] std::uint64_t exchanges() const override { return 0; }
  [[nodiscard]] std::string describe() const override { return "the capture"; }

 private:
  // A module descriptor after the one with tag 0 that ends the list
  // (docs/protocol-facts.md#module-and-pin-descriptors).
  [[nodiscard]] bool pastLastModule(std::uint16_t address) const {
    const auto pointer = registers_.find(idr::kIdromPointer);
    if (pointer == registers_.end()) return false;
    const unsigned first = (pointer->second & 0xFFFF) + idr::kOffsetToModules;
    const unsigned end = first + kMaxModuleDescriptors * idr::kModuleDescriptorBytes;
    if (address < first || address >= end) return false;
    for (unsigned d = first; d < address; d += idr::kModuleDescriptorBytes) {
      const auto w0 = registers_.find(static_cast<std::uint16_t>(d));
      if (w0 != registers_.end() && (w0->second & 0xFF) == 0) return true;
    }
    return false;
  }
  struct Read {
    std::uint16_t address;
    std::uint32_t* into;
    std::size_t count;
  };
  const std::map<std::uint16_t, std::uint32_t>& registers_;
  std::vector<Read> reads_;
};
}  // namespace

RegisterNames::RegisterNames(CardInfo info) : info_(std::move(info)) {}

std::string RegisterNames::name(std::uint16_t a) const {
  // The identification area and the IDROM (docs/protocol-facts.md#identification-area-and-idrom).
  switch (a) {
    case idr::kCookieAddress: return "idrom.cookie";
    case idr::kConfigName: return "idrom.config_name[0]";
    case idr::kConfigName + 4: return "idrom.config_name[1]";
    case idr::kIdromPointer: return "idrom.offset";
    default: break;
  }
  if (a >= idrom_ && a < idrom_ + idr::kOffsetToModules && (a - idrom_) % 4 == 0)
    return fmt::format("idrom.{}", kHeaderFields[static_cast<std::size_t>(a - idrom_) / 4]);
  const unsigned modules = idrom_ + idr::kOffsetToModules;
  if (a >= modules && a < modules + kMaxModuleDescriptors * idr::kModuleDescriptorBytes)
    return fmt::format("idrom.module[{}].word{}", (a - modules) / idr::kModuleDescriptorBytes,
                       (a - modules) % idr::kModuleDescriptorBytes / 4);
  const unsigned pins = idrom_ + idr::kOffsetToPins;
  if (a >= pins && a < pins + std::max<std::uint32_t>(info_.ioWidth, 1) * idr::kPinDescriptorBytes)
    return fmt::format("idrom.pin[{}]", (a - pins) / idr::kPinDescriptorBytes);
  for (const auto& m : info_.modules) {
    if (m.registerStride == 0 || m.instanceStride == 0) continue;
    if (a < m.baseAddress || a >= m.baseAddress + m.registers * m.registerStride) continue;
    const unsigned reg = (a - m.baseAddress) / m.registerStride, off = (a - m.baseAddress) % m.registerStride;
    const std::string word = moduleWord(m.tag);
    const std::string regName = registerName(m.tag, reg);
    if (m.tag == tag::kLed) return word;
    if (m.tag == tag::kSSerial) {
      const unsigned instance = off / m.instanceStride, within = off % m.instanceStride;
      if (reg < 2) return fmt::format("sserial.{}.{}", instance, regName);
      return fmt::format("sserial.{}.ch{}.{}", instance, within / 4, regName);
    }
    const bool perInstance = ((m.multipleRegisters >> reg) & 1U) != 0;
    const unsigned instance = off / m.instanceStride;
    if (!perInstance) return fmt::format("{}.{}", word, regName);
    if (m.tag == tag::kWatchdog && m.instances == 1) return fmt::format("watchdog.{}", regName);
    // LinuxCNC numbers encoders with two digits (hm2_7i92.0.encoder.03).
    if (m.tag == tag::kMuxedQCount || m.tag == tag::kQCount) return fmt::format("encoder.{:02}.{}", instance, regName);
    return fmt::format("{}.{}.{}", word, instance, regName);
  }
  return {};
}

std::optional<RegisterNames::Sserial> RegisterNames::sserial(std::uint16_t a) const {
  for (const auto& m : info_.modules) {
    if (m.tag != tag::kSSerial || m.registerStride == 0 || m.instanceStride == 0) continue;
    if (a < m.baseAddress || a >= m.baseAddress + m.registers * m.registerStride) continue;
    const unsigned reg = (a - m.baseAddress) / m.registerStride, off = (a - m.baseAddress) % m.registerStride;
    return Sserial{off / m.instanceStride, reg, reg < 2 ? 0U : off % m.instanceStride / 4};
  }
  return std::nullopt;
}

CardInfo cardInfoFromRegisters(const std::map<std::uint16_t, std::uint32_t>& registers) {
  CapturedRegisters card(registers);
  return readCardInfo(card);
}

std::string localRegisterName(std::uint8_t c) {
  // docs/protocol-facts.md#lbp-local-commands: the same register at 0xC0+n
  // (read) and 0xE0+n (write), some with a different meaning when written.
  static constexpr std::array<std::string_view, 32> kRead = {
      "UnitAddress", "Status",     "CRCEnable",  "CRCErrorCount", "Local04",     "Local05",    "RemoteSwMode",
      "ClearFault",  "Local08",    "Local09",    "RPCMEM",        "CommandTimeout", "NVAccess", "Local0D",
      "Local0E",     "Local0F",    "CardName0",  "CardName1",     "CardName2",   "CardName3",  "Capability",
      "SwRevision",  "HwMode",     "FaultStatus", "AddressLow",   "AddressHigh", "LBPVersion", "UnitID",
      "RPCPitch",    "RPCSizeLow", "RPCSizeHigh", "Cookie"};
  const unsigned n = c & 0x1FU;
  if (c < 0xC0) return {};
  if (c < 0xE0) return std::string(kRead[n]);
  switch (c) {
    case wire::lbp::local_write::kLeds: return "LEDs";
    case wire::lbp::local_write::kAddToAddress: return "AddToAddress";
    case wire::lbp::local_write::kUnitId: return "SetUnitID";
    case wire::lbp::local_write::kResetProcessor: return "ResetProcessor";
    case wire::lbp::local_write::kResetParser: return "ResetParser";
    default: return std::string(kRead[n]);
  }
}

std::string lbpHeaderName(std::uint8_t h) {
  using wire::lbp::CommandType;
  switch (wire::lbp::commandType(h)) {
    case CommandType::Data: {
      const auto d = wire::lbp::DataCommand::decode(h);
      return fmt::format("{} {} byte{}{}{}{}", d.write ? "write" : "read", d.dataSize, d.dataSize == 1 ? "" : "s",
                         d.hasAddress ? ", 2-byte address" : ", at the pointer", d.autoInc ? ", auto-increment" : "",
                         d.rpcIncludesData ? ", RID" : "");
    }
    case CommandType::Rpc:
      switch (h) {
        case wire::lbp::special_rpc::kDiscovery: return "RPC 0xBB Discovery";
        case wire::lbp::special_rpc::kUnitNumber: return "RPC 0xBC UnitNumber";
        case wire::lbp::special_rpc::kProcessData: return "RPC 0xBD ProcessData";
        default: return fmt::format("RPC {} (stored list)", h & 0x3FU);
      }
    case CommandType::Local:
      return fmt::format("local {} {}", h < 0xE0 ? "read" : "write", localRegisterName(h));
    default: return fmt::format("0x{:02X} is not a command", h);
  }
}

}  // namespace lbpkit::decode
