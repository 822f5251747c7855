// SPDX-License-Identifier: MIT
// Server-side cost of one LBP16 datagram: what `lbpkit sim` spends between
// receiving hm2_eth's per-cycle read request and sending the reply.
#include <benchmark/benchmark.h>

#include <vector>

#include "hostmot2/card.hpp"
#include "lbp16/lbp16_card.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace hm2 = lbpkit::model::hm2;
namespace server = lbpkit::server;

namespace {

void put(std::vector<std::uint8_t>& d, std::uint16_t cmd, std::uint16_t addr) {
  d.insert(d.end(), {static_cast<std::uint8_t>(cmd), static_cast<std::uint8_t>(cmd >> 8), static_cast<std::uint8_t>(addr),
                     static_cast<std::uint8_t>(addr >> 8)});
}

// hm2_eth's read request for a 7I92 + 7I77 (registration order): GPIO,
// watchdog status, encoder timestamp, counts and controls, SSerial command,
// data, CS and interface registers of two remotes, then its packet counters.
std::vector<std::uint8_t> readRequest() {
  std::vector<std::uint8_t> d;
  put(d, 0x4282, 0x1000);
  put(d, 0x4281, 0x0D00);
  put(d, 0x4281, 0x3800);
  put(d, 0x4286, 0x3500);
  put(d, 0x4286, 0x3600);
  put(d, 0x4281, 0x5A00);
  put(d, 0x4281, 0x5B00);
  for (std::uint16_t ch = 0; ch < 2; ++ch) {
    put(d, 0x4281, static_cast<std::uint16_t>(0x5C00 + 4 * ch));
    put(d, 0x4281, static_cast<std::uint16_t>(0x5D00 + 4 * ch));
    put(d, 0x4281, static_cast<std::uint16_t>(0x5E00 + 4 * ch));
  }
  put(d, 0x5901, 0x0008);
  put(d, 0xD182, 0x0010);
  d.insert(d.end(), {1, 0, 0, 0});
  put(d, 0x5184, 0x0010);
  return d;
}

void BM_Lbp16ReadRequest(benchmark::State& state) {
  hm2::HostMot2Card card;
  server::Lbp16Card lbp16(card, {});
  const auto request = readRequest();
  std::uint8_t reply[server::Lbp16Card::kMaxDatagram];
  hm2::SimTime now{0};
  for (auto _ : state) {
    now += hm2::SimTime{1'000'000};  // one servo period per datagram
    benchmark::DoNotOptimize(lbp16.handle(request, reply, now));
  }
}
BENCHMARK(BM_Lbp16ReadRequest);

}  // namespace
BENCHMARK_MAIN();
