// SPDX-License-Identifier: MIT
#include "lbp16/lbp16_card.hpp"

#include <algorithm>
#include <cstring>
#include <stdexcept>

namespace lbpkit::server {

namespace {
constexpr std::uint8_t k16 = 2, k32 = 4;  // the access widths the spaces take (no space takes bytes)
// Flash: the card's part (cards::Lbp16Details: its ID, whose low byte is
// the size code, and its size); 64 KB sectors, 256-byte pages.
using lbp16::kEepromWriteEnableKey;
using lbp16::kFlashWriteEnableKey;
constexpr std::uint32_t kFlashSector = 64 * 1024;
// The EEPROM's first 16 words (MAC, reserved words, card name) cannot be
// written with the public write enable 0x5A02 (LBPPARSE.ASM lbpwrite2: word
// address 15 or below is a write error).
constexpr std::uint32_t kEepromFirstWritable = 0x20;

// Space 4 (ETHERHM2.INC mem4; LinuxCNC's lbp_timers_area), word addresses.
namespace timer {
constexpr unsigned kTimestamp = 0;     // microseconds; writes do nothing
constexpr unsigned kWaitUs = 1;        // a write waits that many us; reads give the last wait
constexpr unsigned kHm2Timeout = 2;    // us the WaitForHM2 registers wait at most
constexpr unsigned kWaitForHm2 = 3;    // 3 RefTime, 4..7 Timer1..4: wait for that timer's edge
// words 8..15 (0x10..0x1F): scratch, kept as written
}  // namespace timer
// Space 6 (ETHERHM2.INC mem6; LinuxCNC's lbp_status_area; mesaflash), word addresses.
namespace status {
constexpr unsigned kError = 0, kParseErrors = 1, kMemErrors = 2, kWriteErrors = 3;
constexpr unsigned kRxPackets = 4, kRxUdp = 5, kRxBad = 6, kTxPackets = 7, kTxUdp = 8, kTxBad = 9;
constexpr unsigned kWriteEnable = lbp16::comm::kEepromWriteEnable / 2;  // 0x1A
constexpr unsigned kConfig = 0x1E / 2;  // ICAP (Xilinx) or configuration register (Efinix)
}  // namespace status

// What reloads the FPGA through the configuration register (mesaflash
// lbp16.c lbp16_board_reload). Xilinx: ICAP words, the IPROG command
// (0x000E) written to the command register (0x30A1 announces one word for
// it; Spartan-6 configuration packets). Efinix: "config enable" (bit 2) with
// "config start" (bit 3); bit 0 picks image 1 (the user area) or 0.
constexpr std::uint16_t kIcapWriteCommand = 0x30A1;
constexpr std::uint16_t kIcapIprog = 0x000E;
constexpr std::uint16_t kEfinixEnableStart = 0x000C;

std::uint16_t le16(const std::uint8_t* p) { return static_cast<std::uint16_t>(p[0] | (p[1] << 8)); }
// The firmware's counters stop at 0xFFFF rather than wrap.
void bump(std::uint16_t& counter) {
  if (counter != 0xFFFF) ++counter;
}
}  // namespace

const Lbp16Card::Area* Lbp16Card::area(std::uint8_t space) {
  // Names, size words and ranges as Mesa's Ethernet firmware sets them up
  // (ETHERHM2.INC LBPMemSpaceN / LBPMemRangesN, ETHERINI.ASM): bit 15 of the
  // size word is "writable", 14..8 the type (1 registers, 2 memory, 0x0E
  // EEPROM, 0x0F flash), 3..0 the widths allowed. Ranges are log2 of the
  // size (the flash's also page and erase sizes: 256 B, 64 KB); spaces 4, 6
  // and 7 say 4 but hold 16 words.
  static constexpr Area kAreas[8] = {
      {"HostMot2", 0x8100 | k32, 0x0010, 0x10000},      // 0
      {"KSZ8851", 0x8100 | k16, 0x0008, 0x100},         // 1
      {"EtherEEP", 0x8E00 | k16, 0x0007, 0x80},         // 2
      {"FPGAFlsh", 0x8F00 | k32, 0x8200 | 21, 0x10},    // 3: 2^21 bytes, 2^8 pages, 2^16 erase
      {"Timers", 0x8200 | k16, 0x0004, 0x20},           // 4
      {nullptr, 0, 0, 0},                               // 5: none
      {"LBP16RW", 0x8200 | k16, 0x0004, 0x20},          // 6
      {"LBP16RO", 0x0200 | k16, 0x0004, 0x20},          // 7
  };
  return space < 8 && kAreas[space].name ? &kAreas[space] : nullptr;
}

Lbp16Card::Lbp16Card(model::hm2::HostMot2Card& card, Identity identity)
    : card_(card),
      identity_(std::move(identity)),
      flash_(card.description().lbp16.flashBytes, 0xFF),
      flashBytes_(card.description().lbp16.flashBytes) {
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
  if (!identity_.flashFile.empty()) {
    const auto loaded = loadFlashFile(identity_.flashFile, flash_);
    if (loaded.status == FlashFileLoad::Status::Refused) throw std::runtime_error(loaded.message);
    saver_ = std::make_unique<FlashSaver>(identity_.flashFile, [this](std::vector<std::uint8_t>& into) {
      const std::lock_guard<std::mutex> l(flashMutex_);
      into.assign(flash_.begin(), flash_.end());
    });
    // A file of the wrong size or CRC starts blank: written at the first change.
  }
}

Lbp16Card::~Lbp16Card() = default;  // the saver saves what changed since its last save

std::uint8_t Lbp16Card::infoByte(std::uint8_t space, std::uint32_t offset) const {
  // Area info (ETHERHM2.INC memNc): cookie 0x5A0n, size word, ranges, the
  // space's address pointer, name (8 characters, NUL padded).
  const Area* a = area(space);
  if (a == nullptr) return 0;
  std::uint16_t ranges = a->ranges;
  if (space == 3) {
    // The flash's size (log2) from the card's part, beside its page and erase sizes.
    unsigned log2 = 0;
    while ((2U << log2) <= flashBytes_) ++log2;
    ranges = static_cast<std::uint16_t>((ranges & 0xFFC0U) | log2);
  }
  const std::uint16_t words[4] = {static_cast<std::uint16_t>(lbp16::kInfoAreaCookie | space), a->sizeWord, ranges,
                                  pointer_[space]};
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

void Lbp16Card::error(std::uint16_t bit) {
  status_[status::kError] |= bit;
  switch (bit) {
    case ErrorBit::kParse: ++counters_.parseErrors; bump(status_[status::kParseErrors]); break;
    case ErrorBit::kMemory: ++counters_.memoryErrors; bump(status_[status::kMemErrors]); break;
    case ErrorBit::kWrite: ++counters_.writeErrors; bump(status_[status::kWriteErrors]); break;
    case ErrorBit::kRx: ++counters_.rxErrors; bump(status_[status::kRxBad]); break;
    case ErrorBit::kTx: ++counters_.txErrors; bump(status_[status::kTxBad]); break;
    case ErrorBit::kHm2Timeout: ++counters_.hm2Timeouts; break;
    default: break;
  }
}

void Lbp16Card::noteSendFailed() { error(ErrorBit::kTx); }

void Lbp16Card::waitForHm2() {
  // WaitForHM2RefTime / Timer1..4 wait for the rising edge of a HostMot2
  // timer (the HM2DPLL module's) or HM2Timeout us. Not modelled against the
  // DPLL of the "d" firmwares (7I92T, 7I96S): every wait ends by the timeout
  // and sets the HostMot2-timeout error (LBPPARSE.ASM waitforhtimer), as it
  // does on a firmware without one.
  const std::uint16_t us = timer_[timer::kHm2Timeout];
  wait(std::chrono::microseconds(us));
  error(ErrorBit::kHm2Timeout);
  timer_[timer::kWaitForHm2] = us;  // a read returns how long it waited
}

std::uint16_t Lbp16Card::readWord16(std::uint8_t space, std::uint32_t address, model::hm2::SimTime now) {
  const unsigned word = address / 2;
  switch (space) {
    case 1: return ethernetChip_[word % ethernetChip_.size()];
    case 2: return static_cast<std::uint16_t>(eeprom_[address & 0x7F] | (eeprom_[(address + 1) & 0x7F] << 8));
    case 4:
      if (word == timer::kTimestamp) return static_cast<std::uint16_t>(now.count() / 1000);  // microseconds
      if (word >= timer::kWaitForHm2 && word < timer::kWaitForHm2 + 5) {
        waitForHm2();
        return timer_[timer::kWaitForHm2];
      }
      return timer_[word % timer_.size()];
    case 6: return status_[word % status_.size()];
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

void Lbp16Card::configure(std::uint16_t value, model::hm2::SimTime now) {
  const bool efinix = card_.description().lbp16.family == model::hm2::cards::FpgaFamily::Efinix;
  const bool reload = efinix ? (value & kEfinixEnableStart) == kEfinixEnableStart
                             : icapLast_ == kIcapWriteCommand && value == kIcapIprog;
  icapLast_ = value;
  if (!reload) return;
  // The whole FPGA loads again: the HostMot2 modules, and the LBP16
  // processor in it with its spaces 4 and 6 (counters, error flags, address
  // pointers); the Ethernet chip and the EEPROM are parts of their own.
  ++counters_.reloads;
  reloading_ = true;
  card_.reconfigure(now);
  status_.fill(0);
  timer_.fill(0);
  pointer_.fill(0);
  infoPointer_ = 0;
  icapLast_ = 0;
}

void Lbp16Card::writeWord16(std::uint8_t space, std::uint32_t address, std::uint16_t value, model::hm2::SimTime now) {
  const unsigned word = address / 2;
  switch (space) {
    case 1: ethernetChip_[word % ethernetChip_.size()] = value; return;
    case 2:
      // The public write enable opens the EEPROM from 0x20 on (IP, LED
      // debug and the rest); the MAC and board name stay as they are.
      if (status_[status::kWriteEnable] != kEepromWriteEnableKey || address < kEepromFirstWritable) {
        error(ErrorBit::kWrite);
        return;
      }
      eeprom_[address & 0x7F] = static_cast<std::uint8_t>(value);
      eeprom_[(address + 1) & 0x7F] = static_cast<std::uint8_t>(value >> 8);
      return;
    case 4:
      timer_[word % timer_.size()] = value;  // stored, as the firmware does, whatever the register
      if (word == timer::kWaitUs) wait(std::chrono::microseconds(value));
      if (word >= timer::kWaitForHm2 && word < timer::kWaitForHm2 + 5) waitForHm2();
      return;
    case 6:
      // Every word is the host's to write (the counters and the error
      // register too: writing 0 clears them); 0x1C reset does nothing
      // here; 0x1E reloads the FPGA when the card's family says so.
      status_[word % status_.size()] = value;
      if (word == status::kConfig) configure(value, now);
      return;
    default: error(ErrorBit::kWrite); return;
  }
}

std::uint64_t Lbp16Card::read(std::uint8_t space, std::uint32_t address, unsigned size, model::hm2::SimTime now) {
  switch (space) {
    case 0: return card_.read32(static_cast<std::uint16_t>(address), now);
    case 3:
      switch (address) {
        case 0: return flashAddress_;
        case 4: {
          std::uint32_t v = 0;
          for (unsigned i = 0; i < 4; ++i) v |= std::uint32_t{flash_[(flashAddress_ + i) % flashBytes_]} << (8 * i);
          flashAddress_ = (flashAddress_ + 4) % flashBytes_;
          return v;
        }
        case 8: return card_.description().lbp16.flashId;
        default: error(ErrorBit::kMemory); return 0;  // the erase register is write only
      }
    default: {
      std::uint64_t v = 0;
      for (unsigned i = 0; i < size; i += 2) v |= static_cast<std::uint64_t>(readWord16(space, address + i, now)) << (8 * i);
      return v;
    }
  }
}

void Lbp16Card::write(std::uint8_t space, std::uint32_t address, unsigned size, std::uint64_t value,
                      model::hm2::SimTime now) {
  switch (space) {
    case 0: card_.write32(static_cast<std::uint16_t>(address), static_cast<std::uint32_t>(value), now); return;
    case 3: {
      if (address == 0) {
        flashAddress_ = static_cast<std::uint32_t>(value) % flashBytes_;
        return;
      }
      if (address == 8) {
        error(ErrorBit::kMemory);  // the ID cannot be written (LBPPARSE.ASM lbpwrite3)
        return;
      }
      if (status_[status::kWriteEnable] != kFlashWriteEnableKey) {
        error(ErrorBit::kWrite);  // programming and erasing need the write enable
        return;
      }
      {
        const std::lock_guard<std::mutex> l(flashMutex_);
        if (address == 0xC) {
          // Sector erase: the 64 KB sector holding the flash address reads 0xFF.
          const auto start = flashAddress_ / kFlashSector * kFlashSector;
          std::fill_n(flash_.begin() + start, kFlashSector, std::uint8_t{0xFF});
        } else {
          // Page program: NOR flash only clears bits; the address advances.
          for (unsigned i = 0; i < 4; ++i) {
            auto& b = flash_[(flashAddress_ + i) % flashBytes_];
            b = static_cast<std::uint8_t>(b & (value >> (8 * i)));
          }
          flashAddress_ = (flashAddress_ + 4) % flashBytes_;
        }
      }
      flashChanged();
      return;
    }
    default:
      for (unsigned i = 0; i < size; i += 2)
        writeWord16(space, address + i, static_cast<std::uint16_t>(value >> (8 * i)), now);
      return;
  }
}

std::size_t Lbp16Card::handle(std::span<const std::uint8_t> request, std::span<std::uint8_t> reply,
                              model::hm2::SimTime now) {
  ++counters_.packets;
  bump(status_[status::kRxPackets]);
  status_[status::kWriteEnable] = 0;  // each datagram starts without the write enable
  waited_ = std::chrono::microseconds{0};
  reloading_ = false;
  if (request.size() > kMaxDatagram) {
    error(ErrorBit::kRx);  // bigger than one frame: a real card never receives it whole
    return 0;
  }
  const std::size_t limit = std::min(reply.size(), kMaxDatagram);
  std::size_t pos = 0, out = 0;
  bool clean = true;
  // A reload ends the datagram: the processor parsing it is part of the FPGA
  // (mesaflash sends the Efinix reload in a datagram whose tail it never
  // filled in).
  while (pos < request.size() && !reloading_) {
    if (pos + 2 > request.size()) {
      error(ErrorBit::kParse);
      clean = false;
      break;
    }
    const auto cmd = lbp16::Command::decode(le16(&request[pos]));
    pos += 2;
    std::uint16_t& pointer = cmd.infoArea ? infoPointer_ : pointer_[cmd.space];
    std::uint32_t address = pointer;
    if (cmd.hasAddress) {
      if (pos + 2 > request.size()) {
        error(ErrorBit::kParse);
        clean = false;
        break;
      }
      address = le16(&request[pos]);
      pos += 2;
    }
    const unsigned bytes = cmd.dataBytes();
    if (cmd.count == 0) {
      error(ErrorBit::kParse);  // a null command ends the datagram (LBPPARSE.ASM)
      clean = false;
      break;
    }
    if (cmd.write ? pos + bytes > request.size() : out + bytes > limit) {
      // Missing write data; or a reply bigger than a frame (the firmware's
      // send buffer limit: a memory error).
      error(cmd.write ? ErrorBit::kParse : ErrorBit::kMemory);
      clean = false;
      break;
    }
    const Area* a = area(cmd.space);
    // A space the card lacks, or a width it does not take (info areas are
    // 16-bit): a parse error in the firmware, which answers nothing; here
    // the command still gets its length (zeros), so a client never waits.
    const bool widthOk = a && (cmd.infoArea ? cmd.size == 2 : (a->sizeWord & cmd.size) != 0);
    if (!widthOk) {
      error(ErrorBit::kParse);
      clean = false;
    }
    // The flash space's registers do not move: its data register advances
    // the flash address itself (LBPPARSE.ASM parse_3 keeps lbpaddr3).
    const bool advance = cmd.autoIncrement && (cmd.infoArea || cmd.space != 3);
    for (unsigned i = 0; i < cmd.count; ++i) {
      const std::uint32_t at = address + (advance ? i * cmd.size : 0);
      const bool inRange = a && at + cmd.size <= (cmd.infoArea ? 16U : a->bytes);
      if (!inRange && widthOk) {
        error(ErrorBit::kMemory);
        clean = false;
      }
      // Waits (timer space) make what follows happen later.
      const model::hm2::SimTime t = now + std::chrono::duration_cast<model::hm2::SimTime>(waited_);
      if (cmd.write) {
        std::uint64_t v = 0;
        for (unsigned b = 0; b < cmd.size; ++b) v |= static_cast<std::uint64_t>(request[pos + b]) << (8 * b);
        pos += cmd.size;
        if (cmd.infoArea || (a && (a->sizeWord & 0x8000) == 0)) {
          error(ErrorBit::kWrite);  // info areas and read-only spaces
          clean = false;
        } else if (widthOk && inRange) {
          write(cmd.space, at, cmd.size, v, t);
        }
      } else {
        std::uint64_t v = 0;
        if (cmd.infoArea && inRange && widthOk) {
          for (unsigned b = 0; b < cmd.size; ++b) v |= static_cast<std::uint64_t>(infoByte(cmd.space, at + b)) << (8 * b);
        } else if (widthOk && inRange) {
          v = read(cmd.space, at, cmd.size, t);
        }
        for (unsigned b = 0; b < cmd.size; ++b) reply[out++] = static_cast<std::uint8_t>(v >> (8 * b));
      }
    }
    pointer = static_cast<std::uint16_t>(advance ? address + bytes : address);
  }
  if (clean) bump(status_[status::kRxUdp]);  // a datagram parsed without error
  if (out > 0) {
    ++counters_.replies;
    bump(status_[status::kTxPackets]);
    bump(status_[status::kTxUdp]);
  }
  return out;
}

}  // namespace lbpkit::server
