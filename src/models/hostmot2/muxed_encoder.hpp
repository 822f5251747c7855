// SPDX-License-Identifier: MIT
// HostMot2 muxed quadrature counters: the 7I77's six encoder inputs reach the
// FPGA over three pin groups, multiplexed by the ENCMUX select line (manual:
// P1 HOST INTERFACE, ENCODER INTERFACE, MAXIMUM ENCODER COUNT RATE).
//
// Registers (lbpkit/wire/hostmot2_modules.hpp; counter i at +4i):
//   count        read: 15..0 count, 31..16 timestamp of the last count;
//                    any write clears the count
//   CCR         31..16 count latched on index (ro), 15 quadrature error,
//                    14 A/B mask polarity, 11 filter (1 = 15 ticks, 0 = 3),
//                    10 counter mode (up/down), 9 use index mask, 8 index mask
//                    polarity, 7 gate index, 6 index just once, 5 clear on
//                    index, 4 latch on index, 3 index polarity, 2..0 filtered
//                    Z, B, A (ro)
//   TSDiv      timestamp counter divisor (counts every TSDiv+2 ClockLow)
//   TS          the 16-bit timestamp counter
//   rate        11..0 mux divisor: a mux tick every divisor+2 ClockLow
//   timer      (single; only with an HM2DPLL in the firmware, one past
//                    the IDROM's five) 15 enable, 14..12 DPLL rate source
//                    (0 reference, 1..4 timers): on the source's rising edge
//                    every count register and the timestamp counter are
//                    latched, and reads show the latched values (LinuxCNC
//                    encoder.c: base + 5 strides, (timer-number << 12) |
//                    0x8000, 0 for -1; hostmot2.9 encoder.timer-number)
//
// The plain (non-muxed) QCount has the same counters and registers without
// the mux (encoder.hpp): a Variant says where its registers are and how its
// counters sample.
//
// The select line toggles every tick, so each counter samples its inputs
// every second tick, and the digital filter needs a new input state for 3
// (or 15) ticks. At the power-up rate (about 8 MHz ticks with a 100 MHz
// ClockLow) a quadrature state must last 2 samples: count rates up to about
// 2 MHz are exact, faster ones lose counts, as on real hardware.
#pragma once

#include <array>
#include <cstdint>

#include "hostmot2/dpll.hpp"
#include "hostmot2/module.hpp"
#include "lbpkit/wire/muxed_encoder.hpp"

namespace lbpkit::model::hm2 {

// The A/B/Z signals of one encoder: a position in quadrature counts moving
// at a set velocity, with an index pulse one count wide every countsPerRev.
struct EncoderSignal {
  double position = 0.0;    // counts (4 per quadrature cycle)
  double velocity = 0.0;    // counts per second
  std::uint32_t countsPerRev = 0;  // 0: no index
  // The quadrature state of one index pulse; the others are every
  // countsPerRev from it. The index is a track of its own on the disc: where
  // the A/B count lost counts, the pulses stay at their shaft angle.
  std::int64_t indexAt = 0;
};

class MuxedEncoder : public Module {
 public:
  static constexpr const ModuleKind& kKind = map::kMuxedQCount;
  // The muxed counters' register addresses.
  static constexpr std::uint16_t kCount = kKind.address(map::qcount::kCount);
  static constexpr std::uint16_t kControl = kKind.address(map::qcount::kControl);
  static constexpr std::uint16_t kTimestampDiv = kKind.address(map::qcount::kTimestampDiv);
  static constexpr std::uint16_t kTimestamp = kKind.address(map::qcount::kTimestamp);
  static constexpr std::uint16_t kRate = kKind.address(map::qcount::kRate);
  static constexpr std::uint16_t kTimerSelect = kKind.address(map::qcount::kTimerSelect);
  static constexpr std::uint32_t kTimerEnable = 1U << 15;
  static constexpr unsigned kMaxCounters = 12;

  // What differs between the muxed counters and the plain ones.
  struct Variant {
    const ModuleKind* kind = &kKind;
    std::uint16_t base = kKind.base;
    std::uint8_t version = kKind.version;
    unsigned ticksPerSample = 2;  // a counter sees its inputs every this many rate ticks
    std::uint32_t powerUpTickHz = 8'000'000;  // the firmware's rate divisor at power-up
    std::array<unsigned, 2> filterSamples{2, 8};  // samples a state must last (filter bit 0, 1)
  };

  // What an observer sees per counter: the count and CCR as the registers
  // hold them, and the encoder signal the world drives into it.
  struct State {
    struct Counter {
      std::uint16_t count = 0;
      std::uint32_t ccr = 0;
      EncoderSignal signal;
    };
    unsigned counters = 0;  // the first `counters` entries are valid
    std::array<Counter, kMaxCounters> counter{};
  };

  // CCR bits.
  static constexpr std::uint32_t kQuadError = lbpkit::wire::qcount::ccr::kQuadError;
  static constexpr std::uint32_t kFilter = lbpkit::wire::qcount::ccr::kFilter;
  static constexpr std::uint32_t kCounterMode = lbpkit::wire::qcount::ccr::kCounterMode;
  static constexpr std::uint32_t kJustOnce = lbpkit::wire::qcount::ccr::kJustOnce;
  static constexpr std::uint32_t kClearOnIndex = lbpkit::wire::qcount::ccr::kClearOnIndex;
  static constexpr std::uint32_t kLatchOnIndex = lbpkit::wire::qcount::ccr::kLatchOnIndex;
  static constexpr std::uint32_t kIndexPolarity = lbpkit::wire::qcount::ccr::kIndexPolarity;

  MuxedEncoder(unsigned counters, std::uint32_t clockLow);  // the muxed counters
  MuxedEncoder(unsigned counters, std::uint32_t clockLow, const Variant& variant);

  // Every word of the count, CCR, TSDiv and TS blocks answers (a counter
  // the firmware lacks reads 0 and refuses writes), the rate at its first;
  // the timer select only with a DPLL (Presence::WithDpll).
  [[nodiscard]] bool decodes(std::uint16_t a) const override {
    return (a >= base_ && a < base_ + map::qcount::kRate * kRegisterStride + 4) ||
           (dpll_ != nullptr && a == base_ + map::qcount::kTimerSelect * kRegisterStride);
  }
  // The firmware's HM2DPLL (the "d" firmwares): the timer register exists
  // and latches on its rate sources. Before the card maps its registers.
  void attachDpll(Dpll* dpll) { dpll_ = dpll; }
  std::uint32_t readRegister(std::uint16_t address, SimTime now) override;
  WriteResult writeRegister(std::uint16_t address, std::uint32_t value, SimTime now) override;
  // Cheap: it only notes the time. The counters catch up (settle) when
  // anything looks at them or changes their inputs: the card advances every
  // module at each host access, tens of times a servo cycle, and counting
  // is exact over any span (run() computes edges, it does not walk time),
  // so working only when someone looks gives the same counts for less.
  void advance(SimTime now) override {
    if (now <= pending_) return;
    if ((timerSelect_ & kTimerEnable) != 0 && dpll_ != nullptr) [[unlikely]]
      latchAtTimer(now);
    pending_ = now;
  }
  void reset() override;  // counts, CCRs and divisors at power-up; the encoders stay where they are

  // The world: what the encoder on input `n` does from `now` on.
  // (Inline: the machine's plant sets every encoder's at every span.)
  void setVelocity(unsigned n, double countsPerSecond, SimTime now) {
    advance(now);
    settle(n);
    signals_.at(n).velocity = countsPerSecond;
  }
  void setIndexPeriod(unsigned n, std::uint32_t countsPerRev, std::int64_t indexAt = 0);
  [[nodiscard]] const EncoderSignal& signal(unsigned n) const {
    settle(n);
    return signals_.at(n);
  }

  [[nodiscard]] std::uint16_t count(unsigned n) const {
    settle(n);
    return static_cast<std::uint16_t>(state_.at(n).count);
  }
  [[nodiscard]] std::uint32_t control(unsigned n) const {
    settle(n);
    return state_.at(n).ccr;
  }
  [[nodiscard]] SimTime samplePeriod() const { return samplePeriod_; }
  [[nodiscard]] unsigned counters() const { return counters_; }
  [[nodiscard]] State state() const;

 private:
  struct Counter {
    std::int32_t count = 0;
    std::uint32_t ccr = 0;
    std::uint16_t latched = 0;
    std::uint16_t countTimestamp = 0;
    std::int64_t filtered = 0;  // quadrature state (position) the filter has accepted
    std::int64_t candidate = 0;
    unsigned stable = 0;
    // The time of the last count, kept as what it is worked out from until
    // the count register is read (stampCount()): a counter catches up several
    // times a servo cycle, the host reads it once. Edge: the signal reached
    // edgeCounts from p0 at `velocity`, starting at `from`; Sample: at `at`.
    enum class Stamp : std::uint8_t { Done, Edge, Sample } stamp = Stamp::Done;
    SimTime from{};  // Edge
    double edgeCounts = 0.0, p0 = 0.0, velocity = 0.0;
    SimTime at{};  // Sample
  };
  // countTimestamp from what run() kept (under the current timestamp divisor).
  void stampCount(Counter& c) const;
  // The count register's value for counter n, settled.
  [[nodiscard]] std::uint32_t countRegister(unsigned n) const;
  // Latches every count register and the timestamp counter at the selected
  // DPLL source's last rising edge up to `now`, if it is a new one.
  void latchAtTimer(SimTime now);
  [[nodiscard]] bool latching() const { return (timerSelect_ & kTimerEnable) != 0 && dpll_ != nullptr && latched_; }
  // Brings counter n (or every counter) to pending_, the card's time
  // (const: a look at a counter settles it; what it is at a time does not
  // depend on when it was last looked at).
  void settle(unsigned n) const {
    if (n < kMaxCounters && settled_[n] < pending_) catchUp(n);
  }
  void catchUp(unsigned n) const {
    if (n < counters_) {
      EncoderSignal& s = signals_[n];
      // A standing signal: all run() would do is move it by velocity * dt, a
      // zero of the velocity's sign (dt > 0 here), which is the velocity itself.
      if (s.velocity == 0.0)
        s.position += s.velocity;
      else
        run(n, settled_[n], pending_);
    }
    settled_[n] = pending_;
  }
  void settle() const;
  void run(unsigned n, SimTime from, SimTime to) const;
  // run()'s rare cases, out of line: counting from state a to b across
  // index pulses while clear or latch on index is armed, and a signal too
  // fast for the filter (sample by sample).
  [[gnu::noinline]] static void countAcrossIndexes(const EncoderSignal& s, Counter& c, std::int64_t a, std::int64_t b);
  [[gnu::noinline]] void runSampled(const EncoderSignal& s, Counter& c, SimTime from, SimTime to, double p0) const;
  static void index(Counter& c, std::int64_t countAtIndex);
  [[nodiscard]] std::uint16_t timestampAt(SimTime t) const;
  [[nodiscard]] unsigned filterSamples(const Counter& c) const { return variant_.filterSamples[(c.ccr & kFilter) ? 1 : 0]; }

  Variant variant_;
  unsigned counters_;
  std::uint32_t clockLow_;
  std::uint32_t rateDivisor_;
  // samplePeriod() for rateDivisor_ (setSamplePeriod() when it changes), and
  // the same in seconds.
  SimTime samplePeriod_{};
  double samplePeriodSeconds_ = 0.0;
  void setSamplePeriod();
  // The fastest |velocity| (counts/s) the filter passes state by state,
  // with the filter off ([0], 2 samples) and on ([1], 8): a quadrature
  // state lasts 1 / |velocity|, and run() counts state by state while that
  // is at least the filter's time (samplePeriodSeconds_ * samples). Worked
  // out with the sample period so that run() compares instead of dividing
  // (maxFilteredVelocity() in the .cpp: exactly the same decision).
  std::array<double, 2> maxFilteredVelocity_{};
  std::uint32_t tsDivisor_ = 0;
  mutable std::array<EncoderSignal, kMaxCounters> signals_{};
  mutable std::array<Counter, kMaxCounters> state_{};
  mutable std::array<SimTime, kMaxCounters> settled_{};  // each counter is settled up to here
  mutable SimTime lastSpan_{-1};        // run()'s last to - from
  mutable double lastSpanSeconds_ = 0;  // and the same in seconds
  SimTime pending_{};  // the card's time: settle() brings them here
  Dpll* dpll_ = nullptr;
  std::uint32_t timerSelect_ = 0;
  std::uint64_t lastLatch_ = 0;  // the DPLL edge (ClockLow tick) latched last
  bool latched_ = false;         // something was latched since the timer was enabled
  std::array<std::uint32_t, kMaxCounters> latchedCount_{};
  std::uint16_t latchedTimestamp_ = 0;
};

}  // namespace lbpkit::model::hm2
