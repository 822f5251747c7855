#include "lbp16/lbp16_card.hpp"

#include <algorithm>
#include <cstring>

namespace net {

namespace {
constexpr std::uint8_t k8 = 1, k16 = 2, k32 = 4, k64 = 8;
// Flash: a 16 Mbit SPI part, as on a real 7I92 (ID low byte 0x14).
constexpr std::uint32_t kFlashId = 0x00164014;
using lbp16::kEepromWriteEnableKey;
using lbp16::kFlashWriteEnableKey;
constexpr std::uint32_t kFlashBytes = 2 * 1024 * 1024;  // 16 Mbit
constexpr std::uint32_t kFlashSector = 64 * 1024;

std::uint16_t le16(const std::uint8_t* p) { return static_cast<std::uint16_t>(p[0] | (p[1] << 8)); }
}  // namespace

const Lbp16Card::Area* Lbp16Card::area(std::uint8_t space) {
  // Declared once: every LBP16 space this card has.
  static constexpr Area kAreas[8] = {
      {"HostMot2", 0x10000, k32 | k64, 1, true},  // 0
      {"ENetChip", 0x100, k16, 1, false},         // 1
      {"EEPROM", 0x80, k8 | k16, 14, true},       // 2
      {"SPIFlash", 0x10, k32, 15, true},          // 3
      {"Timers", 0x20, k16, 1, true},             // 4
      {nullptr, 0, 0, 0, false},                  // 5: none
      {"LBPStat", 0x20, k16, 1, true},            // 6
      {"BoardID", 0x20, k8 | k16, 2, false},      // 7
  };
  return space < 8 && kAreas[space].name ? &kAreas[space] : nullptr;
}

Lbp16Card::Lbp16Card(hm2::HostMot2Card& card, Identity identity)
    : card_(card), identity_(std::move(identity)), flash_(kFlashBytes, 0xFF) {
  // EEPROM layout as hm2_eth and mesaflash read it: MAC at 0x02..0x07 (each
  // word with the first byte of its pair high; word 0x06 holds MAC[0..1]),
  // the card name at 0x10, IP at 0x20 (low word c.d) and 0x22 (high word a.b).
  const auto& m = identity_.mac;
  const std::uint8_t macBytes[6] = {m[5], m[4], m[3], m[2], m[1], m[0]};
  std::copy_n(macBytes, 6, eeprom_.begin() + lbp16::eeprom::kMac);
  std::copy_n(identity_.name.begin(), std::min<std::size_t>(identity_.name.size(), 16),
              eeprom_.begin() + lbp16::eeprom::kCardName);
  const auto& ip = identity_.ip;
  for (unsigned i = 0; i < 4; ++i) eeprom_[lbp16::eeprom::kIp + i] = ip[3 - i];
}

std::uint8_t Lbp16Card::infoByte(std::uint8_t space, std::uint32_t offset) const {
  // Area info: cookie, size (RW, type, widths), range (log2 sizes), address, name[8].
  const Area* a = area(space);
  if (a == nullptr) return 0;
  unsigned log2 = 0;
  while ((1U << log2) < a->bytes) ++log2;
  std::uint16_t words[4] = {
      static_cast<std::uint16_t>(lbp16::kInfoAreaCookie | space),
      static_cast<std::uint16_t>((a->writable ? 0x8000 : 0) | (a->type << 8) | a->widths),
      static_cast<std::uint16_t>(space == 3 ? (21U | (8U << 6) | (16U << 11)) : log2),  // flash: 2 MB, 256 B pages, 64 KB erase
      0};
  if (offset < 8) return static_cast<std::uint8_t>(words[offset / 2] >> (8 * (offset % 2)));
  if (offset < 16) {
    const std::size_t i = offset - 8;
    return i < std::strlen(a->name) ? static_cast<std::uint8_t>(a->name[i]) : 0;
  }
  return 0;
}

Lbp16Card::Eeprom Lbp16Card::eeprom() const {
  // Stored as hm2_eth and mesaflash read them: MAC and IP last byte first,
  // the name NUL padded (lbp16::eeprom).
  Eeprom e;
  for (std::size_t i = 0; i < e.mac.size(); ++i) e.mac[i] = eeprom_[lbp16::eeprom::kMac + e.mac.size() - 1 - i];
  for (std::size_t i = 0; i < e.ip.size(); ++i) e.ip[i] = eeprom_[lbp16::eeprom::kIp + e.ip.size() - 1 - i];
  for (std::size_t i = lbp16::eeprom::kCardName; i < lbp16::eeprom::kCardName + 16U && eeprom_[i] != 0; ++i)
    e.name.push_back(static_cast<char>(eeprom_[i]));
  return e;
}

std::uint16_t Lbp16Card::readWord16(std::uint8_t space, std::uint32_t address, hm2::SimTime now) {
  const auto us = static_cast<std::uint64_t>(now.count() / 1000);
  switch (space) {
    case 2: return static_cast<std::uint16_t>(eeprom_[address & 0x7F] | (eeprom_[(address + 1) & 0x7F] << 8));
    case 4:
      if (address >= lbp16::timer::kScratch && address < lbp16::timer::kScratchEnd)
        return scratch_[(address - lbp16::timer::kScratch) / 2];
      if (address == lbp16::timer::kMicroseconds) return static_cast<std::uint16_t>(us);  // microsecond timestamp
      return 0;
    case 6:
      switch (address) {
        case 0x00: return static_cast<std::uint16_t>(counters_.parseErrors || counters_.memoryErrors || counters_.writeErrors);
        case 0x02: return static_cast<std::uint16_t>(counters_.parseErrors);
        case 0x04: return static_cast<std::uint16_t>(counters_.memoryErrors);
        case 0x06: return static_cast<std::uint16_t>(counters_.writeErrors);
        case 0x08:
        case 0x0A: return static_cast<std::uint16_t>(counters_.packets);  // RX packets / good UDP
        case 0x0C: return static_cast<std::uint16_t>(counters_.parseErrors);
        case 0x0E:
        case 0x10: return static_cast<std::uint16_t>(counters_.replies);
        case 0x14: return ledMode_;
        case lbp16::comm::kScratch: return commScratch_;
        default: return 0;
      }
    case 7: {
      if (address < 0x10) {
        auto ch = [&](std::uint32_t i) {
          return i < identity_.name.size() ? static_cast<std::uint8_t>(identity_.name[i]) : std::uint8_t{0};
        };
        return static_cast<std::uint16_t>(ch(address) | (ch(address + 1) << 8));  // "7I92", NUL padded
      }
      if (address == 0x10) return identity_.lbp16Version;
      if (address == 0x12) return identity_.firmwareVersion;
      if (address == 0x14) return identity_.jumpers;
      return 0;
    }
    default: return 0;
  }
}

std::uint64_t Lbp16Card::read(std::uint8_t space, std::uint32_t address, unsigned size, hm2::SimTime now) {
  switch (space) {
    case 0: {
      const std::uint64_t lo = card_.read32(static_cast<std::uint16_t>(address), now);
      if (size == 4) return lo;
      return lo | (static_cast<std::uint64_t>(card_.read32(static_cast<std::uint16_t>(address + 4), now)) << 32);
    }
    case 3:
      switch (address & 0xC) {
        case 0: return flashAddress_;
        case 4: {
          std::uint32_t v = 0;
          for (unsigned i = 0; i < 4; ++i) v |= std::uint32_t{flash_[(flashAddress_ + i) % kFlashBytes]} << (8 * i);
          flashAddress_ = (flashAddress_ + 4) % kFlashBytes;
          return v;
        }
        case 8: return kFlashId;
        default: return 0;
      }
    default: {
      std::uint64_t v = 0;
      for (unsigned i = 0; i < size; i += 2) v |= static_cast<std::uint64_t>(readWord16(space, address + i, now)) << (8 * i);
      return size == 1 ? v & 0xFF : v;
    }
  }
}

void Lbp16Card::write(std::uint8_t space, std::uint32_t address, unsigned size, std::uint64_t value, hm2::SimTime now) {
  switch (space) {
    case 0:
      card_.write32(static_cast<std::uint16_t>(address), static_cast<std::uint32_t>(value), now);
      if (size == 8) card_.write32(static_cast<std::uint16_t>(address + 4), static_cast<std::uint32_t>(value >> 32), now);
      return;
    case 2:
      if (writeEnable_ != kEepromWriteEnableKey) {
        ++counters_.writeErrors;
        return;
      }
      for (unsigned i = 0; i < size; ++i) eeprom_[(address + i) & 0x7F] = static_cast<std::uint8_t>(value >> (8 * i));
      return;
    case 3:
      if ((address & 0xC) == 0) {
        flashAddress_ = static_cast<std::uint32_t>(value) % kFlashBytes;
        return;
      }
      if (writeEnable_ != kFlashWriteEnableKey || (address & 0xC) == 8) {
        ++counters_.writeErrors;  // programming needs the write enable; the ID is read only
        return;
      }
      if ((address & 0xC) == 0xC) {
        // Sector erase: the 64 KB sector holding the flash address reads 0xFF.
        const auto start = flashAddress_ / kFlashSector * kFlashSector;
        std::fill_n(flash_.begin() + start, kFlashSector, std::uint8_t{0xFF});
        return;
      }
      // Page program: NOR flash only clears bits; the address advances.
      for (unsigned i = 0; i < 4; ++i) {
        auto& b = flash_[(flashAddress_ + i) % kFlashBytes];
        b = static_cast<std::uint8_t>(b & (value >> (8 * i)));
      }
      flashAddress_ = (flashAddress_ + 4) % kFlashBytes;
      return;
    case 4:
      if (address >= lbp16::timer::kScratch && address < lbp16::timer::kScratchEnd) {
        for (unsigned i = 0; i < size; i += 2)
          if (address + i < lbp16::timer::kScratchEnd) scratch_[(address + i - lbp16::timer::kScratch) / 2] = static_cast<std::uint16_t>(value >> (8 * i));
      }
      return;
    case 6:
      if (address == 0x14) ledMode_ = static_cast<std::uint16_t>(value);
      else if (address == lbp16::comm::kScratch) commScratch_ = static_cast<std::uint16_t>(value);
      else if (address == lbp16::comm::kEepromWriteEnable) writeEnable_ = static_cast<std::uint16_t>(value);
      // 0x1C reset and 0x1E ICAP reload: nothing to do for a virtual FPGA
      return;
    default:
      ++counters_.writeErrors;
      return;
  }
}

std::size_t Lbp16Card::handle(std::span<const std::uint8_t> request, std::span<std::uint8_t> reply, hm2::SimTime now) {
  ++counters_.packets;
  writeEnable_ = 0;
  if (request.size() > kMaxDatagram) {
    ++counters_.parseErrors;  // bigger than one frame: a real card never sees it
    return 0;
  }
  const std::size_t limit = std::min(reply.size(), kMaxDatagram);
  std::size_t pos = 0, out = 0;
  while (pos < request.size()) {
    if (pos + 2 > request.size()) {
      ++counters_.parseErrors;
      break;
    }
    const auto cmd = lbp16::Command::decode(le16(&request[pos]));
    pos += 2;
    std::uint32_t address = pointer_[cmd.space];
    if (cmd.hasAddress) {
      if (pos + 2 > request.size()) {
        ++counters_.parseErrors;
        break;
      }
      address = le16(&request[pos]);
      pos += 2;
    }
    const unsigned bytes = cmd.dataBytes();
    if (cmd.write ? pos + bytes > request.size() : out + bytes > limit) {
      ++counters_.parseErrors;  // missing write data, or a reply bigger than a frame
      break;
    }
    const Area* a = area(cmd.space);
    const bool widthOk = a && (cmd.infoArea || (a->widths & cmd.size));
    if (!widthOk) ++counters_.memoryErrors;
    for (unsigned i = 0; i < cmd.count; ++i) {
      const std::uint32_t at = address + (cmd.autoIncrement ? i * cmd.size : 0);
      const bool inRange = a && at + cmd.size <= (cmd.infoArea ? 16U : a->bytes);
      if (!inRange && widthOk) ++counters_.memoryErrors;
      if (cmd.write) {
        std::uint64_t v = 0;
        for (unsigned b = 0; b < cmd.size; ++b) v |= static_cast<std::uint64_t>(request[pos + b]) << (8 * b);
        pos += cmd.size;
        if (cmd.infoArea) ++counters_.writeErrors;
        else if (widthOk && inRange) write(cmd.space, at, cmd.size, v, now);
        else if (a && !a->writable) ++counters_.writeErrors;
      } else {
        std::uint64_t v = 0;
        if (cmd.infoArea && inRange) {
          for (unsigned b = 0; b < cmd.size; ++b) v |= static_cast<std::uint64_t>(infoByte(cmd.space, at + b)) << (8 * b);
        } else if (widthOk && inRange) {
          v = read(cmd.space, at, cmd.size, now);
        }
        for (unsigned b = 0; b < cmd.size; ++b) reply[out++] = static_cast<std::uint8_t>(v >> (8 * b));
      }
    }
    pointer_[cmd.space] = static_cast<std::uint16_t>(cmd.autoIncrement ? address + bytes : address);
  }
  if (out > 0) ++counters_.replies;
  return out;
}

}  // namespace net
