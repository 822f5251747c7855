// SPDX-License-Identifier: MIT
// Test helper: the virtual card serving LBP16 on a real UDP socket
// (127.0.0.1, a free port) from a thread of the test process, which can lose
// replies or send them late, as a network does. Wired like `lbpkit sim
// --demo`: the 7I77's field outputs 0..15 drive its inputs 0..15.
#pragma once

#include <atomic>
#include <chrono>
#include <thread>

#include "hostmot2/card.hpp"
#include "lbp16/lbp16_card.hpp"
#include "lbp16/udp_server.hpp"

namespace testing_net {

class LossyUdpCard {
 public:
  LossyUdpCard() : server_("127.0.0.1", 0), thread_([this] { serve(); }) {}
  ~LossyUdpCard() {
    stop_.store(true);
    thread_.join();
  }
  LossyUdpCard(const LossyUdpCard&) = delete;
  LossyUdpCard& operator=(const LossyUdpCard&) = delete;

  [[nodiscard]] std::uint16_t port() const { return server_.port(); }
  // The next `n` replies are not sent (requests are still carried out).
  void dropNextReplies(unsigned n) { drop_.store(n); }
  // The next `n` replies are sent `delay` late (the card thread waits).
  void delayNextReplies(unsigned n, std::chrono::milliseconds delay) {
    delay_.store(delay.count());
    late_.store(n);
  }
  [[nodiscard]] unsigned dropped() const { return dropped_.load(); }
  [[nodiscard]] unsigned delayed() const { return delayed_.load(); }

 private:
  lbpkit::model::hm2::SimTime now() const {
    return std::chrono::duration_cast<lbpkit::model::hm2::SimTime>(std::chrono::steady_clock::now() - start_);
  }
  void serve() {
    auto& io = card_.daughtercard(0).fieldIo;
    while (!stop_.load()) {
      server_.serveOnce(std::chrono::milliseconds(5), [&](std::span<const std::uint8_t> req,
                                                          std::span<std::uint8_t> reply) -> std::size_t {
        const std::size_t n = lbp16_.handle(req, reply, now());
        if (n == 0) return 0;
        if (unsigned d = drop_.load(); d > 0) {
          drop_.store(d - 1);
          ++dropped_;
          return 0;
        }
        if (unsigned l = late_.load(); l > 0) {
          late_.store(l - 1);
          ++delayed_;
          std::this_thread::sleep_for(std::chrono::milliseconds(delay_.load()));
        }
        return n;
      });
      card_.advance(now());
      for (unsigned i = 0; i < 16; ++i) {
        const double v = io.outputOn(i) ? io.fieldVoltage() : 0.0;
        if (io.inputVoltage(i) != v) io.setInputVoltage(i, v);
      }
    }
  }

  const std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
  lbpkit::model::hm2::HostMot2Card card_;
  lbpkit::server::Lbp16Card lbp16_{card_, lbpkit::server::Lbp16Card::Identity{}};
  lbpkit::server::UdpServer server_;
  std::atomic<bool> stop_{false};
  std::atomic<unsigned> drop_{0}, late_{0}, dropped_{0}, delayed_{0};
  std::atomic<long> delay_{0};
  std::thread thread_;  // last: starts when everything it uses exists
};

}  // namespace testing_net
