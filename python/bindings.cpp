// SPDX-License-Identifier: MIT
// `import lbpkit`: the Python names of Card (card.hpp), VirtualBoard and
// VirtualMachine (virtual_board.hpp) and what they return. Python names are
// snake_case; the manual's words otherwise (field input, AnalogOut0, CS).
// lbpkit::Error and config::FileError raise lbpkit.Error; a value out of
// range raises ValueError, an index out of range IndexError.
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <unistd.h>

#include <fmt/format.h>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <string>

#include "card.hpp"
#include "config/toml_reader.hpp"
#include "lbpkit/error.hpp"
#include "lbpkit/faults.hpp"
#include "lbpkit/wire/seven_i77.hpp"
#include "virtual_board.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace machine = lbpkit::model::machine;
namespace config = lbpkit::config;

namespace py = pybind11;
using pylbpkit::Card;
using pylbpkit::VirtualBoard;
using pylbpkit::VirtualMachine;
using pylbpkit::VirtualSevenI76;

namespace {

// Card.run's bound: more cycles than any run can finish (2**63 would run on
// for ever) are refused.
constexpr std::uint64_t kMaxRunCycles = 1'000'000'000'000ULL;

// Set by an atexit handler: the interpreter is on its way out.
std::atomic<bool> gExiting{false};

bool interpreterExiting() {
#if PY_VERSION_HEX >= 0x030D0000
  return gExiting.load() || Py_IsFinalizing() != 0;
#else
  return gExiting.load() || _Py_IsFinalizing() != 0;
#endif
}

// A Card method called with the card's lock held (card.hpp: not thread-safe).
template <typename R, typename... A>
auto locked(R (Card::*f)(A...)) {
  return [f](Card& c, A... a) -> R {
    auto l = c.lock();
    return (c.*f)(std::forward<A>(a)...);
  };
}
template <typename R, typename... A>
auto locked(R (Card::*f)(A...) const) {
  return [f](Card& c, A... a) -> R {
    auto l = c.lock();
    return (c.*f)(std::forward<A>(a)...);
  };
}

double seconds(std::chrono::nanoseconds d) { return std::chrono::duration<double>(d).count(); }

const char* kind(machine::SwitchKind k) {
  switch (k) {
    case machine::SwitchKind::Home: return "home";
    case machine::SwitchKind::MinLimit: return "min_limit";
    case machine::SwitchKind::MaxLimit: return "max_limit";
    case machine::SwitchKind::Estop: return "estop";
    case machine::SwitchKind::Probe: return "probe";
    case machine::SwitchKind::Other: break;
  }
  return "other";
}

const char* channelName(machine::EncoderChannel c) {
  switch (c) {
    case machine::EncoderChannel::A: return "A";
    case machine::EncoderChannel::B: return "B";
    case machine::EncoderChannel::Index: break;
  }
  return "index";
}

std::vector<std::string> channelNames(const std::vector<machine::EncoderChannel>& v) {
  std::vector<std::string> out;
  for (const auto c : v) out.emplace_back(channelName(c));
  return out;
}

// A stepper axis' state; lbpkit.Error for a servo axis.
machine::Machine::State::Stepper stepperOf(VirtualMachine& vm, const std::string& axis) {
  const auto s = vm.stepper(axis);
  if (!s) throw lbpkit::Error("axis " + axis + " is a servo axis, not a stepper: it has drives, not a StepGen");
  return *s;
}

void bindCardTypes(py::module_& m) {
  py::class_<lbpkit::ModuleInfo>(m, "Module", "A module of the card's IDROM (HostMot2 regmap)")
      .def_readonly("name", &lbpkit::ModuleInfo::name)
      .def_readonly("tag", &lbpkit::ModuleInfo::tag)
      .def_readonly("version", &lbpkit::ModuleInfo::version)
      .def_readonly("instances", &lbpkit::ModuleInfo::instances)
      .def_readonly("base_address", &lbpkit::ModuleInfo::baseAddress)
      .def_readonly("clock_hz", &lbpkit::ModuleInfo::clockHz)
      .def_readonly("register_stride", &lbpkit::ModuleInfo::registerStride)
      .def_readonly("instance_stride", &lbpkit::ModuleInfo::instanceStride)
      .def("__repr__", [](const lbpkit::ModuleInfo& i) {
        return "<lbpkit.Module " + i.name + " x" + std::to_string(i.instances) + ">";
      });

  py::class_<lbpkit::ChannelIdentity>(m, "Remote", "A smart-serial channel as discovery found it")
      .def_readonly("channel", &lbpkit::ChannelIdentity::channel)
      .def_readonly("present", &lbpkit::ChannelIdentity::present)
      .def_readonly("unit_number", &lbpkit::ChannelIdentity::unitNumber)
      .def_readonly("name", &lbpkit::ChannelIdentity::name, "\"7I77\"")
      .def_property_readonly("function", &lbpkit::ChannelIdentity::function, "\"field I/O\", \"analog\"")
      .def_readonly("ptoc", &lbpkit::ChannelIdentity::ptoc)
      .def_readonly("gtoc", &lbpkit::ChannelIdentity::gtoc)
      .def_readonly("cs", &lbpkit::ChannelIdentity::cs, "CS after START")
      .def("__repr__", [](const lbpkit::ChannelIdentity& i) {
        return "<lbpkit.Remote channel " + std::to_string(i.channel) + ": " +
               (i.present ? i.name + " " + i.function() : std::string("no remote")) + ">";
      });

  py::class_<lbpkit::ProcessDataElement>(m, "Element", "A process data element or parameter (PTOC/GTOC record)")
      .def_readonly("name", &lbpkit::ProcessDataElement::name)
      .def_readonly("unit", &lbpkit::ProcessDataElement::unit)
      .def_property_readonly("type", [](const lbpkit::ProcessDataElement& e) { return lbpkit::typeName(e.type); })
      .def_property_readonly("direction",
                             [](const lbpkit::ProcessDataElement& e) { return lbpkit::directionName(e.direction); })
      .def_readonly("bits", &lbpkit::ProcessDataElement::bits)
      .def_readonly("min", &lbpkit::ProcessDataElement::min)
      .def_readonly("max", &lbpkit::ProcessDataElement::max)
      .def("__repr__", [](const lbpkit::ProcessDataElement& e) {
        return "<lbpkit.Element " + e.name + " " + lbpkit::typeName(e.type) + " " + std::to_string(e.bits) + " bits>";
      });

  py::class_<lbpkit::CycleStatus>(m, "CycleStatus", "What one cycle saw (lbpkit/sserial.hpp)")
      .def_readonly("ok", &lbpkit::CycleStatus::ok)
      .def_readonly("failed_mask", &lbpkit::CycleStatus::failedMask)
      .def_readonly("command_busy", &lbpkit::CycleStatus::commandBusy)
      .def_readonly("reply_lost", &lbpkit::CycleStatus::replyLost)
      .def_property_readonly("doit_time", [](const lbpkit::CycleStatus& s) { return seconds(s.doitTime); })
      .def_readonly("fresh_mask", &lbpkit::CycleStatus::freshMask)
      .def_readonly("over_limit_mask", &lbpkit::CycleStatus::overLimitMask)
      .def_readonly("too_many_errors_mask", &lbpkit::CycleStatus::tooManyErrorsMask)
      .def_readonly("recovered_mask", &lbpkit::CycleStatus::recoveredMask)
      .def_readonly("recovery_failed", &lbpkit::CycleStatus::recoveryFailed)
      .def_property_readonly("needs_recovery", &lbpkit::CycleStatus::needsRecovery)
      .def("__bool__", [](const lbpkit::CycleStatus& s) { return s.ok; })
      .def("__repr__", [](const lbpkit::CycleStatus& s) {
        return std::string("<lbpkit.CycleStatus ") + (s.ok ? "ok" : "failed") + ">";
      });
}

void bindCard(py::module_& m) {
  py::class_<Card, std::shared_ptr<Card>>(
      m, "Card",
      "A HostMot2 card through the host library: Card.open(address) over LBP16/UDP, or Card.sim() in process")
      .def_static("open", &Card::openNetwork, py::arg("address"), py::arg("port") = 27181, py::arg("timeout") = 0.2,
                  "A card on the network (a 7I92, or `lbpkit sim`): LBP16 over UDP. `timeout`: seconds set-up "
                  "waits for a reply")
      .def_static(
          "sim",
          [](const std::optional<std::string>& machine, unsigned daughtercards, bool sinking,
             const std::optional<std::string>& state, double fieldVoltage, const std::optional<std::string>& card,
             const std::optional<std::string>& pinout) {
            Card::SimOptions o;
            o.card = card.value_or("");
            o.pinout = pinout.value_or("");
            o.machine = machine.value_or("");
            o.daughtercards = daughtercards;
            o.sinking = sinking;
            o.state = state.value_or("");
            o.fieldVoltage = fieldVoltage;
            return Card::openSim(o);
          },
          py::arg("machine") = py::none(), py::arg("daughtercards") = 1, py::arg("sinking") = false,
          py::arg("state") = py::none(), py::arg("field_voltage") = 24.0, py::arg("card") = py::none(),
          py::arg("pinout") = py::none(),
          "The in-process virtual 7I92 with 7I77s, in simulated time; `machine`: \"mill\", \"lathe\", \"gantry\" "
          "or a machine file behind the first 7I77; `card`: \"7I92T\" (a 7I77 and a 7I76 with StepGens), ... as "
          "lbpkit sim --card; `pinout`: its firmware, e.g. \"7I77+7I76\"")
      .def_property_readonly("board_name", [](Card& c) { return c.info().boardName; })
      .def_property_readonly("config_name", [](Card& c) { return c.info().configName; })
      .def_property_readonly("modules", [](Card& c) { return c.info().modules; })
      .def_property_readonly("in_process", &Card::inProcess)
      .def("describe", locked(&Card::describe))
      .def("__repr__", [](Card& c) { return "<lbpkit.Card " + c.describe() + ">"; })
      .def_property_readonly("time", locked(&Card::time), "Seconds, as the card sees them (simulated in process)")
      .def_property("period", locked(&Card::period), locked(&Card::setPeriod),
                    "Seconds from the start of one cycle() to the next (default 0.001); 0: no wait")
      .def("discover", locked(&Card::discover), py::arg("channels") = std::vector<unsigned>{},
           py::arg("modes") = std::string(),
           "STOP ALL, setup START and discovery of the remotes on `channels` (all when empty); `modes` as "
           "--modes (\"3\": field I/O in mode 3, x skips a channel)")
      .def_property_readonly("channels", locked(&Card::channels), "Channels with a discovered remote")
      .def(
          "process_data",
          [](Card& c, unsigned channel) {
            auto l = c.lock();
            return c.description(channel).processData;
          },
          py::arg("channel"))
      .def(
          "parameters",
          [](Card& c, unsigned channel) {
            auto l = c.lock();
            return c.description(channel).parameters;
          },
          py::arg("channel"))
      .def("remote", locked(&Card::identity), py::arg("channel"))
      .def("start", locked(&Card::start), "Normal START of the discovered remotes (discovering first if needed)")
      .def_property_readonly("running", &Card::running)
      .def("read_parameter", locked(&Card::readParameter), py::arg("name"), py::arg("channel") = py::none(),
           "RPD: a parameter by name (the manual's spellings work)")
      .def("write_parameter", locked(&Card::writeParameter), py::arg("name"), py::arg("value"),
           py::arg("channel") = py::none(), "WPD: a parameter by name; non-volatile ones take effect at power-up")
      .def("set", locked(&Card::set), py::arg("name"), py::arg("value"), py::arg("channel") = py::none(),
           "An output process data element by name, sent at the next cycle(): float in its unit, int for bits, "
           "bool for BOOLEAN")
      .def("get", locked(&Card::get), py::arg("name"), py::arg("channel") = py::none(),
           "A process data element by name, as the last cycle() brought it (outputs: as set)")
      .def("set_bit", locked(&Card::setBit), py::arg("name"), py::arg("bit"), py::arg("on") = true,
           py::arg("channel") = py::none())
      .def("bit", locked(&Card::bit), py::arg("name"), py::arg("bit"), py::arg("channel") = py::none())
      .def("cycle", locked(&Card::cycle), "One servo period: outputs and DOIT, inputs, then the rest of `period`")
      .def(
          "run",
          [](Card& c, std::uint64_t cycles) {
            if (cycles > kMaxRunCycles)
              throw py::value_error(fmt::format("run: at most {} cycles at a time (32 years at 1 kHz), not {}",
                                                kMaxRunCycles, cycles));
            auto l = c.lock();
            bool interrupted = false;
            lbpkit::CycleStatus last;
            {
              py::gil_scoped_release release;
              last = c.run(cycles, [&] {
                // The interpreter is exiting with this thread inside run():
                // taking the GIL now would end the thread from inside a
                // destructor and abort the process ("terminate called
                // without an active exception"). It stops cycling and waits,
                // without the GIL, for the process to end, as Python's own
                // daemon threads do.
                if (interpreterExiting())
                  for (;;) ::pause();
                py::gil_scoped_acquire acquire;
                interrupted = PyErr_CheckSignals() != 0;
                return interrupted;
              });
            }
            if (interrupted) throw py::error_already_set();
            return last;
          },
          py::arg("cycles"), "`cycles` cycle()s without the GIL; the last one's status")
      .def("read32", locked(&Card::read32), py::arg("address"), "A HostMot2 register (Module.base_address + ...)")
      .def("write32", locked(&Card::write32), py::arg("address"), py::arg("value"),
           "A HostMot2 register, written at once (e.g. a StepGen's rate, as LinuxCNC's hostmot2 writes it)")
      .def_property_readonly("cycles", &Card::cycles, "Cycles whose inputs were read")
      .def_property_readonly("lost_cycles", &Card::lostCycles)
      .def("cs", locked(&Card::cs), py::arg("channel"), "The channel's CS register after the last cycle")
      .def("remote_faults", locked(&Card::remoteFaults), py::arg("channel"),
           "The remote's fault byte (CS byte 3): lbpkit.FAULT_NAMES")
      .def("fault_count", locked(&Card::faultCount), py::arg("channel"))
      .def("recover", locked(&Card::recover), py::arg("channel"))
      .def_property_readonly("encoders", &Card::encoders, "The card's muxed encoders (after start())")
      .def("encoder_counts", locked(&Card::encoderCounts), py::arg("encoder"))
      .def("encoder_position", locked(&Card::encoderPosition), py::arg("encoder"))
      .def("encoder_velocity", locked(&Card::encoderVelocity), py::arg("encoder"))
      .def("set_encoder_scale", locked(&Card::setEncoderScale), py::arg("encoder"), py::arg("counts_per_unit"))
      .def("enable_index", locked(&Card::enableIndex), py::arg("encoder"))
      .def("index_enabled", locked(&Card::indexEnabled), py::arg("encoder"))
      .def("step", locked(&Card::step), py::arg("seconds"),
           "In process: let simulated time pass with no host access (the card and the machine)")
      .def("power_cycle", locked(&Card::powerCycle),
           "In process: the board off and on (NV parameters become working values); discover() and start() again")
      .def_property_readonly(
          "board", [](const std::shared_ptr<Card>& c) { return VirtualBoard(c); },
          "In process: the virtual board's terminals and faults")
      .def_property_readonly(
          "machine",
          [](const std::shared_ptr<Card>& c) -> std::optional<VirtualMachine> {
            if (c->machine() == nullptr) return std::nullopt;
            return VirtualMachine(c);
          },
          "In process: the machine behind the first 7I77, or None");
}

void bindBoard(py::module_& m) {
  auto connector = py::arg("connector") = 0U;
  py::class_<VirtualBoard>(m, "VirtualBoard", "The in-process 7I92 + 7I77 from the outside: terminals and faults")
      .def_property_readonly("daughtercards", &VirtualBoard::daughtercards)
      .def("set_input", &VirtualBoard::setInput, py::arg("input"), py::arg("on") = true, connector,
           "Field input switched to field power (on) or ground")
      .def("set_input_voltage", &VirtualBoard::setInputVoltage, py::arg("input"), py::arg("volts"), connector)
      .def("input", &VirtualBoard::input, py::arg("input"), connector, "What the field I/O processor reads")
      .def("input_voltage", &VirtualBoard::inputVoltage, py::arg("input"), connector)
      .def("output", &VirtualBoard::output, py::arg("output"), connector, "Field output driver on")
      .def("output_voltage", &VirtualBoard::outputVoltage, py::arg("output"), connector)
      .def("output_current", &VirtualBoard::outputCurrent, py::arg("output"), connector)
      .def("output_tripped", &VirtualBoard::outputTripped, py::arg("output"), connector,
           "Shut off by its short-circuit protection")
      .def("set_output_load", &VirtualBoard::setOutputLoad, py::arg("output"), py::arg("ohms"), connector,
           "A load to field ground (7I77) or field power (7I77D): inf open, 0 a short")
      .def(
          "short_output",
          [](VirtualBoard& b, unsigned output, bool shorted, unsigned c) {
            b.setOutputLoad(output, shorted ? 0.0 : std::numeric_limits<double>::infinity(), c);
          },
          py::arg("output"), py::arg("shorted") = true, connector)
      .def("set_field_voltage", &VirtualBoard::setFieldVoltage, py::arg("volts"), connector)
      .def("field_voltage", &VirtualBoard::fieldVoltage, connector)
      .def("set_driver_overtemp", &VirtualBoard::setDriverOverTemperature, py::arg("chip"), py::arg("hot") = true,
           connector)
      .def("field_io_faults", &VirtualBoard::fieldIoFaults, connector, "The field I/O processor's fault byte")
      .def("analog_faults", &VirtualBoard::analogFaults, connector, "The analog processor's fault byte")
      .def("analog_output", &VirtualBoard::analogOutput, py::arg("channel"), connector, "Volts at AOUTn (TB5)")
      .def("enable", &VirtualBoard::enable, py::arg("channel"), connector, "ENAn closed")
      .def_property_readonly("watchdog_bitten", &VirtualBoard::watchdogBitten, "The 7I92's HostMot2 watchdog")
      .def("set_cable", &VirtualBoard::setCable, py::arg("channel"), py::arg("connected"),
           "A smart-serial channel's cable plugged in or pulled")
      .def("set_encoder", &VirtualBoard::setEncoder, py::arg("encoder"), py::arg("counts_per_second") = py::none(),
           py::arg("counts_per_rev") = py::none())
      .def("encoder_count", &VirtualBoard::encoderCount, py::arg("encoder"), "The card's 16-bit count register")
      .def_property_readonly(
          "seven_i76",
          [](VirtualBoard& b) -> std::optional<VirtualSevenI76> {
            {
              auto l = b.card()->lock();
              if (b.card()->board().sevenI76() == nullptr) return std::nullopt;
            }
            return VirtualSevenI76(b.card());
          },
          "The 7I76 beside the 7I77 on the 7I77+7I76 firmwares (Card.sim(card=\"7I92T\")), or None")
      .def_property_readonly("time", [](VirtualBoard& b) { return b.card()->time(); })
      .def("step", [](VirtualBoard& b, double s) {
        auto l = b.card()->lock();
        b.card()->step(s);
      }, py::arg("seconds"), "Let simulated time pass (the same as Card.step)");
}

void bindSevenI76(py::module_& m) {
  py::class_<VirtualSevenI76>(m, "VirtualSevenI76",
                              "The 7I76's field I/O processor from the outside: inputs, outputs, field power, spindle")
      .def_property_readonly("channel", &VirtualSevenI76::channel, "Its SSerial channel (3)")
      .def("set_input", &VirtualSevenI76::setInput, py::arg("input"), py::arg("on") = true,
           "Input switched to field power (on) or ground")
      .def("set_input_voltage", &VirtualSevenI76::setInputVoltage, py::arg("input"), py::arg("volts"))
      .def("input", &VirtualSevenI76::input, py::arg("input"), "What the processor reads")
      .def_property_readonly("inputs", &VirtualSevenI76::inputs, "Inputs 0..31 as bits")
      .def("output", &VirtualSevenI76::output, py::arg("output"), "Output driver on")
      .def_property_readonly("outputs", &VirtualSevenI76::outputs, "Outputs 0..15 as bits")
      .def("output_voltage", &VirtualSevenI76::outputVoltage, py::arg("output"))
      .def("set_field_voltage", &VirtualSevenI76::setFieldVoltage, py::arg("volts"))
      .def_property_readonly("field_voltage", &VirtualSevenI76::fieldVoltage)
      .def_property_readonly("spindle_volts", &VirtualSevenI76::spindleVolts, "SpinOut, 0..10 V")
      .def_property_readonly("spindle_enable", &VirtualSevenI76::spindleEnable, "SpinEna")
      .def_property_readonly("spindle_direction", &VirtualSevenI76::spindleDirection, "SpinDir")
      .def_property_readonly("faults", &VirtualSevenI76::faults, "The fault byte (lbpkit.FAULT_NAMES)")
      .def_property_readonly("powered", &VirtualSevenI76::powered);
}

void bindMachine(py::module_& m) {
  using State = machine::Machine::State;
  py::class_<machine::Switches::State>(m, "SwitchState")
      .def_readonly("name", &machine::Switches::State::name)
      .def_property_readonly("kind", [](const machine::Switches::State& s) { return kind(s.kind); })
      .def_readonly("input", &machine::Switches::State::input)
      .def_readonly("tripped", &machine::Switches::State::tripped)
      .def_readonly("input_on", &machine::Switches::State::inputOn)
      .def_property_readonly("daughtercard", [](const machine::Switches::State& s) {
        return std::string(machine::daughtercardName(s.daughtercard));
      }, "\"7I77\" or \"7I76\": whose input");
  py::class_<State::Stepper>(m, "StepperState", "A stepper axis' motor on a StepGen")
      .def_readonly("stepgen", &State::Stepper::stepGen)
      .def_readonly("steps", &State::Stepper::steps, "The StepGen's steps since the machine was built")
      .def_readonly("lost_steps", &State::Stepper::lostSteps, "Those the motor did not follow")
      .def_readonly("stalled", &State::Stepper::stalled, "Out of step now (commanded past its pull-out rate)")
      .def("__repr__", [](const State::Stepper& s) {
        return "<lbpkit.StepperState stepgen " + std::to_string(s.stepGen) + ": " + std::to_string(s.steps) +
               " steps, " + std::to_string(s.lostSteps) + " lost" + (s.stalled ? ", stalled" : "") + ">";
      });
  py::class_<State::Drive>(m, "DriveState")
      .def_readonly("analog_output", &State::Drive::analogOutput)
      .def_readonly("command_volts", &State::Drive::commandVolts)
      .def_readonly("ena_on", &State::Drive::enaOn)
      .def_readonly("enabled", &State::Drive::enabled)
      .def_readonly("torque", &State::Drive::torque)
      .def_readonly("encoder_input", &State::Drive::encoderInput)
      .def_readonly("encoder_count", &State::Drive::encoderCount)
      .def_readonly("true_counts", &State::Drive::trueCounts)
      .def_property_readonly("encoder_broken", [](const State::Drive& d) { return channelNames(d.encoderBroken); })
      .def_readonly("encoder_reversed", &State::Drive::encoderReversed, "A and B swapped: the count runs backwards")
      .def_readonly("enable_ignored", &State::Drive::enableIgnored, "The amplifier runs whatever its ENA says");
  py::class_<State::Axis>(m, "AxisState")
      .def_readonly("name", &State::Axis::name)
      .def_readonly("position", &State::Axis::position)
      .def_readonly("velocity", &State::Axis::velocity)
      .def_readonly("brake_engaged", &State::Axis::brakeEngaged)
      .def_readonly("at_hard_stop", &State::Axis::atHardStop)
      .def_readonly("jammed", &State::Axis::jammed)
      .def_readonly("pushing", &State::Axis::pushing)
      .def_readonly("command_velocity", &State::Axis::commandVelocity)
      .def_readonly("following_error", &State::Axis::followingError)
      .def_readonly("drives", &State::Axis::drives)
      .def_readonly("stepper", &State::Axis::stepper, "A stepper axis' StepperState; None for a servo axis")
      .def_readonly("switches", &State::Axis::switches);
  py::class_<State::Spindle>(m, "SpindleState")
      .def_readonly("command_rpm", &State::Spindle::commandRpm)
      .def_readonly("rpm", &State::Spindle::rpm)
      .def_readonly("revolutions", &State::Spindle::revolutions)
      .def_readonly("running", &State::Spindle::running)
      .def_readonly("encoder_count", &State::Spindle::encoderCount)
      .def_property_readonly("daughtercard", [](const State::Spindle& s) {
        return std::string(machine::daughtercardName(s.daughtercard));
      }, "\"7I77\" (AOUT5, ENA5) or \"7I76\" (SpinOut, SpinEna, SpinDir)");
  py::class_<State::Output>(m, "OutputState")
      .def_readonly("name", &State::Output::name)
      .def_readonly("output", &State::Output::output)
      .def_readonly("on", &State::Output::on)
      .def_property_readonly("daughtercard", [](const State::Output& o) {
        return std::string(machine::daughtercardName(o.daughtercard));
      });
  py::class_<State>(m, "MachineState")
      .def_readonly("name", &State::name)
      .def_property_readonly("time", [](const State& s) { return seconds(s.time); })
      .def_readonly("axes", &State::axes)
      .def_readonly("spindle", &State::spindle)
      .def_readonly("estop_ok", &State::estopOk)
      .def_readonly("probe", &State::probe)
      .def_readonly("switches", &State::switches)
      .def_readonly("outputs", &State::outputs);

  py::class_<VirtualMachine>(m, "VirtualMachine", "The machine behind the virtual 7I77's terminals")
      .def_property_readonly("name", &VirtualMachine::name)
      .def_property_readonly("axes", &VirtualMachine::axes)
      .def("position", &VirtualMachine::position, py::arg("axis"), "Machine units (mm), where the axis truly is")
      .def("velocity", &VirtualMachine::velocity, py::arg("axis"))
      .def("following_error", &VirtualMachine::followingError, py::arg("axis"),
           "The position its drive's velocity command asked for, less where it is")
      .def("brake_engaged", &VirtualMachine::brakeEngaged, py::arg("axis"))
      .def_property_readonly("spindle_rpm", &VirtualMachine::spindleRpm)
      .def("state", &VirtualMachine::state)
      .def("stepper", &VirtualMachine::stepper, py::arg("axis"),
           "A stepper axis' StepperState (steps, lost_steps, stalled); None for a servo axis")
      .def("steps", [](VirtualMachine& vm, const std::string& a) { return stepperOf(vm, a).steps; }, py::arg("axis"),
           "A stepper axis' StepGen steps since the machine was built")
      .def("lost_steps", [](VirtualMachine& vm, const std::string& a) { return stepperOf(vm, a).lostSteps; },
           py::arg("axis"), "The steps a stepper axis' motor did not follow")
      .def("stalled", [](VirtualMachine& vm, const std::string& a) { return stepperOf(vm, a).stalled; },
           py::arg("axis"), "A stepper axis' motor is out of step now")
      .def("set_switch", &VirtualMachine::setSwitch, py::arg("name"), py::arg("tripped") = true)
      .def("estop", &VirtualMachine::estop, py::arg("pressed") = true)
      .def("probe", &VirtualMachine::probe, py::arg("touching") = true)
      .def("push", &VirtualMachine::push, py::arg("axis"), py::arg("distance"), py::arg("speed") = 20.0,
           "An outside force moving the axis by `distance` at `speed` units/s")
      .def("jam", &VirtualMachine::jam, py::arg("axis"), py::arg("jammed") = true)
      .def("break_encoder", &VirtualMachine::breakEncoder, py::arg("axis"), py::arg("channel") = "A",
           py::arg("broken") = true, py::arg("drive") = 0U);
}

}  // namespace

PYBIND11_MODULE(_lbpkit, m) {
  m.doc() = "lbpkit: the host library for Mesa smart-serial (7I77) cards, and the in-process virtual card";
  py::module_::import("atexit").attr("register")(py::cpp_function([] { gExiting = true; }));
  static py::exception<lbpkit::Error> error(m, "Error", PyExc_RuntimeError);
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const lbpkit::Error& e) {
      PyErr_SetString(error.ptr(), e.what());
    } catch (const config::FileError& e) {  // a machine file's mistake, with file, line, column and key
      PyErr_SetString(error.ptr(), e.what());
    }
  });
  std::vector<std::string> names;
  for (const auto n : lbpkit::wire::i7i77::fault::kNames) names.emplace_back(n);
  m.attr("FAULT_NAMES") = names;
  m.def("describe_faults", [](std::uint8_t byte) { return lbpkit::describeRemoteFaults(byte); }, py::arg("fault_byte"),
        "The 7I77's fault bits by name (CS byte 3, the Fault parameter)");
  m.def("describe_cs", [](std::uint32_t cs) { return lbpkit::describeCs(cs); }, py::arg("cs"));
  bindCardTypes(m);
  bindCard(m);
  bindSevenI76(m);
  bindBoard(m);
  bindMachine(m);
}
