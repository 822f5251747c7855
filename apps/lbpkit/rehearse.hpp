// SPDX-License-Identifier: MIT
// lbpkit rehearse: a user's LinuxCNC configuration, run as `lbpkit linuxcnc`
// runs it, through the failures the 7I77 manual warns about before power
// goes to the motors (docs/rehearse.md). What the checks share: the driver
// inside LinuxCNC (rehearse_driver.py, LinuxCNC's display), the sim's
// control API (where every fault is made, as a user would make it), the
// machine the configuration expects, and each joint as LinuxCNC's INI gives
// it.
#pragma once

#include <sys/types.h>

#include <chrono>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "machine/machine_file.hpp"

namespace lbpkit::app::rehearse {

using json = nlohmann::json;

// The driver in LinuxCNC, over two FIFOs: a JSON request a line, a JSON
// answer a line (rehearse_driver.py says which requests there are).
class Driver {
 public:
  // `requests` and `answers`: our ends of the FIFOs; `run`: the `lbpkit
  // linuxcnc` whose LinuxCNC runs the driver (an answer never comes once it
  // has ended).
  Driver(int requests, int answers, pid_t run) : requests_(requests), answers_(answers), run_(run) {}
  // Sends `request`, waits for its answer. Throws lbpkit::Error when none
  // comes within `timeout`, or the run ended; an answer that is not "ok"
  // is returned as it is.
  json ask(const json& request, std::chrono::milliseconds timeout = std::chrono::seconds(120));
  // The first line the driver writes once LinuxCNC has started it.
  json greeting(std::chrono::milliseconds timeout);
  // What LinuxCNC said since the rehearsal began (every answer's "messages").
  [[nodiscard]] const std::vector<std::string>& messages() const { return messages_; }
  // Set when the run was seen to end (its wait status).
  [[nodiscard]] std::optional<int> ended() const { return ended_; }

 private:
  json readAnswer(std::chrono::milliseconds timeout, const std::string& what);
  int requests_, answers_;
  pid_t run_;
  std::string partial_;
  std::vector<std::string> messages_;
  std::optional<int> ended_;
};

// The sim's control API (docs/control-api.md).
class Api {
 public:
  Api(std::string host, int port) : host_(std::move(host)), port_(port) {}
  json get(const std::string& path) const;
  // POSTs `body`; throws lbpkit::Error with the API's own words when it
  // refuses.
  json post(const std::string& path, const json& body) const;

 private:
  std::string host_;
  int port_;
};

// The machine's trace (GET /api/machine/trace): its columns by name.
struct Trace {
  std::map<std::string, std::vector<double>> columns;
  [[nodiscard]] std::size_t rows() const { return columns.count("time_s") ? columns.at("time_s").size() : 0; }
  [[nodiscard]] const std::vector<double>& column(const std::string& name) const;
  [[nodiscard]] bool has(const std::string& name) const { return columns.count(name) != 0; }
};

// One joint of the configuration, as LinuxCNC's INI gives it, and the
// machine's axis it moves.
struct Joint {
  unsigned joint = 0;
  char letter = 'X';
  std::string axis;    // the machine's axis ("x"); empty when the machine has none for it
  bool servo = false;  // the axis has drives (a 7I77 analog output and an encoder)
  double ferror = 0, minFerror = 0, maxVelocity = 0, maxAcceleration = 0, minLimit = 0, maxLimit = 0;
  double hardStopMin = 0, hardStopMax = 0;  // the machine's mechanics end there
  double home = 0;                          // [JOINT_n]HOME: where homing leaves it
  double count = 0;                         // one encoder count (or step) in units, from the INI's scale; 0: not given
  // The room past the soft limits before the hard stops: what a runaway at
  // the end of the travel has before it crashes.
  [[nodiscard]] double room() const { return std::min(hardStopMax - maxLimit, minLimit - hardStopMin); }
};

struct Session {
  Driver& driver;
  const Api& api;
  model::machine::MachineDescription machine;
  std::vector<Joint> joints;
  std::string units;                            // [TRAJ]LINEAR_UNITS: "mm" or "inch"
  std::string ini;                              // the configuration
  std::string networkNamespace;                 // the run's (its rtapi_app is LinuxCNC's real-time part)
  std::optional<long> configuredWatchdogNs;     // the configuration's own hm2 watchdog.timeout_ns setp
  std::vector<std::string> watchdogParameters;  // hm2's NAME.watchdog.timeout_ns in the run
  double since = 0;                             // the trace time of the last check's end
  // --only: the beginnings of the check ids to run ("runaway",
  // "runaway.x", "runaway.x.reversed-encoder.moving", "estop", "host");
  // none: every check.
  std::vector<std::string> only;
  double spindleMaxRpm = 0;  // [SPINDLE_0]MAX_FORWARD_VELOCITY; 0: not given
  double jogVelocity = 0;    // [DISPLAY]DEFAULT_LINEAR_VELOCITY (units/s); 0: not given
  // The FPGA cards' HAL names ("hm2_7i92.0"), from their watchdog parameters.
  [[nodiscard]] std::vector<std::string> boards() const;
  // Whether the check `id` (or a group of them, such as "runaway.x") is
  // one --only asks for.
  [[nodiscard]] bool wanted(const std::string& id) const;

  // Machine on and every joint homed, as a check starts.
  void ready();
  // LinuxCNC's MDI, waited for.
  bool mdi(const std::string& command, double timeoutS = 60);
  Trace trace(double sinceS) const;
  json machineState() const { return api.get("/api/machine"); }
};

// Whether --only's list asks for the check `id` or a group of them: one
// is the other's beginning, at a dot or the end (the list empty: all).
[[nodiscard]] bool wantedBy(const std::vector<std::string>& only, const std::string& id);

// Each check adds its results (the report's "checks" entries,
// rehearse_report.hpp) to `out`.
using Results = std::vector<json>;
void runaway(Session& s, Results& out);
void estopChain(Session& s, Results& out);
void limits(Session& s, Results& out);
void fieldPower(Session& s, Results& out);
void spindle(Session& s, Results& out);
void networkCut(Session& s, Results& out);     // host.network
void losingTheHost(Session& s, Results& out);  // host.stopped

// The checks, in the order they run: the first word of every check id.
inline const std::vector<std::string>& checkNames() {
  static const std::vector<std::string> names = {"runaway", "estop", "limits", "spindle", "field", "host"};
  return names;
}

}  // namespace lbpkit::app::rehearse
