// SPDX-License-Identifier: MIT
#include "lbpkit/parameters.hpp"

#include <fmt/format.h>

#include <cerrno>
#include <cstdlib>

#include "lbpkit/error.hpp"
#include "lbpkit/wire/lbp.hpp"

namespace lbpkit {

namespace {
constexpr std::uint8_t kNonVolatileWrite = wire::lbp::local_write::kNonVolatile;
constexpr std::uint8_t kEeprom = wire::lbp::nonvolatile::kEeprom;
constexpr std::uint8_t kStatusRead = wire::lbp::local_read::kStatus;
constexpr std::uint8_t kStatusWrite = wire::lbp::local_write::kStatus;
constexpr std::uint8_t kInvalidWrite = wire::lbp::status::kInvalidWrite;

// The element's bytes with the widest LBP commands that fit (8, 4, 2, 1).
template <typename Op>
void chunks(const ProcessDataElement& e, Op&& op) {
  const unsigned bytes = (e.bits + 7) / 8;
  unsigned done = 0;
  while (done < bytes) {
    unsigned size = 8;
    while (size > bytes - done) size /= 2;
    op(done, size);
    done += size;
  }
}

struct NvAccess {
  RemoteAccess& r;
  bool on;
  NvAccess(RemoteAccess& remote, bool nv) : r(remote), on(nv) {
    if (on) r.localWrite(kNonVolatileWrite, kEeprom);
  }
  ~NvAccess() {
    if (!on) return;
    try {
      r.localWrite(kNonVolatileWrite, 0);
    } catch (...) {  // the first error is the one to report
    }
  }
};
}  // namespace

std::uint64_t readElement(RemoteAccess& remote, const ProcessDataElement& e) {
  if (e.bits > 64) throw Error(fmt::format("{} has {} bits: too wide to read as a number", e.name, e.bits));
  NvAccess nv(remote, isNonVolatile(e.type));
  std::uint64_t v = 0;
  chunks(e, [&](unsigned offset, unsigned size) {
    v |= remote.read(static_cast<std::uint16_t>(e.address + offset), size) << (8 * offset);
  });
  return e.bits >= 64 ? v : v & ((1ULL << e.bits) - 1);
}

void writeElement(RemoteAccess& remote, const ProcessDataElement& e, std::uint64_t raw) {
  if (e.bits > 64) throw Error(fmt::format("{} has {} bits: too wide to write as a number", e.name, e.bits));
  const bool nonVolatile = isNonVolatile(e.type);
  NvAccess nv(remote, nonVolatile);
  // A refused write still gets its answer; only the status says it did not
  // take (a read-only element, or an EEPROM that could not save the value).
  // Start from a status without the bit, so what follows speaks of this write.
  const std::uint8_t before = remote.localRead(kStatusRead);
  if (before & kInvalidWrite) remote.localWrite(kStatusWrite, static_cast<std::uint8_t>(before & ~kInvalidWrite));
  chunks(e, [&](unsigned offset, unsigned size) {
    const std::uint64_t part = size >= 8 ? raw >> (8 * offset) : (raw >> (8 * offset)) & ((1ULL << (8 * size)) - 1);
    remote.write(static_cast<std::uint16_t>(e.address + offset), size, part);
  });
  const std::uint8_t after = remote.localRead(kStatusRead);
  if (after & kInvalidWrite) {
    remote.localWrite(kStatusWrite, static_cast<std::uint8_t>(after & ~kInvalidWrite));
    throw Error(nonVolatile ? fmt::format("{}: the remote refused to write {} to its EEPROM (LBP status 0x{:02X}: "
                                          "invalid write): the value was not saved",
                                          remote.where(), e.name, after)
                            : fmt::format("{}: the remote refused the write to {} (LBP status 0x{:02X}: invalid write)",
                                          remote.where(), e.name, after));
  }
  if (!nonVolatile) return;  // working values may change under the host's feet (outputs, faults)
  // The EEPROM is read back, as it is what the next power-up will use.
  std::uint64_t back = 0;
  chunks(e, [&](unsigned offset, unsigned size) {
    back |= remote.read(static_cast<std::uint16_t>(e.address + offset), size) << (8 * offset);
  });
  const std::uint64_t mask = e.rawMask();
  if ((back & mask) != (raw & mask))
    throw Error(fmt::format("{}: {} reads back as {} after writing {}: the EEPROM did not keep the value",
                            remote.where(), e.name, back & mask, raw & mask));
}

std::string formatElement(const ProcessDataElement& e, std::uint64_t raw, bool hex) {
  if (hex) return fmt::format("{:0{}X}", raw, (e.bits + 3) / 4);
  if (e.isSigned()) return fmt::format("{}", e.fromRaw(raw));
  return fmt::format("{}", raw);
}

std::uint64_t parseElement(const ProcessDataElement& e, const std::string& text, bool hex) {
  const char* s = text.c_str();
  int base = hex ? 16 : 10;
  if (text.size() > 2 && text[0] == '0' && (text[1] == 'x' || text[1] == 'X')) {
    s += 2;
    base = 16;
  }
  if (*s == '\0') throw Error(fmt::format("\"{}\" is not a number", text));
  errno = 0;
  char* end = nullptr;
  const bool negative = *s == '-';
  std::uint64_t v = 0;
  if (negative) {
    const long long x = std::strtoll(s, &end, base);
    if (!e.isSigned()) throw Error(fmt::format("{} is unsigned: {} is out of range", e.name, text));
    if (!e.fits(x)) throw Error(fmt::format("{} does not fit {} ({} bits)", text, e.name, e.bits));
    v = e.toRaw(x);
  } else {
    v = std::strtoull(s, &end, base);
  }
  if (errno != 0 || end == s || *end != '\0')
    throw Error(fmt::format("\"{}\" is not a {} number", text, base == 16 ? "hexadecimal" : "decimal"));
  if (!negative && v > e.highest()) throw Error(fmt::format("{} does not fit {} ({} bits)", text, e.name, e.bits));
  return v & e.rawMask();
}

}  // namespace lbpkit
