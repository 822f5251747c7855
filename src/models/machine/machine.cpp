// SPDX-License-Identifier: MIT
#include "machine/machine.hpp"

#include "hostmot2/ioport.hpp"

#include <algorithm>
#include <cmath>
#include <chrono>
#include <stdexcept>
#include <string>
#include <utility>

namespace lbpkit::model::machine {

namespace {

constexpr unsigned kEncodersPer7I77 = 6;  // manual: ENCODER INTERFACE
// The 7I76's spindle encoder on the 7I77+7I76 firmwares: muxed counter unit
// 3 (PIN_7I77_7I76_34.vhd; docs/cards.md), i.e. counters 6 and 7. The 7I76
// has no multiplexer, so both see the same signals; LinuxCNC configurations
// take the first, hm2_7i92.0.encoder.06, and it is the one driven here.
constexpr unsigned kSevenI76SpindleCounter = 6;

// The first thing the description wires to the 7I76, in a
// machine file's order (axes, spindle, switches, outputs: the order
// sevenI76Where is noted in), or "" when it wires nothing there.
std::string sevenI76Wiring(const MachineDescription& d) {
  for (const auto& a : d.axes)
    if (a.brakeOutput >= 0 && a.brakeDaughtercard == Daughtercard::SevenI76)
      return "axis " + a.name + "'s brake is on its field output " + std::to_string(a.brakeOutput);
  if (d.spindle && d.spindle->daughtercard == Daughtercard::SevenI76) return "the spindle is on its SpinOut";
  if (d.spindle && d.spindle->encoderInput && d.spindle->encoderDaughtercard == Daughtercard::SevenI76)
    return "the spindle's encoder is on its encoder input";
  for (const auto& s : d.switches)
    if (s.daughtercard == Daughtercard::SevenI76) return "switch " + s.name + " is on its field input " + std::to_string(s.input);
  for (const auto& o : d.outputs)
    if (o.daughtercard == Daughtercard::SevenI76) return "output " + o.name + " is on its field output " + std::to_string(o.output);
  return "";
}

[[noreturn]] void bad(const std::string& what) { throw std::invalid_argument("machine: " + what); }

std::vector<EncoderChannel> brokenChannels(const QuadratureEncoder& e) {
  std::vector<EncoderChannel> out;
  for (const auto ch : {EncoderChannel::A, EncoderChannel::B, EncoderChannel::Index})
    if (e.broken(ch)) out.push_back(ch);
  return out;
}

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
      encoders_(&card.part<hm2::MuxedEncoder>()),
      stepGens_(card.module<hm2::StepGen>()),
      sevenI76_(card.sevenI76()),
      inputs_{&board_->fieldIo, sevenI76_, card.module<hm2::IoPort>()},
      time_(now),
      h_(d_.step),
      switches_(d_.switches, axisIndices(d_)) {
  if (h_ <= SimTime{0}) bad("the step must be positive");
  if (const std::string wired = sevenI76Wiring(d_); !wired.empty() && sevenI76_ == nullptr) {
    const std::string what = "the 7I76 is not on the card: its firmware (" + std::string(card.firmware().name) +
                             ") has none (" + wired +
                             "); the 7I77+7I76 firmwares have one: the 7I92's pinout \"7I77+7I76\", the 7I92T's default";
    if (d_.sevenI76Where.empty()) bad(what);
    throw std::invalid_argument(d_.sevenI76Where + ": " + what);
  }
  const unsigned encoderBase = connector * kEncodersPer7I77;
  auto checkChannel = [](unsigned ch, const std::string& what) {
    if (ch >= remote::AnalogProcessor::kChannels) bad(what + " " + std::to_string(ch) + " is not on the 7I77 (0..5)");
  };
  auto checkEncoder = [&](unsigned input, const std::string& what) {
    if (input >= kEncodersPer7I77) bad(what + " encoder " + std::to_string(input) + " is not on the 7I77 (0..5)");
    return encoderBase + input;
  };
  std::vector<std::string> stepGenOwners(stepGens_ != nullptr ? stepGens_->instances() : 0);
  for (const auto& a : d_.axes) {
    if (a.drives.empty() && !a.stepper) bad("axis " + a.name + " has no drive");
    if (a.drives.size() > kMaxDrivesPerAxis)
      bad("axis " + a.name + " has " + std::to_string(a.drives.size()) + " drives: at most " +
          std::to_string(kMaxDrivesPerAxis) + " move one axis");
    if (!a.drives.empty() && a.stepper) bad("axis " + a.name + " has servo drives and a stepper: one or the other");
    if (a.screwPitch == 0 || a.gearRatio == 0) bad("axis " + a.name + " needs a screw pitch and gear ratio");
    if (a.brakeOutput >= static_cast<int>(remote::FieldIoProcessor::kOutputs)) bad("axis " + a.name + ": no such brake output");
    AxisPlant plant{Axis(axisParameters(a), a.initialPosition), {}, 0.0, a.brakeOutput, a.brakeDaughtercard, 0.0,
                    std::nullopt, std::nullopt, ServoMotion{}};
    plant.commanded = plant.axis.position();
    const auto motors = static_cast<double>(std::max<std::size_t>(a.drives.size(), 1));  // none: a stepper
    plant.inertiaShare = plant.axis.parameters().inertia / motors;
    if (a.stepper) {
      // The StepGen's count now is the motor's step 0 at the initial position.
      const unsigned n = a.stepper->stepGen;
      if (stepGens_ == nullptr)
        bad("axis " + a.name + " is a stepper on StepGen " + std::to_string(n) + ", but the card's firmware (" +
            std::string(card.firmware().name) + ") has no StepGen");
      if (n >= stepGens_->instances())
        bad("axis " + a.name + ": StepGen " + std::to_string(n) + " is not on the card (its firmware has " +
            std::to_string(stepGens_->instances()) + ": 0.." + std::to_string(stepGens_->instances() - 1) + ")");
      if (!stepGenOwners[n].empty())
        bad("axis " + a.name + ": StepGen " + std::to_string(n) + " is already axis " + stepGenOwners[n] + "'s");
      stepGenOwners[n] = a.name;
      if (!(a.stepper->stepsPerUnit > 0)) bad("axis " + a.name + ": steps per unit must be above 0");
      const AxisParameters& p = plant.axis.parameters();
      plant.stepGenCount = stepGens_->steps(n, card.now());
      plant.stepper.emplace(*a.stepper, a.initialPosition, plant.stepGenCount, p.hardStopMin, p.hardStopMax);
      if (a.stepper->encoderInput)
        plant.stepperEncoder.emplace(a.stepper->encoder, *encoders_,
                                     checkEncoder(*a.stepper->encoderInput, "axis " + a.name + ": stepper"),
                                     a.initialPosition / p.unitsPerMotorRev);
    }
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
    if (d_.spindle->daughtercard == Daughtercard::SevenI77) {
      checkChannel(d_.spindle->analogOutput, "spindle: analog output");
      checkChannel(d_.spindle->enable, "spindle: enable");
    }
    spindle_.emplace(d_.spindle->vfd);
    if (d_.spindle->encoderInput) {
      unsigned input = 0;
      if (d_.spindle->encoderDaughtercard == Daughtercard::SevenI76) {
        if (*d_.spindle->encoderInput != 0) bad("spindle: the 7I76 has one encoder input (0)");
        input = kSevenI76SpindleCounter;
        if (input >= encoders_->counters()) bad("spindle: the card's firmware has no counter for the 7I76's encoder");
      } else {
        input = checkEncoder(*d_.spindle->encoderInput, "spindle:");
      }
      spindleEncoder_.emplace(d_.spindle->encoder, *encoders_, input, 0.0);
    }
  }
  for (const auto& s : d_.switches)
    if (s.daughtercard == Daughtercard::Card &&
        (inputs_.card == nullptr || s.input >= inputs_.card->ports() * inputs_.card->width()))
      bad("switch " + s.name + ": IO pin " + std::to_string(s.input) + " is not on the card (its firmware has " +
          std::to_string(inputs_.card == nullptr ? 0 : inputs_.card->ports() * inputs_.card->width()) + ")");
  // What the outputs drive loads them (manual: FIELD OUTPUT CHARACTERISTICS).
  for (const auto& o : d_.outputs) {
    if (o.output >= remote::FieldIoProcessor::kOutputs) bad("output " + o.name + ": no such field output");
    if (o.daughtercard == Daughtercard::SevenI76)
      sevenI76_->setOutputLoad(o.output, o.loadOhms);
    else
      board_->fieldIo.setOutputLoad(o.output, o.loadOhms);
  }
  switches_.apply(positions_.data(), inputs_);
}

bool Machine::setSwitch(const std::string& name, bool tripped) {
  const bool found = switches_.setTripped(name, tripped);
  if (found) switches_.apply(positions_.data(), inputs_);
  return found;
}

std::size_t Machine::setSwitches(SwitchKind kind, bool tripped) {
  std::size_t n = 0;
  for (std::size_t i = 0; i < switches_.size(); ++i)
    if (switches_.parameters(i).kind == kind) {
      switches_.setTripped(switches_.parameters(i).name, tripped);
      ++n;
    }
  if (n > 0) switches_.apply(positions_.data(), inputs_);
  return n;
}

std::optional<std::size_t> Machine::axisIndex(std::string_view name) const {
  for (std::size_t i = 0; i < d_.axes.size(); ++i)
    if (d_.axes[i].name == name) return i;
  return std::nullopt;
}

void Machine::push(std::size_t axis, double distance, double speed) {
  AxisPlant& a = axes_.at(axis);
  // A stepper's position is its steps (StepperMotor): a shove that moves it
  // is not modelled.
  if (a.stepper) bad("axis " + d_.axes.at(axis).name + " is a stepper: it cannot be pushed");
  a.axis.push(distance, speed);
}

void Machine::setJammed(std::size_t axis, bool jammed) { axes_.at(axis).axis.setJammed(jammed); }

void Machine::setEncoderBroken(std::size_t axis, std::size_t drive, EncoderChannel channel, bool broken) {
  AxisPlant& a = axes_.at(axis);
  a.drives.at(drive).encoder.setBroken(channel, broken, a.axis.motorRevs(), card_->now());
}

void Machine::setEncoderReversed(std::size_t axis, std::size_t drive, bool reversed) {
  AxisPlant& a = axes_.at(axis);
  a.drives.at(drive).encoder.setReversed(reversed, a.axis.motorRevs());
}

void Machine::setEnableIgnored(std::size_t axis, std::size_t drive, bool ignored) {
  axes_.at(axis).drives.at(drive).amplifier.setEnableIgnored(ignored);
}

bool Machine::setSpindleEncoderBroken(EncoderChannel channel, bool broken) {
  if (!spindleEncoder_) return false;
  spindleEncoder_->setBroken(channel, broken, spindle_->revolutions(), card_->now());
  return true;
}

bool Machine::setSpindleEncoderReversed(bool reversed) {
  if (!spindleEncoder_) return false;
  spindleEncoder_->setReversed(reversed, spindle_->revolutions());
  return true;
}

bool Machine::commandsVelocity(const AxisPlant& a) const {
  if (a.drives.empty()) return false;
  const Drive& first = a.drives.front();
  return first.amplifier.parameters().mode == AmplifierMode::Velocity &&
         first.amplifier.enabled(board_->analog.enable(first.d.enable));
}

double Machine::commandVelocity(std::size_t axis) const {
  const AxisPlant& a = axes_.at(axis);
  if (a.stepper)
    return stepGens_->stepRate(a.stepper->parameters().stepGen) / a.stepper->parameters().stepsPerUnit *
           (a.stepper->parameters().reversed ? -1.0 : 1.0);
  if (!commandsVelocity(a)) return 0.0;
  const Drive& first = a.drives.front();
  return first.amplifier.command(board_->analog.outputVoltage(first.d.analogOutput)) *
         a.axis.parameters().unitsPerMotorRev;
}

double Machine::followingError(std::size_t axis) const {
  const AxisPlant& a = axes_.at(axis);
  return a.commanded - position(a);
}

std::vector<std::string> Machine::traceColumns() const {
  std::vector<std::string> c{"time_s"};
  for (std::size_t i = 0; i < axes_.size(); ++i) {
    const std::string& name = d_.axes[i].name;
    for (const char* what : {"command_volts", "command_velocity", "position", "velocity", "following_error"})
      c.push_back(name + "_" + what);
    if (!axes_[i].drives.empty()) c.push_back(name + "_enabled");
  }
  if (spindle_) c.emplace_back("spindle_rpm");
  return c;
}

void Machine::traceRow(std::span<double> row) const {
  std::size_t k = 0;
  auto put = [&](double v) {
    if (k < row.size()) row[k] = v;
    ++k;
  };
  put(std::chrono::duration<double>(time_).count());
  for (std::size_t i = 0; i < axes_.size(); ++i) {
    const AxisPlant& a = axes_[i];
    put(a.drives.empty() ? 0.0 : board_->analog.outputVoltage(a.drives.front().d.analogOutput));
    put(commandVelocity(i));
    put(position(a));
    put(velocity(a));
    put(followingError(i));
    if (!a.drives.empty()) {
      const Drive& first = a.drives.front();
      put(first.amplifier.enabled(board_->analog.enable(first.d.enable)) ? 1.0 : 0.0);
    }
  }
  if (spindle_) put(spindle_->rpm());
}

bool Machine::brakeEngaged(const AxisPlant& a) const {
  // The brake holds unless its release coil, on a field output, is
  // energized (fails safe: no field power, a tripped output or a dead host
  // all leave it holding). The coil has field power across it while the
  // output is on, sourcing or sinking (manual: FIELD OUTPUT
  // CHARACTERISTICS); a 24 V brake pulls in from about two thirds of that.
  constexpr double kPullInVolts = 16.0;
  if (a.brakeOutput < 0) return false;
  return !outputOn(a.brakeDaughtercard, static_cast<unsigned>(a.brakeOutput)) ||
         fieldVoltage(a.brakeDaughtercard) < kPullInVolts;
}

bool Machine::outputOn(Daughtercard board, unsigned output) const {
  return board == Daughtercard::SevenI76 ? sevenI76_->outputOn(output) : board_->fieldIo.outputOn(output);
}

double Machine::fieldVoltage(Daughtercard board) const {
  return board == Daughtercard::SevenI76 ? sevenI76_->fieldVoltage() : board_->fieldIo.fieldVoltage();
}

double Machine::spindleVolts() const {
  if (d_.spindle->daughtercard == Daughtercard::SevenI77) return board_->analog.outputVoltage(d_.spindle->analogOutput);
  // The 7I76's spindle interface: SpinOut's 0..10 V is the speed, SpinDir
  // the direction (on: reverse, LinuxCNC's spindle.0.reverse).
  const double volts = sevenI76_->spindleVolts();
  return sevenI76_->spindleDirection() ? -volts : volts;
}

bool Machine::spindleEna() const {
  return d_.spindle->daughtercard == Daughtercard::SevenI76 ? sevenI76_->spindleEnable()
                                                            : board_->analog.enable(d_.spindle->enable);
}

void Machine::advance(SimTime now) {
  if (time_ < now && resting()) {
    // The switches as they are: a change of field power still reaches them.
    switches_.apply(positions_.data(), inputs_);
    time_ = now;
    return;
  }
  while (time_ < now) span(std::min(now, time_ + h_));
}

bool Machine::resting() const {
  if (spindle_) {
    if (spindle_->rpm() != 0.0 || spindle_->commandRpm() != 0.0) return false;
    if (spindle_->running(spindleEna()) && std::abs(spindleVolts()) > spindle_->parameters().deadbandVolts) return false;
    if (spindleEncoder_ && !spindleEncoder_->restsAt(spindle_->revolutions())) return false;
  }
  const remote::AnalogProcessor& analog = board_->analog;
  for (const AxisPlant& a : axes_) {
    if (a.stepper || !a.motion.settled() || !ServoMotion::restsUnpowered(a.axis, brakeEngaged(a))) return false;
    for (const Drive& drive : a.drives)
      if (!ServoMotion::driveOff(drive.amplifier, analog.enable(drive.d.enable)) ||
          !drive.encoder.restsAt(a.axis.motorRevs()))
        return false;
  }
  return true;
}

void Machine::span(SimTime t1) {
  const SimTime t0 = time_;
  const double seconds = std::chrono::duration<double>(t1 - t0).count();
  // The counters may already have run past t0 (the host's accesses advance
  // the card); the encoders aim at t1 from where they are.
  const SimTime from = std::max(t0, card_->now());
  const SimTime minimum = std::min(kEncoderMinimumSpan, h_ / 2);
  const double encoderSeconds = std::chrono::duration<double>(t1 - from).count();
  const remote::AnalogProcessor& analog = board_->analog;
  for (std::size_t i = 0; i < axes_.size(); ++i) {
    AxisPlant& a = axes_[i];
    if (a.stepper) {
      // The steps the StepGen has made by the span's end, or as far as the
      // card has run (the StepGen is never run ahead of the card: a rate
      // written later in this span must still take effect when written).
      const unsigned n = a.stepper->parameters().stepGen;
      const std::int64_t count = stepGens_->steps(n, std::min(t1, card_->now()));
      // After a watchdog bite the step pin is an input: the drive sees no
      // steps (HostMot2 regmap: a bite clears the DDR).
      const bool driven = card_->stepGenDriven(n);
      if (!driven) a.stepsUndriven += count - a.stepGenCount;
      a.stepGenCount = count;
      a.stepper->step(count - a.stepsUndriven, driven ? stepGens_->stepRate(n) : 0.0,
                      a.axis.jammed() || brakeEngaged(a));
      a.commanded = a.stepper->commandedPosition();
      positions_[i] = a.stepper->position();
      continue;
    }
    // The 7I77's outputs as the card has them now hold over the span
    // (they change when the host's process data reaches the 7I77, and the
    // machine is advanced after the host's cycle: machine.hpp).
    const bool brake = brakeEngaged(a);
    std::array<ServoDrive, kMaxDrivesPerAxis> drives;  // the first n set below
    const std::size_t n = a.drives.size();
    for (std::size_t k = 0; k < n; ++k) {
      Drive& drive = a.drives[k];
      const bool ena = analog.enable(drive.d.enable);
      if (ena != drive.ena) {
        drive.ena = ena;
        drive.enaChangedAt = t0;
      }
      drives[k] = ServoDrive{&drive.amplifier, analog.outputVoltage(drive.d.analogOutput), ena, a.inertiaShare, 0.0};
    }
    a.motion.advance(a.axis, std::span(drives.data(), n), brake, t1 - t0);
    for (std::size_t k = 0; k < n; ++k) a.drives[k].torque = drives[k].torque;
    // The first drive's velocity command (constant over the span),
    // integrated while it is enabled: the position it asked for
    // (followingError).
    const bool commanding = commandsVelocity(a);
    const double commanded =
        commanding ? a.drives.front().amplifier.lastVelocityCommand() * a.axis.parameters().unitsPerMotorRev : 0.0;
    a.commanded = commanding ? a.commanded + commanded * seconds : a.axis.position();
    positions_[i] = a.axis.position();
  }
  if (spindle_) spindle_->step(spindleVolts(), spindleEna(), seconds);
  // The field inputs from where the axes are at the span's end: where
  // they are when the host next reads them.
  switches_.apply(positions_.data(), inputs_);
  for (AxisPlant& a : axes_) {
    for (Drive& drive : a.drives) drive.encoder.drive(a.axis.motorRevs(), from, t1, encoderSeconds, minimum);
    if (a.stepperEncoder) {
      // The stepper's position is known as far as the card has run (its
      // StepGen's steps); to the span's end it goes on at the rate the
      // StepGen steps at. Aimed there, the encoder turns smoothly, where
      // chasing a host period's steps within one span would spin it
      // faster than the counter's filter follows.
      const double ahead = std::max(0.0, std::chrono::duration<double>(t1 - card_->now()).count());
      const double position = a.stepper->position() + a.stepper->velocity() * ahead;
      a.stepperEncoder->drive(position / a.axis.parameters().unitsPerMotorRev, from, t1, encoderSeconds, minimum);
    }
  }
  if (spindleEncoder_) spindleEncoder_->drive(spindle_->revolutions(), from, t1, encoderSeconds, minimum);
  time_ = t1;
}

Machine::State Machine::state() const {
  State s;
  s.name = d_.name;
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
    out.position = position(a);
    out.velocity = velocity(a);
    out.brakeEngaged = brakeEngaged(a);
    out.atHardStop = a.stepper ? a.stepper->atHardStop() : a.axis.atHardStop();
    out.jammed = a.axis.jammed();
    out.pushing = a.axis.pushing();
    out.commandVelocity = commandVelocity(i);
    out.followingError = followingError(i);
    for (const Drive& drive : a.drives) {
      const bool ena = analog.enable(drive.d.enable);
      out.drives.push_back(State::Drive{drive.d.analogOutput, analog.outputVoltage(drive.d.analogOutput), ena,
                                        drive.amplifier.enabled(ena), drive.torque, drive.d.encoderInput,
                                        drive.encoder.count(), drive.encoder.shaftCounts(a.axis.motorRevs()),
                                        brokenChannels(drive.encoder), drive.encoder.reversed(),
                                        drive.amplifier.enableIgnored(), drive.enaChangedAt});
    }
    if (a.stepper)
      out.stepper = State::Stepper{a.stepper->parameters().stepGen, a.stepper->steps(), a.stepper->lostSteps(),
                                   a.stepper->stalled()};
    for (std::size_t k = 0; k < switches_.size(); ++k)
      if (switches_.axisOf(k) == static_cast<int>(i)) out.switches.push_back(s.switches[k]);
    s.axes.push_back(std::move(out));
  }
  if (spindle_) {
    State::Spindle sp;
    sp.daughtercard = d_.spindle->daughtercard;
    sp.commandRpm = spindle_->commandRpm();
    sp.rpm = spindle_->rpm();
    sp.revolutions = spindle_->revolutions();
    sp.running = spindle_->running(spindleEna());
    if (spindleEncoder_) {
      sp.encoderCount = spindleEncoder_->count();
      sp.encoderBroken = brokenChannels(*spindleEncoder_);
      sp.encoderReversed = spindleEncoder_->reversed();
    }
    s.spindle = sp;
  }
  for (const auto& o : d_.outputs) s.outputs.push_back({o.name, o.output, outputOn(o.daughtercard, o.output), o.daughtercard});
  return s;
}

}  // namespace lbpkit::model::machine
