// A fault script carried out: control-API requests at set
// simulated times, each perhaps undone a while later (`for`), read from the
// sim's TOML by the app (config/fault_script.hpp) and handed over as these
// entries. The API's own code carries them out (applyAction), so a script
// can do nothing a client of the API cannot.
//
// The whole script is tried on a scratch card before the sim starts, so a
// mistake in the last entry is an error at start, not after an hour.
#pragma once

#include <functional>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "daemon/api_routes.hpp"
#include "hostmot2/card.hpp"
#include "lbp/sim_time.hpp"
#include "machine/machine.hpp"

namespace servers {

struct ScriptedFault {
  lbp::SimTime at{};
  std::string fault;  // the API's kind: network, cable, ...
  nlohmann::json body;
  std::optional<lbp::SimTime> lasts;  // undone this long after `at`
  std::string where;                  // "FILE:LINE:COL"
};

class FaultScript {
 public:
  // Checks every entry (throws std::invalid_argument "WHERE: fault KIND:
  // what is wrong") by carrying it out, in order, on a scratch card made
  // from `card` (EEPROMs in memory) with `machine`, if any.
  FaultScript(std::vector<ScriptedFault> entries, const hm2::HostMot2Card::Options& card,
              const std::optional<machine::MachineDescription>& machine);

  // Carries out what is due by `now` (entries and undos, in time order).
  // `log` hears each, in words. Inline: one comparison until something is due.
  void runDue(lbp::SimTime now, const ApiTarget& target, const std::function<void(const std::string&)>& log) {
    if (now >= next_) run(now, target, log);
  }
  [[nodiscard]] std::size_t size() const { return entries_.size(); }
  [[nodiscard]] std::size_t done() const { return done_; }  // entries carried out so far

 private:
  void run(lbp::SimTime now, const ApiTarget& target, const std::function<void(const std::string&)>& log);
  void findNext();

  struct Undo {
    lbp::SimTime at{};
    std::string where;
    std::function<void(const ApiTarget&)> act;
  };
  std::vector<ScriptedFault> entries_;
  std::size_t done_ = 0;
  std::vector<Undo> undos_;  // not in order; few
  lbp::SimTime next_ = lbp::SimTime::max();
};

}  // namespace servers
