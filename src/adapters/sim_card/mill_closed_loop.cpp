#include "sim_card/mill_closed_loop.hpp"

#include <algorithm>
#include <chrono>
#include <string>
#include <utility>

namespace lbpkit {

namespace {
SmartSerial::Options bothChannels() {
  SmartSerial::Options o;
  o.channelMask = 0x03;
  return o;
}
// Where the mill's axes start (machine::mill()), in mm.
constexpr std::array<double, 3> kInitial{200.0, 150.0, -75.0};
}  // namespace

MillClosedLoop::StartedCard::StartedCard() : info(readCardInfo(t)), ss(t, info, bothChannels()), enc(t, info) {
  ss.discover(0x03);
  ss.startNormal();
  enc.initialize();
}

MillClosedLoop::MillClosedLoop(machine::MachineDescription mill)
    : machine_(std::move(mill), card_.t.card(), hm2::SimTime{card_.t.now()}) {
  auto& ss = card_.ss;
  for (unsigned i = 0; i < aout_.size(); ++i) aout_[i] = ss.find(1, "analogout" + std::to_string(i));
  ss.setRaw(ss.find(1, "analogena"), 1);
  ss.setRaw(ss.find(1, "spinena"), 1);
  ss.setRaw(ss.find(0, "output"), 0x7);  // coolant, lube, Z brake released
  ss.set(aout_[5], 5.0);                  // the spindle turning
  for (unsigned a = 0; a < kAxes; ++a) card_.enc.setScale(a, 1600.0);
}

CycleStatus MillClosedLoop::cycle() {
  using namespace std::chrono_literals;
  auto& t = card_.t;
  auto& ss = card_.ss;
  auto& enc = card_.enc;
  const auto start = t.now();
  const double phase = static_cast<double>(cycles_ % 2000) / 2000.0;
  for (unsigned a = 0; a < kAxes; ++a) {
    const double target = kInitial[a] + (phase < 0.5 ? 20.0 : -20.0);
    const double pos = kInitial[a] + enc.position(a) - offset_[a];
    ss.set(aout_[a], std::clamp(5.0 * (target - pos), -10.0, 10.0));
  }
  ss.queueOutputs();
  enc.queue();
  t.flush();
  const CycleStatus st = ss.collectInputs();
  enc.update();
  if (cycles_ == 0)
    for (unsigned a = 0; a < kAxes; ++a) offset_[a] = enc.position(a);
  machine_.advance(hm2::SimTime{start + 1ms});
  ++cycles_;
  return st;
}

}  // namespace lbpkit
