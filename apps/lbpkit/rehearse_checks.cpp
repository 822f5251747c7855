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
// whose enable does nothing), when its analog command first reads 0 V
// instead: what disables such a drive.
double disabledAt(const Trace& t, const std::string& axis, double t0, bool atZeroVolts = false) {
  const auto column = axis + (atZeroVolts ? "_command_volts" : "_enabled");
  if (!t.has(column)) return -1;
  const auto& ts = t.column("time_s");
  const auto& v = t.column(column);
  for (std::size_t i = 0; i < ts.size(); ++i)
    if (ts[i] >= t0 && (atZeroVolts ? std::abs(v[i]) < 1e-3 : v[i] < 0.5)) return ts[i];
  return -1;
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
  const auto before = s.machineState();
  const double p0 = axisOf(before, j.axis).at("position").get<double>();
  double t0 = 0;
  for (const auto& action : f.inject) t0 = s.api.post("/api/machine", action).at("time_s").get<double>();
  const auto off = s.driver.ask({{"op", "wait_off"}, {"timeout", kWatchSeconds}});
  // A runaway LinuxCNC did not see is stopped here, as the operator's
  // Machine Off would: the drives' enables drop and the axis coasts.
  if (!off.value("ok", false)) s.driver.ask({{"op", "machine_off"}});
  const auto after = atRest(s, j);
  const auto t = s.trace(t0 - 0.2);
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

void estopChain(Session& s, Results& out) {
  const char* cites =
      "7I77 manual, SERVO ENABLE OUTPUTS and the introduction (never depend on software commands to disable a "
      "motor); LinuxCNC iocontrol.0.emc-enable-in: the E-stop chain's input";
  std::vector<const model::machine::SwitchParameters*> chain;
  for (const auto& sw : s.machine.switches)
    if (sw.kind == model::machine::SwitchKind::Estop) chain.push_back(&sw);
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
    const double p0 = axisOf(s.machineState(), mover->axis).at("position").get<double>();
    const double t0 = s.api.post("/api/machine", {{"action", "switch"}, {"name", sw->name}, {"tripped", true}})
                          .at("time_s")
                          .get<double>();
    const auto off = s.driver.ask({{"op", "wait_off"}, {"timeout", 2}});
    const auto after = atRest(s, *mover);
    const auto status = s.driver.ask({{"op", "status"}});
    const auto t = s.trace(t0 - 0.2);
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

void losingTheHost(Session& s, Results& out) {
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
  json r = {{"id", "host.stopped"},
            {"check", "host"},
            {"title", fmt::format("Losing the host: LinuxCNC's real-time part stops while {} moves at MAX_VELOCITY",
                                  upper(mover->axis))},
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
  // LinuxCNC's real-time part: the rtapi_app of the run's namespace.
  struct stat ns {};
  if (::stat(("/run/netns/" + s.networkNamespace).c_str(), &ns) != 0)
    throw lbpkit::Error("the run's network namespace is gone");
  pid_t rtapi = -1;
  lbpkit::linuxcnc::forEachProcessIn(static_cast<unsigned long>(ns.st_ino), [&](const std::filesystem::path& proc) {
    if (lbpkit::linuxcnc::commandOf(proc) == "rtapi_app") rtapi = std::stoi(proc.filename().string());
  });
  if (rtapi <= 0) throw lbpkit::Error("LinuxCNC's rtapi_app is not running");
  const auto before = s.machineState();
  const double p0 = axisOf(before, mover->axis).at("position").get<double>();
  const double tStop = before.at("time_s").get<double>();
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
  // Stopped, not killed: to the card the same silence, and LinuxCNC's other
  // parts stay to be shut down in order afterwards.
  const auto stopped = std::chrono::steady_clock::now();
  ::kill(rtapi, SIGSTOP);
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
  ::kill(rtapi, SIGCONT);
  const double distance = std::abs(p1 - p0);
  // Until ENA drops the drive holds the speed its last command asked for
  // (the host's last AOUT stands): the axis runs on at the speed it had.
  const double v0 = std::abs(axisOf(before, mover->axis).at("velocity").get<double>());
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

}  // namespace lbpkit::app::rehearse
