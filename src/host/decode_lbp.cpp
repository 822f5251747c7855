// SPDX-License-Identifier: MIT
// `lbpkit decode` of LBP on a serial line (manual: REFERENCE INFORMATION,
// LBP; docs/protocol-facts.md#lbp): each command the host sent, by its
// header (data read/write, RPC, local register by name), its CRC checked
// (manual: CRC), and the remote's answer with its CRC.
#include <fmt/format.h>

#include <algorithm>

#include "lbpkit/decode.hpp"
#include "lbpkit/wire/crc8.hpp"
#include "lbpkit/wire/lbp.hpp"

namespace lbpkit::decode {

namespace {
namespace lbp = wire::lbp;

// A gap longer than the longest framing timeout, 25.5 characters at the
// setup-mode 115.2 kBaud (manual: FRAMING), resets the remote's parser: a
// command cut by one is incomplete.
constexpr std::int64_t kGapNs = 2'300'000;

std::string hexBytes(std::span<const std::uint8_t> b) {
  std::string s;
  for (auto c : b) s += fmt::format("{}{:02X}", s.empty() ? "" : " ", c);
  return s;
}

std::uint32_t little32(std::span<const std::uint8_t> b) {
  std::uint32_t v = 0;
  for (std::size_t i = std::min<std::size_t>(b.size(), 4); i-- > 0;) v = v << 8 | b[i];
  return v;
}

std::string crcNote(std::span<const std::uint8_t> covered, std::uint8_t crc) {
  const std::uint8_t want = lbp::crc8(covered);
  return want == crc ? "CRC ok" : fmt::format("CRC BAD (0x{:02X}, should be 0x{:02X})", crc, want);
}
}  // namespace

void LbpStreamDecoder::toRemote(std::int64_t ns, std::span<const std::uint8_t> bytes, std::vector<Event>& out) {
  // A new command: the ones before it had all the answer they will get.
  for (const auto& c : waiting_) {
    const std::size_t n = c.replyBytes < 0 ? reply_.size() : std::min<std::size_t>(reply_.size(), static_cast<std::size_t>(c.replyBytes));
    tell(c, std::span<const std::uint8_t>(reply_).first(n), false, out);
    reply_.erase(reply_.begin(), reply_.begin() + static_cast<std::ptrdiff_t>(n));
  }
  waiting_.clear();
  if (!reply_.empty()) {
    out.push_back({ns, fmt::format("  {} stray bytes from the remote: {}", reply_.size(), hexBytes(reply_)), true});
    reply_.clear();
  }
  if (!in_.empty() && ns - lastInNs_ > kGapNs) {
    out.push_back({inNs_, fmt::format("> incomplete command {} (cut short by a {:.1f} ms gap: the remote's parser "
                                      "starts again)",
                                      hexBytes(in_), double(ns - lastInNs_) / 1e6),
                   true});
    in_.clear();
  }
  if (in_.empty()) inNs_ = ns;
  lastInNs_ = ns;
  in_.insert(in_.end(), bytes.begin(), bytes.end());
  parse(out);
}

void LbpStreamDecoder::parse(std::vector<Event>& out) {
  while (!in_.empty()) {
    const std::uint8_t h = in_[0];
    std::size_t need = 0;
    int reply = -1;
    std::string text;
    switch (lbp::commandType(h)) {
      case lbp::CommandType::Undefined:
        // Not a command: the remote's parser skips to the next gap (manual: FRAMING).
        out.push_back({inNs_, fmt::format("> 0x{:02X} is not an LBP command (bits 7..6 are 00); {} bytes skipped: {}",
                                          h, in_.size(), hexBytes(in_)),
                       true});
        in_.clear();
        return;
      case lbp::CommandType::Data: {
        const auto d = lbp::DataCommand::decode(h);
        need = 1 + d.streamBytes() + 1;
        reply = d.write ? 1 : d.dataSize + 1;
        break;
      }
      case lbp::CommandType::Rpc:
        need = 2;
        if (h == lbp::special_rpc::kDiscovery) reply = 7;
        else if (h == lbp::special_rpc::kUnitNumber) reply = 5;
        else if (h == lbp::special_rpc::kProcessData && sizesKnown_) {
          need = 1 + txSize_ + 1;
          reply = static_cast<int>(rxSize_) + 1;
        } else if (h == lbp::special_rpc::kProcessData) {
          need = in_.size();  // its sizes come from a discovery RPC this capture lacks: the burst is the command
        }
        break;
      case lbp::CommandType::Local:
        if (h == lbp::local_write::kResetParser) {
          need = 1;
          reply = 0;
        } else if (h < 0xE0) {
          need = 2;
          reply = 2;
        } else {
          need = 3;
          reply = 1;
        }
        break;
    }
    if (in_.size() < need) return;  // the rest is still coming
    Command c;
    c.ns = inNs_;
    c.bytes.assign(in_.begin(), in_.begin() + static_cast<std::ptrdiff_t>(need));
    in_.erase(in_.begin(), in_.begin() + static_cast<std::ptrdiff_t>(need));
    inNs_ = lastInNs_;
    c.replyBytes = reply;
    const std::span<const std::uint8_t> b(c.bytes);
    text = fmt::format("> LBP 0x{:02X} {}", h, lbpHeaderName(h));
    if (lbp::commandType(h) == lbp::CommandType::Data) {
      const auto d = lbp::DataCommand::decode(h);
      std::size_t at = 1;
      if (d.hasAddress) {
        text += fmt::format(" at 0x{:04X}", b[1] | b[2] << 8);
        at = 3;
      }
      if (d.write && !d.rpcIncludesData) text += fmt::format(" = {}", hexBytes(b.subspan(at, d.dataSize)));
    } else if (h >= 0xE0 && h != lbp::local_write::kResetParser) {
      text += fmt::format(" = 0x{:02X}", b[1]);
    } else if (h == lbp::special_rpc::kProcessData && b.size() > 2) {
      text += fmt::format(" outputs {}", hexBytes(b.subspan(1, b.size() - 2)));
    }
    if (need > 1) {
      c.crcOk = lbp::crc8(b.first(need - 1)) == b[need - 1];
      text += "  " + crcNote(b.first(need - 1), b[need - 1]);
    }
    c.text = std::move(text);
    if (reply == 0) {
      tell(c, {}, true, out);
    } else {
      waiting_.push_back(std::move(c));
    }
  }
}

void LbpStreamDecoder::fromRemote(std::int64_t ns, std::span<const std::uint8_t> bytes, std::vector<Event>& out) {
  if (waiting_.empty()) {
    out.push_back({ns, fmt::format("< {} bytes from the remote with no command waiting: {}", bytes.size(),
                                   hexBytes(bytes)),
                   true});
    return;
  }
  reply_.insert(reply_.end(), bytes.begin(), bytes.end());
  replyNs_ = ns;
  answer(out);
}

void LbpStreamDecoder::answer(std::vector<Event>& out) {
  while (!waiting_.empty() && waiting_.front().replyBytes >= 0 &&
         reply_.size() >= static_cast<std::size_t>(waiting_.front().replyBytes)) {
    const auto n = static_cast<std::size_t>(waiting_.front().replyBytes);
    tell(waiting_.front(), std::span<const std::uint8_t>(reply_).first(n), true, out);
    reply_.erase(reply_.begin(), reply_.begin() + static_cast<std::ptrdiff_t>(n));
    waiting_.erase(waiting_.begin());
  }
}

void LbpStreamDecoder::tell(const Command& c, std::span<const std::uint8_t> r, bool whole, std::vector<Event>& out) {
  std::string text = c.text;
  bool bad = !c.crcOk;
  const std::uint8_t h = c.bytes.front();
  if (c.replyBytes == 0) {
    out.push_back({c.ns, text, bad});
    return;
  }
  if (r.empty()) {
    out.push_back({c.ns, text + "  (no answer)", true});
    return;
  }
  const auto data = r.first(r.size() - 1);
  text += fmt::format("  < {}", data.empty() ? "(no data)" : hexBytes(data));
  if (h == lbp::special_rpc::kDiscovery && data.size() == 6) {
    // RXSize, TXSize, PTOCP, GTOCP (docs/protocol-facts.md#special-rpcs).
    rxSize_ = data[0];
    txSize_ = data[1];
    sizesKnown_ = true;
    text += fmt::format(" (RXSize {}, TXSize {}, PTOCP 0x{:04X}, GTOCP 0x{:04X})", data[0], data[1],
                        data[2] | data[3] << 8, data[4] | data[5] << 8);
  } else if (h == lbp::special_rpc::kUnitNumber && data.size() == 4) {
    text += fmt::format(" (unit 0x{:08X})", little32(data));
  } else if (h == lbp::local_read::kStatus && data.size() == 1 && data[0] != 0) {
    // LBP status bits (manual: LOCAL LBP READ COMMANDS, 0xC1).
    std::string bits;
    for (unsigned b = 0; b < 8; ++b)
      if (data[0] & (1U << b))
        bits += fmt::format("{}{}", bits.empty() ? "" : " ",
                            lbp::status::kNames[b].empty() ? fmt::format("bit{}", b) : std::string(lbp::status::kNames[b]));
    text += fmt::format(" ({})", bits);
  } else if (h == lbp::local_read::kCookie && data.size() == 1) {
    text += data[0] == lbp::kCookie ? " (the cookie)" : " (not the cookie 0x5A)";
  } else if (h >= lbp::local_read::kCardName0 && h < lbp::local_read::kCardName0 + 4 && data.size() == 1 &&
             data[0] >= 0x20 && data[0] < 0x7F) {
    text += fmt::format(" '{}'", static_cast<char>(data[0]));
  } else if (data.size() > 1 && data.size() <= 4 && lbp::commandType(h) == lbp::CommandType::Data) {
    text += fmt::format(" (0x{:0{}X})", little32(data), 2 * data.size());
  }
  text += "  " + crcNote(data, r.back());
  bad = bad || lbp::crc8(data) != r.back();
  if (!whole && c.replyBytes > 0)
    text += fmt::format("  (answer cut short: {} of {} bytes)", r.size(), c.replyBytes);
  if (replyNs_ > c.ns) text += fmt::format("  [{:.0f} us]", double(replyNs_ - c.ns) / 1e3);
  out.push_back({c.ns, text, bad || (!whole && c.replyBytes > 0)});
}

void LbpStreamDecoder::finish(std::vector<Event>& out) {
  for (const auto& c : waiting_) {
    const std::size_t n = c.replyBytes < 0 ? reply_.size() : std::min<std::size_t>(reply_.size(), static_cast<std::size_t>(c.replyBytes));
    tell(c, std::span<const std::uint8_t>(reply_).first(n), c.replyBytes < 0, out);
    reply_.erase(reply_.begin(), reply_.begin() + static_cast<std::ptrdiff_t>(n));
  }
  waiting_.clear();
  if (!in_.empty())
    out.push_back({inNs_, fmt::format("> incomplete command at the end of the capture: {}", hexBytes(in_)), true});
  in_.clear();
}

}  // namespace lbpkit::decode
