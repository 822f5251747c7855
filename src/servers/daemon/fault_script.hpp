// SPDX-License-Identifier: MIT
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
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "daemon/api_routes.hpp"
#include "hostmot2/card.hpp"
#include "lbp/sim_time.hpp"
#include "machine/machine.hpp"

namespace lbpkit::server {

struct ScriptedFault {
  model::lbp::SimTime at{};
  std::string fault;  // the API's kind: network, cable, ...
  nlohmann::json body;
  std::optional<model::lbp::SimTime> lasts;  // undone this long after `at`
  std::string where;                  // "FILE:LINE:COL"
};

class FaultScript {
 public:
  // Checks every entry (throws std::invalid_argument "WHERE: fault KIND:
  // what is wrong") by carrying it out, in order, on a scratch card made
  // from `card` (EEPROMs in memory) with `machine`, if any.
  FaultScript(std::vector<ScriptedFault> entries, const model::hm2::HostMot2Card::Options& card,
              const std::optional<model::machine::MachineDescription>& machine);

  // Carries out what is due by `now` (entries and undos, in time order).
  // `log` hears each, in words. Inline: one comparison until something is due.
  void runDue(model::lbp::SimTime now, const ApiTarget& target, const std::function<void(const std::string&)>& log) {
    if (now >= next_) run(now, target, log);
  }
  [[nodiscard]] std::size_t size() const { return entries_.size(); }
  [[nodiscard]] std::size_t done() const { return done_; }  // entries carried out so far
  // Whether an entry or an undo is still to come.
  [[nodiscard]] bool pending() const { return next_ != model::lbp::SimTime::max(); }

 private:
  void run(model::lbp::SimTime now, const ApiTarget& target, const std::function<void(const std::string&)>& log);
  void findNext();

  // What an entry with `for` changed, setting by setting ("network.reply.drop",
  // "link.1.to_remote.bit_error_rate", "cable.{...}"): each setting keeps the
  // value it had before the first entry that is still on changed it, and the
  // value each entry still on gave it, in the order they began. An entry
  // that ends takes only its own value away: the setting goes to the value
  // of the latest entry still on, or back to where it was before them all.
  // So entries that overlap each undo their own change, whatever the order
  // in which they end.
  struct Setting {
    nlohmann::json before;
    std::vector<std::pair<std::size_t, nlohmann::json>> layers;  // (entry, value it set)
    std::function<void(const ApiTarget&, const nlohmann::json&)> set;
  };
  struct Undo {
    model::lbp::SimTime at{};
    std::string where;
    std::size_t entry = 0;
    std::vector<std::string> settings;  // the Setting keys it took part in
  };
  void end(const Undo& undo, const ApiTarget& target);

  std::vector<ScriptedFault> entries_;
  std::size_t done_ = 0;
  std::vector<Undo> undos_;  // not in order; few
  std::map<std::string, Setting> settings_;
  model::lbp::SimTime next_ = model::lbp::SimTime::max();
};

}  // namespace lbpkit::server
