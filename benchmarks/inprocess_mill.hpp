// The in-process mill, as one object both the benchmark and the profiling
// tool run: the 7I92 (Mesa's 7i92_7i77x2 firmware, as `lbpkit sim` runs it) with
// one 7I77 and the mill behind it, driven by the host library at 1 kHz as a
// LinuxCNC servo thread would (SSLBP outputs and inputs, the muxed
// encoders, a P position loop closed on every axis), with all six of the
// 7I77's encoders turning. The built-in mill uses four of them (X, Y, Z,
// the spindle on encoder 5); two rotary tables on AOUT3/ENC3 and AOUT4/ENC4
// (ENA3 and ENA4 follow AnalogEna with the others: manual, SERVO ENABLE
// OUTPUTS) turn the other two.
#pragma once

#include <algorithm>
#include <array>
#include <chrono>
#include <cstdint>
#include <string>

#include "lbpkit/encoders.hpp"
#include "lbpkit/sserial.hpp"
#include "machine/machine.hpp"
#include "support/running_card.hpp"

namespace lbpkit_bench {

// The mill plus rotary tables A and B (10 degrees per motor revolution, no
// switches), so that every encoder input of the 7I77 counts.
inline machine::MachineDescription millWithSixEncoders(std::chrono::microseconds step) {
  auto d = machine::mill();
  d.name = "mill+ab";
  d.step = step;
  for (unsigned channel : {3U, 4U}) {
    machine::AxisDescription rotary = d.axes[0];  // X's drive and motor
    // A new string moved in, not operator=(const char*) on X's copied name: GCC 12
    // at -O3 warns on that (-Wrestrict, a false positive: GCC bugs 105329, 105651).
    rotary.name = std::string(1, channel == 3 ? 'a' : 'b');
    rotary.drives[0].analogOutput = rotary.drives[0].enable = rotary.drives[0].encoderInput = channel;
    rotary.screwPitch = 10.0;  // degrees per motor revolution
    rotary.massKg = 20.0;
    rotary.travelMin = -1e6;
    rotary.travelMax = 1e6;
    rotary.initialPosition = 0.0;
    d.axes.push_back(rotary);
  }
  return d;
}

class InProcessMill {
 public:
  static constexpr unsigned kAxes = 5;  // X, Y, Z, A, B (encoders 0..4); the spindle is encoder 5

  explicit InProcessMill(std::chrono::microseconds step = std::chrono::microseconds(50))
      : enc_(rc_.t, rc_.info, 6), machine_(millWithSixEncoders(step), rc_.t.card(), hm2::SimTime{rc_.t.now()}) {
    auto& ss = rc_.ss;
    enc_.initialize();
    for (unsigned i = 0; i < 6; ++i) aout_[i] = ss.find(1, "analogout" + std::to_string(i));
    ss.setRaw(ss.find(1, "analogena"), 1);
    ss.setRaw(ss.find(1, "spinena"), 1);
    ss.setRaw(ss.find(0, "output"), 0x7);  // coolant, lube, Z brake released
    ss.set(aout_[5], 5.0);                   // spindle at 12000 rpm: 51 k counts/s
    for (unsigned a = 0; a < kAxes; ++a) {
      initial_[a] = machine_.axis(a).position();
      enc_.setScale(a, a < 3 ? 1600.0 : 800.0);  // counts per mm, per degree
    }
    begin_ = rc_.t.now();
  }

  // One servo period: everything a LinuxCNC servo thread and the card do
  // for it, then the machine up to the next period.
  void cycle() {
    hostCycle();
    advanceMachine();
  }

  // The host's part: outputs, DOIT, inputs, encoders, the position loops.
  void hostCycle() {
    auto& t = rc_.t;
    auto& ss = rc_.ss;
    start_ = t.now();
    // Every axis follows a triangle wave, +-20 mm (degrees) at 20 mm/s,
    // turning round every 2 s: the encoders never stand still.
    const auto phase = static_cast<double>(cycles_ % 4000);  // ms
    const double triangle = phase < 2000 ? phase / 50.0 - 20.0 : 20.0 - (phase - 2000) / 50.0;
    for (unsigned a = 0; a < kAxes; ++a) {
      const double target = initial_[a] + triangle;
      const double pos = initial_[a] + enc_.position(a) - offset_[a];
      ss.set(aout_[a], std::clamp(5.0 * (target - pos), -10.0, 10.0));
    }
    ss.queueOutputs();
    enc_.queue();
    t.flush();
    status_ = ss.collectInputs();
    enc_.update();
    if (cycles_ == 0)
      for (unsigned a = 0; a < kAxes; ++a) offset_[a] = enc_.position(a);
  }

  // The machine up to the next period, and the card with it.
  void advanceMachine() {
    using namespace std::chrono_literals;
    machine_.advance(hm2::SimTime{start_ + 1ms});
    rc_.t.sleep(start_ + 1ms - rc_.t.now());
    ++cycles_;
  }

  [[nodiscard]] double simulatedSeconds() { return std::chrono::duration<double>(rc_.t.now() - begin_).count(); }
  [[nodiscard]] std::uint64_t cycles() const { return cycles_; }
  [[nodiscard]] const lbpkit::CycleStatus& status() const { return status_; }
  [[nodiscard]] const machine::Machine& machine() const { return machine_; }
  [[nodiscard]] const lbpkit::MuxedEncoders& encoders() const { return enc_; }

 private:
  testing_host::RunningCard rc_;  // both 7I77 channels discovered and started
  lbpkit::MuxedEncoders enc_;
  machine::Machine machine_;
  std::array<lbpkit::ElementRef, 6> aout_{};
  std::array<double, kAxes> initial_{};
  std::array<double, kAxes> offset_{};
  lbpkit::CycleStatus status_{};
  lbpkit::Nanoseconds begin_{};
  lbpkit::Nanoseconds start_{};  // of the current period
  std::uint64_t cycles_ = 0;
};

}  // namespace lbpkit_bench
