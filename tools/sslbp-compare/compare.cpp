// SPDX-License-Identifier: MIT
// sslbp-compare: the same host sequences against Mesa's real SSLBP (version 43: the SSLBP sources
// of LinuxCNC/hostmot2-firmware, sserialwa.vhd + the DumbAss8 CPU + sslbprom43.vhd, run under
// Verilator by the external sslbp-oracle tool, not part of this repository) with lbpkit's own 7I77 processors on channels 0 and 1, and
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

// The layers' namespaces this file names (docs/architecture.md).
namespace hm2 = lbpkit::model::hm2;
namespace remote = lbpkit::model::remote;
namespace lbp = lbpkit::model::lbp;

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
  virtual void fieldVoltage(double volts) = 0;  // the field I/O processor's field supply
  virtual void fieldInput(unsigned input, double volts) = 0;  // a field input's terminal
  virtual void driverHot(unsigned chip, bool hot) = 0;        // an output driver's over-temperature
  virtual int channels() = 0;
  virtual std::string remoteInfo() = 0;
};

// ---------------------------------------------------------------- lbpkit's model
// Both sides: the field I/O processor's VIN from a separate 24 V supply (7I77 W1 right), so
// dropping field power leaves it running and reporting LowVoltageFault.
remote::FieldIoProcessor::Options fieldIoOptions() {
  remote::FieldIoProcessor::Options o;
  o.vinFromField = false;
  o.vin = 24.0;
  return o;
}
// The same channel count as the oracle build: 3 (one 7I77, GPIO on the second connector) unless
// it is the 6-channel one (two 7I77 connectors, PIN_7I77x2_34, lbpkit's default card).
hm2::HostMot2Card::Options cardOptions() {
  hm2::HostMot2Card::Options o;
  o.first.fieldIo = fieldIoOptions();
#if defined(ORACLE_PORTS) && ORACLE_PORTS == 6
  o.pinout = hm2::HostMot2Card::Pinout::SevenI77x2;
#else
  o.pinout = hm2::HostMot2Card::Pinout::SevenI77Gpio;
#endif
  return o;
}

struct LbpkitBackend : Backend {
  hm2::HostMot2Card card{cardOptions()};
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
  void cable(int ch, bool c) override { card.part<hm2::Sslbp>().link(static_cast<unsigned>(ch)).setConnected(c); }
  void fieldVoltage(double v) override { card.daughtercard(0).fieldIo.setFieldVoltage(v, lbp::SimTime{t}); }
  void fieldInput(unsigned i, double v) override { card.daughtercard(0).fieldIo.setInputVoltage(i, v); }
  void driverHot(unsigned chip, bool hot) override { card.daughtercard(0).fieldIo.setDriverOverTemperature(chip, hot); }
  int channels() override { return static_cast<int>(card.part<hm2::Sslbp>().channels()); }
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
  remote::FieldIoProcessor fio{fieldIoOptions()};
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
  void fieldVoltage(double v) override { fio.setFieldVoltage(v, lbp::SimTime{static_cast<std::int64_t>(s.now)}); }
  void fieldInput(unsigned i, double v) override { fio.setInputVoltage(i, v); }
  void driverHot(unsigned chip, bool hot) override { fio.setDriverOverTemperature(chip, hot); }
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
  // waitCs false: as mesaflash's sslbp_read_remote8 (CS write, DOIT at once).
  std::uint8_t getByte(int ch, std::uint16_t addr, Disc& d, bool waitCs = true) {
    b.wr(csA(ch), 0x4C000000U | addr);
    for (int i = 0; waitCs && i < 100000 && (b.rd(csA(ch)) & 0xFF00U) != 0; ++i) b.idle(200);
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
  // Parameter records' names, sizes (bits) and addresses go to params.
  struct Param {
    std::string name;
    int bits;
    std::uint16_t addr;
  };
  std::vector<Param> params[2];
  std::string names4C[2];  // "PTOC | GTOC" names from the first (0x4C) discovery
  void walk(int ch, std::uint16_t toc, Disc& d) {
    for (int i = 0; i < 64; ++i) {
      const std::uint16_t p = static_cast<std::uint16_t>(getByte(ch, static_cast<std::uint16_t>(toc + 2 * i), d) |
                                                         (getByte(ch, static_cast<std::uint16_t>(toc + 2 * i + 1), d) << 8));
      if (p == 0) break;
      const std::uint8_t type = getByte(ch, p, d);
      int header = type == 0xA0 ? 14 : 4, strings = type == 0xA0 ? 2 : 1;
      std::uint8_t h[14] = {type};
      std::uint16_t a = static_cast<std::uint16_t>(p + 1);
      for (int k = 1; k < header; ++k) h[k] = getByte(ch, a++, d);
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
      if (type == 0xA0 && ch < 2) params[ch].push_back({name, h[1], static_cast<std::uint16_t>(h[12] | (h[13] << 8))});
      if (!d.text.empty()) d.text += ",";
      d.text += name;
    }
  }
  const Param* param(int ch, const char* name) {
    for (const auto& p : params[ch])
      if (p.name == name) return &p;
    return nullptr;
  }

  // One LBP command through setup mode as lbpkit's SetupChannelAccess sends it: interface 0/1
  // (writes), CS = header << 24 | address, DOIT, then COMMAND/DATA/CS/IF0/IF1 until COMMAND is 0.
  struct Xfer {
    long long t;
    std::uint32_t data, cs;
    std::uint64_t value;
  };
  Xfer lbpCmd(int ch, std::uint8_t header, std::uint16_t addr, std::uint64_t wdata = 0, bool write = false) {
    if (write) {
      b.wr(ifA(0, ch), static_cast<std::uint32_t>(wdata));
      b.wr(ifA(1, ch), static_cast<std::uint32_t>(wdata >> 32));
    }
    b.wr(csA(ch), (static_cast<std::uint32_t>(header) << 24) | addr);
    Xfer x{};
    x.t = command(0x1000U | (1U << ch));
    x.data = b.rd(kData) & 0xFF;
    x.cs = b.rd(csA(ch));
    x.value = b.rd(ifA(0, ch)) | (static_cast<std::uint64_t>(b.rd(ifA(1, ch))) << 32);
    return x;
  }
  void xferOp(const char* name, const Xfer& x, bool showValue) {
    char buf[256];
    if (showValue)
      snprintf(buf, sizeof buf, "DATA=%02X CS=%08X IF1:IF0=%016" PRIX64, x.data, x.cs, x.value);
    else
      snprintf(buf, sizeof buf, "DATA=%02X CS=%08X", x.data, x.cs);
    op(name, x.t, buf);
  }

  // lbpkit's own discovery (src/host/discovery.cpp ChunkReader): aligned 8-byte reads, LBP 0x47
  // (read, 2-byte address, 8 bytes), each chunk read once.
  struct Chunks {
    Host& h;
    int ch;
    std::vector<std::pair<std::uint16_t, std::uint64_t>> got;
    int doits = 0, bad = 0;
    std::uint64_t ns = 0, maxns = 0;
    std::uint8_t byte(std::uint16_t a) {
      const auto base = static_cast<std::uint16_t>(a & ~7U);
      for (auto& [k, v] : got)
        if (k == base) return static_cast<std::uint8_t>(v >> (8 * (a & 7U)));
      const auto x = h.lbpCmd(ch, 0x47, base);
      ++doits;
      if (x.data != 0 || x.t < 0 || (x.cs & 0xFF) != 0) ++bad;
      ns += static_cast<std::uint64_t>(x.t < 0 ? 0 : x.t);
      maxns = std::max<std::uint64_t>(maxns, static_cast<std::uint64_t>(x.t));
      got.emplace_back(base, x.value);
      return static_cast<std::uint8_t>(x.value >> (8 * (a & 7U)));
    }
    std::string walk(std::uint16_t toc) {
      std::string text;
      for (int i = 0; i < 64; ++i) {
        const std::uint16_t p = static_cast<std::uint16_t>(byte(static_cast<std::uint16_t>(toc + 2 * i)) |
                                                           (byte(static_cast<std::uint16_t>(toc + 2 * i + 1)) << 8));
        if (p == 0) break;
        const std::uint8_t type = byte(p);
        int strings = type == 0xA0 ? 2 : 1;
        std::uint16_t a = static_cast<std::uint16_t>(p + (type == 0xA0 ? 14 : 4));
        std::string name;
        for (int n = 0; n < 64 && strings > 0; ++n) {
          const auto c = byte(a++);
          if (c == 0) {
            if (--strings > 0) name.clear();
          } else {
            name += static_cast<char>(c);
          }
        }
        if (!text.empty()) text += ",";
        text += name;
      }
      return text;
    }
  };

  // mesaflash --sserial (LinuxCNC/mesaflash sserial_module.c, sserial_module_init, not verbose):
  // STOP ALL|RESET, STOP ALL, wait; local reads 0..7, the baud rate (4 bytes from local
  // channel start + 42, high byte first) and the clock (0x230.., high first); then for every
  // channel below local 1 ("width"): CS 0, setup START of that channel alone, skip it if DATA is
  // not 0, read CS and interface 0..2, walk the PTOC (pointer and record type only) and the GTOC
  // (record header, unit, name; SwRevision's value), one 0x4C byte read per DOIT without waiting
  // for CS. mesaflash waits for COMMAND without a limit; here 100 ms ends the sequence.
  // sslbp_read_remote16: the high byte first.
  std::uint16_t remote16(int ch, std::uint16_t a, Disc& d) {
    const std::uint8_t hi = getByte(ch, static_cast<std::uint16_t>(a + 1), d, false);
    const std::uint8_t lo = getByte(ch, a, d, false);
    return static_cast<std::uint16_t>(lo | (hi << 8));
  }
  void mesaflash() {
    char buf[512];
    b.wr(kCmd, 0x4800);
    b.wr(kCmd, 0x0800);
    const auto t0 = b.now() - 10;
    long long t = waitcmd(t0);
    snprintf(buf, sizeof buf, "DATA=%02X", b.rd(kData) & 0xFF);
    op("mesaflash STOPALL+RESET, STOPALL", t, buf);
    std::string s;
    std::uint8_t loc[8];
    for (int a = 0; a < 8; ++a) {
      loc[a] = local(static_cast<std::uint16_t>(a));
      snprintf(buf, sizeof buf, "%s%02X", a ? " " : "", loc[a]);
      s += buf;
    }
    std::uint32_t baud = 0, clock = 0;
    for (int k = 3; k >= 0; --k) baud = (baud << 8) | local(static_cast<std::uint16_t>(loc[4] + 42 + k));
    for (int k = 3; k >= 0; --k) clock = (clock << 8) | local(static_cast<std::uint16_t>(0x230 + k));
    snprintf(buf, sizeof buf, " | baud=%u clock=%u", baud, clock);
    op("mesaflash local reads", -1, s + buf);
    for (int ch = 0; ch < loc[1]; ++ch) {
      b.wr(csA(ch), 0);
      b.wr(kCmd, 0x0F00U | (1U << ch));
      const auto ts = b.now() - 10;
      t = waitcmd(ts, 100'000'000ULL);
      const auto data = b.rd(kData) & 0xFF;
      snprintf(buf, sizeof buf, "mesaflash setup START ch%d", ch);
      if (t < 0) {
        char r[128];
        snprintf(r, sizeof r, "COMMAND still %04X after 100 ms (mesaflash waits forever)", b.rd(kCmd));
        op(buf, t, r);
        return;
      }
      const auto cs = b.rd(csA(ch));
      const auto if0 = b.rd(ifA(0, ch)), if1 = b.rd(ifA(1, ch)), if2 = b.rd(ifA(2, ch));
      char r[256];
      snprintf(r, sizeof r, "DATA=%02X CS=%08X IF=%08X,%08X,%08X", data, cs, if0, if1, if2);
      op(buf, t, r);
      if (data != 0) continue;
      Disc d;
      int entries = 0;
      for (std::uint16_t a = static_cast<std::uint16_t>(if2 & 0xFFFF);; a = static_cast<std::uint16_t>(a + 2)) {
        const std::uint16_t p = remote16(ch, a, d);
        if (p == 0 || ++entries > 64) break;
        getByte(ch, p, d, false);
      }
      std::string names;
      std::uint32_t swrev = 0;
      entries = 0;
      for (std::uint16_t a = static_cast<std::uint16_t>(if2 >> 16);; a = static_cast<std::uint16_t>(a + 2)) {
        const std::uint16_t p = remote16(ch, a, d);
        if (p == 0 || ++entries > 64) break;
        const auto type = getByte(ch, p, d, false);
        const int hdr = type == 0xA0 ? 14 : type == 0xB0 ? 4 : 0;
        if (hdr == 0) continue;
        std::uint8_t h[14];
        for (int k = 0; k < hdr; ++k) h[k] = getByte(ch, static_cast<std::uint16_t>(p + k), d, false);
        std::uint16_t q = static_cast<std::uint16_t>(p + hdr);
        std::string unit, name;
        if (type == 0xA0)
          for (int n = 0; n < 48; ++n) {
            const auto c = getByte(ch, q++, d, false);
            if (c == 0) break;
            unit += static_cast<char>(c);
          }
        for (int n = 0; n < 48; ++n) {
          const auto c = getByte(ch, q++, d, false);
          if (c == 0) break;
          name += static_cast<char>(c);
        }
        if (type == 0xA0 && name.rfind("SwRevision", 0) == 0) {
          const std::uint16_t pa = static_cast<std::uint16_t>(h[12] | (h[13] << 8));
          swrev = 0;
          for (int k = 0; k < h[1] / 8; ++k) swrev |= static_cast<std::uint32_t>(getByte(ch, static_cast<std::uint16_t>(pa + k), d, false)) << (8 * k);
        }
        if (!names.empty()) names += ",";
        names += name;
      }
      snprintf(buf, sizeof buf, "mesaflash ch%d discovery", ch);
      char rr[2048];
      snprintf(rr, sizeof rr, "doits=%d failed=%d mean=%.2fus max=%.2fus hash=%08X swrev=%u | PTOC - | GTOC %s", d.doits,
               d.bad, d.ns / 1000.0 / d.doits, d.maxns / 1000.0, d.hash, swrev, names.c_str());
      op(buf, static_cast<long long>(d.ns), rr);
    }
  }

  // Interface 0..2 after STOP ALL (and after STOP of one channel) that follows a
  // normal-run DOIT with field inputs 16..23 on, i.e. with byte 2 of interface 0 set
  // (SSLBP.MAC `initchannel` writes bytes 0, 1 and 3 of interface 0, not byte 2).
  void stopAfterNormalRun() {
    for (unsigned i = 16; i < 24; ++i) b.fieldInput(i, 24.0);
    for (const std::uint32_t stop : {0x0800U, 0x0801U}) {
      command(0x0800);
      b.wr(csA(0), 0);
      b.wr(csA(1), 0);
      long long t = command(0x0903);
      op(stop == 0x0800 ? "normal START, inputs 16..23 on" : "normal START again", t, regs(0x3));
      b.wr(ifA(0, 0), 0);
      t = command(0x1003);
      op("DOIT, inputs 16..23 on", t, regs(0x3));
      t = command(stop);
      const char* name = stop == 0x0800 ? "STOP ALL after a normal DOIT" : "STOP 0x0801 after a normal DOIT";
      op(name, t, regs(0x3));
      b.idle(100000);
      op(stop == 0x0800 ? "100 us after STOP ALL (normal run)" : "100 us after STOP 0x0801", -1, regs(0x3));
      b.idle(900000);
      op(stop == 0x0800 ? "1 ms after STOP ALL (normal run)" : "1 ms after STOP 0x0801", -1, regs(0x3));
    }
    for (unsigned i = 16; i < 24; ++i) b.fieldInput(i, 0.0);
  }

  // A remote fault held for n DOITs of the normal run. Prints the sequence of
  // (DATA, channel 0's CS) after each DOIT, run-length encoded, and whether TooManyErrors (CS
  // bit 7) ever set.
  template <typename Set>
  void faultHeld(const char* what, int n, Set set) {
    char buf[256];
    command(0x0800);
    b.wr(csA(0), 0);
    b.wr(csA(1), 0);
    long long t = command(0x0903);
    snprintf(buf, sizeof buf, "normal START before %s", what);
    op(buf, t, regs(0x3));
    set(true);
    std::string runs;
    std::uint32_t last = 0;
    std::uint8_t lastData = 0;
    int count = 0, tooMany = -1, bad = 0;
    std::uint64_t sum = 0;
    auto flush = [&] {
      if (count == 0) return;
      snprintf(buf, sizeof buf, "%sDATA=%02X CS=%08X x%d", runs.empty() ? "" : ", ", lastData, last, count);
      runs += buf;
    };
    for (int k = 0; k < n; ++k) {
      b.wr(ifA(0, 0), 0x00FF);
      t = command(0x1003);
      sum += static_cast<std::uint64_t>(t < 0 ? 0 : t);
      const auto data = static_cast<std::uint8_t>(b.rd(kData) & 0xFF);
      const auto cs = b.rd(csA(0));
      if (data != 0 || t < 0) ++bad;
      if ((cs & 0x80U) && tooMany < 0) tooMany = k + 1;
      if (k > 0 && cs == last && data == lastData) {
        ++count;
        continue;
      }
      flush();
      last = cs;
      lastData = data;
      count = 1;
    }
    flush();
    snprintf(buf, sizeof buf, "%d DOITs, %s held", n, what);
    char head[128];
    snprintf(head, sizeof head, "failed=%d toomany-at=%d | ", bad, tooMany);
    op(buf, static_cast<long long>(sum), head + runs);
    set(false);
    for (int k = 0; k < 2; ++k) {
      t = command(0x1003);
      snprintf(buf, sizeof buf, "DOIT %d after %s", k + 1, what);
      op(buf, t, regs(0x3));
    }
    op("remotes", -1, b.remoteInfo());
  }

  // The M bit (COMMAND bit 14, sserialwa.vhd `romwrena`) holds the processor in
  // reset; while it is set, DATA reads and writes the program ROM word addressed by COMMAND bits
  // 10..0 (16 bits). Only our own pattern is printed, not the ROM's contents (the one exception:
  // the word at 0x7FF, which SSLBP.ASM fills with a "rom cookie" constant). Releasing M boots the
  // processor (SSLBP.ASM: initmem, then commandcomplete).
  void romAccess() {
    char buf[512];
    command(0x0800);
    // Local RAM changed before the reset: channel 0's baud rate (local 0x9A..0x9D) to 115200.
    for (int k = 0; k < 4; ++k) {
      b.wr(kData, (115200U >> (8 * k)) & 0xFF);
      command(0xA000U | static_cast<std::uint16_t>(0x9A + k));
    }
    std::uint32_t baud = 0;
    for (int k = 3; k >= 0; --k) baud = (baud << 8) | local(static_cast<std::uint16_t>(0x9A + k));
    snprintf(buf, sizeof buf, "ch0 baud=%u", baud);
    op("local write ch0 baud 115200", -1, buf);

    b.wr(kCmd, 0x47FF);
    const auto cookie = b.rd(kData);
    snprintf(buf, sizeof buf, "CMD=%04X DATA(ROM 0x7FF)=%08X", b.rd(kCmd), cookie);
    op("M set, ROM word 0x7FF", -1, buf);
    b.wr(kCmd, 0x4123);
    const auto orig = b.rd(kData);
    const std::uint32_t pattern = (orig & 0xFFFF) == 0xC3A5 ? 0x5A3C : 0xC3A5;
    b.wr(kData, 0xFFFF0000U | pattern);  // bits 31..16 are not ROM bits
    const auto rb1 = b.rd(kData);
    b.idle(100);
    const auto rb2 = b.rd(kData);
    b.wr(kCmd, 0x4124);
    const auto other = b.rd(kData);
    b.wr(kCmd, 0x4123);
    const auto rb3 = b.rd(kData);
    b.wr(kData, orig);
    b.idle(100);
    const auto rb4 = b.rd(kData);
    auto show = [&](std::uint32_t v) {
      static char r[4][32];
      static int i = 0;
      char* o = r[i++ & 3];
      if (v == pattern) snprintf(o, 32, "pattern");
      else if (v == orig) snprintf(o, 32, "original");
      else snprintf(o, 32, "other(hi=%04X)", v >> 16);
      return o;
    };
    snprintf(buf, sizeof buf, "DATA after write: at once %s, 100 ns later %s, back from 0x124 %s; 0x124 %s; restored %s",
             show(rb1), show(rb2), show(rb3), other == pattern ? "pattern" : "not pattern", show(rb4));
    op("M set, ROM word 0x123 write/read", -1, buf);
    // Not regs(): its DATA read would show a ROM word.
    snprintf(buf, sizeof buf, "CMD=%04X ch0:CS=%08X IF0=%08X ch1:CS=%08X IF0=%08X", b.rd(kCmd), b.rd(csA(0)),
             b.rd(ifA(0, 0)), b.rd(csA(1)), b.rd(ifA(0, 1)));
    op("M set, registers", -1, buf);

    // Release with a command: is it run (a local read of the version, 0x2003) or dropped?
    b.wr(kCmd, 0x2003);
    const auto t0 = b.now() - 10;
    const auto cmd0 = b.rd(kCmd);
    const long long t = waitcmd(t0);
    const auto d0 = b.rd(kData) & 0xFF;
    b.idle(200000);
    const auto d1 = b.rd(kData) & 0xFF;
    snprintf(buf, sizeof buf, "CMD at once=%04X, DATA at clear=%02X, 200 us later DATA=%02X", cmd0, d0, d1);
    op("M released by 0x2003", t, buf);
    baud = 0;
    for (int k = 3; k >= 0; --k) baud = (baud << 8) | local(static_cast<std::uint16_t>(0x9A + k));
    snprintf(buf, sizeof buf, "version=%d ch0 baud=%u | ", local(3), baud);
    op("after M release", -1, buf + regs(0x3));
    // A normal START at the default baud rate works again.
    b.wr(csA(0), 0);
    b.wr(csA(1), 0);
    long long ts = command(0x0903);
    op("normal START after M release", ts, regs(0x3));
    ts = command(0x1003);
    op("DOIT after M release", ts, regs(0x3));
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
      names4C[ch] = ptoc + " | GTOC " + d.text;
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

    // Field power dropped: the field I/O processor raises LowVoltageFault (its fault byte in
    // the process data); then power back.
    b.fieldVoltage(0.0);
    for (int k = 0; k < 3; ++k) {
      b.wr(ifA(0, 0), 0x00FF);
      t = command(0x1003);
      snprintf(buf, sizeof buf, "DOIT %d field power off", k + 1);
      op(buf, t, regs(0x3));
    }
    op("remotes, field power off", -1, b.remoteInfo());
    b.fieldVoltage(24.0);
    for (int k = 0; k < 2; ++k) {
      b.wr(ifA(0, 0), 0x00FF);
      t = command(0x1003);
      snprintf(buf, sizeof buf, "DOIT %d field power back", k + 1);
      op(buf, t, regs(0x3));
    }
    op("remotes, field power back", -1, b.remoteInfo());

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

    // Parameter writes in setup mode, as lbpkit's writeElement (src/host/parameters.cpp): status
    // read (local 0xC1), write (0x65: write, 2-byte address, 2 bytes), status read, read back (0x45).
    b.cable(0, true);
    b.wr(csA(0), 0);
    b.wr(csA(1), 0);
    t = command(0x0F03);
    op("setup START 0x0F03 (again)", t, regs(0x3));
    const std::uint32_t toc[2] = {b.rd(ifA(2, 0)), b.rd(ifA(2, 1))};
    const Param* wd = param(0, "WatchDogTime");
    const Param* sw = param(0, "SwRevision");
    if (wd == nullptr || sw == nullptr) {
      op("ch0 WatchDogTime/SwRevision not discovered", -1, "");
    } else {
      snprintf(buf, sizeof buf, "ch0 read WatchDogTime@%04X 0x45", wd->addr);
      xferOp(buf, lbpCmd(0, 0x45, wd->addr), true);
      xferOp("ch0 local read status 0xC1", lbpCmd(0, 0xC1, 0), true);
      xferOp("ch0 write WatchDogTime=500 0x65", lbpCmd(0, 0x65, wd->addr, 500, true), false);
      xferOp("ch0 local read status 0xC1", lbpCmd(0, 0xC1, 0), true);
      xferOp("ch0 read back WatchDogTime", lbpCmd(0, 0x45, wd->addr), true);
      xferOp("ch0 write SwRevision (read only)", lbpCmd(0, 0x65, sw->addr, 0x1234, true), false);
      xferOp("ch0 local read status 0xC1", lbpCmd(0, 0xC1, 0), true);
      xferOp("ch0 read back SwRevision", lbpCmd(0, 0x45, sw->addr), true);
      xferOp("ch0 local write status 0 0xE1", lbpCmd(0, 0xE1, 0, 0, true), false);
      xferOp("ch0 local read status 0xC1", lbpCmd(0, 0xC1, 0), true);
    }

    // lbpkit's own discovery: 8-byte reads (LBP 0x47), each aligned chunk once.
    for (int ch = 0; ch < 2; ++ch) {
      Chunks c{*this, ch};
      const std::string ptoc = c.walk(static_cast<std::uint16_t>(toc[ch] & 0xFFFF));
      const std::string names = ptoc + " | GTOC " + c.walk(static_cast<std::uint16_t>(toc[ch] >> 16));
      snprintf(buf, sizeof buf, "ch%d lbpkit discovery 0x47", ch);
      char r[2048];
      snprintf(r, sizeof r, "doits=%d failed=%d mean=%.2fus max=%.2fus same-as-0x4C=%s | PTOC %s", c.doits, c.bad,
               c.ns / 1000.0 / c.doits, c.maxns / 1000.0, names == names4C[ch] ? "yes" : "NO", names.c_str());
      op(buf, static_cast<long long>(c.ns), r);
    }
    op("after lbpkit discovery", -1, regs(0x3));
    // Does STOP ALL (no reset) clear the fault byte left in CS byte 3?
    t = command(0x0800);
    op("STOP ALL", t, regs(0x3));
    b.idle(100000);
    op("100 us after STOP ALL", -1, regs(0x3));

    mesaflash();
    op("remotes after mesaflash", -1, b.remoteInfo());

    stopAfterNormalRun();
    faultHeld("field power off", 1100, [this](bool on) { b.fieldVoltage(on ? 0.0 : 24.0); });
    faultHeld("driver 0 over-temperature", 1100, [this](bool on) { b.driverHot(0, on); });
    romAccess();
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
