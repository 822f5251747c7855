// SPDX-License-Identifier: MIT
// lbpkit decode FILE.pcap: every LBP16 command in a capture (UDP port
// 27181), with the register it names, the SSLBP commands written through
// them, and every LBP command of a serial-line capture (`lbpkit remote --pty
// --trace`), with their times. The file is read with libpcap; the decoding
// is the host library's (lbpkit/decode.hpp).
//
// Register names come from the IDROM the capture shows the host reading
// (any host reads it at start-up), else from the default virtual 7I92 +
// 7I77 card's IDROM, read by the host library from the in-process card: the
// one source of that IDROM there is (src/models/hostmot2/idrom), not a copy.
#include <fmt/core.h>
#include <pcap/pcap.h>

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "common.hpp"
#include "lbpkit/decode.hpp"
#include "lbpkit/error.hpp"
#include "lbpkit/wire/capture.hpp"
#include "lbpkit/wire/lbp16.hpp"
#include "sim_card/sim_transport.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace app = lbpkit::app;

namespace lbpkit::app {
extern std::function<int()> gRun;
}

namespace {

namespace capture = lbpkit::wire::capture;

struct DecodeOptions {
  std::string file;
  unsigned port = lbpkit::wire::lbp16::kPort;
  bool absolute = false;
  std::string idrom = "auto";  // auto, capture, default
};

// One packet of the capture, reduced to what the decoders take.
struct Packet {
  std::size_t number = 0;  // 1-based, as Wireshark counts
  std::int64_t ns = 0;
  enum class Kind { Request, Reply, ToRemote, FromRemote, Problem } kind = Kind::Problem;
  std::uint64_t card = 0;  // the card's IPv4 address and port (LBP16)
  std::vector<std::uint8_t> bytes;
  std::string problem;  // Kind::Problem: what is wrong with it
};

std::uint16_t be16(const std::uint8_t* p) { return static_cast<std::uint16_t>(p[0] << 8 | p[1]); }

std::string ipText(std::uint32_t a) {
  return fmt::format("{}.{}.{}.{}", a >> 24, (a >> 16) & 0xFF, (a >> 8) & 0xFF, a & 0xFF);
}

// An IPv4 packet from its first byte: the UDP datagram to or from `port`.
// Returns false for packets that are not LBP16 (skipped).
bool fromIpv4(const std::uint8_t* p, std::size_t caplen, std::size_t len, unsigned port, Packet& out) {
  if (caplen < 1 || (p[0] >> 4) != 4) return false;  // not IPv4 (IPv6 and others are not LBP16's)
  const std::size_t ihl = (p[0] & 0x0F) * 4U;
  if (caplen < ihl || ihl < 20) {
    out.kind = Packet::Kind::Problem;
    out.problem = fmt::format("IPv4 header cut short ({} of {} bytes captured)", caplen, std::max<std::size_t>(ihl, 20));
    return true;
  }
  if (p[9] != 17) return false;  // not UDP
  if ((be16(p + 6) & 0x3FFF) != 0) {
    out.kind = Packet::Kind::Problem;
    out.problem = "an IPv4 fragment (LBP16 datagrams are never fragmented): not decoded";
    return true;
  }
  if (caplen < ihl + 8) {
    out.kind = Packet::Kind::Problem;
    out.problem = fmt::format("UDP header cut short ({} of {} bytes captured)", caplen, ihl + 8);
    return true;
  }
  const std::uint8_t* u = p + ihl;
  const unsigned src = be16(u), dst = be16(u + 2), udpLength = be16(u + 4);
  if (src != port && dst != port) return false;
  const std::uint32_t srcIp = std::uint32_t{be16(p + 12)} << 16 | be16(p + 14);
  const std::uint32_t dstIp = std::uint32_t{be16(p + 16)} << 16 | be16(p + 18);
  const bool request = dst == port;
  out.kind = request ? Packet::Kind::Request : Packet::Kind::Reply;
  out.card = request ? (std::uint64_t{dstIp} << 16 | dst) : (std::uint64_t{srcIp} << 16 | src);
  if (udpLength < 8) {
    out.kind = Packet::Kind::Problem;
    out.problem = fmt::format("UDP length {} is less than its own header", udpLength);
    return true;
  }
  const std::size_t payload = udpLength - 8U, have = caplen - ihl - 8;
  if (have < payload) {
    out.kind = Packet::Kind::Problem;
    out.problem = fmt::format("truncated datagram: {} of its {} LBP16 bytes captured{}", have, payload,
                              len > caplen ? " (the capture's snap length cut it)" : " (the file is damaged)");
    return true;
  }
  out.bytes.assign(u + 8, u + 8 + payload);
  return true;
}

// Reads the whole capture (a few MB for a minute of hm2_eth at 1 kHz): the
// decoders go over it twice, once to find the IDROM.
std::vector<Packet> readCapture(const DecodeOptions& o, bool& lbpStream, std::string& trouble) {
  char err[PCAP_ERRBUF_SIZE] = {};
  std::unique_ptr<pcap_t, decltype(&pcap_close)> pcap(
      pcap_open_offline_with_tstamp_precision(o.file.c_str(), PCAP_TSTAMP_PRECISION_NANO, err), &pcap_close);
  if (!pcap) throw lbpkit::Error(fmt::format("decode {}: {}", o.file, err));
  const int link = pcap_datalink(pcap.get());
  lbpStream = link == DLT_USER0;
  if (link != DLT_RAW && link != DLT_EN10MB && link != DLT_LINUX_SLL && link != DLT_LINUX_SLL2 && link != DLT_NULL &&
      link != DLT_LOOP && link != DLT_USER0 && link != DLT_IPV4)
    throw lbpkit::Error(fmt::format("decode {}: link type {} ({}) is not one lbpkit reads: it reads IPv4 captures "
                                    "(raw IP, Ethernet, Linux cooked, loopback) and its own LBP stream records "
                                    "(USER0, 147)",
                                    o.file, link, pcap_datalink_val_to_name(link) ? pcap_datalink_val_to_name(link) : "?"));
  std::vector<Packet> packets;
  pcap_pkthdr* h = nullptr;
  const u_char* data = nullptr;
  for (std::size_t number = 1;; ++number) {
    const int r = pcap_next_ex(pcap.get(), &h, &data);
    if (r == PCAP_ERROR_BREAK) break;  // the end
    if (r != 1) {
      trouble = fmt::format("decode {}: packet {}: {}", o.file, number, pcap_geterr(pcap.get()));
      break;
    }
    Packet p;
    p.number = number;
    p.ns = static_cast<std::int64_t>(h->ts.tv_sec) * 1'000'000'000LL + h->ts.tv_usec;  // nanosecond precision asked
    const std::uint8_t* b = data;
    std::size_t cap = h->caplen;
    if (lbpStream) {
      if (cap < 1) {
        p.problem = "an empty LBP stream record (no direction byte)";
      } else if (b[0] != capture::kToRemote && b[0] != capture::kFromRemote) {
        p.problem = fmt::format("LBP stream record with direction byte 0x{:02X} (0 to the remote, 1 from it)", b[0]);
      } else if (h->len > cap) {
        p.problem = fmt::format("truncated LBP stream record: {} of {} bytes captured", cap, h->len);
      } else {
        p.kind = b[0] == capture::kToRemote ? Packet::Kind::ToRemote : Packet::Kind::FromRemote;
        p.bytes.assign(b + 1, b + cap);
      }
      packets.push_back(std::move(p));
      continue;
    }
    // Down to the IPv4 header.
    std::size_t skip = 0;
    bool ipv4 = true;
    switch (link) {
      case DLT_EN10MB: {
        skip = 14;
        if (cap < 14) { ipv4 = false; break; }
        unsigned type = be16(b + 12);
        while ((type == 0x8100 || type == 0x88A8) && cap >= skip + 4) {  // VLAN tags
          type = be16(b + skip + 2);
          skip += 4;
        }
        ipv4 = type == 0x0800;
        break;
      }
      case DLT_LINUX_SLL: skip = 16; ipv4 = cap >= 16 && be16(b + 14) == 0x0800; break;
      case DLT_LINUX_SLL2: skip = 20; ipv4 = cap >= 20 && be16(b) == 0x0800; break;
      case DLT_NULL:
      case DLT_LOOP: skip = 4; ipv4 = cap >= 4 && (b[0] == 2 || b[3] == 2); break;  // AF_INET either byte order
      default: break;
    }
    if (!ipv4 || cap < skip) continue;
    if (fromIpv4(b + skip, cap - skip, h->len - skip, o.port, p)) packets.push_back(std::move(p));
  }
  return packets;
}

int runDecode(const DecodeOptions& o) {
  bool lbpStream = false;
  std::string trouble;
  const auto packets = readCapture(o, lbpStream, trouble);
  const std::int64_t t0 = packets.empty() ? 0 : packets.front().ns;
  auto stamp = [&](std::int64_t ns) {
    return o.absolute ? fmt::format("{}.{:09}", ns / 1'000'000'000, ns % 1'000'000'000)
                      : fmt::format("{:12.6f}", static_cast<double>(ns - t0) / 1e9);
  };
  std::size_t malformed = 0;
  std::vector<lbpkit::decode::Event> events;
  auto print = [&](const std::string& prefix) {
    for (const auto& e : events) {
      fmt::print("{}  {}{}\n", stamp(e.ns), prefix, e.text);
      malformed += e.malformed ? 1 : 0;
    }
    events.clear();
  };
  auto problem = [&](const Packet& p) {
    fmt::print("{}  ! packet {}: {}\n", stamp(p.ns), p.number, p.problem);
    ++malformed;
  };

  if (lbpStream) {
    fmt::print("LBP on a serial line ({} records)\n", packets.size());
    lbpkit::decode::LbpStreamDecoder d;
    for (const auto& p : packets) {
      if (p.kind == Packet::Kind::Problem) {
        problem(p);
        continue;
      }
      if (p.kind == Packet::Kind::ToRemote) d.toRemote(p.ns, p.bytes, events);
      else d.fromRemote(p.ns, p.bytes, events);
      print("");
    }
    d.finish(events);
    print("");
  } else {
    // Pass 1: the HostMot2 registers each card was seen answering.
    std::map<std::uint64_t, lbpkit::decode::Lbp16Decoder> first;
    for (const auto& p : packets) {
      if (p.kind == Packet::Kind::Request) first[p.card].request(p.ns, p.bytes, events);
      else if (p.kind == Packet::Kind::Reply) first[p.card].reply(p.ns, p.bytes, events);
      events.clear();
    }
    std::optional<lbpkit::CardInfo> fallback;
    auto defaultCard = [&]() -> const lbpkit::CardInfo& {
      if (!fallback) {
        lbpkit::SimTransport card;  // the default virtual 7I92 + 7I77
        fallback = lbpkit::readCardInfo(card);
      }
      return *fallback;
    };
    std::map<std::uint64_t, lbpkit::decode::Lbp16Decoder> decoders;
    for (auto& [card, d] : first) {
      const std::string where = ipText(static_cast<std::uint32_t>(card >> 16)) + fmt::format(":{}", card & 0xFFFF);
      std::optional<lbpkit::CardInfo> info;
      std::string why;
      if (o.idrom != "default") {
        try {
          info = lbpkit::decode::cardInfoFromRegisters(d.registersRead());
        } catch (const lbpkit::Error& e) {
          why = e.what();
          if (o.idrom == "capture") throw lbpkit::Error(fmt::format("decode {}: card {}: {}", o.file, where, why));
        }
      }
      if (info) {
        fmt::print("card {}: register names from the IDROM read in the capture ({}, {} modules)\n", where,
                   info->boardName, info->modules.size());
      } else {
        info = defaultCard();
        fmt::print("card {}: register names from the default virtual 7I92 + 7I77's IDROM ({})\n", where,
                   why.empty() ? "as asked" : why);
      }
      decoders.emplace(card, lbpkit::decode::Lbp16Decoder(*info));
    }
    const bool several = decoders.size() > 1;
    for (const auto& p : packets) {
      if (p.kind == Packet::Kind::Problem) {
        problem(p);
        continue;
      }
      auto& d = decoders.at(p.card);
      if (p.kind == Packet::Kind::Request) d.request(p.ns, p.bytes, events);
      else d.reply(p.ns, p.bytes, events);
      print(several ? ipText(static_cast<std::uint32_t>(p.card >> 16)) + " " : std::string());
    }
    for (auto& [card, d] : decoders) {
      d.finish(events);
      print(several ? ipText(static_cast<std::uint32_t>(card >> 16)) + " " : std::string());
    }
  }
  std::fflush(stdout);
  if (malformed) fmt::print(stderr, "lbpkit decode: {} malformed packets or commands (marked above)\n", malformed);
  if (!trouble.empty()) {
    fmt::print(stderr, "lbpkit: {}\n", trouble);
    return 1;
  }
  if (packets.empty()) fmt::print(stderr, "lbpkit decode: {} holds no LBP16 datagram (UDP port {})\n", o.file, o.port);
  return 0;
}

}  // namespace

void addDecodeCommand(CLI::App& app) {
  auto o = std::make_shared<DecodeOptions>();
  auto* cmd = app.add_subcommand("decode", "Name every LBP16, SSLBP and LBP command in a capture (pcap)");
  cmd->add_option("file", o->file, "pcap file: lbpkit sim --trace, lbpkit remote --pty --trace, tcpdump, Wireshark")
      ->required();
  cmd->add_option("--port", o->port, "UDP port of the cards (LBP16)")->capture_default_str();
  cmd->add_flag("--absolute", o->absolute, "Times since the epoch, not since the first packet");
  cmd->add_option("--idrom", o->idrom,
                  "Where register names come from: auto (the capture's IDROM reads, else the default card), "
                  "capture, default")
      ->check(CLI::IsMember({"auto", "capture", "default"}))
      ->capture_default_str();
  cmd->callback([o] { app::gRun = [o] { return runDecode(*o); }; });
}
