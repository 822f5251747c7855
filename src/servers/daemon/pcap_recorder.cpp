// SPDX-License-Identifier: MIT
#include "daemon/pcap_recorder.hpp"

#include <fmt/format.h>
#include <pcap/pcap.h>
#include <time.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <utility>

#include "daemon/output_file.hpp"
#include "lbpkit/wire/capture.hpp"

namespace lbpkit::server {

namespace {
namespace capture = lbpkit::wire::capture;
constexpr std::size_t kIpHeader = 20, kUdpHeader = 8;

void putBig16(std::uint8_t* p, unsigned v) {  // network byte order
  p[0] = static_cast<std::uint8_t>(v >> 8);
  p[1] = static_cast<std::uint8_t>(v);
}
void putBig32(std::uint8_t* p, std::uint32_t v) {
  putBig16(p, v >> 16);
  putBig16(p + 2, v & 0xFFFF);
}
}  // namespace

PcapRecorder::PcapRecorder(std::string path, Link link, Report warn, std::size_t slots,
                           const std::vector<std::filesystem::path>& own)
    : path_(std::move(path)), link_(link), warn_(std::move(warn)), ring_(slots) {
  const int dlt = link_ == Link::Ipv4Udp ? DLT_RAW : DLT_USER0;
  pcap_ = pcap_open_dead_with_tstamp_precision(dlt, 65535, PCAP_TSTAMP_PRECISION_NANO);
  if (pcap_ == nullptr) throw std::runtime_error(fmt::format("--trace {}: libpcap cannot make a capture", path_));
  std::FILE* file = nullptr;
  try {
    file = openOutputFile("--trace", path_, isCapture, own);
  } catch (...) {
    pcap_close(pcap_);
    throw;
  }
  dumper_ = pcap_dump_fopen(pcap_, file);  // closes `file` with the dumper
  if (dumper_ == nullptr) {
    const std::string why = pcap_geterr(pcap_);
    std::fclose(file);
    pcap_close(pcap_);
    throw std::runtime_error(fmt::format("--trace {}: {}", path_, why));
  }
  pcap_dump_flush(dumper_);  // the file header, so even an idle run leaves a valid capture
  // A hundred times a second: a host polling as fast as the card answers
  // (lbpkit's 10 us poll over loopback) makes some 75,000 packets a second,
  // which fill the 4096 slots in about 55 ms: at ten drains a second the
  // end of a whole `lbpkit discover` would not fit.
  thread_ = std::make_unique<DrainThread>(std::chrono::milliseconds(10), [this] { drain(); });
}

PcapRecorder::~PcapRecorder() {
  thread_.reset();  // joins, then writes what is left
  pcap_dump_close(dumper_);
  pcap_close(pcap_);
}

std::int64_t PcapRecorder::nowNs() {
  timespec t{};
  ::clock_gettime(CLOCK_REALTIME, &t);
  return t.tv_sec * 1'000'000'000LL + t.tv_nsec;
}

void PcapRecorder::udp(std::int64_t ns, Endpoint from, Endpoint to, std::span<const std::uint8_t> payload) {
  PacketRing::Slot* s = ring_.claim();
  if (s == nullptr) return;
  // The IPv4 and UDP headers the datagram had on the network (RFC 791, 768);
  // UDP checksum 0: none computed, which IPv4 allows.
  const std::size_t total = kIpHeader + kUdpHeader + payload.size();
  std::uint8_t* ip = s->bytes;
  std::memset(ip, 0, kIpHeader + kUdpHeader);
  ip[0] = 0x45;  // version 4, 5 words
  putBig16(ip + 2, static_cast<unsigned>(std::min<std::size_t>(total, 0xFFFF)));
  ip[6] = 0x40;  // don't fragment
  ip[8] = 64;    // TTL
  ip[9] = 17;    // UDP
  putBig32(ip + 12, from.ip);
  putBig32(ip + 16, to.ip);
  std::uint32_t sum = 0;
  for (std::size_t i = 0; i < kIpHeader; i += 2) sum += static_cast<std::uint32_t>(ip[i] << 8 | ip[i + 1]);
  while (sum >> 16) sum = (sum & 0xFFFF) + (sum >> 16);
  putBig16(ip + 10, ~sum & 0xFFFF);
  std::uint8_t* udp = ip + kIpHeader;
  putBig16(udp, from.port);
  putBig16(udp + 2, to.port);
  putBig16(udp + 4, static_cast<unsigned>(std::min<std::size_t>(kUdpHeader + payload.size(), 0xFFFF)));
  const std::size_t room = PacketRing::kSlotBytes - kIpHeader - kUdpHeader;
  const std::size_t n = std::min(payload.size(), room);
  std::memcpy(udp + kUdpHeader, payload.data(), n);
  s->ns = ns;
  s->length = static_cast<std::uint32_t>(total);
  s->captured = static_cast<std::uint32_t>(kIpHeader + kUdpHeader + n);
  ring_.commit();
}

void PcapRecorder::lbp(std::int64_t ns, bool fromRemote, std::span<const std::uint8_t> bytes) {
  PacketRing::Slot* s = ring_.claim();
  if (s == nullptr) return;
  s->bytes[0] = fromRemote ? capture::kFromRemote : capture::kToRemote;
  const std::size_t n = std::min(bytes.size(), PacketRing::kSlotBytes - 1);
  std::memcpy(s->bytes + 1, bytes.data(), n);
  s->ns = ns;
  s->length = static_cast<std::uint32_t>(1 + bytes.size());
  s->captured = static_cast<std::uint32_t>(1 + n);
  ring_.commit();
}

void PcapRecorder::drain() {
  bool any = false;
  ring_.drain([&](const PacketRing::Slot& s) {
    pcap_pkthdr h{};
    h.ts.tv_sec = static_cast<time_t>(s.ns / 1'000'000'000);
    h.ts.tv_usec = static_cast<suseconds_t>(s.ns % 1'000'000'000);  // nanoseconds: the file says so
    h.caplen = s.captured;
    h.len = s.length;
    pcap_dump(reinterpret_cast<u_char*>(dumper_), &h, s.bytes);
    ++written_;
    any = true;
  });
  if (any && pcap_dump_flush(dumper_) != 0 && !errorSaid_) {
    errorSaid_ = true;
    if (warn_) warn_(fmt::format("--trace {}: cannot write: {}", path_, std::strerror(errno)));
  }
  const std::uint64_t lost = ring_.dropped();
  if (lost != droppedSaid_ && droppedSaid_ == 0 && warn_)
    warn_(fmt::format("--trace {}: the writer fell {} packets behind; {} packets are missing from the capture", path_,
                      ring_.capacity(), lost));
  droppedSaid_ = lost;
}

}  // namespace lbpkit::server
