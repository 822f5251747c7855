// SPDX-License-Identifier: MIT
#include "lbpkit/discovery.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <bit>
#include <cctype>
#include <cmath>
#include <map>

#include "lbpkit/error.hpp"
#include "lbpkit/wire/names.hpp"

namespace lbpkit {

namespace {

// Reads a remote's memory in aligned 8-byte chunks (LBP read 0x47) and
// keeps them, so records and strings next to each other cost one command
// per 8 bytes instead of one per byte.
class ChunkReader {
 public:
  explicit ChunkReader(RemoteAccess& r) : remote_(r) {}
  std::uint8_t byte(std::uint32_t address) {
    if (address > 0xFFFF) throw Error(fmt::format("{}: read past the end of remote memory", remote_.where()));
    const auto base = static_cast<std::uint16_t>(address & ~7U);
    auto it = chunks_.find(base);
    if (it == chunks_.end()) it = chunks_.emplace(base, remote_.read(base, 8)).first;
    return static_cast<std::uint8_t>(it->second >> (8 * (address & 7U)));
  }
  std::uint64_t value(std::uint32_t address, unsigned bytes) {
    std::uint64_t v = 0;
    for (unsigned i = 0; i < bytes; ++i) v |= static_cast<std::uint64_t>(byte(address + i)) << (8 * i);
    return v;
  }
  std::string string(std::uint32_t& address, unsigned max, const std::string& what) {
    std::string s;
    for (unsigned i = 0; i <= max; ++i) {
      const auto c = static_cast<char>(byte(address++));
      if (c == 0) return s;
      s.push_back(c);
    }
    throw Error(fmt::format("{}: {} at 0x{:04X} is unterminated or longer than {} characters", remote_.where(), what,
                            address - max - 1, max));
  }

 private:
  RemoteAccess& remote_;
  std::map<std::uint16_t, std::uint64_t> chunks_;
};


std::vector<std::uint16_t> readToc(ChunkReader& r, RemoteAccess& remote, std::uint16_t toc, const char* table,
                                   const DiscoveryLimits& limits) {
  std::vector<std::uint16_t> entries;
  for (unsigned i = 0;; ++i) {
    if (i >= limits.maxEntries)
      throw Error(fmt::format("{}: {} at 0x{:04X} has no 0 sentinel within {} entries", remote.where(), table, toc,
                              limits.maxEntries));
    const auto at = static_cast<std::uint32_t>(toc) + 2 * i;
    const auto e = static_cast<std::uint16_t>(r.value(at, 2));
    if (e == 0) break;
    if (std::find(entries.begin(), entries.end(), e) != entries.end())
      throw Error(fmt::format("{}: {} entry {} at 0x{:04X} points to record 0x{:04X} again (a pointer loop)",
                              remote.where(), table, i, at, e));
    if (e > 0xFFFF - wire::lbp::pdd::kStrings)
      throw Error(fmt::format("{}: {} entry {} at 0x{:04X} points out of range (0x{:04X})", remote.where(), table, i,
                              at, e));
    entries.push_back(e);
  }
  return entries;
}

}  // namespace

std::string typeName(DataType t) {
  switch (t) {
    case DataType::Pad: return "PAD";
    case DataType::Bits: return "BITS";
    case DataType::Unsigned: return "UNSIGNED";
    case DataType::Signed: return "SIGNED";
    case DataType::NonVolUnsigned: return "NONVOL_UNSIGNED";
    case DataType::NonVolSigned: return "NONVOL_SIGNED";
    case DataType::Stream: return "STREAM";
    case DataType::Boolean: return "BOOLEAN";
    case DataType::Encoder: return "ENCODER";
    case DataType::Float: return "FLOAT";
    case DataType::NonVolFloat: return "NONVOL_FLOAT";
  }
  return fmt::format("0x{:02X}", static_cast<unsigned>(t));
}

std::string directionName(Direction d) {
  switch (d) {
    case Direction::Input: return "in";
    case Direction::Bidirectional: return "io";
    case Direction::Output: return "out";
  }
  return "?";
}

bool ProcessDataElement::numeric() const {
  return type == DataType::Unsigned || type == DataType::Signed || type == DataType::NonVolUnsigned ||
         type == DataType::NonVolSigned;
}
std::int64_t ProcessDataElement::lowest() const {
  if (!isSigned() || width() == 0) return 0;
  return width() >= 64 ? INT64_MIN : -(std::int64_t{1} << (width() - 1));
}

bool ProcessDataElement::fits(std::int64_t v) const {
  if (isSigned()) return v >= lowest() && v <= static_cast<std::int64_t>(highest());
  return v >= 0 && static_cast<std::uint64_t>(v) <= highest();
}

double ProcessDataElement::scale(std::uint64_t raw) const {
  const unsigned n = width();
  if (isSigned()) {
    const std::int64_t v = fromRaw(raw);
    if (min == max || n < 2) return static_cast<double>(v);
    return static_cast<double>(v) * static_cast<double>(max) / static_cast<double>((1ULL << (n - 1)) - 1);
  }
  if (type == DataType::Unsigned || type == DataType::NonVolUnsigned) {
    if (min == max || n == 0) return static_cast<double>(raw);
    const double full = n >= 64 ? 18446744073709551615.0 : static_cast<double>((1ULL << n) - 1);
    return min + static_cast<double>(raw) * (static_cast<double>(max) - min) / full;
  }
  return static_cast<double>(raw);
}

std::uint64_t ProcessDataElement::unscale(double value) const {
  const unsigned n = width();
  const std::uint64_t mask = rawMask();
  if (!numeric() || min == max) return toRaw(std::llround(value));
  value = std::clamp(value, static_cast<double>(min), static_cast<double>(max));
  if (isSigned()) {
    const double top = static_cast<double>((1ULL << (n - 1)) - 1);
    return static_cast<std::uint64_t>(std::llround(value / static_cast<double>(max) * top)) & mask;
  }
  const double full = static_cast<double>(mask);
  return static_cast<std::uint64_t>(std::llround((value - min) / (static_cast<double>(max) - min) * full)) & mask;
}

std::string canonicalParameterName(const std::string& name) {
  const std::string l = wire::asciiLower(name);
  // The manual's RPD/WPD spellings for what real remotes call NVWatchDogTimeout and WatchDogTime.
  if (l == "nvwatchdogtime" || l == "nvwatchdogtimeout") return "nvwatchdogtimeout";
  if (l == "watchdogtime" || l == "watchdogtimeout") return "watchdogtime";
  return l;
}

unsigned RemoteDescription::bytewiseReads() const {
  std::size_t n = 0;
  n += 2 * (processData.size() + modes.size() + 1);  // PTOC
  n += 2 * (static_cast<std::size_t>(gtocEntries) + 1);  // GTOC
  for (const auto* list : {&processData, &parameters})
    for (const auto& e : *list) n += wire::lbp::pdd::kStrings + e.unit.size() + 1 + e.name.size() + 1;
  // Mode records: the GTOC's (all the remote's modes, the PTOC's among them) when it has any.
  for (const auto& m : gtocModes.empty() ? modes : gtocModes) n += wire::lbp::mode_record::kName + m.name.size() + 1;
  return static_cast<unsigned>(n);
}

const ProcessDataElement* RemoteDescription::find(const std::string& name) const {
  const std::string want = canonicalParameterName(name);
  for (const auto* list : {&parameters, &processData})
    for (const auto& e : *list)
      if (canonicalParameterName(e.name) == want) return &e;
  return nullptr;
}

RemoteDescription discover(RemoteAccess& remote, std::uint16_t ptoc, std::uint16_t gtoc,
                           std::optional<unsigned> expectedRx, std::optional<unsigned> expectedTx,
                           DiscoveryLimits limits) {
  if (ptoc == 0) throw Error(fmt::format("{}: the remote reports no PTOC (no process data discovery)", remote.where()));
  ChunkReader r(remote);
  RemoteDescription d;

  auto record = [&](std::uint16_t at, const char* table, unsigned index, ProcessDataElement& e, ModeDescriptor& m) {
    const auto type = r.byte(at);
    namespace pdd = wire::lbp::pdd;
    namespace mode = wire::lbp::mode_record;
    if (type == wire::lbp::kModeRecord) {
      m.index = r.byte(at + mode::kIndex);
      m.type = r.byte(at + mode::kType);
      std::uint32_t p = at + mode::kName;
      m.name = r.string(p, limits.maxString, fmt::format("{} entry {} mode name", table, index));
      return false;
    }
    if (type != wire::lbp::kProcessDataRecord)
      throw Error(fmt::format("{}: {} entry {} points to 0x{:04X}, a record of unknown type 0x{:02X} "
                              "(expected 0x{:02X} process data or 0x{:02X} mode)",
                              remote.where(), table, index, at, type, wire::lbp::kProcessDataRecord,
                              wire::lbp::kModeRecord));
    e.record = at;
    e.bits = r.byte(at + pdd::kDataSize);
    const auto dataType = r.byte(at + pdd::kDataType);
    const auto dir = r.byte(at + pdd::kDirection);
    e.min = std::bit_cast<float>(static_cast<std::uint32_t>(r.value(at + pdd::kMin, 4)));
    e.max = std::bit_cast<float>(static_cast<std::uint32_t>(r.value(at + pdd::kMax, 4)));
    e.address = static_cast<std::uint16_t>(r.value(at + pdd::kAddress, 2));
    std::uint32_t p = at + pdd::kStrings;
    e.unit = r.string(p, limits.maxString, fmt::format("{} entry {} unit string", table, index));
    e.name = r.string(p, limits.maxString, fmt::format("{} entry {} name string", table, index));
    const auto where = fmt::format("{}: {} entry {} (record 0x{:04X}, \"{}\")", remote.where(), table, index, at, e.name);
    if (!wire::lbp::isKnownDataType(dataType)) throw Error(fmt::format("{}: unknown data type 0x{:02X}", where, dataType));
    if (!wire::lbp::isDirection(dir))
      throw Error(fmt::format("{}: invalid data direction 0x{:02X}", where, dir));
    if (e.bits == 0) throw Error(fmt::format("{}: data size of 0 bits", where));
    if (e.bits > limits.maxBitsPerDirection)
      throw Error(fmt::format("{}: data size of {} bits is over the {} bits SSLBP can carry", where, e.bits,
                              limits.maxBitsPerDirection));
    if (e.name.empty()) throw Error(fmt::format("{}: empty name", where));
    e.type = static_cast<DataType>(dataType);
    e.direction = static_cast<Direction>(dir);
    return true;
  };

  const auto ptocEntries = readToc(r, remote, ptoc, "PTOC", limits);
  for (unsigned i = 0; i < ptocEntries.size(); ++i) {
    ProcessDataElement e;
    ModeDescriptor m;
    if (record(ptocEntries[i], "PTOC", i, e, m)) {
      if (isNonVolatile(e.type))
        throw Error(fmt::format("{}: PTOC entry {} (\"{}\") is non-volatile; process data cannot be", remote.where(),
                                i, e.name));
      if (e.fromRemote()) d.inputBits += e.bits;
      if (e.toRemote()) d.outputBits += e.bits;
      d.processData.push_back(std::move(e));
    } else {
      d.modes.push_back(std::move(m));
    }
  }
  if (d.inputBits > limits.maxBitsPerDirection || d.outputBits > limits.maxBitsPerDirection)
    throw Error(fmt::format("{}: process data of {} bits in and {} bits out does not fit {} bits each way",
                            remote.where(), d.inputBits, d.outputBits, limits.maxBitsPerDirection));
  if (expectedRx && *expectedRx != d.rxBytes())
    throw Error(fmt::format("{}: the PTOC adds up to {} bytes from the remote (fault byte included) but the "
                            "discovery RPC says {}",
                            remote.where(), d.rxBytes(), *expectedRx));
  if (expectedTx && *expectedTx != d.txBytes())
    throw Error(fmt::format("{}: the PTOC adds up to {} bytes to the remote but the discovery RPC says {}",
                            remote.where(), d.txBytes(), *expectedTx));

  if (gtoc != 0) {
    const auto gtocEntries = readToc(r, remote, gtoc, "GTOC", limits);
    d.gtocEntries = static_cast<unsigned>(gtocEntries.size());
    for (unsigned i = 0; i < gtocEntries.size(); ++i) {
      ProcessDataElement e;
      ModeDescriptor m;
      if (!record(gtocEntries[i], "GTOC", i, e, m)) {
        d.gtocModes.push_back(std::move(m));
        continue;
      }
      // A GTOC entry at a PTOC element's address is that process data (as LinuxCNC decides).
      const bool inPtoc = std::any_of(d.processData.begin(), d.processData.end(),
                                      [&](const ProcessDataElement& p) { return p.address == e.address; });
      if (!inPtoc) d.parameters.push_back(std::move(e));
    }
  }
  return d;
}

}  // namespace lbpkit
