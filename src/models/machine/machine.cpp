#include "machine/machine.hpp"

#include <algorithm>
#include <chrono>
#include <stdexcept>
#include <string>
#include <utility>

namespace machine {

namespace {

constexpr unsigned kEncodersPer7I77 = 6;  // manual: ENCODER INTERFACE

[[noreturn]] void bad(const std::string& what) { throw std::invalid_argument("machine: " + what); }

std::vector<int> axisIndices(const MachineDescription& d) {
  std::vector<int> out;
  for (const auto& s : d.switches) {
    int index = -1;
    if (!s.axis.empty()) {
      for (std::size_t a = 0; a < d.axes.size(); ++a)
        if (d.axes[a].name == s.axis) index = static_cast<int>(a);
      if (index < 0) bad("switch " + s.name + " is on axis \"" + s.axis + "\", which the machine does not have");
    }
    out.push_back(index);
  }
  return out;
}

AxisParameters axisParameters(const AxisDescription& a) {
  AxisParameters p;
  const double units = a.unitsPerMotorRev();
  double rotors = 0.0;
  for (const auto& drive : a.drives) rotors += drive.motorInertia;
  p.inertia = rotors + a.screwInertia + reflectedInertia(a.massKg, units);
  p.viscous = a.viscous;
  p.coulomb = a.coulomb;
  p.gravityTorque = a.vertical ? gravityTorque(a.massKg, units) : 0.0;
  p.brakeTorque = a.brakeOutput >= 0 ? a.brakeTorque : 0.0;
  p.unitsPerMotorRev = units;
  p.hardStopMin = a.travelMin - a.overtravel;
  p.hardStopMax = a.travelMax + a.overtravel;
  return p;
}

}  // namespace

Machine::Machine(MachineDescription description, hm2::HostMot2Card& card, SimTime now, unsigned connector)
    : d_(std::move(description)),
      card_(&card),
      board_(&card.daughtercard(connector)),
      encoders_(&card.encoders()),
      time_(now),
      h_(d_.step),
      hSeconds_(std::chrono::duration<double>(d_.step).count()),
      switches_(d_.switches, axisIndices(d_)) {
  if (h_ <= SimTime{0}) bad("the step must be positive");
  const unsigned encoderBase = connector * kEncodersPer7I77;
  auto checkChannel = [](unsigned ch, const std::string& what) {
    if (ch >= remote::AnalogProcessor::kChannels) bad(what + " " + std::to_string(ch) + " is not on the 7I77 (0..5)");
  };
  auto checkEncoder = [&](unsigned input, const std::string& what) {
    if (input >= kEncodersPer7I77) bad(what + " encoder " + std::to_string(input) + " is not on the 7I77 (0..5)");
    return encoderBase + input;
  };
  for (const auto& a : d_.axes) {
    if (a.drives.empty()) bad("axis " + a.name + " has no drive");
    if (a.screwPitch == 0 || a.gearRatio == 0) bad("axis " + a.name + " needs a screw pitch and gear ratio");
    if (a.brakeOutput >= static_cast<int>(remote::FieldIoProcessor::kOutputs)) bad("axis " + a.name + ": no such brake output");
    AxisPlant plant{Axis(axisParameters(a), a.initialPosition), {}, 0.0, a.brakeOutput};
    plant.inertiaShare = plant.axis.parameters().inertia / static_cast<double>(a.drives.size());
    for (const auto& drive : a.drives) {
      checkChannel(drive.analogOutput, "axis " + a.name + ": analog output");
      checkChannel(drive.enable, "axis " + a.name + ": enable");
      const unsigned input = checkEncoder(drive.encoderInput, "axis " + a.name + ":");
      plant.drives.push_back(Drive{drive, ServoAmplifier(drive.amplifier),
                                   QuadratureEncoder(drive.encoder, *encoders_, input, plant.axis.motorRevs()), 0.0});
    }
    positions_.push_back(plant.axis.position());
    axes_.push_back(std::move(plant));
  }
  if (d_.spindle) {
    checkChannel(d_.spindle->analogOutput, "spindle: analog output");
    checkChannel(d_.spindle->enable, "spindle: enable");
    spindle_.emplace(d_.spindle->vfd);
    if (d_.spindle->encoderInput) {
      const unsigned input = checkEncoder(*d_.spindle->encoderInput, "spindle:");
      spindleEncoder_.emplace(d_.spindle->encoder, *encoders_, input, 0.0);
    }
  }
  // What the outputs drive loads them (manual: FIELD OUTPUT CHARACTERISTICS).
  for (const auto& o : d_.outputs) {
    if (o.output >= remote::FieldIoProcessor::kOutputs) bad("output " + o.name + ": no such field output");
    board_->fieldIo.setOutputLoad(o.output, o.loadOhms);
  }
  switches_.apply(positions_.data(), board_->fieldIo);
}

bool Machine::setSwitch(const std::string& name, bool tripped) {
  const bool found = switches_.setTripped(name, tripped);
  if (found) switches_.apply(positions_.data(), board_->fieldIo);
  return found;
}

bool Machine::brakeEngaged(const AxisPlant& a) const {
  // The brake holds unless its release coil, on a field output, is
  // energized (fails safe: no field power, a tripped output or a dead host
  // all leave it holding). The coil has field power across it while the
  // output is on, sourcing or sinking (manual: FIELD OUTPUT
  // CHARACTERISTICS); a 24 V brake pulls in from about two thirds of that.
  constexpr double kPullInVolts = 16.0;
  if (a.brakeOutput < 0) return false;
  const auto& io = board_->fieldIo;
  return !io.outputOn(static_cast<unsigned>(a.brakeOutput)) || io.fieldVoltage() < kPullInVolts;
}

void Machine::advance(SimTime now) {
  while (time_ < now) step();
}

void Machine::step() {
  const SimTime t0 = time_;
  const SimTime t1 = t0 + h_;
  // The counters may already have run past t0 (the host's accesses advance
  // the card); the encoders aim at t1 from where they are.
  const SimTime from = std::max(t0, card_->now());
  // The field inputs from where the axes are at the start of the step.
  switches_.apply(positions_.data(), board_->fieldIo);
  const remote::AnalogProcessor& analog = board_->analog;
  for (std::size_t i = 0; i < axes_.size(); ++i) {
    AxisPlant& a = axes_[i];
    double torque = 0.0;
    for (Drive& drive : a.drives) {
      drive.torque = drive.amplifier.torque(analog.outputVoltage(drive.d.analogOutput), analog.enable(drive.d.enable),
                                            a.axis.motorRevsPerSecond(), a.inertiaShare, hSeconds_);
      torque += drive.torque;
    }
    a.axis.step(torque, brakeEngaged(a), hSeconds_);
    for (Drive& drive : a.drives) drive.encoder.drive(a.axis.motorRevs(), from, t1, h_ / 2);
    positions_[i] = a.axis.position();
  }
  if (spindle_) {
    spindle_->step(analog.outputVoltage(d_.spindle->analogOutput), analog.enable(d_.spindle->enable), hSeconds_);
    if (spindleEncoder_) spindleEncoder_->drive(spindle_->revolutions(), from, t1, h_ / 2);
  }
  time_ = t1;
}

Machine::State Machine::state() const {
  State s;
  s.time = time_;
  const remote::AnalogProcessor& analog = board_->analog;
  for (std::size_t i = 0; i < switches_.size(); ++i) {
    const auto sw = switches_.state(i);
    if (sw.kind == SwitchKind::Estop && sw.tripped) s.estopOk = false;
    if (sw.kind == SwitchKind::Probe && sw.tripped) s.probe = true;
    s.switches.push_back(sw);
  }
  for (std::size_t i = 0; i < axes_.size(); ++i) {
    const AxisPlant& a = axes_[i];
    State::Axis out;
    out.name = d_.axes[i].name;
    out.position = a.axis.position();
    out.velocity = a.axis.velocity();
    out.brakeEngaged = brakeEngaged(a);
    out.atHardStop = a.axis.atHardStop();
    for (const Drive& drive : a.drives) {
      const bool ena = analog.enable(drive.d.enable);
      out.drives.push_back(State::Drive{drive.d.analogOutput, analog.outputVoltage(drive.d.analogOutput), ena,
                                        drive.amplifier.enabled(ena), drive.torque, drive.d.encoderInput,
                                        drive.encoder.count(),
                                        drive.encoder.shaftCounts(a.axis.motorRevs())});
    }
    for (std::size_t k = 0; k < switches_.size(); ++k)
      if (switches_.axisOf(k) == static_cast<int>(i)) out.switches.push_back(s.switches[k]);
    s.axes.push_back(std::move(out));
  }
  if (spindle_) {
    State::Spindle sp;
    sp.commandRpm = spindle_->commandRpm();
    sp.rpm = spindle_->rpm();
    sp.revolutions = spindle_->revolutions();
    sp.running = spindle_->running(analog.enable(d_.spindle->enable));
    if (spindleEncoder_) sp.encoderCount = spindleEncoder_->count();
    s.spindle = sp;
  }
  for (const auto& o : d_.outputs) s.outputs.push_back({o.name, o.output, board_->fieldIo.outputOn(o.output)});
  return s;
}

}  // namespace machine
