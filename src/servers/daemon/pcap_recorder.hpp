// SPDX-License-Identifier: MIT
// `lbpkit sim --trace FILE.pcap` and `lbpkit remote --pty --trace FILE.pcap`:
// every datagram the card took and every reply it sent (or every LBP byte
// in and out of a remote), with its time, to a pcap file (libpcap's
// pcap_dump; formats in lbpkit/wire/capture.hpp).
//
// The card thread only copies into a preallocated ring (packet_ring.hpp):
// no allocation, no system call but the clock, no waiting. A thread of its
// own (drain_thread.hpp) writes the file a hundred times a second.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "daemon/drain_thread.hpp"
#include "daemon/packet_ring.hpp"

struct pcap;
struct pcap_dumper;

namespace lbpkit::server {

class PcapRecorder {
 public:
  enum class Link { Ipv4Udp, LbpStream };
  using Report = std::function<void(const std::string&)>;
  // An IPv4 address and UDP port, host byte order.
  struct Endpoint {
    std::uint32_t ip = 0;
    std::uint16_t port = 0;
  };

  // Creates (or truncates) `path`: throws std::runtime_error naming the file
  // and why when it cannot. `warn` hears of packets lost (the writer a whole
  // ring behind) and of write errors, once each, on the writer's thread.
  // The file is opened as daemon/output_file.hpp says (`own`: the files it
  // must never be).
  PcapRecorder(std::string path, Link link, Report warn, std::size_t slots = 4096,
               const std::vector<std::filesystem::path>& own = {});
  // Writes what is left and closes the file.
  ~PcapRecorder();
  PcapRecorder(const PcapRecorder&) = delete;
  PcapRecorder& operator=(const PcapRecorder&) = delete;

  // The recording thread (one only): a UDP datagram from `from` to `to` at
  // `ns` (CLOCK_REALTIME nanoseconds). No allocation, never waits.
  void udp(std::int64_t ns, Endpoint from, Endpoint to, std::span<const std::uint8_t> payload);
  // LBP bytes on a serial line: `fromRemote` says which way.
  void lbp(std::int64_t ns, bool fromRemote, std::span<const std::uint8_t> bytes);

  // CLOCK_REALTIME now, in nanoseconds (what pcap timestamps count from).
  static std::int64_t nowNs();

  [[nodiscard]] const std::string& path() const { return path_; }
  [[nodiscard]] std::uint64_t written() const { return written_; }
  [[nodiscard]] std::uint64_t dropped() const { return ring_.dropped(); }

 private:
  void drain();

  std::string path_;
  Link link_;
  Report warn_;
  PacketRing ring_;
  pcap* pcap_ = nullptr;
  pcap_dumper* dumper_ = nullptr;
  std::uint64_t written_ = 0;  // the writer's thread only (read after it stops)
  std::uint64_t droppedSaid_ = 0;
  bool errorSaid_ = false;
  std::unique_ptr<DrainThread> thread_;  // last: it calls drain() until it goes
};

}  // namespace lbpkit::server
