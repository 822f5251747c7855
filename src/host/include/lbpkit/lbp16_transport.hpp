// A HostMot2 card on the network: LBP16 over UDP (Mesa 7I92 and kin). A
// flush sends everything queued as one datagram (more only past 1400 bytes,
// the limit hm2_eth keeps to) and waits for the one reply holding every
// read, in order.
#pragma once

#include <array>
#include <chrono>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "lbpkit/transport.hpp"

namespace lbpkit {

class Lbp16Transport final : public Transport {
 public:
  static constexpr std::size_t kMaxDatagram = 1400;
  static constexpr std::uint16_t kPort = 27181;

  explicit Lbp16Transport(const std::string& address, std::uint16_t port = kPort,
                          Nanoseconds timeout = std::chrono::milliseconds(200));
  ~Lbp16Transport() override;
  Lbp16Transport(const Lbp16Transport&) = delete;
  Lbp16Transport& operator=(const Lbp16Transport&) = delete;

  void queueRead(std::uint16_t address, std::uint32_t* into, std::size_t count = 1) override;
  void queueWrite(std::uint16_t address, const std::uint32_t* from, std::size_t count = 1) override;
  void flush() override;
  Nanoseconds now() override;
  void sleep(Nanoseconds d) override;
  [[nodiscard]] std::uint64_t exchanges() const override { return exchanges_; }
  [[nodiscard]] std::string describe() const override;

  // One raw LBP16 request expecting `replyBytes` back (other memory spaces).
  std::vector<std::uint8_t> request(std::span<const std::uint8_t> datagram, std::size_t replyBytes);
  // The name in the board-info space ("7I92").
  std::string boardName();

 private:
  void sendAndReceive();
  struct PendingRead {
    std::uint32_t* into;
    std::size_t count;
  };
  int fd_ = -1;
  std::string address_;
  std::uint16_t port_;
  Nanoseconds timeout_;
  std::array<std::uint8_t, kMaxDatagram> out_{};
  std::size_t outLen_ = 0;
  std::array<PendingRead, 256> reads_{};
  std::size_t readCount_ = 0;
  std::size_t replyLen_ = 0;
  std::array<std::uint8_t, 2048> in_{};
  std::uint64_t exchanges_ = 0;
  std::chrono::steady_clock::time_point start_;
};

}  // namespace lbpkit
