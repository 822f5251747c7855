// SPDX-License-Identifier: MIT
// The checks of lbpkit rehearse (rehearse.hpp; docs/rehearse.md says what
// each measures and where the manual or LinuxCNC defines it). Each fault is
// a POST to the sim's control API, as a user makes it; what LinuxCNC does
// about it comes from the driver in LinuxCNC, what the machine did from the
// machine's trace (one row per servo cycle, in the sim's time: on the host
// clock a servo period late on this PC is one period to the machine, as on
// an on-time PC) and, once the host is gone, from the API on the wall clock.
#include <signal.h>
#include <sys/stat.h>

#include <fmt/core.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <optional>
#include <thread>

#include "lbpkit/error.hpp"
#include "linuxcnc/namespace_processes.hpp"
#include "rehearse.hpp"

namespace lbpkit::app::rehearse {

namespace {

using namespace std::chrono_literals;

constexpr int kStateEstop = 1;  // linuxcnc.STATE_ESTOP
// How long a runaway is watched for LinuxCNC to take the machine off.
constexpr int kWatchSeconds = 3;

std::string upper(const std::string& s) {
  std::string u = s;
  for (auto& c : u) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return u;
}

const json& axisOf(const json& machine, const std::string& name) {
  for (const auto& a : machine.at("axes"))
    if (a.at("name") == name) return a;
  throw lbpkit::Error(fmt::format("the machine has no axis {}", name));
}

// Until `axis` is at rest (under a thousandth of its MAX_VELOCITY for 50 ms
// of the wall clock), at most `timeout`: the machine's state then.
json atRest(const Session& s, const Joint& j, std::chrono::milliseconds timeout = 3000ms) {
  const auto end = std::chrono::steady_clock::now() + timeout;
  unsigned still = 0;
  while (true) {
    auto m = s.machineState();
    const double v = std::abs(axisOf(m, j.axis).at("velocity").get<double>());
    still = v < std::max(1e-3, j.maxVelocity * 1e-3) ? still + 1 : 0;
    if (still >= 5 || std::chrono::steady_clock::now() > end) return m;
    std::this_thread::sleep_for(10ms);
  }
}

// The plot of one axis from the trace (time from the fault, at most about
// 600 points): the position the drive was asked for, where the axis is,
// the drive's following error and its enable.
json plotOf(const Trace& t, const std::string& axis, double t0, const json& events) {
  const auto& A = axis;
  json time = json::array(), command = json::array(), position = json::array(), ferror = json::array(),
       enabled = json::array();
  const auto& ts = t.column("time_s");
  const std::size_t step = std::max<std::size_t>(1, ts.size() / 600);
  for (std::size_t i = 0; i < ts.size(); i += step) {
    const double p = t.column(A + "_position")[i], fe = t.column(A + "_following_error")[i];
    time.push_back(std::round((ts[i] - t0) * 1e6) / 1e6);
    command.push_back(p + fe);
    position.push_back(p);
    ferror.push_back(fe);
    enabled.push_back(t.has(A + "_enabled") ? t.column(A + "_enabled")[i] : 1.0);
  }
  return {{"time_s", time},
          {"series", {{"command", command}, {"position", position}, {"following_error", ferror}, {"enabled", enabled}}},
          {"events", events}};
}

// The first trace time at or after t0 when `axis`'s drive is no longer
// enabled; negative when it never was off. With `atZeroVolts` (a drive
// whose enable does nothing), when its analog command went to 0 V for good
// instead (the row after its last one off 0 V): what disables such a
// drive. A command held at rest reads 0 V before anything happened.
double disabledAt(const Trace& t, const std::string& axis, double t0, bool atZeroVolts = false) {
  const auto column = axis + (atZeroVolts ? "_command_volts" : "_enabled");
  if (!t.has(column)) return -1;
  const auto& ts = t.column("time_s");
  const auto& v = t.column(column);
  if (!atZeroVolts) {
    for (std::size_t i = 0; i < ts.size(); ++i)
      if (ts[i] >= t0 && v[i] < 0.5) return ts[i];
    return -1;
  }
  std::optional<std::size_t> lastDriven;
  for (std::size_t i = 0; i < ts.size(); ++i)
    if (ts[i] >= t0 && std::abs(v[i]) >= 1e-3) lastDriven = i;
  if (!lastDriven) return t0;
  return *lastDriven + 1 < ts.size() ? ts[*lastDriven + 1] : -1;
}

// Where `axis` was at trace time `t` (the last row at or before it).
double positionAt(const Trace& tr, const std::string& axis, double t) {
  const auto& ts = tr.column("time_s");
  const auto& p = tr.column(axis + "_position");
  double at = p.empty() ? 0.0 : p.front();
  for (std::size_t i = 0; i < ts.size() && ts[i] <= t; ++i) at = p[i];
  return at;
}

double peakSpeed(const Trace& t, const std::string& axis, double t0) {
  const auto& ts = t.column("time_s");
  const auto& v = t.column(axis + "_velocity");
  double peak = 0;
  for (std::size_t i = 0; i < ts.size(); ++i)
    if (ts[i] >= t0) peak = std::max(peak, std::abs(v[i]));
  return peak;
}

double round3(double v) { return std::round(v * 1000.0) / 1000.0; }

// The motion a check makes: `holding` at the middle of the travel, or
// moving across it at MAX_VELOCITY (from a tenth in from one soft limit
// towards a tenth in from the other), running when this returns.
std::string makeMotion(Session& s, const Joint& j, bool moving) {
  const std::string L(1, j.letter);
  const double span = j.maxLimit - j.minLimit;
  // What LinuxCNC said when it would not (its messages, its state).
  auto refused = [&](const std::string& what) {
    const auto st = s.driver.ask({{"op", "status"}});
    return fmt::format("LinuxCNC would not {} (task state {}, homed {}, it said: {})", what, st.value("task_state", 0),
                       st.value("homed", json::array()).dump(),
                       json(s.driver.messages().size() > 3
                                ? std::vector<std::string>(s.driver.messages().end() - 3, s.driver.messages().end())
                                : s.driver.messages())
                           .dump());
  };
  if (!moving) {
    const auto to = fmt::format("G53 G0 {}{:.4f}", L, j.minLimit + span / 2);
    return s.mdi(to) ? std::string() : refused(to);
  }
  if (const auto to = fmt::format("G53 G0 {}{:.4f}", L, j.minLimit + span / 10); !s.mdi(to)) return refused(to);
  const auto started = s.driver.ask(
      {{"op", "mdi"},
       {"command", fmt::format("G53 G1 {}{:.4f} F{:.3f}", L, j.maxLimit - span / 10, j.maxVelocity * 60.0)},
       {"wait", false}});
  if (!started.value("ok", false)) return refused("start the move across the travel");
  if (!s.driver.ask({{"op", "wait_moving"}, {"joint", j.joint}, {"speed", 0.9 * j.maxVelocity}, {"timeout", 10}})
           .value("ok", false))
    return refused("reach 90 % of MAX_VELOCITY");
  return {};
}

struct Fault {
  std::string key, title;
  std::vector<json> inject, revert;
  bool rehome;      // the position LinuxCNC has is lost with it
  std::string why;  // what it rehearses
  [[nodiscard]] bool enableIgnored() const { return key == "enable-ignored"; }
};

std::vector<Fault> runawayFaults(const Joint& j) {
  const json axis = j.axis;
  return {
      {"reversed-encoder",
       "reversed encoder",
       {{{"action", "encoder"}, {"axis", axis}, {"drive", 0}, {"reversed", true}}},
       {{{"action", "encoder"}, {"axis", axis}, {"drive", 0}, {"reversed", false}}},
       true,
       "its count runs against the motion: the position loop is positive feedback"},
      {"broken-a",
       "broken encoder A channel",
       {{{"action", "encoder"}, {"axis", axis}, {"drive", 0}, {"channel", "A"}, {"broken", true}}},
       {{{"action", "encoder"}, {"axis", axis}, {"drive", 0}, {"channel", "A"}, {"broken", false}}},
       true,
       "the count stops while the axis moves: the loop drives on"},
      {"enable-ignored",
       "amplifier enable does nothing, encoder reversed",
       {{{"action", "amplifier"}, {"axis", axis}, {"drive", 0}, {"enable_ignored", true}},
        {{"action", "encoder"}, {"axis", axis}, {"drive", 0}, {"reversed", true}}},
       {{{"action", "encoder"}, {"axis", axis}, {"drive", 0}, {"reversed", false}},
        {{"action", "amplifier"}, {"axis", axis}, {"drive", 0}, {"enable_ignored", false}}},
       true,
       "dropping ENA does not stop the drive: only the analog command's 0 V does"},
      {"jammed",
       "jammed axis",
       {{{"action", "jam"}, {"axis", axis}, {"jammed", true}}},
       {{{"action", "jam"}, {"axis", axis}, {"jammed", false}}},
       false,
       "the axis cannot follow its command"},
  };
}

const char* kRunawayCites =
    "7I77 manual, introduction: a bad encoder connection can lead to a runaway servo system; LinuxCNC "
    "[JOINT_n]FERROR and MIN_FERROR (joint.N.f-error, joint.N.f-error-lim): the following error that takes the "
    "machine off";

json runawayCase(Session& s, const Joint& j, const Fault& f, bool moving) {
  const std::string id = fmt::format("runaway.{}.{}.{}", j.axis, f.key, moving ? "moving" : "holding");
  const std::string title = fmt::format(
      "{}: {} while {}", upper(j.axis), f.title,
      moving ? fmt::format("moving at MAX_VELOCITY ({:g} {}/s)", j.maxVelocity, s.units) : "holding position");
  json r = {{"id", id}, {"check", "runaway"}, {"title", title}, {"cites", kRunawayCites}, {"reason", ""}};
  s.ready();
  if (const auto why = makeMotion(s, j, moving); !why.empty()) {
    r["verdict"] = "fail";
    r["reason"] = why;
    r["figures"] = json::object();
    return r;
  }
  double t0 = 0;
  for (const auto& action : f.inject) t0 = s.api.post("/api/machine", action).at("time_s").get<double>();
  const auto off = s.driver.ask({{"op", "wait_off"}, {"timeout", kWatchSeconds}});
  // A runaway LinuxCNC did not see is stopped here, as the operator's
  // Machine Off would: the drives' enables drop and the axis coasts.
  if (!off.value("ok", false)) s.driver.ask({{"op", "machine_off"}});
  const auto after = atRest(s, j);
  const auto t = s.trace(t0 - 0.2);
  // Where the axis was when the fault was made (the machine's time of the
  // request), not when last looked at: at speed, a look's few
  // milliseconds are millimetres.
  const double p0 = positionAt(t, j.axis, t0);
  const double p1 = axisOf(after, j.axis).at("position").get<double>();
  const bool hit = axisOf(after, j.axis).at("at_hard_stop").get<bool>();
  const double off_at = disabledAt(t, j.axis, t0, f.enableIgnored());
  const double distance = std::abs(p1 - p0);
  // LinuxCNC's part: the travel until it disabled the drive. The coast
  // after it is the machine's (its inertia and friction, assumed where a
  // derived machine has them).
  const double reaction = off_at >= 0 ? std::abs(positionAt(t, j.axis, off_at) - p0) : distance;
  const double left = p1 >= p0 ? j.hardStopMax - p1 : p1 - j.hardStopMin;
  const double bound = j.room();
  for (const auto& action : f.revert) s.api.post("/api/machine", action);
  r["figures"] = {{"time_to_disable_s", off_at >= 0 ? json(round3(off_at - t0)) : json(nullptr)},
                  {"distance_to_disable", round3(reaction)},
                  {"distance", round3(distance)},
                  {"bound", round3(bound)},
                  {"peak_velocity", round3(peakSpeed(t, j.axis, t0))},
                  {"left_to_hard_stop", round3(left)},
                  {"hit_hard_stop", hit}};
  json events = json::array({{{"t", 0.0}, {"what", f.title}}});
  if (off_at >= 0)
    events.push_back({{"t", round3(off_at - t0)}, {"what", f.enableIgnored() ? "command at 0 V" : "drive disabled"}});
  r["plot"] = plotOf(t, j.axis, t0, events);
  r["plot"]["units"] = {{"command", s.units}, {"position", s.units}, {"following_error", s.units}, {"enabled", ""}};
  r["linuxcnc_said"] = off.value("messages", json::array());
  r["why"] = f.why;
  if (hit) {
    r["verdict"] = "fail";
    r["reason"] = "the axis hit its hard stop";
  } else if (!off.value("ok", false) && distance > j.minFerror) {
    r["verdict"] = "fail";
    r["reason"] = fmt::format(
        "LinuxCNC never took the machine off: the axis went {:.3f} {} (past MIN_FERROR, {:g} {}) in the {} s "
        "watched (then turned off by the rehearsal), and LinuxCNC saw no following error",
        distance, s.units, j.minFerror, s.units, kWatchSeconds);
  } else if (!off.value("ok", false)) {
    r["verdict"] = "pass";
    r["reason"] = fmt::format("LinuxCNC did not need to act: the axis stayed within {:.3f} {} of where it was",
                              distance, s.units);
  } else if (reaction > bound) {
    r["verdict"] = "fail";
    r["reason"] = fmt::format(
        "it travelled {:.3f} {} before LinuxCNC disabled the drive, more than the {:.3f} {} the "
        "machine has past its soft limits",
        reaction, s.units, bound, s.units);
  } else {
    r["verdict"] = "pass";
  }
  // The joint is homed again where its position was lost (by the next
  // check's Session::ready).
  if (f.rehome) s.driver.ask({{"op", "unhome"}, {"joint", j.joint}});
  return r;
}

}  // namespace

void runaway(Session& s, Results& out) {
  for (const auto& j : s.joints) {
    if (j.axis.empty() || !s.wanted(fmt::format("runaway.{}", j.axis))) continue;
    if (!j.servo) {
      out.push_back({{"id", fmt::format("runaway.{}", j.axis)},
                     {"check", "runaway"},
                     {"title", fmt::format("{}: runaway", upper(j.axis))},
                     {"verdict", "not applicable"},
                     {"reason", "a stepper joint: it goes where its steps say, with no encoder closing its loop"},
                     {"cites", kRunawayCites},
                     {"figures", json::object()}});
      continue;
    }
    for (const auto& f : runawayFaults(j))
      for (const bool moving : {false, true})
        if (s.wanted(fmt::format("runaway.{}.{}.{}", j.axis, f.key, moving ? "moving" : "holding")))
          out.push_back(runawayCase(s, j, f, moving));
  }
}

namespace {

// The machine's E-stop inputs: the switches in iocontrol.0.emc-enable-in's
// chain.
std::vector<const model::machine::SwitchParameters*> estopSwitches(const Session& s) {
  std::vector<const model::machine::SwitchParameters*> chain;
  for (const auto& sw : s.machine.switches)
    if (sw.kind == model::machine::SwitchKind::Estop) chain.push_back(&sw);
  return chain;
}

// What LinuxCNC said since the driver had `before` messages.
std::vector<std::string> saidSince(const Driver& d, std::size_t before) {
  return {d.messages().begin() + static_cast<std::ptrdiff_t>(before), d.messages().end()};
}

}  // namespace

void estopChain(Session& s, Results& out) {
  const char* cites =
      "7I77 manual, SERVO ENABLE OUTPUTS and the introduction (never depend on software commands to disable a "
      "motor); LinuxCNC iocontrol.0.emc-enable-in: the E-stop chain's input";
  const auto chain = estopSwitches(s);
  if (chain.empty()) {
    out.push_back({{"id", "estop"},
                   {"check", "estop"},
                   {"title", "E-stop chain"},
                   {"verdict", "fail"},
                   {"reason",
                    "no field input reaches iocontrol.0.emc-enable-in: nothing outside the software stops "
                    "the machine"},
                   {"cites", cites},
                   {"figures", json::object()}});
    return;
  }
  // The motion: the first servo joint (else the first joint) across its travel.
  const Joint* mover = nullptr;
  for (const auto& j : s.joints)
    if (!j.axis.empty() && (mover == nullptr || (j.servo && !mover->servo))) mover = &j;
  if (mover == nullptr) return;
  for (const auto* sw : chain) {
    if (!s.wanted("estop." + sw->name)) continue;
    json r = {{"id", "estop." + sw->name},
              {"check", "estop"},
              {"title", fmt::format("E-stop: {} (field input {}) opened while {} moves at MAX_VELOCITY", sw->name,
                                    sw->input, upper(mover->axis))},
              {"cites", cites},
              {"reason", ""}};
    s.ready();
    if (const auto why = makeMotion(s, *mover, true); !why.empty()) {
      r["verdict"] = "fail";
      r["reason"] = why;
      r["figures"] = json::object();
      out.push_back(r);
      continue;
    }
    const double t0 = s.api.post("/api/machine", {{"action", "switch"}, {"name", sw->name}, {"tripped", true}})
                          .at("time_s")
                          .get<double>();
    const auto off = s.driver.ask({{"op", "wait_off"}, {"timeout", 2}});
    const auto after = atRest(s, *mover);
    const auto status = s.driver.ask({{"op", "status"}});
    const auto t = s.trace(t0 - 0.2);
    const double p0 = positionAt(t, mover->axis, t0);  // where it was when the input opened
    // Every drive's ENA, from the machine's trace.
    double allOff = -1;
    bool everyDrive = true;
    for (const auto& j : s.joints) {
      if (!j.servo) continue;
      const double at = disabledAt(t, j.axis, t0);
      if (at < 0) everyDrive = false;
      allOff = std::max(allOff, at);
    }
    bool enaOff = true;
    for (const auto& a : after.at("axes"))
      for (const auto& d : a.at("drives")) enaOff = enaOff && !d.at("ena").get<bool>();
    const auto refused = s.driver.ask({{"op", "machine_on"}, {"timeout", 1}});
    s.api.post("/api/machine", {{"action", "switch"}, {"name", sw->name}, {"tripped", false}});
    const auto again = s.driver.ask({{"op", "machine_on"}});
    const double p1 = axisOf(after, mover->axis).at("position").get<double>();
    const double reaction =
        everyDrive && allOff >= 0 ? std::abs(positionAt(t, mover->axis, allOff) - p0) : std::abs(p1 - p0);
    r["figures"] = {{"time_to_ena_off_s", everyDrive && allOff >= 0 ? json(round3(allOff - t0)) : json(nullptr)},
                    {"distance_to_disable", round3(reaction)},
                    {"distance", round3(std::abs(p1 - p0))},
                    {"bound", round3(mover->room())},
                    {"machine_on_refused_while_open", !refused.value("ok", false)},
                    {"machine_on_after_release", again.value("ok", false)}};
    json events = json::array({{{"t", 0.0}, {"what", sw->name + " opened"}}});
    if (allOff >= 0) events.push_back({{"t", round3(allOff - t0)}, {"what", "ENA off"}});
    r["plot"] = plotOf(t, mover->axis, t0, events);
    r["plot"]["units"] = {{"command", s.units}, {"position", s.units}, {"following_error", s.units}, {"enabled", ""}};
    r["linuxcnc_said"] = off.value("messages", json::array());
    if (!off.value("ok", false) || status.value("task_state", 0) != kStateEstop) {
      r["verdict"] = "fail";
      r["reason"] = fmt::format("LinuxCNC did not go to E-stop when {} opened", sw->name);
    } else if (!enaOff) {
      r["verdict"] = "fail";
      r["reason"] = "a drive's ENA stayed on";
    } else if (refused.value("ok", false)) {
      r["verdict"] = "fail";
      r["reason"] = "Machine On was taken while the chain was open";
    } else if (reaction > mover->room()) {
      r["verdict"] = "fail";
      r["reason"] = fmt::format(
          "it travelled {:.3f} {} before ENA dropped, more than the {:.3f} {} the machine has "
          "past its soft limits",
          reaction, s.units, mover->room(), s.units);
    } else {
      r["verdict"] = "pass";
    }
    out.push_back(r);
  }
}

namespace {

const char* kLimitsCites =
    "LinuxCNC [JOINT_n]MIN_LIMIT/MAX_LIMIT (soft limits), HOME and HOME_OFFSET (where homing leaves the joint), "
    "joint.N.neg-lim-sw-in/pos-lim-sw-in (the limit switches that stop it); 7I77 manual, FIELD I/O: the "
    "inputs they are wired to";

json result(const std::string& id, const std::string& check, const std::string& title, const char* cites) {
  return {{"id", id},       {"check", check}, {"title", title},
          {"cites", cites}, {"reason", ""},   {"figures", json::object()}};
}

// G53 G0 of joint `j` to `to`, by MDI: whether LinuxCNC refused it (its
// commanded position stayed on this side of the limit).
json softLimitCase(Session& s, const Joint& j, bool max) {
  const std::string L(1, j.letter);
  const double span = j.maxLimit - j.minLimit;
  const double margin = std::max(span * 0.01, 10 * j.count);
  const double target = max ? j.maxLimit + margin : j.minLimit - margin;
  const double limit = max ? j.maxLimit : j.minLimit;
  const auto before = s.driver.messages().size();
  s.driver.ask({{"op", "mdi"}, {"command", fmt::format("G53 G0 {}{:.4f}", L, target)}, {"timeout", 10}});
  const auto st = s.driver.ask({{"op", "status"}});
  const double commanded = st.at("commanded").at(j.joint).get<double>();
  const bool beyond = max ? commanded > limit + 1e-6 : commanded < limit - 1e-6;
  const auto said = saidSince(s.driver, before);
  s.driver.ask({{"op", "abort"}});
  return {{"target", round3(target)}, {"commanded", round3(commanded)}, {"refused", !beyond}, {"said", said}};
}

json homeCase(Session& s, const Joint& j) {
  json r = result(fmt::format("limits.{}.home", j.axis), "limits",
                  fmt::format("{}: homing lands where HOME and HOME_OFFSET say", upper(j.axis)), kLimitsCites);
  s.ready();
  const auto m = atRest(s, j);
  const auto st = s.driver.ask({{"op", "status"}});
  const double linuxcnc = st.at("feedback").at(j.joint).get<double>();
  const double machine = axisOf(m, j.axis).at("position").get<double>();
  const double tolerance = j.count > 0 ? j.count : 0.001;
  const double diff = std::abs(linuxcnc - machine);
  r["figures"] = {{"linuxcnc_position", round3(linuxcnc)},
                  {"machine_position", round3(machine)},
                  {"difference", std::round(diff * 1e6) / 1e6},
                  {"one_count", tolerance},
                  {"home", j.home}};
  if (diff > tolerance + 1e-9) {
    r["verdict"] = "fail";
    r["reason"] = fmt::format(
        "LinuxCNC has the joint at {:.4f} {} where the machine is at {:.4f}: {:.4f} {} apart, more than one count "
        "({:g} {}{})",
        linuxcnc, s.units, machine, diff, s.units, tolerance, s.units, j.count > 0 ? "" : ", the INI giving no scale");
  } else {
    r["verdict"] = "pass";
  }
  return r;
}

json softLimitsCase(Session& s, const Joint& j) {
  json r = result(fmt::format("limits.{}.soft", j.axis), "limits",
                  fmt::format("{}: MDI past the soft limits is refused", upper(j.axis)), kLimitsCites);
  s.ready();
  const auto high = softLimitCase(s, j, true);
  s.ready();
  const auto low = softLimitCase(s, j, false);
  r["figures"] = {{"max_limit", j.maxLimit},
                  {"min_limit", j.minLimit},
                  {"asked_past_max", high.at("target")},
                  {"asked_past_min", low.at("target")},
                  {"refused_past_max", high.at("refused")},
                  {"refused_past_min", low.at("refused")}};
  json said = high.at("said");
  for (const auto& m : low.at("said")) said.push_back(m);
  r["linuxcnc_said"] = said;
  if (!high.at("refused").get<bool>() || !low.at("refused").get<bool>()) {
    r["verdict"] = "fail";
    r["reason"] = fmt::format("LinuxCNC took a G53 G0 to {:.4f} {}, past its {} limit",
                              (high.at("refused").get<bool>() ? low : high).at("target").get<double>(), s.units,
                              high.at("refused").get<bool>() ? "MIN_LIMIT" : "MAX_LIMIT");
  } else {
    r["verdict"] = "pass";
  }
  return r;
}

// Joint `j` jogged, unhomed (no soft limits then), into limit switch `sw`
// at the jog speed AXIS starts with ([DISPLAY]DEFAULT_LINEAR_VELOCITY, at
// most the joint's MAX_VELOCITY; a tenth of that without one).
json limitSwitchCase(Session& s, const Joint& j, const model::machine::SwitchParameters& sw) {
  const bool up = sw.kind == model::machine::SwitchKind::MaxLimit;
  const double speed = s.jogVelocity > 0 ? std::min(s.jogVelocity, j.maxVelocity) : j.maxVelocity / 10;
  json r = result(fmt::format("limits.{}.{}", j.axis, sw.name), "limits",
                  fmt::format("{}: jogged at {:g} {}/s into its {} limit switch {} (field input {})", upper(j.axis),
                              speed, s.units, up ? "positive" : "negative", sw.name, sw.input),
                  kLimitsCites);
  s.ready();
  const double span = j.maxLimit - j.minLimit;
  s.mdi(fmt::format("G53 G0 {}{:.4f}", std::string(1, j.letter), j.minLimit + span / 2));
  s.driver.ask({{"op", "unhome"}, {"joint", j.joint}});
  const auto before = s.machineState();
  const double p0 = axisOf(before, j.axis).at("position").get<double>();
  const double t0 = before.at("time_s").get<double>();
  const double stop = up ? j.hardStopMax : j.hardStopMin;
  const double timeout = std::abs(stop - p0) / std::max(speed, 1e-6) + 3.0;
  const auto jog =
      s.driver.ask({{"op", "jog"}, {"joint", j.joint}, {"velocity", (up ? 1 : -1) * speed}, {"timeout", timeout}},
                   std::chrono::milliseconds(static_cast<long>(timeout * 1000) + 30000));
  const auto after = atRest(s, j);
  const auto t = s.trace(t0);
  const double p1 = axisOf(after, j.axis).at("position").get<double>();
  const bool hit = axisOf(after, j.axis).at("at_hard_stop").get<bool>();
  // When the switch tripped: the first row at or past its position.
  double tripped = -1;
  const auto& ts = t.column("time_s");
  const auto& ps = t.column(j.axis + "_position");
  for (std::size_t i = 0; i < ts.size() && tripped < 0; ++i)
    if (up ? ps[i] >= sw.position : ps[i] <= sw.position) tripped = ts[i];
  const double past = up ? p1 - sw.position : sw.position - p1;
  const double room = up ? j.hardStopMax - sw.position : sw.position - j.hardStopMin;
  const bool seen = jog.value("limit", 0) != 0 || jog.value("task_state", 0) != 4;  // linuxcnc.STATE_ON
  r["figures"] = {{"jog_velocity", speed},
                  {"distance_past_switch", round3(std::max(0.0, past))},
                  {"room_past_switch", round3(room)},
                  {"peak_velocity", round3(peakSpeed(t, j.axis, t0))},
                  {"linuxcnc_limit_mask", jog.value("limit", 0)},
                  {"hit_hard_stop", hit}};
  if (tripped >= 0) {
    r["plot"] = plotOf(t, j.axis, tripped, json::array({{{"t", 0.0}, {"what", sw.name + " tripped"}}}));
    r["plot"]["units"] = {{"command", s.units}, {"position", s.units}, {"following_error", s.units}, {"enabled", ""}};
  }
  r["linuxcnc_said"] = jog.value("messages", json::array());
  if (tripped < 0) {
    r["verdict"] = "fail";
    r["reason"] =
        fmt::format("the axis never reached the switch at {:.4f} {} (it stopped at {:.4f})", sw.position, s.units, p1);
  } else if (hit) {
    r["verdict"] = "fail";
    r["reason"] = "the axis ran through the switch into its hard stop";
  } else if (!seen) {
    r["verdict"] = "fail";
    r["reason"] = fmt::format("LinuxCNC did not see the switch: the jog ran on {:.3f} {} past it", past, s.units);
  } else {
    r["verdict"] = "pass";
  }
  // Off the switch as an operator gets off it, and homed again by the
  // next check (the joint was unhomed for the jog).
  const auto off = s.driver.ask(
      {{"op", "jog_off_limit"}, {"joint", j.joint}, {"velocity", (up ? -1 : 1) * speed / 2}, {"timeout", 10}});
  if (!off.value("ok", false))
    throw lbpkit::Error(
        fmt::format("could not jog {} off its limit switch {}: {}", upper(j.axis), sw.name, off.dump()));
  return r;
}

}  // namespace

void limits(Session& s, Results& out) {
  for (const auto& j : s.joints) {
    if (j.axis.empty()) continue;
    if (s.wanted(fmt::format("limits.{}.home", j.axis))) out.push_back(homeCase(s, j));
    if (s.wanted(fmt::format("limits.{}.soft", j.axis))) out.push_back(softLimitsCase(s, j));
    for (const auto& sw : s.machine.switches) {
      if (sw.axis != j.axis ||
          (sw.kind != model::machine::SwitchKind::MinLimit && sw.kind != model::machine::SwitchKind::MaxLimit))
        continue;
      if (s.wanted(fmt::format("limits.{}.{}", j.axis, sw.name))) out.push_back(limitSwitchCase(s, j, sw));
    }
  }
}

std::vector<std::string> Session::boards() const {
  std::vector<std::string> out;
  constexpr std::string_view kWatchdog = ".watchdog.timeout_ns";
  for (const auto& p : watchdogParameters)
    if (p.size() > kWatchdog.size() && p.ends_with(kWatchdog)) out.push_back(p.substr(0, p.size() - kWatchdog.size()));
  return out;
}

namespace {

// Every smart-serial port of the run's cards stopped and started again
// through its run pin (hostmot2: NAME.sserial.port-N.run), as an operator
// recovers a port hostmot2 stopped, and waited for until running: whether
// every port came back.
bool restartSmartSerial(Session& s) {
  bool all = true;
  for (const auto& board : s.boards())
    for (int port = 0; port < 4; ++port) {
      const auto run = fmt::format("{}.sserial.port-{}.run", board, port);
      if (!s.driver.ask({{"op", "setp"}, {"name", run}, {"value", 0}}).value("ok", false)) continue;
      std::this_thread::sleep_for(100ms);
      s.driver.ask({{"op", "setp"}, {"name", run}, {"value", 1}});
      all = s.driver
                .ask({{"op", "wait_pin"},
                      {"name", fmt::format("{}.sserial.port-{}.port_state", board, port)},
                      {"value", 3},
                      {"timeout", 5}})
                .value("ok", false) &&
            all;
    }
  return all;
}

}  // namespace

void fieldPower(Session& s, Results& out) {
  const char* cites =
      "7I77 manual, FIELD POWER and FIELD I/O: the field inputs and outputs run from field power; without it the "
      "inputs read off and the outputs are dead";
  const auto state = s.api.get("/api/state");
  for (std::size_t d = 0; d < state.at("daughtercards").size(); ++d) {
    const auto& card = state["daughtercards"][d];
    if (!card.contains("field_io")) continue;
    const std::string id = fmt::format("field.{}", d);
    if (!s.wanted(id)) continue;
    json r = result(id, "field", fmt::format("Field power of daughtercard {} lost for 1 s, then restored", d), cites);
    s.ready();
    const double volts = card["field_io"].value("field_voltage", 24.0);
    const json at = card.contains("connector") ? json{{"connector", card["connector"]}} : json::object();
    json off = at, on = at;
    off["volts"] = 0.0;
    on["volts"] = volts;
    const auto before = s.driver.messages().size();
    s.api.post("/api/field", off);
    const auto taken = s.driver.ask({{"op", "wait_off"}, {"timeout", 1}});
    const auto st = s.driver.ask({{"op", "status"}});
    s.api.post("/api/field", on);
    const auto said = saidSince(s.driver, before);
    // The 7I77's field I/O processor runs from VIN, normally field power
    // (manual: VIN AND FIELD POWER SUPPLY): without it the processor is
    // silent and hostmot2 may have stopped the smart-serial port. Started
    // again as an operator would, through its run pin, for the checks after.
    bool stopped = false;
    for (const auto& m : said) stopped = stopped || m.find("will be stopped") != std::string::npos;
    const bool restarted = stopped && restartSmartSerial(s);
    const int task = st.value("task_state", 0);
    const std::string did = task == kStateEstop        ? "went to E-stop"
                            : taken.value("ok", false) ? "turned the machine off"
                                                       : "did nothing: the machine stayed on";
    r["figures"] = {{"field_volts", volts},
                    {"linuxcnc_did", did},
                    {"smart_serial_port_stopped", stopped},
                    {"smart_serial_port_restarted", restarted},
                    {"time_to_react_s", taken.value("ok", false) ? json(taken.value("after_s", 0.0)) : json(nullptr)}};
    r["linuxcnc_said"] = said;
    if (taken.value("ok", false)) {
      r["verdict"] = "pass";
    } else {
      r["verdict"] = "fail";
      r["reason"] = stopped
                        ? "LinuxCNC ran on with field power gone: the 7I77's field I/O processor fell silent, hostmot2 "
                          "stopped its smart-serial port (its inputs, the E-stop's among them, then stand where they "
                          "were), and nothing in the configuration took the machine off"
                        : "LinuxCNC ran on with field power gone: every field input read off and every field output "
                          "was dead, and nothing in the configuration took the machine off";
    }
    out.push_back(r);
  }
}

void spindle(Session& s, Results& out) {
  const char* cites =
      "LinuxCNC spindle.0.at-speed (motion waits for it before cutting), spindle.0.on and the E-stop chain; 7I77 "
      "manual, SPINDLE INTERFACE (AOUT5, ENA5 from SpinEna)";
  if (!s.machine.spindle) {
    if (s.wanted("spindle")) {
      json r = result("spindle", "spindle", "Spindle", cites);
      r["verdict"] = "not applicable";
      r["reason"] = "the machine has no spindle";
      out.push_back(r);
    }
    return;
  }
  // Half the lower of the VFD's top speed and the configuration's.
  const double top =
      s.spindleMaxRpm > 0 ? std::min(s.spindleMaxRpm, s.machine.spindle->vfd.maxRpm) : s.machine.spindle->vfd.maxRpm;
  const double rpm = std::max(100.0, std::round(top / 2));
  if (s.wanted("spindle.at-speed")) {
    json r = result("spindle.at-speed", "spindle", fmt::format("Spindle: M3 S{:g} reaches its speed", rpm), cites);
    s.ready();
    const double t0 = s.machineState().at("time_s").get<double>();
    s.driver.ask({{"op", "spindle"}, {"rpm", rpm}});
    const auto at =
        s.driver.ask({{"op", "wait_pin"}, {"name", "spindle.0.at-speed"}, {"value", true}, {"timeout", 20}});
    const auto m = s.machineState();
    const double actual = m.at("spindle").is_null() ? 0.0 : m["spindle"].value("rpm", 0.0);
    r["figures"] = {
        {"commanded_rpm", rpm},
        {"rpm_at_at_speed", std::round(actual)},
        {"time_to_at_speed_s", at.value("ok", false) ? json(round3(m.at("time_s").get<double>() - t0)) : json(nullptr)},
        {"error_percent", std::round(std::abs(actual - rpm) / rpm * 1000) / 10}};
    if (!at.value("ok", false)) {
      r["verdict"] = "fail";
      r["reason"] = "spindle.0.at-speed never came within 20 s: LinuxCNC would wait before every cut";
    } else if (std::abs(actual - rpm) > 0.1 * rpm) {
      r["verdict"] = "fail";
      r["reason"] = fmt::format("spindle.0.at-speed came at {:.0f} rpm of the {:g} asked for", actual, rpm);
    } else {
      r["verdict"] = "pass";
    }
    out.push_back(r);
  }
  const auto chain = estopSwitches(s);
  if (chain.empty() || !s.wanted("spindle.estop")) return;
  json r = result(
      "spindle.estop", "spindle",
      fmt::format("Spindle: E-stop ({}) while it runs at {:g} rpm drops its enable", chain.front()->name, rpm), cites);
  s.ready();
  s.driver.ask({{"op", "spindle"}, {"rpm", rpm}});
  s.driver.ask({{"op", "wait_pin"}, {"name", "spindle.0.at-speed"}, {"value", true}, {"timeout", 20}});
  const double t0 = s.api.post("/api/machine", {{"action", "switch"}, {"name", chain.front()->name}, {"tripped", true}})
                        .at("time_s")
                        .get<double>();
  s.driver.ask({{"op", "wait_off"}, {"timeout", 2}});
  // The VFD's run input (ENA5, or the 7I76's SpinEna): when the machine's
  // spindle stopped being driven.
  double stoppedAt = -1;
  const auto end = std::chrono::steady_clock::now() + 3s;
  while (std::chrono::steady_clock::now() < end) {
    const auto m = s.machineState();
    if (!m.at("spindle").value("running", true)) {
      stoppedAt = m.at("time_s").get<double>();
      break;
    }
    std::this_thread::sleep_for(5ms);
  }
  s.api.post("/api/machine", {{"action", "switch"}, {"name", chain.front()->name}, {"tripped", false}});
  s.driver.ask({{"op", "machine_on"}});
  s.driver.ask({{"op", "spindle"}, {"rpm", 0}});
  r["figures"] = {{"time_to_enable_off_s", stoppedAt >= 0 ? json(round3(stoppedAt - t0)) : json(nullptr)}};
  if (stoppedAt < 0) {
    r["verdict"] = "fail";
    r["reason"] = "the spindle was still driven 3 s after the E-stop opened";
  } else {
    r["verdict"] = "pass";
  }
  out.push_back(r);
}

namespace {

// The host lost while an axis moves at MAX_VELOCITY: `lose` stops it (and
// says how, for the title), `restore` ends that once the watchdogs have
// been watched.
void losingTheHost(Session& s, Results& out, const std::string& id, const std::string& how,
                   const std::function<void()>& lose, const std::function<void()>& restore) {
  const char* cites =
      "7I77 manual, ANALOG SECTION WATCHDOG and SERVO ENABLE OUTPUTS: a host that stops talking makes the analog "
      "outputs 0 V and drops ENA; LinuxCNC hostmot2 NAME.watchdog.timeout_ns: the FPGA card's own watchdog";
  // The axis that moves: a stepper's where the machine has one (its StepGen
  // steps on at its last rate until the FPGA card's own watchdog stops it:
  // the setting the configuration makes), else a servo axis (the 7I77's
  // watchdog drops its ENA and makes its analog output 0 V).
  const Joint* mover = nullptr;
  for (const auto& j : s.joints)
    if (!j.axis.empty() && (mover == nullptr || (!j.servo && mover->servo))) mover = &j;
  if (mover == nullptr) return;
  json r = {{"id", id},
            {"check", "host"},
            {"title", fmt::format("Losing the host: {} while {} moves at MAX_VELOCITY", how, upper(mover->axis))},
            {"cites", cites},
            {"reason", ""}};
  s.ready();
  // The configuration's own hm2 watchdog, in place of lbpkit linuxcnc's
  // 500 ms for a servo thread that runs late on this PC: the host stops
  // for good here, and the card then meets the watchdog the user wrote
  // (hostmot2's 5 ms when the configuration sets none).
  const long watchdogNs = s.configuredWatchdogNs.value_or(5'000'000);
  for (const auto& p : s.watchdogParameters) s.driver.ask({{"op", "setp"}, {"name", p}, {"value", watchdogNs}});
  if (const auto why = makeMotion(s, *mover, true); !why.empty()) {
    r["verdict"] = "fail";
    r["reason"] = why;
    r["figures"] = json::object();
    out.push_back(r);
    return;
  }
  bool outputsWereOn = false;
  auto outputsOn = [](const json& state) {
    bool on = false;
    for (const auto& d : state.at("daughtercards"))
      if (d.contains("field_io"))
        for (const auto& o : d["field_io"].at("outputs")) on = on || o.at("on").get<bool>();
    return on;
  };
  const auto state = s.api.get("/api/state");
  outputsWereOn = outputsOn(state);
  json sevenI77Watchdog = nullptr;
  for (const auto& d : state.at("daughtercards"))
    if (d.contains("field_io") && d["field_io"].contains("watchdog_ms") && sevenI77Watchdog.is_null())
      sevenI77Watchdog = d["field_io"]["watchdog_ms"].get<double>() / 1000.0;
  // The last look before the host is lost: the times and the travel count
  // from here.
  const auto before = s.machineState();
  const double p0 = axisOf(before, mover->axis).at("position").get<double>();
  const double tStop = before.at("time_s").get<double>();
  const auto stopped = std::chrono::steady_clock::now();
  lose();
  double enaOff = -1, zeroVolts = -1, outputsOff = -1, enaOffAt = -1, stepsStopped = mover->servo ? 0 : -1;
  while (std::chrono::steady_clock::now() - stopped < 5s &&
         (enaOff < 0 || zeroVolts < 0 || outputsOff < 0 || stepsStopped < 0)) {
    const auto m = s.machineState();
    // The machine's own time: once the host is silent the sim's clock is
    // the wall clock again, counted from the host's last cycle
    // (docs/clocks.md), so this is when the 7I77 saw it.
    const double now = m.at("time_s").get<double>() - tStop;
    bool anyEna = false, anyVolts = false;
    for (const auto& a : m.at("axes"))
      for (const auto& d : a.at("drives")) {
        anyEna = anyEna || d.at("ena").get<bool>();
        anyVolts = anyVolts || std::abs(d.at("command_volts").get<double>()) > 0.01;
      }
    if (!anyEna && enaOff < 0) {
      // When the 7I77 dropped it, as the machine met it (the last drive's).
      double changed = 0;
      for (const auto& a : m.at("axes"))
        for (const auto& d : a.at("drives")) changed = std::max(changed, d.at("ena_changed_s").get<double>());
      enaOff = changed - tStop;
      enaOffAt = changed;
    }
    // The analog watchdog makes the outputs 0 V as it drops ENA (manual:
    // ANALOG SECTION WATCHDOG): seen together, that time; else when seen.
    if (stepsStopped < 0 && std::abs(axisOf(m, mover->axis).at("velocity").get<double>()) < 1e-6) stepsStopped = now;
    if (!anyVolts && zeroVolts < 0) zeroVolts = !anyEna && enaOffAt >= 0 && enaOff >= 0 ? enaOff : now;
    if (outputsOff < 0 && (!outputsWereOn || !outputsOn(s.api.get("/api/state")))) outputsOff = outputsWereOn ? now : 0;
    std::this_thread::sleep_for(2ms);
  }
  const auto after = atRest(s, *mover);
  const double p1 = axisOf(after, mover->axis).at("position").get<double>();
  const bool hit = axisOf(after, mover->axis).at("at_hard_stop").get<bool>();
  restore();
  const double distance = std::abs(p1 - p0);
  // Until ENA drops the drive holds the speed its last command asked for
  // (the host's last AOUT stands): the axis runs on at the speed it had.
  const double v0 = std::abs(axisOf(before, mover->axis).at("velocity").get<double>());
  // How long a stepper stepped on: its travel at the speed it had. The
  // poll above meets the host's silence only once the sim's clock has
  // taken it for one (40 ms: docs/clocks.md), too late to time the stop.
  if (!mover->servo && stepsStopped >= 0 && v0 > 0) stepsStopped = distance / v0;
  // A stepper stops where its last step puts it: all of its travel is the
  // StepGen's.
  const double reaction = !mover->servo ? distance : enaOff >= 0 ? v0 * enaOff : distance;
  r["figures"] = {
      {"time_to_ena_off_s", enaOff >= 0 ? json(round3(enaOff)) : json(nullptr)},
      {"time_to_zero_volts_s", zeroVolts >= 0 ? json(round3(zeroVolts)) : json(nullptr)},
      {"time_to_outputs_off_s", outputsWereOn && outputsOff >= 0 ? json(round3(outputsOff)) : json(nullptr)},
      {"time_to_steps_stopped_s", !mover->servo && stepsStopped >= 0 ? json(round3(stepsStopped)) : json(nullptr)},
      {"hm2_watchdog_s", static_cast<double>(watchdogNs) / 1e9},
      {"seven_i77_watchdog_s", sevenI77Watchdog},
      {"distance_to_disable", round3(reaction)},
      {"distance", round3(distance)},
      {"bound", round3(mover->room())},
      {"hit_hard_stop", hit}};
  if ((mover->servo && (enaOff < 0 || zeroVolts < 0)) || stepsStopped < 0) {
    r["verdict"] = "fail";
    r["reason"] = mover->servo ? "the drives were still enabled or commanded 5 s after the host stopped"
                               : "the StepGen was still stepping 5 s after the host stopped";
  } else if (hit) {
    r["verdict"] = "fail";
    r["reason"] = "the axis hit its hard stop before the watchdogs stopped it";
  } else if (reaction > mover->room()) {
    r["verdict"] = "fail";
    r["reason"] = fmt::format(
        "it ran {:.3f} {} after the host stopped before {}, more than the {:.3f} {} the "
        "machine has past its soft limits",
        reaction, s.units, mover->servo ? "ENA dropped" : "its StepGen stopped", mover->room(), s.units);
  } else {
    r["verdict"] = "pass";
  }
  out.push_back(r);
}

}  // namespace

void networkCut(Session& s, Results& out) {
  // The network cut for 2 s, far over the 7I77's watchdog: the sim's
  // cable out (POST /api/network {"silent_ms": 2000}), every datagram
  // either way lost, LinuxCNC running on.
  if (!s.wanted("host.network")) return;
  losingTheHost(
      s, out, "host.network", "the network cut for 2 s",
      [&] {
        s.api.post("/api/network", {{"silent_ms", 2000}});
      },
      [&] {
        s.api.post("/api/network", {{"silent_ms", 0}});
      });
}

void losingTheHost(Session& s, Results& out) {
  if (!s.wanted("host.stopped")) return;
  // LinuxCNC's real-time part: the rtapi_app of the run's namespace.
  // Stopped, not killed: to the card the same silence, and LinuxCNC's other
  // parts stay to be shut down in order afterwards.
  struct stat ns {};
  if (::stat(("/run/netns/" + s.networkNamespace).c_str(), &ns) != 0)
    throw lbpkit::Error("the run's network namespace is gone");
  pid_t rtapi = -1;
  lbpkit::linuxcnc::forEachProcessIn(static_cast<unsigned long>(ns.st_ino), [&](const std::filesystem::path& proc) {
    if (lbpkit::linuxcnc::commandOf(proc) == "rtapi_app") rtapi = std::stoi(proc.filename().string());
  });
  if (rtapi <= 0) throw lbpkit::Error("LinuxCNC's rtapi_app is not running");
  losingTheHost(
      s, out, "host.stopped", "LinuxCNC's real-time part stops", [rtapi] { ::kill(rtapi, SIGSTOP); },
      [rtapi] { ::kill(rtapi, SIGCONT); });
}

}  // namespace lbpkit::app::rehearse
