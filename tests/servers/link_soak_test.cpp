// SPDX-License-Identifier: MIT
// A noisy RS-422 cable under a running host: both 7I77 channels
// at 1 kHz in simulated time, every character on both links in both
// directions with each data bit flipped at a bit error rate of 1e-4 (and,
// in the second test, characters dropped and added and replies ending in a
// break as well). Each cycle the host sends new random field outputs and
// analog outputs and the field inputs take new random levels (the truth).
// Checked at every cycle:
//  (a) each output terminal (field outputs, the six analog codes and their
//      enables) shows a value the host sent: this cycle's when the DOIT
//      succeeded, this cycle's or what it showed before when it failed (the
//      remote rejected the frame or only its reply was lost), or all off
//      right after a START (the START clears the outputs, manual: NORMAL
//      START). Never anything else;
//  (b) the inputs the host library reports fresh (CycleStatus::freshMask)
//      equal the truth, a channel that failed keeps its last good value, and
//      the remote fault byte in CS is the remote's;
//  (c) a DOIT fails only when the link damaged something during it, and a
//      DOIT the link damaged fails, save the damage that cannot matter
//      (chatter after a restart, a noise character after a complete frame or
//      reply): both counted and printed. A damaged exchange that passed
//      CRC-8 is printed with the frame the remote got, and a wrong value in
//      its cycle is counted apart (soak() says why it happens);
//  (d) a channel SSLBP gives up on (TooManyErrors) or over the host's fault
//      limit is restarted by SmartSerial::recover() and DOITs again; at the
//      end, the rates cleared, both channels DOIT cleanly.
//
// ctest runs a modest count; the long run (docs/faults.md):
//   LBPKIT_LINK_SOAK_DOITS=1000000 LBPKIT_LINK_SOAK_SEED=1
//   build/default/tests/lbpkit_tests --gtest_filter='LinkSoak.*'
// (all on one line).
#include <gtest/gtest.h>

#include <array>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <random>

#include "hostmot2/sslbp.hpp"
#include "lbp/protocol.hpp"
#include "lbpkit/faults.hpp"
#include "lbpkit/wire/process_data.hpp"
#include "lbpkit/wire/sslbp.hpp"
#include "support/running_card.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace hm2 = lbpkit::model::hm2;
namespace remote = lbpkit::model::remote;
namespace lbp = lbpkit::model::lbp;

namespace {

using namespace std::chrono_literals;
using hm2::SerialLink;

std::uint64_t envOr(const char* name, std::uint64_t fallback) {
  const char* v = std::getenv(name);
  return v ? std::strtoull(v, nullptr, 0) : fallback;
}

constexpr unsigned kFieldIo = 0;  // channel (and slot) of the 7I77's field I/O processor
constexpr unsigned kAnalog = 1;   // and of its analog processor
constexpr unsigned kAnalogOuts = 6;

// What the analog terminals show (or what the host sent, as terminals would show it).
struct AnalogTerminals {
  std::array<std::int16_t, kAnalogOuts> codes{};
  std::array<bool, kAnalogOuts> enables{};  // ENA0..4 follow AnalogEna, ENA5 SpinEna
  bool operator==(const AnalogTerminals&) const = default;
};

std::int16_t signed13(std::uint64_t raw) {
  const auto v = static_cast<std::int64_t>(raw & 0x1FFFU);
  return static_cast<std::int16_t>(v >= 0x1000 ? v - 0x2000 : v);
}

// A link's damage as its counters tell it.
std::uint64_t damage(const SerialLink::Counters& c) { return c.corrupted + c.dropped + c.added + c.breaks; }

struct Figures {
  std::uint64_t doits = 0;
  std::uint64_t damagedToRemote = 0;    // frames the remote did not act on (a failed DOIT without a reply)
  std::uint64_t damagedFromRemote = 0;  // replies damaged on the way back (the remote acted on the frame)
  std::uint64_t failed = 0;             // channel-DOITs that failed, every one of them damaged
  std::uint64_t failedAfterRestart = 0;  // damage since the restart (START, chatter or the DOIT)
  std::uint64_t undamagedFailures = 0;  // must stay 0
  std::uint64_t chatterDamage = 0;      // damage during the chatter after a restart, before the first DOIT
  std::uint64_t harmlessExtra = 0;      // only noise after a complete frame or reply
  std::uint64_t undetected = 0;         // damaged, passed CRC-8
  std::uint64_t wrongOutputs = 0;       // a value the host never sent on a terminal
  std::uint64_t staleReportedGood = 0;  // a terminal kept the last values, the DOIT reported good
  std::uint64_t wrongAfterPassed = 0;   // a wrong value in the cycle of an exchange that passed CRC-8
  std::uint64_t remoteFaulted = 0;      // a remote raised a fault (a misframed command changed it)
  std::uint64_t wrongInputs = 0;
  std::uint64_t staleKept = 0;          // cycles a channel kept its last good inputs
  std::uint64_t remoteCrc = 0;          // the remotes' own CRC error counts (local 0xC3), summed
  std::uint64_t tooManyErrors = 0;      // cycles that found TooManyErrors (each then recovered)
  std::uint64_t overLimit = 0;
  std::uint64_t recoveries = 0;
  std::uint64_t failedRecoveries = 0;
  lbpkit::Nanoseconds recoveryTime{};
};

class LinkSoak {
 public:
  LinkSoak(std::uint64_t seed, SerialLink::Rates rates, double breakRate) : rng_(seed) {
    auto& io = field();
    io.setFieldVoltage(24.0, now());
    for (unsigned ch = 0; ch < 2; ++ch) {
      SerialLink::RateSettings r;
      r.toRemote = rates;
      r.fromRemote = rates;
      r.breakRate = breakRate;
      r.seed = seed * 16 + ch;
      settings_[ch] = r;
    }
    output_ = rc_.ss.find(kFieldIo, "output");
    input_ = rc_.ss.find(kFieldIo, "input");
    ena_ = rc_.ss.find(kAnalog, "analogena");
    spin_ = rc_.ss.find(kAnalog, "spinena");
    for (unsigned i = 0; i < kAnalogOuts; ++i) aout_[i] = rc_.ss.find(kAnalog, "analogout" + std::to_string(i));
  }

  hm2::HostMot2Card& card() { return rc_.t.card(); }
  remote::FieldIoProcessor& field() { return card().daughtercard(0).fieldIo; }
  remote::AnalogProcessor& analog() { return card().daughtercard(0).analog; }
  SerialLink& link(unsigned ch) { return card().part<hm2::Sslbp>().link(ch); }
  remote::RemoteDevice& remoteOf(unsigned ch) {
    return ch == kFieldIo ? static_cast<remote::RemoteDevice&>(field()) : analog();
  }
  lbpkit::SmartSerial& ss() { return rc_.ss; }
  hm2::SimTime now() { return hm2::SimTime{rc_.t.now()}; }
  const Figures& figures() const { return f_; }

  void noisy(bool on) {
    for (unsigned ch = 0; ch < 2; ++ch) link(ch).setRates(on ? settings_[ch] : SerialLink::RateSettings{});
  }

  AnalogTerminals analogTerminals() {
    AnalogTerminals a;
    for (unsigned i = 0; i < kAnalogOuts; ++i) {
      a.codes[i] = analog().dacCode(i);
      a.enables[i] = analog().enable(i);
    }
    return a;
  }
  AnalogTerminals analogSent() {
    AnalogTerminals a;
    for (unsigned i = 0; i < kAnalogOuts; ++i) {
      a.codes[i] = signed13(rc_.ss.raw(aout_[i]));
      a.enables[i] = rc_.ss.raw(i < 5 ? ena_ : spin_) & 1U;
    }
    return a;
  }

  // Some cycles without noise: every value gets through.
  void settle() {
    for (int i = 0; i < 20; ++i) {
      const auto st = cycle(false);
      ASSERT_TRUE(st.ok) << "cycle " << i << " without noise: " << lbpkit::describeCs(rc_.ss.cs(kFieldIo)) << " / "
                         << lbpkit::describeCs(rc_.ss.cs(kAnalog));
    }
  }

  // One 1 ms cycle: new outputs and input levels, the DOIT, every check.
  lbpkit::CycleStatus cycle(bool count = true) {
    const auto start = rc_.t.now();
    randomize();
    // The links as they are before the DOIT: a damaged exchange that passed
    // CRC-8 is replayed on a copy to show the frame the remote got.
    probe_ = {link(0), link(1)};
    const auto st = rc_.ss.cycle();
    if (count) ++f_.doits;

    // (c) damage against failure, per channel. Each channel's windows are
    // back to back (from the end of the last one, or from the STOP of a
    // restart), so damage to an exchange between cycles (a chattering
    // channel's) is not lost.
    std::array<bool, 2> passed{};  // damaged, not failed, not explained
    for (unsigned ch = 0; ch < 2; ++ch) {
      const auto& now = link(ch).counters();
      const bool damaged = damage(now) != damage(window_[ch]);
      const bool failed = !(st.freshMask & (1U << ch));
      const bool acted = remoteOf(ch).processDataCount() != windowPd_[ch];
      if (count) passed[ch] = classify(ch, damaged, failed, acted, now, window_[ch]);
      window_[ch] = now;
      windowPd_[ch] = remoteOf(ch).processDataCount();
      if (!failed) chattering_[ch] = false;  // the first DOIT since the START is taken
    }

    // (b) inputs: fresh equals the truth, stale is the last good value, the
    // remote fault byte is the remote's. A wrong one in the cycle of an
    // exchange that passed CRC-8 is counted apart (see soak()).
    const auto in = static_cast<std::uint32_t>(rc_.ss.raw(input_));
    if (st.freshMask & (1U << kFieldIo)) {
      if (in != truth_) noteWrong(passed[kFieldIo], f_.wrongInputs, "input", in, truth_);
      lastGoodInput_ = in;
    } else {
      if (in != lastGoodInput_) noteWrong(passed[kFieldIo], f_.wrongInputs, "stale input", in, lastGoodInput_);
      if (count) ++f_.staleKept;
    }
    std::array<bool, 2> faulted{};
    for (unsigned ch = 0; ch < 2; ++ch) {
      // The soak causes no fault; a misframed command can (see soak()).
      faulted[ch] = remoteOf(ch).faults() != 0;
      if (st.freshMask & (1U << ch)) lastFaults_[ch] = remoteOf(ch).faults();
      if (rc_.ss.remoteFaults(ch) != lastFaults_[ch])
        noteWrong(passed[ch], f_.wrongInputs, "remote fault byte", rc_.ss.remoteFaults(ch), lastFaults_[ch]);
      if (faulted[ch] && !faulted_[ch] && count) ++f_.remoteFaulted;
      faulted_[ch] = faulted[ch];
    }

    // (a) outputs: this cycle's values or, when the remote did not take
    // them, what was there, or all off while the remote has a fault (its
    // safe state, 7I77 manual: WATCHDOG AND FAULTS). A DOIT reported good
    // whose values did not arrive is counted apart (it takes a reply that
    // passed CRC-8 but was not the remote's answer to this DOIT).
    const auto out = field().outputs();
    const auto sentOut = static_cast<std::uint16_t>(rc_.ss.raw(output_));
    if (out != sentOut && !(faulted[kFieldIo] && out == 0)) {
      if (out != lastOut_)
        noteWrong(passed[kFieldIo], f_.wrongOutputs, "field outputs", out, sentOut);
      else if (st.freshMask & (1U << kFieldIo))
        noteStale("field outputs");
    }
    const auto a = analogTerminals();
    const auto sentA = analogSent();
    if (!(a == sentA) && !(faulted[kAnalog] && a == AnalogTerminals{})) {
      if (!(a == lastAnalog_))
        noteWrong(passed[kAnalog], f_.wrongOutputs, "analog outputs", static_cast<std::uint64_t>(a.codes[0] & 0x1FFF),
                  static_cast<std::uint64_t>(sentA.codes[0] & 0x1FFF));
      else if (st.freshMask & (1U << kAnalog))
        noteStale("analog outputs");
    }
    lastOut_ = out;
    lastAnalog_ = a;
    trackRemoteCrc();

    // (d) the host library's error handling.
    if (count && st.tooManyErrorsMask) ++f_.tooManyErrors;
    if (count && st.overLimitMask) ++f_.overLimit;
    for (unsigned slot = 0; slot < 2; ++slot) {
      // TooManyErrors or over the limit (the host library's verdicts), or
      // a remote fault, which a START clears (the caller's policy here).
      if (!(st.needsRecovery() & (1U << slot)) && rc_.ss.running(slot) && !faulted[slot]) continue;
      const auto t0 = rc_.t.now();
      if (!rc_.ss.recover(slot)) continue;  // rate limited: the next cycle asks again
      ++f_.recoveries;
      f_.recoveryTime += rc_.t.now() - t0;
      if (!rc_.ss.running(slot)) ++f_.failedRecoveries;
      EXPECT_EQ(rc_.ss.faultCount(slot), 0U);
      // Until its first DOIT the channel chatters (manual: NORMAL START):
      // damage to those exchanges fails only the DOIT they meet.
      chattering_[slot] = true;
      // The START cleared the outputs (manual: NORMAL START): the terminals
      // now show all off, which the next failed DOIT may leave in place.
      const bool off = slot == kFieldIo ? field().outputs() == 0 : analogTerminals() == AnalogTerminals{};
      if (!off) noteWrong(false, f_.wrongOutputs, "outputs after START", slot, 0);
      if (slot == kFieldIo)
        lastOut_ = field().outputs();
      else
        lastAnalog_ = analogTerminals();
      trackRemoteCrc();
    }
    const auto spent = rc_.t.now() - start;
    if (spent < 1ms) rc_.t.sleep(1ms - spent);
    return st;
  }

 private:
  void randomize() {
    rc_.ss.setRaw(output_, rng_() & 0xFFFFU);
    for (auto e : aout_) rc_.ss.set(e, std::uniform_real_distribution<double>(-10.0, 10.0)(rng_));
    const auto bits = rng_();
    rc_.ss.setRaw(ena_, bits & 1U);
    rc_.ss.setRaw(spin_, (bits >> 1) & 1U);
    const auto truth = static_cast<std::uint32_t>(rng_());
    for (unsigned i = 0; i < 32; ++i)
      if (((truth ^ truth_) >> i) & 1U) field().setInputVoltage(i, ((truth >> i) & 1U) ? 24.0 : 0.0);
    truth_ = truth;
  }

  // Returns true for a damaged exchange that passed and that nothing but
  // CRC-8 missing it explains.
  bool classify(unsigned ch, bool damaged, bool failed, bool acted, const SerialLink::Counters& now,
                const SerialLink::Counters& before) {
    if (failed) {
      ++f_.failed;
      if (!damaged) {
        ++f_.undamagedFailures;
        if (f_.undamagedFailures <= 5)
          ADD_FAILURE() << "DOIT " << f_.doits << " channel " << ch << " failed with no damage on its link: "
                        << lbpkit::describeCs(rc_.ss.cs(ch));
        return false;
      }
      if (chattering_[ch])
        ++f_.failedAfterRestart;  // the START's and the chatter's exchanges are in its window too
      else
        (acted ? f_.damagedFromRemote : f_.damagedToRemote) += 1;
      return false;
    }
    if (!damaged) return false;
    if (chattering_[ch]) {
      ++f_.chatterDamage;
      return false;
    }
    const bool onlyExtra = now.added != before.added && now.corrupted == before.corrupted &&
                           now.dropped == before.dropped && now.breaks == before.breaks;
    if (onlyExtra) {
      ++f_.harmlessExtra;
      return false;
    }
    ++f_.undetected;
    std::printf("link soak: DOIT %llu channel %u: damaged (%llu bits flipped, %llu dropped, %llu added) and "
                "passed CRC-8; %s\n",
                static_cast<unsigned long long>(f_.doits), ch,
                static_cast<unsigned long long>(now.bitErrors - before.bitErrors),
                static_cast<unsigned long long>(now.dropped - before.dropped),
                static_cast<unsigned long long>(now.added - before.added), replay(ch).c_str());
    return true;
  }

  // The DOIT's frame to the remote on `ch` as sent and as the copy of the
  // link taken before it delivers it (its generator draws the same damage).
  std::string replay(unsigned ch) {
    std::array<std::uint8_t, 12> data{};
    unsigned bytes = 0;
    if (ch == kFieldIo) {
      lbpkit::wire::lbp::packBits(data, 0, 16, rc_.ss.raw(output_));
      bytes = 2;
    } else {
      for (unsigned i = 0; i < kAnalogOuts; ++i) lbpkit::wire::lbp::packBits(data, 13 * i, 13, rc_.ss.raw(aout_[i]));
      lbpkit::wire::lbp::packBits(data, 78, 1, rc_.ss.raw(ena_));
      lbpkit::wire::lbp::packBits(data, 79, 1, rc_.ss.raw(spin_));
      bytes = 10;
    }
    std::array<std::uint8_t, 13> frame{};
    frame[0] = lbp::special_rpc::kProcessData;
    std::copy_n(data.begin(), bytes, frame.begin() + 1);
    frame[bytes + 1] = lbp::crc8({frame.data(), bytes + 1});
    SerialLink copy = probe_[ch];
    copy.setExternal(true);
    (void)copy.exchange({frame.data(), bytes + 2}, hm2::SimTime{0}, card().part<hm2::Sslbp>().channelBaud(ch));
    std::string out = "sent";
    for (unsigned i = 0; i < bytes + 2; ++i) out += fmt(" %02X", frame[i]);
    out += ", the remote got";
    for (auto b : copy.outbox()) out += fmt(" %02X", b);
    return out;
  }
  static std::string fmt(const char* f, unsigned v) {
    char buf[48];
    std::snprintf(buf, sizeof buf, f, v);
    return buf;
  }

  void noteWrong(bool passedCrc, std::uint64_t& counter, const char* what, std::uint64_t seen, std::uint64_t want) {
    if (passedCrc) {
      ++f_.wrongAfterPassed;
      std::printf("link soak: DOIT %llu: %s 0x%llx, the truth 0x%llx, from that exchange\n",
                  static_cast<unsigned long long>(f_.doits), what, static_cast<unsigned long long>(seen),
                  static_cast<unsigned long long>(want));
      return;
    }
    ++counter;
    if (counter <= 5)
      ADD_FAILURE() << "DOIT " << f_.doits << ": " << what << " 0x" << std::hex << seen << ", the truth 0x" << want;
  }

  void noteStale(const char* what) {
    ++f_.staleReportedGood;
    std::printf("link soak: DOIT %llu: the %s kept the last cycle's values though the DOIT was reported good\n",
                static_cast<unsigned long long>(f_.doits), what);
  }

  void trackRemoteCrc() {
    for (unsigned ch = 0; ch < 2; ++ch) {
      const std::uint8_t n = remoteOf(ch).crcErrorCount();
      f_.remoteCrc += static_cast<std::uint8_t>(n - remoteCrcSeen_[ch]);  // the 8-bit counter wraps
      remoteCrcSeen_[ch] = n;
    }
  }

  testing_host::RunningCard rc_;
  std::mt19937_64 rng_;
  std::array<SerialLink::RateSettings, 2> settings_{};
  std::array<SerialLink, 2> probe_{};
  lbpkit::ElementRef output_, input_, ena_, spin_;
  std::array<lbpkit::ElementRef, kAnalogOuts> aout_{};
  std::uint32_t truth_ = 0;
  std::uint32_t lastGoodInput_ = 0;
  std::uint16_t lastOut_ = 0;
  AnalogTerminals lastAnalog_{};
  std::array<bool, 2> chattering_{};
  std::array<std::uint8_t, 2> lastFaults_{};  // the remote fault byte of each channel's last good DOIT
  std::array<bool, 2> faulted_{};
  std::array<SerialLink::Counters, 2> window_{};  // the link counters where each channel's window starts
  std::array<std::uint32_t, 2> windowPd_{};       // and the remote's process data count
  std::array<std::uint8_t, 2> remoteCrcSeen_{};
  Figures f_;
};

void soak(const char* name, SerialLink::Rates rates, double breakRate, std::uint64_t defaultDoits) {
  const std::uint64_t doits = envOr("LBPKIT_LINK_SOAK_DOITS", defaultDoits);
  const std::uint64_t seed = envOr("LBPKIT_LINK_SOAK_SEED", 1);
  const auto wall0 = std::chrono::steady_clock::now();
  LinkSoak s(seed, rates, breakRate);
  s.settle();
  if (::testing::Test::HasFatalFailure()) return;
  const auto sim0 = s.now();
  s.noisy(true);
  for (std::uint64_t i = 0; i < doits; ++i) {
    s.cycle();
    if (s.figures().wrongOutputs + s.figures().wrongInputs + s.figures().undamagedFailures > 20) break;
  }
  const auto sim = s.now() - sim0;
  s.noisy(false);

  // The rates cleared: whatever still needs a restart gets it (after the
  // rate limit), then both channels DOIT cleanly and every value is right.
  for (int i = 0; i < 1500; ++i) {
    const auto st = s.cycle(false);
    if (st.needsRecovery() == 0 && s.ss().running(0) && s.ss().running(1)) break;
  }
  unsigned clean = 0;
  for (int i = 0; i < 50; ++i) {
    const auto st = s.cycle(false);
    if (st.ok && st.freshMask == 0x03 && st.needsRecovery() == 0) ++clean;
  }
  EXPECT_EQ(clean, 50U) << "after the noise: " << lbpkit::describeCs(s.ss().cs(0)) << " / "
                        << lbpkit::describeCs(s.ss().cs(1));

  const auto& f = s.figures();
  SerialLink::Counters link{};
  hm2::Sslbp::ErrorTotals sslbp{};
  const auto state = s.card().part<hm2::Sslbp>().state();
  for (unsigned ch = 0; ch < 2; ++ch) {
    const auto& c = s.link(ch).counters();
    link.corrupted += c.corrupted;
    link.bitErrors += c.bitErrors;
    link.dropped += c.dropped;
    link.added += c.added;
    link.breaks += c.breaks;
    const auto& e = state.channel[ch].errors;
    sslbp.crc += e.crc;
    sslbp.timeout += e.timeout;
    sslbp.serialBreak += e.serialBreak;
    sslbp.extraCharacter += e.extraCharacter;
  }
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
  const auto u = [](std::uint64_t v) { return static_cast<unsigned long long>(v); };
  std::printf(
      "link soak (%s, seed %llu): %llu DOITs on 2 channels, %.1f s simulated in %.1f s; link: %llu bits flipped, "
      "%llu characters corrupted, %llu dropped, %llu added, %llu breaks; failed channel-DOITs %llu (frame to the "
      "remote damaged %llu, reply damaged %llu, after a restart %llu), undamaged failures %llu; SSLBP counted CRC "
      "%llu, timeout %llu, break %llu, extra %llu; remotes counted CRC %llu; damaged but harmless: chatter %llu, "
      "trailing noise %llu; damaged and passed CRC-8: %llu (a DOIT reported good whose outputs did not arrive: "
      "%llu, a wrong value from one: %llu, a remote fault raised: %llu); cycles with TooManyErrors %llu, over the fault limit %llu, recoveries %llu (%llu failed, %.2f ms each); inputs "
      "kept from the last good cycle %llu; wrong values: outputs %llu, inputs %llu\n",
      name, u(seed), u(f.doits), std::chrono::duration<double>(sim).count(), wall, u(link.bitErrors),
      u(link.corrupted), u(link.dropped), u(link.added), u(link.breaks), u(f.failed), u(f.damagedToRemote),
      u(f.damagedFromRemote), u(f.failedAfterRestart), u(f.undamagedFailures), u(sslbp.crc), u(sslbp.timeout),
      u(sslbp.serialBreak), u(sslbp.extraCharacter), u(f.remoteCrc), u(f.chatterDamage), u(f.harmlessExtra),
      u(f.undetected), u(f.staleReportedGood), u(f.wrongAfterPassed), u(f.remoteFaulted), u(f.tooManyErrors), u(f.overLimit), u(f.recoveries),
      u(f.failedRecoveries),
      f.recoveries ? std::chrono::duration<double, std::milli>(f.recoveryTime).count() / static_cast<double>(f.recoveries)
                   : 0.0,
      u(f.staleKept), u(f.wrongOutputs), u(f.wrongInputs));

  // No value the host did not send on a terminal, no input the remote did
  // not send taken for fresh, no failure without damage.
  EXPECT_EQ(f.wrongOutputs, 0U);
  EXPECT_EQ(f.wrongInputs, 0U);
  EXPECT_EQ(f.undamagedFailures, 0U);
  // CRC-8 catches every error of 1 to 3 bits in a frame of LBP's sizes, but
  // a flipped command header reframes the frame: the remote then checks
  // pieces of it against bytes that were never CRCs (1 in 256 each passes)
  // and answers what they ask, and the 7I77 analog processor's good reply
  // (fault byte 0, CRC 0) is also what two CRC-only answers look like. So a
  // damaged exchange can pass (about 1 in 20 000 damaged DOITs in the long
  // run); each one is printed above with the frame the remote got. Its cost
  // is a DOIT reported good whose outputs did not arrive (the terminals kept
  // the last cycle's values): never a wrong value, as checked above.
  EXPECT_LE(f.staleReportedGood, f.undetected);
  EXPECT_LE(f.wrongAfterPassed, f.undetected);
  EXPECT_LE(f.undetected * 1000, f.failed) << "far more damaged exchanges passed CRC-8 than reframing explains";
  // The noise did something, and what it did was counted on both sides.
  EXPECT_GT(f.damagedToRemote, 0U);
  EXPECT_GT(f.damagedFromRemote, 0U);
  EXPECT_GE(f.remoteCrc, f.damagedToRemote / 2);  // most damaged frames fail the remote's CRC
  EXPECT_GE(sslbp.crc, f.damagedFromRemote / 2);  // most damaged replies fail SSLBP's
  EXPECT_GE(sslbp.timeout, f.failed);             // a discarded reply times out too
  EXPECT_GT(f.recoveries, 0U);
  EXPECT_EQ(f.failedRecoveries, 0U);
}

TEST(LinkSoak, BitErrorsNeverReachATerminalOrAHostInput) {
  soak("bit error rate 1e-4", SerialLink::Rates{1e-4, 0, 0}, 0, 200'000);
}

TEST(LinkSoak, DroppedAndAddedCharactersAndBreaksToo) {
  soak("bit error rate 1e-4, drop and extra 1e-5, break 1e-4", SerialLink::Rates{1e-4, 1e-5, 1e-5}, 1e-4, 100'000);
}

}  // namespace
