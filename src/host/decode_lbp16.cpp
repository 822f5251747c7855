// SPDX-License-Identifier: MIT
// `lbpkit decode` of LBP16 datagrams (docs/protocol-facts.md#lbp16), and of
// the SSLBP commands the host writes through them
// (docs/protocol-facts.md#sslbp: COMMAND, CS, setup-mode remote accesses).
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <string_view>

#include "lbpkit/decode.hpp"
#include "lbpkit/wire/hostmot2.hpp"
#include "lbpkit/wire/lbp.hpp"
#include "lbpkit/wire/lbp16.hpp"
#include "lbpkit/wire/sslbp.hpp"

namespace lbpkit::decode {

namespace {
namespace lbp16 = wire::lbp16;
namespace command = wire::sslbp::command;
namespace tag = wire::hm2::tag;

constexpr std::array<std::string_view, 8> kSpaceNames = {"hm2",   "ethernet", "eeprom", "flash",
                                                         "timer", "space5",   "comm",   "board"};

// Names in the 16-bit spaces hm2_eth and mesaflash use (LinuxCNC, mesaflash: lbp16.h).
std::string spaceRegister(unsigned space, std::uint16_t a) {
  switch (space) {
    case 2:
      if (a >= lbp16::eeprom::kMac && a < lbp16::eeprom::kMac + 6) return "eeprom.mac";
      if (a >= lbp16::eeprom::kCardName && a < lbp16::eeprom::kCardName + 16) return "eeprom.card_name";
      if (a == lbp16::eeprom::kIp || a == lbp16::eeprom::kIp + 2) return "eeprom.ip";
      return {};
    case 3:
      switch (a) {
        case 0x0: return "flash.address";
        case 0x4: return "flash.data";
        case 0x8: return "flash.id";
        case 0xC: return "flash.erase";
        default: return {};
      }
    case 4:
      if (a == lbp16::timer::kMicroseconds) return "timer.microseconds";
      if (a >= lbp16::timer::kScratch && a < lbp16::timer::kScratchEnd) return "timer.scratch";
      return {};
    case 6: {
      static constexpr std::array<std::string_view, 14> kComm = {
          "comm.error",      "comm.parse_errors", "comm.memory_errors", "comm.write_errors", "comm.rx_packets",
          "comm.rx_success", "comm.rx_bad",       "comm.tx_packets",    "comm.tx_success",   "comm.tx_bad",
          "comm.led_mode",   "comm.debug",        "comm.scratch",       "comm.write_enable"};
      return a % 2 == 0 && a / 2 < kComm.size() ? std::string(kComm[a / 2]) : std::string();
    }
    case 7:
      if (a < 0x10) return "board.name";
      if (a == 0x10) return "board.lbp16_version";
      if (a == 0x12) return "board.firmware_version";
      if (a == 0x14) return "board.jumpers";
      return {};
    default: return {};
  }
}

std::string channelList(unsigned mask) {
  std::string s;
  for (unsigned c = 0; c < 8; ++c)
    if (mask & (1U << c)) s += fmt::format("{}{}", s.empty() ? "" : ",", c);
  return s.empty() ? "none" : s;
}

// SSLBP local parameters (docs/protocol-facts.md#sslbp-local-parameters).
std::string localParameter(unsigned a) {
  static constexpr std::array<std::string_view, 8> kHead = {
      "INTERFACE_TYPE", "INTERFACE_WIDTH", "MAJORREV", "MINORREV", "GP_INPUTS (channel block start)",
      "GP_OUTPUTS (channel block stride)", "PROCESSOR_TYPE", "CHANNELS"};
  if (a < kHead.size()) return std::string(kHead[a]);
  if (a < 0x28) return "remote names";
  if (a < 0x70) return {};
  const unsigned c = (a - 0x70) / 0x32, off = (a - 0x70) % 0x32;
  if (c >= 8) return {};
  const char* what = nullptr;
  switch (off) {
    case 0x10: what = "state"; break;
    case 0x12: what = "error log"; break;
    case 0x13: what = "status"; break;
    case 0x14: what = "CRC errors"; break;
    case 0x15: what = "cookie errors"; break;
    case 0x16: what = "overrun errors"; break;
    case 0x17: what = "timeout errors"; break;
    case 0x18: what = "extra character errors"; break;
    case 0x19: what = "break errors"; break;
    case 0x1A: what = "remote fault errors"; break;
    case 0x25: what = "remote fault"; break;
    case 0x2A: case 0x2B: case 0x2C: case 0x2D: what = "baud rate"; break;
    case 0x2E: what = "RX size"; break;
    case 0x2F: what = "TX size"; break;
    default: return fmt::format("channel {} +0x{:02X}", c, off);
  }
  return fmt::format("channel {} {}", c, what);
}

std::string hexValue(std::uint64_t v, unsigned size) {
  return fmt::format("0x{:0{}X}", v, 2 * size);
}

std::uint64_t little(std::span<const std::uint8_t> b) {
  std::uint64_t v = 0;
  for (std::size_t i = b.size(); i-- > 0;) v = v << 8 | b[i];
  return v;
}

std::string csBits(std::uint32_t v) {
  // CS after START / DOIT (docs/protocol-facts.md#sslbp-cs-register).
  std::string s;
  for (unsigned b = 0; b < 8; ++b)
    if (v & (1U << b)) s += fmt::format(" {}", wire::sslbp::cs::kLocalFaultNames[b]);
  for (unsigned b = 0; b < 8; ++b) {
    const auto& n = wire::sslbp::cs::kStatusNames[b];
    if ((v >> 8) & (1U << b) && !n.empty()) s += fmt::format(" {}", n);
  }
  if (v >> 24) s += fmt::format(" remote fault byte 0x{:02X}", v >> 24);
  return s;
}

std::string printable(std::span<const std::uint8_t> b) {
  std::string s;
  for (auto c : b) {
    if (c == 0) continue;
    if (c < 0x20 || c > 0x7E) return {};
    s.push_back(static_cast<char>(c));
  }
  return s.empty() ? s : fmt::format(" \"{}\"", s);
}
}  // namespace

Lbp16Decoder::Lbp16Decoder(CardInfo info) : names_(std::move(info)) {}

std::string Lbp16Decoder::remoteAccess(unsigned instance, unsigned channel) const {
  // A setup-mode access (manual: SETUP MODE OPERATION, REMOTE READ EXAMPLE):
  // the LBP command in CS's top byte, the remote address in its low word,
  // data to write in interface 0.
  const auto& ch = sserial_.at(instance).channel[channel];
  const auto h = static_cast<std::uint8_t>(ch.cs >> 24);
  const auto address = static_cast<std::uint16_t>(ch.cs & 0xFFFF);
  using wire::lbp::CommandType;
  switch (wire::lbp::commandType(h)) {
    case CommandType::Data: {
      const auto d = wire::lbp::DataCommand::decode(h);
      const std::string at = d.hasAddress ? fmt::format(" at 0x{:04X}", address) : " at the pointer";
      if (!d.write) return fmt::format("ch{}: remote read {} byte{}{} (LBP 0x{:02X})", channel, d.dataSize,
                                       d.dataSize == 1 ? "" : "s", at, h);
      const std::uint64_t mask = d.dataSize >= 4 ? 0xFFFFFFFFULL : (1ULL << (8 * d.dataSize)) - 1;
      return fmt::format("ch{}: remote write {} byte{} {}{} (LBP 0x{:02X})", channel, d.dataSize,
                         d.dataSize == 1 ? "" : "s", hexValue(ch.interface0 & mask, std::min<unsigned>(d.dataSize, 4)),
                         at, h);
    }
    case CommandType::Local:
      if (h < 0xE0) return fmt::format("ch{}: remote local read 0x{:02X} {}", channel, h, localRegisterName(h));
      return fmt::format("ch{}: remote local write 0x{:02X} {} = 0x{:02X}", channel, h, localRegisterName(h),
                         ch.interface0 & 0xFF);
    case CommandType::Rpc: return fmt::format("ch{}: remote {}", channel, lbpHeaderName(h));
    default: return fmt::format("ch{}: CS 0x{:08X} holds no LBP command", channel, ch.cs);
  }
}

std::string Lbp16Decoder::describeWrite(std::uint16_t address, std::uint32_t v) {
  const auto where = names_.sserial(address);
  if (!where) {
    // The HostMot2 watchdog (docs/protocol-facts.md#hostmot2-watchdog).
    const std::string n = names_.name(address);
    if (n == "watchdog.timer") {
      if (v & 0x80000000U) return "  (disabled)";
      const auto* m = names_.card().module(tag::kWatchdog);
      if (m && m->clockHz) return fmt::format("  (bites after {:g} us)", (double(v) + 1) * 1e6 / m->clockHz);
    }
    if (n == "watchdog.reset" && (v >> 24) == 0x5A) return "  (pet)";
    return {};
  }
  auto& inst = sserial_[where->instance];
  if (where->reg == wire::sslbp::reg::kCs) {
    auto& ch = inst.channel[where->channel];
    ch.cs = v;
    if (ch.setup) {
      // The address matters to data commands only (manual: SETUP MODE OPERATION).
      const auto h = static_cast<std::uint8_t>(v >> 24);
      const bool data = wire::lbp::commandType(h) == wire::lbp::CommandType::Data;
      return fmt::format("  (setup-mode access: {}{})", lbpHeaderName(h),
                         data ? fmt::format(" 0x{:04X}", v & 0xFFFF) : std::string());
    }
    return v >> 24 ? fmt::format("  (remote software mode {} for START)", v >> 24) : std::string();
  }
  if (where->reg == wire::sslbp::reg::kInterface0) {
    inst.channel[where->channel].interface0 = v;
    return {};
  }
  if (where->reg != wire::sslbp::reg::kCommand) return {};
  // The COMMAND register (docs/protocol-facts.md#sslbp-command-register).
  if (v & command::kIgnore) return "  (ignored: bit 31 set)";
  inst.lastCommand = v;
  const unsigned mask = v & 0xFF;
  if (v & command::kRequest) {
    const unsigned a = v & command::kAddressMask;
    const std::string n = localParameter(a);
    return fmt::format("  SSLBP local {} 0x{:03X}{}", (v & command::kWrite) ? "write" : "read", a,
                       n.empty() ? "" : " " + n);
  }
  switch (v & command::kTypeMask) {
    case command::kStop:
      for (unsigned c = 0; c < 8; ++c)
        if (mask == 0 || (mask & (1U << c))) inst.channel[c].setup = false;
      return mask == 0 ? "  SSLBP STOP ALL" : fmt::format("  SSLBP STOP channels {}", channelList(mask));
    case command::kStart: {
      std::string modes;
      for (unsigned c = 0; c < 8; ++c)
        if (mask & (1U << c)) {
          inst.channel[c].setup = false;
          modes += fmt::format("{}ch{} mode {}", modes.empty() ? " (" : ", ", c, inst.channel[c].cs >> 24);
        }
      return fmt::format("  SSLBP START channels {}{}", channelList(mask), modes.empty() ? "" : modes + ")");
    }
    case command::kSetupStart:
      for (unsigned c = 0; c < 8; ++c)
        if (mask & (1U << c)) inst.channel[c].setup = true;
      return fmt::format("  SSLBP setup START channels {}", channelList(mask));
    case command::kDoit: {
      std::string s = fmt::format("  SSLBP DOIT channels {}", channelList(mask));
      for (unsigned c = 0; c < 8; ++c) {
        auto& ch = inst.channel[c];
        ch.remoteRead = false;
        if (!(mask & (1U << c)) || !ch.setup) continue;
        s += "; " + remoteAccess(where->instance, c);
        const auto h = static_cast<std::uint8_t>(ch.cs >> 24);
        ch.remoteRead = wire::lbp::commandType(h) == wire::lbp::CommandType::Rpc ||
                        (wire::lbp::commandType(h) == wire::lbp::CommandType::Data &&
                         !wire::lbp::DataCommand::decode(h).write) ||
                        (h >= 0xC0 && h < 0xE0);
      }
      return s;
    }
    case command::kReset: return "  SSLBP processor reset";
    case 0: return mask ? fmt::format("  SSLBP 0x{:04X}", v) : std::string();
    default: return fmt::format("  SSLBP command 0x{:04X} (not one of the manual's)", v & 0xFFFF);
  }
}

std::string Lbp16Decoder::describeRead(std::uint16_t address, std::uint32_t v) const {
  const auto where = names_.sserial(address);
  if (!where) return {};
  const auto it = sserial_.find(where->instance);
  if (where->reg == wire::sslbp::reg::kCs) {
    const std::string bits = csBits(v);
    return bits.empty() ? std::string() : fmt::format("  ({})", bits.substr(1));
  }
  if (it == sserial_.end()) return {};
  const auto& inst = it->second;
  if (where->reg == wire::sslbp::reg::kData && (inst.lastCommand & command::kRequest) &&
      !(inst.lastCommand & command::kWrite)) {
    const unsigned a = inst.lastCommand & command::kAddressMask;
    const std::string n = localParameter(a);
    return fmt::format("  (local 0x{:03X}{})", a, n.empty() ? "" : " " + n);
  }
  if (where->reg == wire::sslbp::reg::kData && (inst.lastCommand & command::kTypeMask) == command::kDoit && v != 0)
    return fmt::format("  (failed channels {})", channelList(v & 0xFF));
  if (where->reg == wire::sslbp::reg::kInterface0 && inst.channel[where->channel].remoteRead)
    return "  (the remote's answer)";
  return {};
}

void Lbp16Decoder::request(std::int64_t ns, std::span<const std::uint8_t> d, std::vector<Event>& out) {
  finish(out);  // an earlier request's reads that had no reply
  pendingNs_ = ns;
  if (d.empty()) {
    out.push_back({ns, "> empty datagram: no LBP16 command", true});
    return;
  }
  std::size_t at = 0;
  while (at < d.size()) {
    if (d.size() - at < 2) {
      out.push_back({ns, fmt::format("> truncated datagram: 1 byte (0x{:02X}) at offset {} where a 2-byte command word "
                                     "should be",
                                     d[at], at),
                     true});
      return;
    }
    const auto word = static_cast<std::uint16_t>(d[at] | d[at + 1] << 8);
    const auto c = lbp16::Command::decode(word);
    const std::size_t commandAt = at;
    at += 2;
    std::uint16_t address = pointer_[c.space];
    if (c.hasAddress) {
      if (d.size() - at < 2) {
        out.push_back({ns, fmt::format("> truncated datagram: command 0x{:04X} at offset {} wants a 2-byte address, "
                                       "{} byte left",
                                       word, commandAt, d.size() - at),
                       true});
        return;
      }
      address = static_cast<std::uint16_t>(d[at] | d[at + 1] << 8);
      at += 2;
    }
    if (c.count == 0) {
      pending_.push_back({ns, word, address, c.hasAddress, 0});
      continue;
    }
    if (!c.infoArea) pointer_[c.space] = static_cast<std::uint16_t>(address + (c.autoIncrement ? c.dataBytes() : 0));
    if (c.write) {
      if (d.size() - at < c.dataBytes()) {
        out.push_back({ns, fmt::format("> truncated datagram: write 0x{:04X} at offset {} carries {} data bytes of {}",
                                       word, commandAt, d.size() - at, c.dataBytes()),
                       true});
        return;
      }
      Access a{ns, word, address, c.hasAddress, 0};
      emit(a, d.subspan(at, c.dataBytes()), true, out);
      at += c.dataBytes();
    } else {
      pending_.push_back({ns, word, address, c.hasAddress, pendingBytes_});
      pendingBytes_ += c.dataBytes();
    }
  }
}

void Lbp16Decoder::emit(const Access& a, std::span<const std::uint8_t> data, bool answered, std::vector<Event>& out) {
  const auto c = lbp16::Command::decode(a.word);
  const std::string space = c.infoArea ? fmt::format("{} info area", kSpaceNames[c.space]) : std::string(kSpaceNames[c.space]);
  std::string head = fmt::format("{} {} {} 0x{:04X}", c.write ? ">" : "<", c.write ? "write" : "read ", space, a.address);
  if (c.count != 1) head += fmt::format(" x{}{}", c.count, c.autoIncrement ? "" : " (same address)");
  if (!a.hasAddress) head += " (at the pointer)";
  if (c.count == 0) {
    out.push_back({a.ns, head + ": no transfers", false});
    return;
  }
  std::vector<std::string> items;
  std::string notes, lastName;
  std::vector<std::uint8_t> text;  // the characters of a name read
  const unsigned n = std::min<unsigned>(c.count, static_cast<unsigned>(data.size() / c.size));
  for (unsigned i = 0; i < c.count; ++i) {
    const auto addr = static_cast<std::uint16_t>(a.address + (c.autoIncrement ? i * c.size : 0));
    std::string name;
    if (!c.infoArea) name = c.space == 0 ? names_.name(addr) : spaceRegister(c.space, addr);
    if (i >= n) {
      items.push_back(name.empty() ? "?" : name + " = ?");
      continue;
    }
    const auto bytes = data.subspan(i * c.size, c.size);
    const std::uint64_t v = little(bytes);
    if (c.space == 0 && c.size == 4 && !c.infoArea) {
      if (c.write)
        notes += describeWrite(addr, static_cast<std::uint32_t>(v));
      else {
        read_[addr] = static_cast<std::uint32_t>(v);
        notes += describeRead(addr, static_cast<std::uint32_t>(v));
      }
    }
    // A register read or written several times over (a name spread over
    // words) is named once.
    const bool same = !name.empty() && i > 0 && name == lastName;
    items.push_back(name.empty() || same ? hexValue(v, c.size) : fmt::format("{} = {}", name, hexValue(v, c.size)));
    lastName = name;
    if (name == "board.name" || name == "eeprom.card_name") text.insert(text.end(), bytes.begin(), bytes.end());
  }
  std::string body;
  if (items.size() <= 8) {
    for (const auto& s : items) body += (body.empty() ? "" : ", ") + s;
  } else {
    // A block (the IDROM, a flash page): its first and last, and how many.
    body = fmt::format("{} .. {}", items.front(), items.back());
  }
  body += printable(text);
  std::string line = fmt::format("{}  {}{}", head, body, notes);
  if (!answered) line += "  (no reply)";
  else if (n < c.count) line += fmt::format("  (reply truncated: {} of {} values)", n, c.count);
  out.push_back({a.ns, line, answered && n < c.count});
}

void Lbp16Decoder::reply(std::int64_t ns, std::span<const std::uint8_t> d, std::vector<Event>& out) {
  if (pending_.empty()) {
    out.push_back({ns, fmt::format("< reply of {} bytes with no read waiting for one", d.size()), true});
    return;
  }
  for (const auto& a : pending_) {
    const auto c = lbp16::Command::decode(a.word);
    const std::size_t from = std::min<std::size_t>(a.offset, d.size());
    emit(a, d.subspan(from, std::min<std::size_t>(c.dataBytes(), d.size() - from)), true, out);
  }
  if (d.size() != pendingBytes_)
    out.push_back({ns, fmt::format("< reply of {} bytes, {} expected: {}", d.size(), pendingBytes_,
                                   d.size() < pendingBytes_ ? "truncated" : "extra bytes after the reads"),
                   true});
  pending_.clear();
  pendingBytes_ = 0;
}

void Lbp16Decoder::finish(std::vector<Event>& out) {
  for (const auto& a : pending_) emit(a, {}, false, out);
  pending_.clear();
  pendingBytes_ = 0;
}

}  // namespace lbpkit::decode
