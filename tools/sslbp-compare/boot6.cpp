// SPDX-License-Identifier: MIT
// boot6: the remote fault byte across the M-bit boot on the 6-channel SSLBP 43 (Verilated by the
// external sslbp-oracle tool; not part of the product's build). lbpkit's field I/O processor on
// channel FIO_CH (default 3): START, field power off (LowVoltageFault), STOP ALL, M set and
// released, setup START; prints channel FIO_CH's CS after each. SSLBP.MAC initmem clears RAM
// 0x000..0x0FF only, so channels 3..5 (blocks from 0x106) keep their fault byte
// (docs/sslbp-vs-firmware.md, "boot with 6 channels"). Build: see README.md.
#include <cstdio>
#include <cstdlib>
#include <deque>
#include <vector>
#include "remote/field_io.hpp"
#include "sslbp_vsim.h"

// The layers' namespaces this file names (docs/architecture.md).
namespace remote = lbpkit::model::remote;
namespace lbp = lbpkit::model::lbp;
int main() {
  const int fch = getenv("FIO_CH") ? atoi(getenv("FIO_CH")) : 3;
  SslbpSim s(6);
  s.verbose = false;
  s.out = fopen("/dev/null", "w");
  remote::FieldIoProcessor::Options o;
  o.vinFromField = false;
  o.vin = 24.0;
  remote::FieldIoProcessor fio{o};
  struct P { uint64_t due; std::vector<uint8_t> b; };
  std::deque<P> pend;
  s.on_tx_byte = [&](int ch, uint8_t b, uint64_t t) {
    if (ch != fch) return;
    auto rep = fio.receive(b, lbp::SimTime{(int64_t)t});
    if (!rep.empty()) pend.push_back({t + 2000, std::vector<uint8_t>(rep.begin(), rep.end())});
  };
  uint64_t nextAdv = 0;
  s.on_tick = [&](SslbpSim& sim) {
    while (!pend.empty() && pend.front().due <= sim.now) {
      for (auto x : pend.front().b) sim.tx[fch].q.push_back(x);
      pend.pop_front();
    }
    if (sim.now >= nextAdv) { fio.advance(lbp::SimTime{(int64_t)sim.now}); nextAdv = sim.now + 10000; }
  };
  s.ticks(10);
  auto cmd = [&](uint32_t c) { s.hw(0x5A00, c, true); s.waitcmd(300000000, "cmd"); return s.hr(0x5B00, true) & 0xFF; };
  const uint16_t csa = (uint16_t)(0x5C00 + 4 * fch);
  s.hw(0x5A00, 0x4000, true); s.hw(0x5A00, 0x0001, true); s.waitcmd(1000000, "reset"); s.ticks(20000);
  cmd(0x0800);
  s.hw(csa, 0, true);
  { auto d = cmd(0x0900 | (1u << fch)); printf("START -> DATA %02X CS %08X\n", d, s.hr(csa, true)); }
  { auto d = cmd(0x1000 | (1u << fch)); printf("DOIT -> DATA %02X CS %08X\n", d, s.hr(csa, true)); }
  fio.setFieldVoltage(0.0, lbp::SimTime{(int64_t)s.now});
  for (int k = 0; k < 3; ++k) { auto d = cmd(0x1000 | (1u << fch)); printf("DOIT power off -> DATA %02X CS %08X\n", d, s.hr(csa, true)); }
  fio.setFieldVoltage(24.0, lbp::SimTime{(int64_t)s.now});
  cmd(0x0800); s.ticks(10000);
  printf("100us after STOP ALL CS %08X\n", s.hr(csa, true));
  s.hw(0x5A00, 0x4000, true); s.ticks(1000);
  printf("M held CS %08X\n", s.hr(csa, true));
  s.hw(0x5A00, 0x0001, true); s.waitcmd(1000000, "release"); s.ticks(20000);
  printf("200us after M release CS %08X DATA %02X\n", s.hr(csa, true), s.hr(0x5B00, true) & 0xFF);
  s.hw(csa, 0, true);
  { auto d = cmd(0x0F00 | (1u << fch)); printf("setup START -> DATA %02X CS %08X\n", d, s.hr(csa, true)); }
  return 0;
}
