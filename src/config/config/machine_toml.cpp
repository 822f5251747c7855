// SPDX-License-Identifier: MIT
#include "config/machine_toml.hpp"

#include <fmt/core.h>

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <map>
#include <numbers>
#include <string_view>
#include <system_error>
#include <utility>
#include <vector>

#include "config/toml_reader.hpp"
#include "hostmot2/stepgen.hpp"
#include "remote/analog.hpp"
#include "remote/field_io.hpp"
#include "remote/seven_i76.hpp"

namespace lbpkit::config {

namespace {

using model::machine::AmplifierMode;
using model::machine::AmplifierParameters;
using model::machine::AxisDescription;
using model::machine::Contact;
using model::machine::Daughtercard;
using model::machine::DriveDescription;
using model::machine::EnablePolarity;
using model::machine::EncoderParameters;
using model::machine::MachineDescription;
using model::machine::OutputDescription;
using model::machine::SpindleDescription;
using model::machine::StepperParameters;
using model::machine::SwitchKind;
using model::machine::SwitchParameters;

// What one 7I77 has (manual: ANALOG SERVO DRIVE INTERFACE, SERVO ENABLE
// OUTPUTS, ENCODER INTERFACE, FIELD INPUT/OUTPUT CONNECTORS).
constexpr std::int64_t kAnalogOutputs = model::remote::AnalogProcessor::kChannels;  // AOUT0..5
constexpr std::int64_t kEnables = 6;                                         // ENA0..5
constexpr std::int64_t kEncoders = 6;                                        // TB3 0..2, TB4 3..5
constexpr std::int64_t kInputs = model::remote::FieldIoProcessor::kInputs;   // 0..31
constexpr std::int64_t kOutputs = model::remote::FieldIoProcessor::kOutputs;  // 0..15
// The 7I76's (docs/cards.md#the-7i76-field-io): 32 inputs, 16 outputs, one
// spindle encoder input.
constexpr std::int64_t kInputs76 = model::remote::SevenI76FieldIo::kInputs;  // 0..31
constexpr std::int64_t kCardPins = 144;  // a card's IO pins: at most 6 ports of 24 (the machine checks the card's)
constexpr std::int64_t kOutputs76 = model::remote::SevenI76FieldIo::kOutputs;  // 0..15
// A HostMot2 firmware's StepGens (how many this card's has, the machine
// checks against the card: machine.cpp).
constexpr std::int64_t kStepGens = model::hm2::StepGen::kMaxInstances;

// Generous bounds that still catch a slipped decimal point.
constexpr double kMaxPosition = 1e6;  // mm
constexpr double kMaxTorque = 1e4;    // Nm

// Who has each analog output, encoder, field input or field output: a
// second claim is an error that names the first.
class Claims {
 public:
  Claims(const ConfigReader& r, std::string what) : r_(&r), what_(std::move(what)) {}
  void claim(unsigned n, std::string owner, const toml::node* node, const std::string& key) {
    const auto [it, fresh] = owners_.try_emplace(n, Owner{std::move(owner), node});
    if (!fresh)
      r_->fail(node, key,
               fmt::format("{} {} is already {}'s (at {})", what_, n, it->second.name, ConfigReader::where(it->second.node)));
  }

 private:
  struct Owner {
    std::string name;
    const toml::node* node;
  };
  const ConfigReader* r_;
  std::string what_;
  std::map<unsigned, Owner> owners_;
};

std::string kindName(SwitchKind k) {
  switch (k) {
    case SwitchKind::Home: return "home";
    case SwitchKind::MinLimit: return "min_limit";
    case SwitchKind::MaxLimit: return "max_limit";
    case SwitchKind::Estop: return "estop";
    case SwitchKind::Probe: return "probe";
    case SwitchKind::Other: return "other";
  }
  return "other";
}

class MachineReader {
 public:
  MachineReader(const std::string& path, const toml::table& root)
      : r_(path), root_(root), analog_(r_, "analog output"), encoders_(r_, "encoder"), inputs_(r_, "field input"),
        outputs_(r_, "field output"), inputs76_(r_, "the 7I76's field input"),
        outputs76_(r_, "the 7I76's field output"), inputsCard_(r_, "the card's IO pin"), stepGens_(r_, "StepGen") {}

  MachineDescription read(std::string defaultName) {
    MachineDescription m;
    r_.onlyKeys(root_, "", {"name", "step_us", "axis", "spindle", "switch", "output"});
    m.name = r_.name(root_, "", "name", std::move(defaultName));
    // The longest span the plant solves in one piece (MachineDescription::step).
    const double stepUs = r_.number(root_, "", "step_us", 1000.0, 1.0, 1000.0, "us");
    m.step = model::lbp::SimTime{static_cast<std::int64_t>(std::llround(stepUs * 1000.0))};

    readList(root_, "axis", m.axes, [&](const toml::table& t, const std::string& prefix) { return axis(t, prefix); });
    if (const toml::table* s = r_.table(root_, "", "spindle")) m.spindle = spindle(*s);
    readList(root_, "switch", m.switches,
             [&](const toml::table& t, const std::string& prefix) { return switchAt(t, prefix, m); });
    readList(root_, "output", m.outputs,
             [&](const toml::table& t, const std::string& prefix) { return output(t, prefix); });
    // An empty file is no machine: an empty or truncated file of the user's
    // must not start a sim with nothing behind the 7I77.
    if (m.axes.empty() && !m.spindle && m.switches.empty() && m.outputs.empty())
      r_.fail(&root_, "axis",
              "missing: a machine has at least one [[axis]], [spindle], [[switch]] or [[output]] (the file has none)");
    m.sevenI76Where = sevenI76Where_;
    return m;
  }

 private:
  // [[key]] tables, each read by `read` into `out`; names are unique within
  // the list (the API and the trace find things by name).
  template <typename T, typename Read>
  void readList(const toml::table& root, const std::string& key, std::vector<T>& out, Read read) {
    const toml::array* a = r_.tables(root, "", key);
    if (a == nullptr) return;
    for (std::size_t i = 0; i < a->size(); ++i) {
      const toml::table& t = r_.element(*a, key, i);
      const auto prefix = fmt::format("{}[{}].", key, i);
      T item = read(t, prefix);
      for (std::size_t j = 0; j < out.size(); ++j)
        if (out[j].name == item.name)
          r_.fail(t.get("name"), prefix + "name", fmt::format("\"{}\" is already {}[{}]'s name", item.name, key, j));
      out.push_back(std::move(item));
    }
  }

  // The key's node, or the table's when the key is absent (a default that
  // clashes is pointed at where it was left out).
  static const toml::node* at(const toml::table& t, std::string_view key) {
    const toml::node* n = t.get(key);
    return n != nullptr ? n : &t;
  }

  unsigned index(const toml::table& t, const std::string& prefix, std::string_view key, std::int64_t fallback,
                 std::int64_t count) const {
    return static_cast<unsigned>(r_.integer(t, prefix, key, fallback, 0, count - 1));
  }

  // Whose terminals: "7I77" (the default) or "7I76", Mesa's names as the
  // card file's pinout and daughtercards give them. The first 7I76 wiring
  // is noted: the machine names it when the card's firmware has no 7I76.
  Daughtercard daughtercard(const toml::table& t, const std::string& prefix, std::string_view key,
                            Daughtercard fallback = Daughtercard::SevenI77, bool wired = true) {
    const auto text =
        r_.text(t, prefix, key, std::string(model::machine::daughtercardName(fallback)), {"7I77", "7I76"});
    const Daughtercard d = text == "7I76" ? Daughtercard::SevenI76 : Daughtercard::SevenI77;
    if (d == Daughtercard::SevenI76 && wired && sevenI76Where_.empty())
      sevenI76Where_ = fmt::format("{}:{}: {}{}", r_.path(), ConfigReader::where(at(t, key)), prefix, key);
    return d;
  }

  EncoderParameters encoder(const toml::table& t, const std::string& prefix, EncoderParameters e) const {
    e.linesPerRev = static_cast<std::uint32_t>(r_.integer(t, prefix, "encoder_lines", e.linesPerRev, 1, 1'000'000));
    e.index = r_.boolean(t, prefix, "encoder_index", e.index);
    e.reversed = r_.boolean(t, prefix, "encoder_reversed", e.reversed);
    return e;
  }

  EnablePolarity polarity(const toml::table& t, const std::string& prefix, EnablePolarity fallback) const {
    return r_.text(t, prefix, "enable_polarity", fallback == EnablePolarity::ActiveHigh ? "high" : "low",
                   {"high", "low"}) == "high"
               ? EnablePolarity::ActiveHigh
               : EnablePolarity::ActiveLow;
  }

  AmplifierParameters amplifier(const toml::table& t, const std::string& prefix) const {
    AmplifierParameters a;
    r_.onlyKeys(t, prefix,
                {"mode", "gain", "limit", "deadband_volts", "offset_volts", "peak_torque", "bandwidth_hz",
                 "enable_polarity", "reversed"});
    a.mode = r_.text(t, prefix, "mode", "velocity", {"velocity", "torque"}) == "velocity" ? AmplifierMode::Velocity
                                                                                         : AmplifierMode::Torque;
    a.gain = r_.positive(t, prefix, "gain", a.gain, 1e-6, 1e4, a.mode == AmplifierMode::Velocity ? "rev/s per V" : "Nm per V");
    a.limit = r_.positive(t, prefix, "limit", a.limit, 1e-6, 1e4, a.mode == AmplifierMode::Velocity ? "rev/s" : "Nm");
    a.deadbandVolts = r_.number(t, prefix, "deadband_volts", a.deadbandVolts, 0.0, 10.0, "V");
    a.offsetVolts = r_.number(t, prefix, "offset_volts", a.offsetVolts, -10.0, 10.0, "V");
    a.peakTorque = r_.positive(t, prefix, "peak_torque", a.peakTorque, 1e-6, kMaxTorque, "Nm");
    a.bandwidthHz = r_.positive(t, prefix, "bandwidth_hz", a.bandwidthHz, 0.1, 1e5, "Hz");
    a.enablePolarity = polarity(t, prefix, a.enablePolarity);
    a.reversed = r_.boolean(t, prefix, "reversed", a.reversed);
    return a;
  }

  DriveDescription drive(const toml::table& t, const std::string& prefix, const std::string& owner) {
    DriveDescription d;
    r_.onlyKeys(t, prefix,
                {"analog_output", "enable", "motor_inertia", "encoder_input", "encoder_lines", "encoder_index",
                 "encoder_reversed", "amplifier"});
    (void)r_.required(t, prefix, "analog_output");
    d.analogOutput = index(t, prefix, "analog_output", 0, kAnalogOutputs);
    analog_.claim(d.analogOutput, owner, at(t, "analog_output"), prefix + "analog_output");
    // ENAn and encoder n by default: the 7I77's own pairing of its terminals.
    d.enable = index(t, prefix, "enable", d.analogOutput, kEnables);
    d.motorInertia = r_.positive(t, prefix, "motor_inertia", d.motorInertia, 1e-9, 1.0, "kg m^2");
    d.encoderInput = index(t, prefix, "encoder_input", d.analogOutput, kEncoders);
    encoders_.claim(d.encoderInput, owner, at(t, "encoder_input"), prefix + "encoder_input");
    d.encoder = encoder(t, prefix, d.encoder);
    if (const toml::table* a = r_.table(t, prefix, "amplifier")) d.amplifier = amplifier(*a, prefix + "amplifier.");
    return d;
  }

  AxisDescription axis(const toml::table& t, const std::string& prefix) {
    AxisDescription a;
    r_.onlyKeys(t, prefix,
                {"name", "screw_pitch", "gear_ratio", "mass_kg", "screw_inertia", "viscous", "coulomb", "vertical",
                 "travel", "overtravel", "initial_position", "brake_output", "brake_daughtercard", "brake_torque",
                 "drive", "stepper"});
    (void)r_.required(t, prefix, "name");
    a.name = r_.name(t, prefix, "name", "");
    // The API names the spindle's encoder "spindle" where it names axes.
    if (a.name == "spindle") r_.fail(t.get("name"), prefix + "name", "\"spindle\" is the spindle's name, not an axis'");
    a.screwPitch = r_.positive(t, prefix, "screw_pitch", a.screwPitch, 0.01, 1e4, "mm");
    a.gearRatio = r_.positive(t, prefix, "gear_ratio", a.gearRatio, 1e-3, 1e3, "motor revolutions per screw revolution");
    a.massKg = r_.positive(t, prefix, "mass_kg", a.massKg, 1e-3, 1e5, "kg");
    a.screwInertia = r_.number(t, prefix, "screw_inertia", a.screwInertia, 0.0, 10.0, "kg m^2");
    a.viscous = r_.number(t, prefix, "viscous", a.viscous, 0.0, 1e3, "Nm per rad/s");
    a.coulomb = r_.number(t, prefix, "coulomb", a.coulomb, 0.0, kMaxTorque, "Nm");
    a.vertical = r_.boolean(t, prefix, "vertical", a.vertical);
    std::tie(a.travelMin, a.travelMax) =
        r_.interval(t, prefix, "travel", {a.travelMin, a.travelMax}, -kMaxPosition, kMaxPosition, "mm");
    a.overtravel = r_.number(t, prefix, "overtravel", a.overtravel, 0.0, 1e4, "mm");
    const double hardMin = a.travelMin - a.overtravel, hardMax = a.travelMax + a.overtravel;
    a.initialPosition = r_.number(t, prefix, "initial_position", (a.travelMin + a.travelMax) / 2, -kMaxPosition,
                                  kMaxPosition, "mm");
    if (a.initialPosition < hardMin || a.initialPosition > hardMax)
      r_.fail(t.get("initial_position"), prefix + "initial_position",
              fmt::format("{} mm is past the hard stops ({} to {} mm: the travel and the overtravel)", a.initialPosition,
                          hardMin, hardMax));
    a.brakeOutput = static_cast<int>(r_.integer(t, prefix, "brake_output", a.brakeOutput, -1, kOutputs - 1));
    a.brakeDaughtercard = daughtercard(t, prefix, "brake_daughtercard", Daughtercard::SevenI77, a.brakeOutput >= 0);
    a.brakeTorque = r_.number(t, prefix, "brake_torque", a.brakeTorque, 0.0, kMaxTorque, "Nm");
    const toml::array* drives = r_.tables(t, prefix, "drive");
    if (const toml::table* s = r_.table(t, prefix, "stepper")) {
      if (drives != nullptr)
        r_.fail(s, prefix + "stepper",
                "an axis has servo drives ([[axis.drive]]) or a stepper ([axis.stepper]), not both");
      a.stepper = stepper(*s, prefix + "stepper.", a);
      return a;
    }
    if (drives == nullptr || drives->empty())
      r_.fail(&t, prefix + "drive", "missing: an axis needs at least one motor ([[axis.drive]])");
    for (std::size_t i = 0; i < drives->size(); ++i)
      a.drives.push_back(drive(r_.element(*drives, prefix + "drive", i), fmt::format("{}drive[{}].", prefix, i),
                               "axis " + a.name));
    return a;
  }

  // A stepper on a StepGen: its steps per machine unit as such,
  // or from the motor (full steps per revolution, the drive's microsteps)
  // and the axis' screw and gearing, as a stepper's data sheet gives them.
  StepperParameters stepper(const toml::table& t, const std::string& prefix, const AxisDescription& a) {
    StepperParameters s;
    r_.onlyKeys(t, prefix, {"stepgen", "steps_per_unit", "full_steps", "microsteps", "max_step_rate", "reversed",
                            "encoder_input", "encoder_lines", "encoder_index", "encoder_reversed"});
    (void)r_.required(t, prefix, "stepgen");
    s.stepGen = index(t, prefix, "stepgen", 0, kStepGens);
    stepGens_.claim(s.stepGen, "axis " + a.name, at(t, "stepgen"), prefix + "stepgen");
    const bool fromMotor = t.get("full_steps") != nullptr || t.get("microsteps") != nullptr;
    if (t.get("steps_per_unit") != nullptr) {
      if (fromMotor) {
        const std::string_view key = t.get("full_steps") != nullptr ? "full_steps" : "microsteps";
        r_.fail(t.get(key), prefix + std::string(key),
                "steps_per_unit is given: the motor's full_steps and microsteps are for working it out instead");
      }
      s.stepsPerUnit = r_.positive(t, prefix, "steps_per_unit", s.stepsPerUnit, 1e-3, 1e6, "steps per mm");
    } else if (fromMotor) {
      const auto fullSteps = r_.integer(t, prefix, "full_steps", 200, 1, 10'000);
      const auto microsteps = r_.integer(t, prefix, "microsteps", 1, 1, 1'000);
      s.stepsPerUnit = static_cast<double>(fullSteps * microsteps) * a.gearRatio / a.screwPitch;
    } else {
      r_.fail(&t, prefix + "steps_per_unit", "missing: the steps per mm (or the motor's full_steps and microsteps)");
    }
    // Absent: the motor follows every rate.
    s.maxStepRate = r_.positive(t, prefix, "max_step_rate", s.maxStepRate, 1.0, 1e7, "steps/s");
    s.reversed = r_.boolean(t, prefix, "reversed", s.reversed);
    // A closed-loop stepper's encoder.
    if (t.get("encoder_input") != nullptr) {
      s.encoderInput = index(t, prefix, "encoder_input", 0, kEncoders);
      encoders_.claim(*s.encoderInput, "axis " + a.name, at(t, "encoder_input"), prefix + "encoder_input");
      s.encoder = encoder(t, prefix, s.encoder);
    } else {
      for (std::string_view key : {"encoder_lines", "encoder_index", "encoder_reversed"})
        if (t.get(key) != nullptr)
          r_.fail(t.get(key), prefix + std::string(key), "no encoder_input: the stepper has no encoder to describe");
    }
    return s;
  }

  SpindleDescription spindle(const toml::table& t) {
    SpindleDescription s;
    const std::string prefix = "spindle.";
    r_.onlyKeys(t, prefix,
                {"daughtercard", "analog_output", "enable", "rpm_per_volt", "max_rpm", "acceleration",
                 "deadband_volts", "enable_polarity", "encoder_daughtercard", "encoder_input", "encoder_lines",
                 "encoder_index", "encoder_reversed"});
    // The VFD on the 7I77's AOUTn and ENAn, or on the 7I76's spindle
    // interface: SpinOut (0..10 V), SpinEna, SpinDir (sserial(9)).
    s.daughtercard = daughtercard(t, prefix, "daughtercard");
    if (s.daughtercard == Daughtercard::SevenI76) {
      for (std::string_view key : {"analog_output", "enable"})
        if (t.get(key) != nullptr)
          r_.fail(t.get(key), prefix + std::string(key),
                  "the spindle is on the 7I76 (daughtercard = \"7I76\"): its speed, run and direction are the 7I76's "
                  "SpinOut, SpinEna and SpinDir; analog_output and enable are the 7I77's");
    } else {
      s.analogOutput = index(t, prefix, "analog_output", s.analogOutput, kAnalogOutputs);
      analog_.claim(s.analogOutput, "the spindle", at(t, "analog_output"), prefix + "analog_output");
      s.enable = index(t, prefix, "enable", s.enable, kEnables);
    }
    s.vfd.rpmPerVolt = r_.positive(t, prefix, "rpm_per_volt", s.vfd.rpmPerVolt, 1e-3, 1e5, "rpm per V");
    s.vfd.maxRpm = r_.positive(t, prefix, "max_rpm", s.vfd.maxRpm, 1.0, 1e6, "rpm");
    s.vfd.accelerationRpmPerSecond = r_.positive(t, prefix, "acceleration", s.vfd.accelerationRpmPerSecond, 1e-3, 1e7, "rpm/s");
    s.vfd.deadbandVolts = r_.number(t, prefix, "deadband_volts", s.vfd.deadbandVolts, 0.0, 10.0, "V");
    s.vfd.enablePolarity = polarity(t, prefix, s.vfd.enablePolarity);
    // The encoder on the VFD's board unless told: the 7I77's 0..5 (5 by
    // default), or the 7I76's one spindle encoder input, 0. -1: none.
    const bool encoderInput = t.get("encoder_input") == nullptr || t.get("encoder_input")->value<std::int64_t>() != -1;
    s.encoderDaughtercard = daughtercard(t, prefix, "encoder_daughtercard", s.daughtercard, encoderInput);
    const bool on76 = s.encoderDaughtercard == Daughtercard::SevenI76;
    const auto input = r_.integer(t, prefix, "encoder_input", on76 ? 0 : s.encoderInput.value_or(-1), -1, kEncoders - 1);
    if (on76 && input > 0)
      r_.fail(t.get("encoder_input"), prefix + "encoder_input",
              fmt::format("the 7I76 has one encoder input, its spindle encoder: 0 (the card's muxed counter 6), or -1 "
                          "for none; the 7I77's 0..5 need encoder_daughtercard = \"7I77\", not {}",
                          input));
    s.encoderInput.reset();
    if (input >= 0) {
      s.encoderInput = static_cast<unsigned>(input);
      if (!on76) encoders_.claim(*s.encoderInput, "the spindle", at(t, "encoder_input"), prefix + "encoder_input");
    }
    s.encoder = encoder(t, prefix, s.encoder);
    return s;
  }

  SwitchParameters switchAt(const toml::table& t, const std::string& prefix, const MachineDescription& m) {
    SwitchParameters s;
    r_.onlyKeys(t, prefix, {"name", "kind", "input", "contact", "axis", "position", "trip_above", "daughtercard"});
    (void)r_.required(t, prefix, "name");
    s.name = r_.name(t, prefix, "name", "");
    const auto kind = r_.text(t, prefix, "kind", "other", {"home", "min_limit", "max_limit", "estop", "probe", "other"});
    for (auto k : {SwitchKind::Home, SwitchKind::MinLimit, SwitchKind::MaxLimit, SwitchKind::Estop, SwitchKind::Probe,
                   SwitchKind::Other})
      if (kindName(k) == kind) s.kind = k;
    // A switch may also be on one of the card's own IO pins (gpio.NNN).
    const bool onCard = r_.text(t, prefix, "daughtercard", "7I77", {"7I77", "7I76", "card"}) == "card";
    s.daughtercard = onCard ? Daughtercard::Card : daughtercard(t, prefix, "daughtercard");
    const bool on76 = s.daughtercard == Daughtercard::SevenI76;
    (void)r_.required(t, prefix, "input");
    s.input = index(t, prefix, "input", 0, onCard ? kCardPins : on76 ? kInputs76 : kInputs);
    (onCard ? inputsCard_ : on76 ? inputs76_ : inputs_).claim(s.input, "switch " + s.name, at(t, "input"), prefix + "input");
    // Limits and the E-stop chain are normally closed, so that a broken wire
    // reads as tripped (manual: WHY SINKING INPUTS).
    const bool ncByDefault = s.kind == SwitchKind::MinLimit || s.kind == SwitchKind::MaxLimit || s.kind == SwitchKind::Estop;
    s.contact = r_.text(t, prefix, "contact", ncByDefault ? "nc" : "no", {"no", "nc"}) == "nc" ? Contact::NormallyClosed
                                                                                          : Contact::NormallyOpen;
    s.axis = r_.name(t, prefix, "axis", "");
    const AxisDescription* axis = nullptr;
    for (const auto& a : m.axes)
      if (a.name == s.axis) axis = &a;
    if (!s.axis.empty() && axis == nullptr) {
      std::string names;
      for (const auto& a : m.axes) names += (names.empty() ? "" : ", ") + a.name;
      r_.fail(t.get("axis"), prefix + "axis",
              fmt::format("the machine has no axis \"{}\" ({})", s.axis,
                          names.empty() ? "it has no axes" : "its axes: " + names));
    }
    const bool onAxisKind = s.kind == SwitchKind::Home || s.kind == SwitchKind::MinLimit || s.kind == SwitchKind::MaxLimit;
    if (axis == nullptr) {
      if (onAxisKind) r_.fail(&t, prefix + "axis", fmt::format("missing: a {} switch is on an axis", kind));
      for (std::string_view key : {"position", "trip_above"})
        if (t.get(key) != nullptr)
          r_.fail(t.get(key), prefix + std::string(key),
                  "only a switch on an axis trips at a position (this one trips when told: E-stop button, probe)");
      return s;
    }
    (void)r_.required(t, prefix, "position");
    s.position = r_.number(t, prefix, "position", 0.0, -kMaxPosition, kMaxPosition, "mm");
    s.tripAbove = r_.boolean(t, prefix, "trip_above", s.kind != SwitchKind::MinLimit);
    if (s.kind == SwitchKind::MinLimit && s.tripAbove)
      r_.fail(t.get("trip_above"), prefix + "trip_above", "a min limit trips at or below its position");
    if (s.kind == SwitchKind::MaxLimit && !s.tripAbove)
      r_.fail(t.get("trip_above"), prefix + "trip_above", "a max limit trips at or above its position");
    const double hardMin = axis->travelMin - axis->overtravel, hardMax = axis->travelMax + axis->overtravel;
    if (s.position < hardMin || s.position > hardMax)
      r_.fail(t.get("position"), prefix + "position",
              fmt::format("{} mm is past axis {}'s hard stops ({} to {} mm): the switch would {}", s.position, s.axis,
                          hardMin, hardMax, (s.position > hardMax) == s.tripAbove ? "never trip" : "always be tripped"));
    if (s.kind == SwitchKind::MinLimit && s.position > axis->travelMin)
      r_.fail(t.get("position"), prefix + "position",
              fmt::format("{} mm is inside axis {}'s travel ({} to {} mm): a min limit trips at or below the travel",
                          s.position, s.axis, axis->travelMin, axis->travelMax));
    if (s.kind == SwitchKind::MaxLimit && s.position < axis->travelMax)
      r_.fail(t.get("position"), prefix + "position",
              fmt::format("{} mm is inside axis {}'s travel ({} to {} mm): a max limit trips at or above the travel",
                          s.position, s.axis, axis->travelMin, axis->travelMax));
    return s;
  }

  OutputDescription output(const toml::table& t, const std::string& prefix) {
    OutputDescription o;
    r_.onlyKeys(t, prefix, {"name", "output", "load_ohms", "daughtercard"});
    (void)r_.required(t, prefix, "name");
    o.name = r_.name(t, prefix, "name", "");
    o.daughtercard = daughtercard(t, prefix, "daughtercard");
    const bool on76 = o.daughtercard == Daughtercard::SevenI76;
    (void)r_.required(t, prefix, "output");
    o.output = index(t, prefix, "output", 0, on76 ? kOutputs76 : kOutputs);
    (on76 ? outputs76_ : outputs_).claim(o.output, "output " + o.name, at(t, "output"), prefix + "output");
    o.loadOhms = r_.positive(t, prefix, "load_ohms", o.loadOhms, 1e-3, 1e6, "ohms");
    return o;
  }

  ConfigReader r_;
  const toml::table& root_;
  Claims analog_, encoders_, inputs_, outputs_, inputs76_, outputs76_, inputsCard_, stepGens_;
  std::string sevenI76Where_;  // the first key that wires the 7I76 (daughtercard)
};

}  // namespace

model::machine::MachineDescription loadMachineFile(const std::string& path) {
  const toml::table root = parseFile(path, "a TOML machine file");
  return MachineReader(path, root).read(std::filesystem::path(path).stem().string());
}

model::machine::MachineDescription loadMachine(const std::string& nameOrPath) {
  if (nameOrPath == "mill") return model::machine::mill();
  if (nameOrPath == "lathe") return model::machine::lathe();
  if (nameOrPath == "gantry") return model::machine::gantry();
  std::error_code ec;
  if (!std::filesystem::exists(nameOrPath, ec))
    throw FileError(fmt::format("{}: no such file (a machine file, or a built-in machine: mill, lathe or gantry)",
                                nameOrPath));
  return loadMachineFile(nameOrPath);
}

}  // namespace lbpkit::config
