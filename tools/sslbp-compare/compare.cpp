// sslbp-compare: the same host sequences against Mesa's real SSLBP (version 43, Verilated by
// /work/shared/tools/sslbp-oracle) with lbpkit's own 7I77 processors on channels 0 and 1, and
// against lbpkit's SSLBP model (hm2::HostMot2Card). Prints one line per host operation with the
// registers at the command's completion and its duration; compare.py turns two such logs into
// the table in docs/sslbp-vs-firmware.md.
//
//   sslbp_compare oracle|lbpkit [NDOITS]
//
// A tool beside the product: it is not part of the product's build and contains no firmware.
// The host is the same code for both backends: every register access takes two 100 MHz
// clocks (20 ns), and COMMAND is polled every 220 ns (as the oracle's waitcmd does).
#include <cinttypes>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <memory>
#include <string>
#include <vector>

#include "hostmot2/card.hpp"
#include "remote/analog.hpp"
#include "remote/field_io.hpp"

#ifdef WITH_ORACLE
#include "sslbp_vsim.h"
#endif

namespace {

constexpr std::uint16_t kCmd = 0x5A00, kData = 0x5B00;
std::uint16_t csA(int ch) { return static_cast<std::uint16_t>(0x5C00 + 4 * ch); }
std::uint16_t ifA(int n, int ch) { return static_cast<std::uint16_t>(0x5D00 + 0x100 * n + 4 * ch); }

struct Backend {
  virtual ~Backend() = default;
  virtual std::uint32_t rd(std::uint16_t a) = 0;
  virtual void wr(std::uint16_t a, std::uint32_t v) = 0;
  virtual void idle(std::uint64_t ns) = 0;
  virtual std::uint64_t now() = 0;
  virtual void cable(int ch, bool connected) = 0;
  virtual int channels() = 0;
  virtual std::string remoteInfo() = 0;
};

// ---------------------------------------------------------------- lbpkit's model
struct LbpkitBackend : Backend {
  hm2::HostMot2Card card;
  std::int64_t t = 0;
  std::uint32_t rd(std::uint16_t a) override {
    t += 10;
    const auto v = card.read32(a, lbp::SimTime{t});
    t += 10;
    return v;
  }
  void wr(std::uint16_t a, std::uint32_t v) override {
    t += 10;
    card.write32(a, v, lbp::SimTime{t});
    t += 10;
  }
  void idle(std::uint64_t ns) override {
    t += static_cast<std::int64_t>(ns);
    card.advance(lbp::SimTime{t});
  }
  std::uint64_t now() override { return static_cast<std::uint64_t>(t); }
  void cable(int ch, bool c) override { card.smartSerial().link(static_cast<unsigned>(ch)).setConnected(c); }
  int channels() override { return static_cast<int>(card.smartSerial().channels()); }
  std::string remoteInfo() override {
    auto& d = card.daughtercard(0);
    char b[200];
    snprintf(b, sizeof b, "fieldio faults=%02X crcerr=%u pd=%u | analog faults=%02X crcerr=%u pd=%u",
             d.fieldIo.faults(), d.fieldIo.crcErrorCount(), d.fieldIo.processDataCount(), d.analog.faults(),
             d.analog.crcErrorCount(), d.analog.processDataCount());
    return b;
  }
};

#ifdef WITH_ORACLE
// ---------------------------------------------------------------- the real SSLBP
// lbpkit's processors behind the Verilated UARTs: each byte the SSLBP sends is handed to
// receive() at its stop-bit sample time; a reply goes out on the RX line 2 us later
// (SerialLink::kTurnaround, the same turnaround lbpkit's link uses).
struct OracleBackend : Backend {
  SslbpSim s;
  remote::FieldIoProcessor fio{remote::FieldIoProcessor::Options{}};
  remote::AnalogProcessor ana{remote::AnalogProcessor::Options{}};
  struct Pending {
    std::uint64_t due;
    std::vector<std::uint8_t> bytes;
  };
  std::deque<Pending> pending[2];
  bool connected[2] = {true, true};
  std::uint64_t nextAdvance = 0;
  FILE* txlog = getenv("TXLOG") ? fopen(getenv("TXLOG"), "w") : nullptr;

  explicit OracleBackend(int ports) : s(ports) {
    s.verbose = false;
    s.out = fopen("/dev/null", "w");
    s.on_tx_byte = [this](int ch, std::uint8_t b, std::uint64_t t) {
      if (txlog) fprintf(txlog, "%llu TX ch%d %02X\n", (unsigned long long)t, ch, b);
      if (ch > 1 || !connected[ch]) return;
      remote::RemoteDevice& r = ch == 0 ? static_cast<remote::RemoteDevice&>(fio) : ana;
      auto rep = r.receive(b, lbp::SimTime{static_cast<std::int64_t>(t)});
      if (!rep.empty()) pending[ch].push_back({t + 2000, std::vector<std::uint8_t>(rep.begin(), rep.end())});
    };
    s.on_tick = [this](SslbpSim& sim) {
      for (int ch = 0; ch < 2; ++ch)
        while (!pending[ch].empty() && pending[ch].front().due <= sim.now) {
          for (auto x : pending[ch].front().bytes) {
            sim.tx[ch].q.push_back(x);
            if (txlog) fprintf(txlog, "%llu RX ch%d %02X\n", (unsigned long long)sim.now, ch, x);
          }
          pending[ch].pop_front();
        }
      if (sim.now >= nextAdvance) {
        fio.advance(lbp::SimTime{static_cast<std::int64_t>(sim.now)});
        ana.advance(lbp::SimTime{static_cast<std::int64_t>(sim.now)});
        nextAdvance = sim.now + 10000;
      }
    };
    s.ticks(10);
  }
  std::uint32_t rd(std::uint16_t a) override { return s.hr(a, true); }
  void wr(std::uint16_t a, std::uint32_t v) override { s.hw(a, v, true); }
  void idle(std::uint64_t ns) override { s.ticks(ns / 10); }
  std::uint64_t now() override { return s.now; }
  void cable(int ch, bool c) override {
    connected[ch] = c;
    if (!c) {
      pending[ch].clear();
      s.tx[ch].q.clear();
    }
  }
  int channels() override { return s.ports; }
  std::string remoteInfo() override {
    char b[200];
    snprintf(b, sizeof b, "fieldio faults=%02X crcerr=%u pd=%u | analog faults=%02X crcerr=%u pd=%u", fio.faults(),
             fio.crcErrorCount(), fio.processDataCount(), ana.faults(), ana.crcErrorCount(), ana.processDataCount());
    return b;
  }
};
#endif

// ---------------------------------------------------------------- the host
struct Host {
  Backend& b;
  FILE* out = stdout;
  int nch;  // channels reported in register dumps (0..2: field I/O, analog, nothing)
  explicit Host(Backend& be) : b(be), nch(3) {}

  // Polls COMMAND until 0; returns ns from the write, or -1.
  long long waitcmd(std::uint64_t t0, std::uint64_t limit_ns = 2'000'000'000ULL) {
    for (;;) {
      if (b.rd(kCmd) == 0) return static_cast<long long>(b.now() - t0);
      if (b.now() - t0 > limit_ns) return -1;
      b.idle(200);
    }
  }
  long long command(std::uint32_t c) {
    b.wr(kCmd, c);
    const auto t0 = b.now() - 10;  // the write strobe
    return waitcmd(t0);
  }
  std::uint8_t local(std::uint16_t a) {
    command(0x2000U | a);
    return static_cast<std::uint8_t>(b.rd(kData));
  }
  // Registers after a command: COMMAND, DATA, then per channel CS and interface 0..2.
  std::string regs(std::uint8_t mask) {
    char buf[512];
    int k = snprintf(buf, sizeof buf, "CMD=%04X DATA=%02X", b.rd(kCmd), b.rd(kData) & 0xFF);
    for (int ch = 0; ch < nch; ++ch)
      if (mask & (1U << ch))
        k += snprintf(buf + k, sizeof buf - k, " ch%d:CS=%08X IF=%08X,%08X,%08X", ch, b.rd(csA(ch)),
                      b.rd(ifA(0, ch)), b.rd(ifA(1, ch)), b.rd(ifA(2, ch)));
    return buf;
  }
  void op(const char* name, long long dur, const std::string& regs) {
    if (FILE* m = getenv("MARKS") ? fopen(getenv("MARKS"), "a") : nullptr) {
      fprintf(m, "%llu OP %s\n", static_cast<unsigned long long>(b.now()), name);
      fclose(m);
    }
    fprintf(out, "OP %-28s | %10lld ns | %s\n", name, dur, regs.c_str());
    fflush(out);
  }

  // One remote byte per DOIT, as LinuxCNC's hm2_sserial_get_bytes: LBP 0x4C (read 1 byte,
  // 2-byte address) with the address in CS, wait for CS bits 15..8 to clear, DOIT, read IF0.
  struct Disc {
    int doits = 0, bad = 0;
    std::uint64_t ns = 0, maxns = 0;
    std::uint32_t hash = 2166136261U;
    std::string text;
  };
  std::uint8_t getByte(int ch, std::uint16_t addr, Disc& d) {
    b.wr(csA(ch), 0x4C000000U | addr);
    for (int i = 0; i < 100000 && (b.rd(csA(ch)) & 0xFF00U) != 0; ++i) b.idle(200);
    const long long t = command(0x1000U | (1U << ch));
    const auto data = b.rd(kData) & 0xFF;
    const auto v = static_cast<std::uint8_t>(b.rd(ifA(0, ch)));
    ++d.doits;
    if (data != 0 || t < 0) ++d.bad;
    d.ns += static_cast<std::uint64_t>(t < 0 ? 0 : t);
    if (static_cast<std::uint64_t>(t) > d.maxns) d.maxns = static_cast<std::uint64_t>(t);
    d.hash = (d.hash ^ v) * 16777619U;
    return v;
  }
  // Walks a discovery table: 16-bit pointers up to 0, each record (type 0xA0: 14 header bytes
  // then unit and name strings; 0xB0: 4 header bytes then the name) (manual: PROCESS DATA DISCOVERY).
  void walk(int ch, std::uint16_t toc, Disc& d) {
    for (int i = 0; i < 64; ++i) {
      const std::uint16_t p = static_cast<std::uint16_t>(getByte(ch, static_cast<std::uint16_t>(toc + 2 * i), d) |
                                                         (getByte(ch, static_cast<std::uint16_t>(toc + 2 * i + 1), d) << 8));
      if (p == 0) break;
      const std::uint8_t type = getByte(ch, p, d);
      int header = type == 0xA0 ? 14 : 4, strings = type == 0xA0 ? 2 : 1;
      std::uint16_t a = static_cast<std::uint16_t>(p + 1);
      for (int k = 1; k < header; ++k) getByte(ch, a++, d);
      std::string name;
      for (int n = 0; n < 64 && strings > 0; ++n) {
        const auto c = getByte(ch, a++, d);
        if (c == 0) {
          --strings;
          if (strings > 0) name.clear();
        } else {
          name += static_cast<char>(c);
        }
      }
      if (!d.text.empty()) d.text += ",";
      d.text += name;
    }
  }

  void run(int ndoits) {
    // Reset and clear, as LinuxCNC does, then wait for the version.
    b.wr(kCmd, 0x4000);
    const auto t0 = b.now();
    b.wr(kCmd, 0x0001);
    long long t = waitcmd(t0);
    int polls = 0;
    std::uint8_t ver;
    do {
      ver = local(3);
      ++polls;
    } while (ver == 0xAA && polls < 10000);
    char buf[256];
    snprintf(buf, sizeof buf, "version=%d after %d reads", ver, polls);
    op("reset 0x4000,0x0001", t, buf);

    std::string s;
    for (int a = 0; a < 8; ++a) {
      snprintf(buf, sizeof buf, "%s%02X", a ? " " : "", local(static_cast<std::uint16_t>(a)));
      s += buf;
    }
    op("local params 0..7", -1, s);
    s.clear();
    for (int a = 0x230; a <= 0x234; ++a) {
      snprintf(buf, sizeof buf, "%s%02X", a > 0x230 ? " " : "", local(static_cast<std::uint16_t>(a)));
      s += buf;
    }
    op("local 0x230..0x234", -1, s);
    s.clear();
    for (int a = 0x70 + 0x2A; a < 0x70 + 0x2E; ++a) {
      snprintf(buf, sizeof buf, "%s%02X", a > 0x9A ? " " : "", local(static_cast<std::uint16_t>(a)));
      s += buf;
    }
    op("local ch0 baud 0x9A..0x9D", -1, s);

    t = command(0x0800);
    op("STOP ALL 0x0800", t, regs(0x7));

    // No remote: channel 2 (the TB6 port; nothing attached in either).
    b.wr(csA(2), 0);
    t = command(0x0F04);
    op("setup START ch2 (no remote)", t, regs(0x4));
    t = command(0x0800);
    op("STOP ALL", t, regs(0));
    b.wr(csA(2), 0);
    t = command(0x0904);
    op("normal START ch2 (no remote)", t, regs(0x4));
    t = command(0x0800);
    op("STOP ALL", t, regs(0x4));
    b.idle(100000);
    op("ch2 100 us after STOP ALL", -1, regs(0x4));

    // Setup START of both processors.
    b.wr(csA(0), 0);
    b.wr(csA(1), 0);
    t = command(0x0F03);
    op("setup START 0x0F03", t, regs(0x3));
    for (int ch = 0; ch < 2; ++ch) {
      const auto if2 = b.rd(ifA(2, ch));
      Disc d;
      walk(ch, static_cast<std::uint16_t>(if2 & 0xFFFF), d);
      const std::string ptoc = d.text;
      d.text.clear();
      walk(ch, static_cast<std::uint16_t>(if2 >> 16), d);
      snprintf(buf, sizeof buf, "ch%d discovery DOITs", ch);
      char r[2048];
      snprintf(r, sizeof r, "doits=%d failed=%d mean=%.2fus max=%.2fus hash=%08X | PTOC %s | GTOC %s", d.doits, d.bad,
               d.ns / 1000.0 / d.doits, d.maxns / 1000.0, d.hash, ptoc.c_str(), d.text.c_str());
      op(buf, static_cast<long long>(d.ns), r);
    }
    op("after discovery", -1, regs(0x3));

    // Normal START (LinuxCNC's stopstart: STOP ALL, mode 0 in CS byte 3, START).
    t = command(0x0800);
    op("STOP ALL", t, regs(0));
    b.wr(csA(0), 0);
    b.wr(csA(1), 0);
    t = command(0x0903);
    op("normal START 0x0903", t, regs(0x3));

    // Process data DOITs.
    int bad = 0;
    std::uint64_t sum = 0, mx = 0, mn = ~0ULL;
    std::uint32_t hash = 2166136261U;
    FILE* per = getenv("PERDOIT") ? fopen(getenv("PERDOIT"), "w") : nullptr;
    for (int k = 0; k < ndoits; ++k) {
      b.wr(ifA(0, 0), static_cast<std::uint32_t>(k * 7) & 0xFFFF);  // field outputs 0..15
      b.wr(ifA(0, 1), static_cast<std::uint32_t>(k * 13) & 0xFFFF);  // analog out 0
      b.wr(ifA(1, 1), 0);
      b.wr(ifA(2, 1), 0);
      t = command(0x1003);
      std::string rg = regs(0x3);
      const auto data = b.rd(kData) & 0xFF;
      if (data != 0 || t < 0) ++bad;
      sum += static_cast<std::uint64_t>(t);
      mx = std::max<std::uint64_t>(mx, static_cast<std::uint64_t>(t));
      mn = std::min<std::uint64_t>(mn, static_cast<std::uint64_t>(t));
      for (char c : rg) hash = (hash ^ static_cast<std::uint8_t>(c)) * 16777619U;
      if (per) fprintf(per, "%d %lld %s\n", k, t, rg.c_str());
      if (k == 0) op("DOIT 1 (first)", t, rg);
      if (k == ndoits - 1) op("DOIT last", t, rg);
    }
    if (per) fclose(per);
    snprintf(buf, sizeof buf, "doits=%d failed=%d min=%.2fus mean=%.2fus max=%.2fus reghash=%08X", ndoits, bad,
             mn / 1000.0, sum / 1000.0 / ndoits, mx / 1000.0, hash);
    op("process data DOITs 0x1003", static_cast<long long>(sum), buf);
    op("remotes after DOITs", -1, b.remoteInfo());

    // A parameter read while running: channel 0's discovered RX/TX sizes (local 0x9E, 0x9F).
    t = command(0x2000 + 0x70 + 0x2E);
    snprintf(buf, sizeof buf, "rx=%02X", b.rd(kData) & 0xFF);
    s = buf;
    t += command(0x2000 + 0x70 + 0x2F);
    snprintf(buf, sizeof buf, " tx=%02X", b.rd(kData) & 0xFF);
    op("local read ch0 RX/TX size", t, s + buf + " | " + regs(0x3));

    // The field I/O cable pulled mid-run.
    b.cable(0, false);
    for (int k = 0; k < 3; ++k) {
      b.wr(ifA(0, 0), 0x5555);
      t = command(0x1003);
      snprintf(buf, sizeof buf, "DOIT %d after cable pull", k + 1);
      op(buf, t, regs(0x3));
    }
    t = command(0x0803);
    op("STOP 0x0803", t, regs(0x3));
    op("remotes at end", -1, b.remoteInfo());
  }
};

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    fprintf(stderr, "usage: %s oracle|lbpkit [NDOITS]\n", argv[0]);
    return 2;
  }
  const std::string which = argv[1];
  const int ndoits = argc > 2 ? atoi(argv[2]) : 1000;
  std::unique_ptr<Backend> be;
  if (which == "lbpkit") be = std::make_unique<LbpkitBackend>();
#ifdef WITH_ORACLE
  else if (which == "oracle") be = std::make_unique<OracleBackend>(ORACLE_PORTS);
#endif
  else {
    fprintf(stderr, "unknown backend %s\n", which.c_str());
    return 2;
  }
  printf("# backend %s, %d channels\n", which.c_str(), be->channels());
  Host h(*be);
  h.run(ndoits);
  printf("# simulated %.3f ms\n", be->now() / 1e6);
  return 0;
}
