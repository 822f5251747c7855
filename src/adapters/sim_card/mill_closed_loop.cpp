// SPDX-License-Identifier: MIT
#include "sim_card/mill_closed_loop.hpp"

#include <algorithm>
#include <string>
#include <utility>

#include "lbpkit/servo_cycle.hpp"

namespace lbpkit {

namespace {
SmartSerial::Options bothChannels() {
  SmartSerial::Options o;
  o.channelMask = 0x03;
  return o;
}
constexpr unsigned kEncodersUsed = 6;  // the 7I77's, as LinuxCNC's num_encoders=6 reads them
}  // namespace

model::machine::MachineDescription millWithRotaryTables(std::chrono::microseconds step) {
  auto d = model::machine::mill();
  d.name = "mill+ab";
  d.step = step;
  for (unsigned channel : {3U, 4U}) {
    model::machine::AxisDescription rotary = d.axes[0];  // X's drive and motor
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

MillClosedLoop::StartedCard::StartedCard()
    : info(readCardInfo(t)), ss(t, info, bothChannels()), enc(t, info, kEncodersUsed) {
  ss.discover(0x03);
  ss.startNormal();
  enc.initialize();
}

MillClosedLoop::MillClosedLoop(std::chrono::microseconds plantStep)
    : machine_(millWithRotaryTables(plantStep), card_.t.card(), model::hm2::SimTime{card_.t.now()}) {
  auto& ss = card_.ss;
  for (unsigned i = 0; i < aout_.size(); ++i) aout_[i] = ss.find(1, "analogout" + std::to_string(i));
  ss.setRaw(ss.find(1, "analogena"), 1);
  ss.setRaw(ss.find(1, "spinena"), 1);
  ss.setRaw(ss.find(0, "output"), 0x7);  // coolant, lube, Z brake released
  ss.set(aout_[5], 5.0);                  // the spindle at 12000 rpm: 51 k counts/s
  for (unsigned a = 0; a < kAxes; ++a) {
    initial_[a] = machine_.axis(a).position();
    card_.enc.setScale(a, a < 3 ? 1600.0 : 800.0);  // counts per mm, per degree
  }
  begin_ = card_.t.now();
}

CycleStatus MillClosedLoop::cycle() {
  using namespace std::chrono_literals;
  auto& t = card_.t;
  auto& ss = card_.ss;
  auto& enc = card_.enc;
  const auto start = t.now();
  // A triangle wave, +-20 mm (degrees) at 20 mm/s, turning every 2 s.
  const auto phase = static_cast<double>(cycles_ % 4000);  // ms
  const double triangle = phase < 2000 ? phase / 50.0 - 20.0 : 20.0 - (phase - 2000) / 50.0;
  for (unsigned a = 0; a < kAxes; ++a) {
    const double target = initial_[a] + triangle;
    const double pos = initial_[a] + enc.position(a) - offset_[a];
    ss.set(aout_[a], std::clamp(5.0 * (target - pos), -10.0, 10.0));
  }
  status_ = servoCycle(t, ss, &enc);
  if (cycles_ == 0)
    for (unsigned a = 0; a < kAxes; ++a) offset_[a] = enc.position(a);
  machine_.advance(model::hm2::SimTime{start + 1ms});
  t.sleep(start + 1ms - t.now());
  ++cycles_;
  return status_;
}

}  // namespace lbpkit
