// SPDX-License-Identifier: MIT
#include "daemon/state_json.hpp"

#include <fmt/format.h>

#include <chrono>
#include <cmath>
#include <nlohmann/json.hpp>

namespace lbpkit::server {

using nlohmann::json;

namespace {

std::string hex32(std::uint32_t v) { return fmt::format("0x{:08X}", v); }

std::string macText(const std::array<std::uint8_t, 6>& m) {
  return fmt::format("{:02x}:{:02x}:{:02x}:{:02x}:{:02x}:{:02x}", m[0], m[1], m[2], m[3], m[4], m[5]);
}

}  // namespace

json faultNames(std::uint8_t faults) {
  json a = json::array();
  for (unsigned b = 0; b < 8; ++b)
    if ((static_cast<unsigned>(faults) >> b) & 1U) a.push_back(std::string(model::remote::fault::kNames[b]));
  return a;
}

json toJson(const model::hm2::Watchdog::State& s) { return {{"bitten", s.bitten}, {"timer", s.timer}}; }

json toJson(const model::hm2::Sslbp::State& s) {
  json chans = json::array();
  for (unsigned ch = 0; ch < s.channels; ++ch) {
    const auto& c = s.channel[ch];
    const auto& lc = c.link;
    chans.push_back({{"channel", ch},
                     {"running", c.running},
                     {"cs", hex32(c.cs)},
                     {"remote_faults", faultNames(c.remoteFaults)},
                     {"baud", c.baud},
                     {"cable_connected", c.cableConnected},
                     {"link",
                      {{"to_remote", lc.toRemote},
                       {"from_remote", lc.fromRemote},
                       {"corrupted", lc.corrupted},
                       {"dropped", lc.dropped},
                       {"added", lc.added},
                       {"breaks", lc.breaks}}}});
  }
  return {{"command", fmt::format("0x{:04X}", s.command)},
          {"data", fmt::format("0x{:02X}", s.data)},
          {"doits", s.counters.doits},
          {"lost_commands", s.counters.lostCommands},
          {"channels", chans}};
}

json toJson(const model::hm2::MuxedEncoder::State::Counter& s) {
  return {{"count", s.count},
          {"position", s.signal.position},
          {"velocity", s.signal.velocity},
          {"counts_per_rev", s.signal.countsPerRev}};
}

namespace {

// What a field I/O processor (the 7I77's, the 7I76's) shows of itself.
json fieldProcessor(const model::remote::RemoteDevice::DeviceState& d, double fieldVoltage, json inputs, json outputs) {
  return {{"powered", d.powered},
          {"field_voltage", fieldVoltage},
          {"mode", d.softwareMode},
          {"unit_number", hex32(d.unitNumber)},
          {"watchdog_ms", d.watchdogMs},
          {"faults", faultNames(d.faults)},
          {"baud", d.baud},
          {"inputs", std::move(inputs)},
          {"outputs", std::move(outputs)}};
}

}  // namespace

json toJson(const model::remote::FieldIoProcessor::State& s) {
  json inputs = json::array(), outputs = json::array();
  for (const auto& in : s.inputs) inputs.push_back({{"volts", in.volts}, {"on", in.on}});
  // JSON has no infinity: a dead short's current reads -1.
  for (const auto& out : s.outputs)
    outputs.push_back({{"on", out.on},
                       {"volts", out.volts},
                       {"amps", std::isinf(out.amps) ? -1.0 : out.amps},
                       {"tripped", out.tripped}});
  json j = fieldProcessor(s.device, s.fieldVoltage, inputs, outputs);
  j["vin"] = s.vin;
  j["mpg"] = s.mpg;
  return j;
}

json toJson(const model::remote::AnalogProcessor::State& s) {
  json outputs = json::array();
  for (const auto& out : s.outputs) outputs.push_back({{"volts", out.volts}, {"code", out.code}, {"enable", out.enable}});
  return {{"powered", s.device.powered},
          {"unit_number", hex32(s.device.unitNumber)},
          {"faults", faultNames(s.device.faults)},
          {"outputs", outputs}};
}

json toJson(const Lbp16Card::Counters& s) {
  return {{"packets", s.packets},
          {"replies", s.replies},
          {"parse_errors", s.parseErrors},
          {"memory_errors", s.memoryErrors},
          {"write_errors", s.writeErrors}};
}

json toJson(const model::hm2::AccessCounters& s) {
  return {{"unmapped_reads", s.unmappedReads},
          {"unmapped_writes", s.unmappedWrites},
          {"read_only_writes", s.readOnlyWrites},
          {"ignored_commands", s.ignoredCommands},
          {"lost_commands", s.lostCommands}};
}

json toJson(const SimState::Server& s) {
  return {{"datagrams", s.datagrams},
          {"scheduling", s.scheduling},
          {"median_us", s.medianUs},
          {"p99_us", s.p99Us},
          {"max_us", s.maxUs},
          {"queue_median_us", s.queueMedianUs},
          {"queue_p99_us", s.queueP99Us},
          {"queue_max_us", s.queueMaxUs},
          {"p999_us", s.p999Us},
          {"queue_p999_us", s.queueP999Us},
          {"at_least_us", [&] {
             json j;
             for (std::size_t i = 0; i < s.atLeast.size(); ++i)
               j[std::to_string(SimState::Server::kAtLeastUs[i])] = s.atLeast[i];
             return j;
           }()}};
}

json toJson(const SimState::Daughtercard& s, unsigned connector) {
  json enc = json::array();
  for (const auto& e : s.encoders) enc.push_back(toJson(e));
  const auto& io = s.fieldIo;
  // CR1, CR6 and CR7 watch the 5 V, +16 V and -12 V supplies (manual: STATUS
  // LEDs); the model has no supply faults, so they are always on.
  return {{"connector", connector},
          {"type", io.outputType == model::remote::OutputType::Sinking ? "7I77D" : "7I77"},
          {"leds",
           {{"CR1", true},
            {"CR3", io.fieldVoltageLed},
            {"CR6", true},
            {"CR7", true},
            {"CR15", io.device.activityLed},
            {"CR16", io.device.faultLed}}},
          {"field_io", toJson(io)},
          {"analog", toJson(s.analog)},
          {"encoders", enc}};
}

json toJson(const SimState::SevenI76& s) {
  const auto& io = s.fieldIo;
  json inputs = json::array(), outputs = json::array();
  for (unsigned i = 0; i < model::remote::SevenI76FieldIo::kInputs; ++i)
    inputs.push_back({{"on", ((io.inputs >> i) & 1U) != 0}});
  // Sourcing outputs: one that is on is at field power (seven_i76.hpp).
  for (unsigned i = 0; i < model::remote::SevenI76FieldIo::kOutputs; ++i) {
    const bool on = ((io.outputs >> i) & 1U) != 0;
    const double amps = io.outputAmps[i];
    outputs.push_back({{"on", on}, {"volts", on ? io.fieldVoltage : 0.0}, {"amps", std::isinf(amps) ? -1.0 : amps}});
  }
  return {{"connector", s.connector},
          {"connector_name", s.connectorName},
          {"type", "7I76"},
          {"channel", s.channel},
          {"field_io", fieldProcessor(io.device, io.fieldVoltage, inputs, outputs)},
          {"spindle",
           {{"volts", io.spindleVolts}, {"enable", io.spindleEnable}, {"direction", io.spindleDirection}}}};
}

namespace {

const char* kindName(model::machine::SwitchKind k) {
  using K = model::machine::SwitchKind;
  switch (k) {
    case K::Home: return "home";
    case K::MinLimit: return "min_limit";
    case K::MaxLimit: return "max_limit";
    case K::Estop: return "estop";
    case K::Probe: return "probe";
    case K::Other: break;
  }
  return "other";
}

json channelNames(const std::vector<model::machine::EncoderChannel>& channels) {
  json a = json::array();
  for (const auto c : channels)
    a.push_back(c == model::machine::EncoderChannel::A ? "A" : c == model::machine::EncoderChannel::B ? "B" : "index");
  return a;
}

}  // namespace

json toJson(const model::machine::Switches::State& s) {
  return {{"name", s.name},        {"kind", kindName(s.kind)},
          {"input", s.input},      {"tripped", s.tripped},
          {"input_on", s.inputOn}, {"daughtercard", model::machine::daughtercardName(s.daughtercard)}};
}

json toJson(const model::machine::Machine::State& s) {
  auto switches = [](const std::vector<model::machine::Switches::State>& list) {
    json a = json::array();
    for (const auto& sw : list) a.push_back(toJson(sw));
    return a;
  };
  json axes = json::array();
  for (const auto& a : s.axes) {
    json drives = json::array();
    for (const auto& d : a.drives)
      drives.push_back({{"analog_output", d.analogOutput},
                        {"command_volts", d.commandVolts},
                        {"ena", d.enaOn},
                        {"enabled", d.enabled},
                        {"ena_changed_s", std::chrono::duration<double>(d.enaChangedAt).count()},
                        {"torque", d.torque},
                        {"encoder_input", d.encoderInput},
                        {"encoder_count", d.encoderCount},
                        {"true_counts", d.trueCounts},
                        {"encoder_broken", channelNames(d.encoderBroken)},
                        {"encoder_reversed", d.encoderReversed},
                        {"enable_ignored", d.enableIgnored}});
    // A stepper axis (no drives): its StepGen's steps, those the motor lost,
    // whether it is out of step, and where the steps say the axis is (its
    // following error is the lost steps in machine units). null on a servo axis.
    json stepper = nullptr;
    if (a.stepper)
      stepper = {{"stepgen", a.stepper->stepGen},
                 {"steps", a.stepper->steps},
                 {"lost_steps", a.stepper->lostSteps},
                 {"stalled", a.stepper->stalled},
                 {"commanded_position", a.position + a.followingError}};
    axes.push_back({{"name", a.name},
                    {"position", a.position},
                    {"velocity", a.velocity},
                    {"command_velocity", a.commandVelocity},
                    {"following_error", a.followingError},
                    {"brake_engaged", a.brakeEngaged},
                    {"at_hard_stop", a.atHardStop},
                    {"jammed", a.jammed},
                    {"pushing", a.pushing},
                    {"drives", drives},
                    {"stepper", stepper},
                    {"switches", switches(a.switches)}});
  }
  json spindle = nullptr;
  if (s.spindle) {
    const auto& sp = *s.spindle;
    spindle = {{"command_rpm", sp.commandRpm},
               {"rpm", sp.rpm},
               {"revolutions", sp.revolutions},
               {"running", sp.running},
               {"encoder_count", sp.encoderCount ? json(*sp.encoderCount) : json(nullptr)},
               {"encoder_broken", channelNames(sp.encoderBroken)},
               {"encoder_reversed", sp.encoderReversed},
               {"daughtercard", model::machine::daughtercardName(sp.daughtercard)}};
  }
  json outputs = json::array();
  for (const auto& o : s.outputs)
    outputs.push_back({{"name", o.name},
                       {"output", o.output},
                       {"on", o.on},
                       {"daughtercard", model::machine::daughtercardName(o.daughtercard)}});
  return {{"name", s.name},
          {"time_s", std::chrono::duration<double>(s.time).count()},
          {"axes", axes},
          {"spindle", spindle},
          {"estop_ok", s.estopOk},
          {"probe", s.probe},
          {"switches", switches(s.switches)},
          {"outputs", outputs}};
}

json toJson(const SimState& s) {
  json j;
  j["time_s"] = std::chrono::duration<double>(s.time).count();
  j["clock"] = {{"speed", s.clock.speed},
                {"paused", s.clock.paused},
                {"behind_ms", std::chrono::duration<double, std::milli>(s.clock.behind).count()},
                {"slips", s.clock.slips},
                {"source", s.clock.host ? "host" : "wall"}};
  if (s.clock.host) {
    j["clock"]["period_ms"] = std::chrono::duration<double, std::milli>(s.clock.period).count();
    j["clock"]["driven_by_host"] = s.clock.driven;
    j["clock"]["host_cycles"] = s.clock.hostCycles;
    j["clock"]["host_silences"] = s.clock.silences;
    j["clock"]["held_back_ms"] = std::chrono::duration<double, std::milli>(s.clock.heldBack).count();
    j["clock"]["held_back_times"] = s.clock.heldBackTimes;
    j["clock"]["host_left_cycle"] = s.clock.cyclesLeft;
    j["clock"]["host_late_held"] = s.clock.runningHolds;
    j["clock"]["host_pid"] = s.clock.hostPid;
  }
  const auto& e = s.card.eeprom;
  j["card"] = {{"name", s.card.name},
               {"address", s.card.address},
               {"port", s.card.port},
               {"mac", macText(s.card.mac)},
               {"eeprom",
                {{"mac", macText(e.mac)},
                 {"ip", fmt::format("{}.{}.{}.{}", e.ip[0], e.ip[1], e.ip[2], e.ip[3])},
                 {"name", e.name}}}};
  j["lbp16"] = toJson(s.lbp16);
  j["server"] = toJson(s.server);
  j["watchdog"] = toJson(s.watchdog);
  j["card_leds"] = s.cardLeds.leds;
  j["sserial"] = toJson(s.sserial);
  j["access_counters"] = toJson(s.accessCounters);
  json boards = json::array();
  for (unsigned d = 0; d < s.daughtercards.size(); ++d) boards.push_back(toJson(s.daughtercards[d], d));
  if (s.sevenI76) boards.push_back(toJson(*s.sevenI76));
  j["daughtercards"] = boards;
  j["machine"] = s.machine ? toJson(*s.machine) : json(nullptr);
  return j;
}

std::string stateJson(const SimState& s) { return toJson(s).dump(); }

}  // namespace lbpkit::server
