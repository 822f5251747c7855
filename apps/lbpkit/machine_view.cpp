// SPDX-License-Identifier: MIT
#include "machine_view.hpp"

#include <fmt/core.h>
#include <httplib.h>

#include <nlohmann/json.hpp>
#include <optional>
#include <utility>

namespace lbpkit::app {

namespace {

using nlohmann::json;

// Fields read leniently: a missing or mistyped one shows as "?".
std::optional<double> number(const json& j, const char* key) {
  if (!j.is_object()) return std::nullopt;
  const auto it = j.find(key);
  if (it == j.end() || !it->is_number()) return std::nullopt;
  return it->get<double>();
}
std::optional<bool> flag(const json& j, const char* key) {
  if (!j.is_object()) return std::nullopt;
  const auto it = j.find(key);
  if (it == j.end() || !it->is_boolean()) return std::nullopt;
  return it->get<bool>();
}
std::string text(const json& j, const char* key) {
  if (!j.is_object()) return "?";
  const auto it = j.find(key);
  if (it == j.end() || !it->is_string()) return "?";
  return it->get<std::string>();
}
const json& list(const json& j, const char* key) {
  static const json empty = json::array();
  if (!j.is_object()) return empty;
  const auto it = j.find(key);
  return it != j.end() && it->is_array() ? *it : empty;
}
std::string fixed(std::optional<double> v, int decimals, bool sign = false) {
  if (!v) return "?";
  return sign ? fmt::format("{:+.{}f}", *v, decimals) : fmt::format("{:.{}f}", *v, decimals);
}
std::string whole(std::optional<double> v) { return v ? fmt::format("{:.0f}", *v) : "?"; }
std::string onOff(std::optional<bool> v, const char* on, const char* off) { return v ? (*v ? on : off) : "?"; }

// " (7I76)" for what is wired to the 7I76 rather than the 7I77.
std::string board(const json& part) { return text(part, "daughtercard") == "7I76" ? " (7I76)" : ""; }

// "x-home -" while clear, "x-max TRIPPED" when the cam (or the operator) has it.
std::string switches(const json& all) {
  std::string s;
  for (const auto& sw : all) {
    if (!s.empty()) s += "  ";
    s += fmt::format("{}{} {}", text(sw, "name"), board(sw), onOff(flag(sw, "tripped"), "TRIPPED", "-"));
  }
  return s;
}

// A stepper axis' StepGen: "StepGen 0: 4000 steps, 12 lost  STALLED".
std::string stepper(const json& st) {
  const auto stalled = flag(st, "stalled");
  return fmt::format("StepGen {}: {} steps, {} lost{}", whole(number(st, "stepgen")), whole(number(st, "steps")),
                     whole(number(st, "lost_steps")), !stalled ? "  stall ?" : *stalled ? "  STALLED" : "");
}

std::string drive(const json& d) {
  std::string broken;
  for (const auto& channel : list(d, "encoder_broken"))
    if (channel.is_string()) broken += (broken.empty() ? " broken: " : ",") + channel.get<std::string>();
  // Its encoder's A and B swapped, its amplifier deaf to ENA (faults to rehearse).
  if (flag(d, "encoder_reversed").value_or(false)) broken += "  encoder reversed";
  if (flag(d, "enable_ignored").value_or(false)) broken += "  ENA ignored";
  const auto count = number(d, "encoder_count");
  // The ENA number is the drive's own when the API says it (ENA0..4 switch
  // together anyway: manual, SERVO ENABLE OUTPUTS).
  const auto ena = number(d, "enable");
  return fmt::format("AOUT{} {:>7} V  ENA{} {:<3} {:<8}  enc{} {:>5}{}", whole(number(d, "analog_output")),
                     fixed(number(d, "command_volts"), 3, true), ena ? whole(ena) : "",
                     onOff(flag(d, "ena"), "on", "off"), onOff(flag(d, "enabled"), "enabled", "disabled"),
                     whole(number(d, "encoder_input")), count ? fmt::format("{:.0f}", *count) : "?", broken);
}

}  // namespace

std::string machineSection(const json& m) {
  std::string s = fmt::format("machine: {} at {} s   E-stop chain: {}   probe: {}\n", text(m, "name"),
                              fixed(number(m, "time_s"), 3),
                              onOff(flag(m, "estop_ok"), "closed (ok)", "OPEN (E-stop)"),
                              onOff(flag(m, "probe"), "TOUCHING", "clear"));
  s += fmt::format("  {:<6} {:>10} {:>10}  {}\n", "axis", "position", "velocity", "drive: command, enable, encoder count");
  for (const auto& a : list(m, "axes")) {
    std::string state;
    if (flag(a, "brake_engaged").value_or(false)) state += "  brake on";
    if (flag(a, "at_hard_stop").value_or(false)) state += "  AT HARD STOP";
    if (flag(a, "jammed").value_or(false)) state += "  JAMMED";
    if (flag(a, "pushing").value_or(false)) state += "  pushed";
    const auto& drives = list(a, "drives");
    const auto it = a.is_object() ? a.find("stepper") : a.end();
    const bool isStepper = a.is_object() && it != a.end() && it->is_object();
    const std::string first = isStepper ? stepper(*it) : drives.empty() ? "(no drive)" : drive(drives[0]);
    s += fmt::format("  {:<6} {:>10} {:>10}  {}{}\n", text(a, "name"), fixed(number(a, "position"), 3),
                     fixed(number(a, "velocity"), 3), first, state);
    for (std::size_t i = 1; i < drives.size(); ++i) s += fmt::format("  {:<6} {:>10} {:>10}  {}\n", "", "", "", drive(drives[i]));
    if (!list(a, "switches").empty()) s += fmt::format("  {:<6} switches: {}\n", "", switches(list(a, "switches")));
  }
  // The switches on no axis (the E-stop chain, a probe told to trip).
  json other = json::array();
  for (const auto& sw : list(m, "switches")) {
    bool onAxis = false;
    for (const auto& a : list(m, "axes"))
      for (const auto& mine : list(a, "switches")) onAxis = onAxis || text(mine, "name") == text(sw, "name");
    if (!onAxis) other.push_back(sw);
  }
  if (!other.empty()) s += fmt::format("  other switches: {}\n", switches(other));
  if (const auto it = m.is_object() ? m.find("spindle") : m.end(); m.is_object() && it != m.end() && it->is_object()) {
    const auto& sp = *it;
    const auto count = number(sp, "encoder_count");
    s += fmt::format("spindle{}: command {} rpm, actual {} rpm, {}{}\n", board(sp), whole(number(sp, "command_rpm")),
                     whole(number(sp, "rpm")), onOff(flag(sp, "running"), "running", "stopped"),
                     count ? fmt::format(", encoder {:.0f}", *count) : "");
  }
  if (!list(m, "outputs").empty()) {
    s += "outputs:";
    for (const auto& o : list(m, "outputs"))
      s += fmt::format("  {} ({}out {}) {}", text(o, "name"), text(o, "daughtercard") == "7I76" ? "7I76 " : "",
                       whole(number(o, "output")), onOff(flag(o, "on"), "ON", "off"));
    s += "\n";
  }
  return s;
}

MachineWatcher::MachineWatcher(std::string host, int port, std::string token, std::chrono::milliseconds period)
    : host_(std::move(host)), port_(port), token_(std::move(token)), period_(period) {
  httplib::Client client(host_, port_);
  fetch(client);
  thread_ = std::thread([this] { run(); });
}

MachineWatcher::~MachineWatcher() {
  {
    const std::lock_guard lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  thread_.join();
}

std::string MachineWatcher::section() const {
  const std::lock_guard lock(mutex_);
  return section_;
}

std::string MachineWatcher::describe() const { return fmt::format("http://{}:{}/api/machine", host_, port_); }

void MachineWatcher::fetch(httplib::Client& client) {
  client.set_connection_timeout(std::chrono::duration_cast<std::chrono::microseconds>(kConnectTimeout));
  client.set_read_timeout(std::chrono::duration_cast<std::chrono::microseconds>(kReadTimeout));
  client.set_keep_alive(true);
  httplib::Headers headers;
  if (!token_.empty()) headers.emplace("Authorization", "Bearer " + token_);
  std::string section;
  // No API, no machine (404) or no answer: nothing to show, every frame
  // (a real card has no API behind it; that is not an error).
  if (const auto res = client.Get("/api/machine", headers)) {
    if (res->status == 200) {
      const auto j = json::parse(res->body, nullptr, false);
      section = j.is_object() ? machineSection(j)
                              : fmt::format("machine: {} answered something that is not a JSON object\n", describe());
    } else if (res->status == 401 || res->status == 403) {
      section = fmt::format("machine: {} wants the sim's API token (--api-token or LBPKIT_API_TOKEN)\n", describe());
    }
  }
  const std::lock_guard lock(mutex_);
  section_ = std::move(section);
}

void MachineWatcher::run() {
  httplib::Client client(host_, port_);
  std::unique_lock lock(mutex_);
  while (!stop_) {
    if (wake_.wait_for(lock, period_, [this] { return stop_; })) break;
    lock.unlock();
    fetch(client);
    lock.lock();
  }
}

}  // namespace lbpkit::app
