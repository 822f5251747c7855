// SPDX-License-Identifier: MIT
#include "daemon/fault_script.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <stdexcept>
#include <string_view>

#include "daemon/network_api.hpp"
#include "daemon/sim_clock.hpp"

namespace lbpkit::server {

using nlohmann::json;

namespace {

// One setting an entry with `for` changes: how to read it now and how to
// put a value back, through the API's own code.
struct Touched {
  std::string key;
  std::function<json(const ApiTarget&)> get;
  std::function<void(const ApiTarget&, const json&)> set;
};

const std::vector<std::pair<const char*, std::function<json(const NetworkFaultSettings::Direction&)>>>&
networkFields() {
  using D = NetworkFaultSettings::Direction;
  static const std::vector<std::pair<const char*, std::function<json(const D&)>>> f = {
      {"drop", [](const D& d) { return json(d.drop); }},
      {"drop_every", [](const D& d) { return json(d.dropEvery); }},
      {"drop_next", [](const D& d) { return json(d.dropNext); }},
      {"duplicate", [](const D& d) { return json(d.duplicate); }},
      {"corrupt", [](const D& d) { return json(d.corrupt); }},
      {"reorder", [](const D& d) { return json(d.reorder); }},
      {"delay_us", [](const D& d) { return json(d.delayUs); }},
      {"jitter_us", [](const D& d) { return json(d.jitterUs); }},
      {"delay_every", [](const D& d) { return json(d.delayEvery); }},
      {"writes_only", [](const D& d) { return json(d.writesOnly); }}};
  return f;
}

const std::vector<std::pair<const char*, std::function<json(const model::hm2::SerialLink::Rates&)>>>& linkFields() {
  using R = model::hm2::SerialLink::Rates;
  static const std::vector<std::pair<const char*, std::function<json(const R&)>>> f = {
      {"bit_error_rate", [](const R& r) { return json(r.bitErrorRate); }},
      {"drop_rate", [](const R& r) { return json(r.dropRate); }},
      {"extra_rate", [](const R& r) { return json(r.extraRate); }}};
  return f;
}

// The settings entry `f` changes, read before it is carried out. A bad
// entry (a channel out of range) is refused by the entry itself just after.
std::vector<Touched> touchedBy(const ScriptedFault& f, const ApiTarget& t) {
  std::vector<Touched> out;
  const json& b = f.body;
  const bool clear = b.value("clear", false);
  if (f.fault == "network") {
    if (t.udp == nullptr) return out;
    const std::string direction = b.value("direction", std::string("both"));
    for (const char* dir : {"request", "reply"}) {
      if (direction != "both" && direction != dir) continue;
      const bool request = std::string(dir) == "request";
      for (const auto& [name, read] : networkFields()) {
        if (!clear && !b.contains(name)) continue;
        if (!request && std::string_view(name) == "writes_only") continue;  // sorts requests only
        out.push_back({fmt::format("network.{}.{}", dir, name),
                       [request, read = read](const ApiTarget& target) {
                         const auto s = target.udp->faults().settings();
                         return read(request ? s.request : s.reply);
                       },
                       [dir = std::string(dir), name = std::string(name)](const ApiTarget& target, const json& v) {
                         applyAction(target, "network", {{"direction", dir}, {name, v}});
                       }});
      }
    }
    if (b.contains("seed"))
      out.push_back({"network.seed", [](const ApiTarget& target) { return json(target.udp->faults().settings().seed); },
                     [](const ApiTarget& target, const json& v) { applyAction(target, "network", {{"seed", v}}); }});
    if (b.contains("silent_ms") || clear)
      out.push_back({"network.silent", [](const ApiTarget&) { return json(0); },
                     [](const ApiTarget& target, const json& v) {
                       if (v == json(0)) applyAction(target, "network", {{"silent_ms", 0}});
                     }});
    return out;
  }
  if (f.fault == "link") {
    const json& channel = b.contains("channel") ? b.at("channel") : json();
    if (!channel.is_number_integer() || channel.get<std::int64_t>() < 0 ||
        channel.get<std::int64_t>() >= static_cast<std::int64_t>(t.card.part<model::hm2::Sslbp>().channels()))
      return out;
    const auto ch = channel.get<unsigned>();
    auto link = [ch](const ApiTarget& target) -> model::hm2::SerialLink& {
      return target.card.part<model::hm2::Sslbp>().link(ch);
    };
    const std::string direction = b.value("direction", std::string("both"));
    for (const char* dir : {"to_remote", "from_remote"}) {
      if (direction != "both" && direction != dir) continue;
      const bool toRemote = std::string(dir) == "to_remote";
      for (const auto& [name, read] : linkFields()) {
        if (!clear && !b.contains(name)) continue;
        out.push_back({fmt::format("link.{}.{}.{}", ch, dir, name),
                       [link, toRemote, read = read](const ApiTarget& target) {
                         const auto r = link(target).rates();
                         return read(toRemote ? r.toRemote : r.fromRemote);
                       },
                       [ch, dir = std::string(dir), name = std::string(name)](const ApiTarget& target, const json& v) {
                         applyAction(target, "link", {{"channel", ch}, {"direction", dir}, {name, v}});
                       }});
      }
    }
    for (const char* name : {"break_rate", "seed"}) {
      if (!b.contains(name) && !(clear && std::string(name) == "break_rate")) continue;
      const bool isBreak = std::string(name) == "break_rate";
      out.push_back({fmt::format("link.{}.{}", ch, name),
                     [link, isBreak](const ApiTarget& target) {
                       const auto r = link(target).rates();
                       return isBreak ? json(r.breakRate) : json(r.seed);
                     },
                     [ch, name = std::string(name)](const ApiTarget& target, const json& v) {
                       applyAction(target, "link", {{"channel", ch}, {name, v}});
                     }});
    }
    if (b.contains("connected") || clear)
      out.push_back({fmt::format("link.{}.connected", ch), [link](const ApiTarget& target) { return json(link(target).connected()); },
                     [ch](const ApiTarget& target, const json& v) {
                       applyAction(target, "link", {{"channel", ch}, {"connected", v}});
                     }});
    if (b.contains("cut_ms") || clear)
      out.push_back({fmt::format("link.{}.cut", ch), [](const ApiTarget&) { return json(0); },
                     [ch](const ApiTarget& target, const json& v) {
                       if (v == json(0)) applyAction(target, "link", {{"channel", ch}, {"cut_ms", 0}});
                     }});
    return out;
  }
  // A cable or a chip: the same one (the entry's other keys) to the other
  // state, the one it was in before.
  const char* key = f.fault == "cable" ? "connected" : f.fault == "overtemp" ? "hot" : nullptr;
  if (key == nullptr) return out;
  json which = b;
  which.erase(key);
  const bool on = b.value(key, true);
  out.push_back({fmt::format("{}.{}", f.fault, which.dump()), [on](const ApiTarget&) { return json(!on); },
                 [kind = f.fault, which, key = std::string(key)](const ApiTarget& target, const json& v) {
                   json body = which;
                   body[key] = v;
                   applyAction(target, kind, body);
                 }});
  return out;
}

}  // namespace

FaultScript::FaultScript(std::vector<ScriptedFault> entries, const model::hm2::HostMot2Card::Options& card,
                         const std::optional<model::machine::MachineDescription>& machine)
    : entries_(std::move(entries)) {
  std::stable_sort(entries_.begin(), entries_.end(),
                   [](const ScriptedFault& a, const ScriptedFault& b) { return a.at < b.at; });
  if (entries_.empty()) return;
  // The dry run: the same requests on a card of the same kind whose EEPROMs
  // are in memory, and a network that is not wired to anything.
  auto options = card;
  options.first.fieldIo.nvFile.clear();
  options.first.analog.nvFile.clear();
  if (options.second) {
    options.second->fieldIo.nvFile.clear();
    options.second->analog.nvFile.clear();
  }
  model::hm2::HostMot2Card scratch(options);
  SimClock clock(1.0, true);
  std::unique_ptr<model::machine::Machine> m;
  if (machine) m = std::make_unique<model::machine::Machine>(*machine, scratch, scratch.now(), 0);
  NetworkFaults network;
  const ApiTarget t{scratch, clock, {}, m.get(), {}, nullptr, nullptr};
  for (const auto& f : entries_) {
    try {
      if (!f.body.is_object()) throw std::invalid_argument("the entry's keys are not a table");
      if (f.fault == "network")
        applyNetwork(network, f.body, NetworkFaults::Clock::now());
      else
        applyAction(t, f.fault, f.body);
    } catch (const std::exception& e) {
      throw std::invalid_argument(fmt::format("{}: fault \"{}\": {}", f.where, f.fault, e.what()));
    }
  }
  undos_.reserve(entries_.size());
  findNext();
}

void FaultScript::findNext() {
  next_ = done_ < entries_.size() ? entries_[done_].at : model::lbp::SimTime::max();
  for (const auto& u : undos_) next_ = std::min(next_, u.at);
}

void FaultScript::run(model::lbp::SimTime now, const ApiTarget& target,
                      const std::function<void(const std::string&)>& log) {
  for (;;) {
    // The earliest thing due: an undo before an entry at the same time (an
    // entry that ends as the next begins).
    auto u = std::min_element(undos_.begin(), undos_.end(), [](const Undo& a, const Undo& b) { return a.at < b.at; });
    const bool undoDue = u != undos_.end() && u->at <= now &&
                         (done_ >= entries_.size() || u->at <= entries_[done_].at);
    if (undoDue) {
      const Undo undo = *u;
      undos_.erase(u);
      try {
        end(undo, target);
        log(fmt::format("fault script {}: ended", undo.where));
      } catch (const std::exception& e) {
        log(fmt::format("fault script {}: could not end it: {}", undo.where, e.what()));
      }
      continue;
    }
    if (done_ >= entries_.size() || entries_[done_].at > now) break;
    const std::size_t index = done_++;
    const auto& f = entries_[index];
    try {
      const auto touched = f.lasts ? touchedBy(f, target) : std::vector<Touched>{};
      std::vector<json> before;
      before.reserve(touched.size());
      for (const auto& t : touched) before.push_back(t.get(target));
      applyAction(target, f.fault, f.body);
      if (f.lasts) {
        Undo undo{f.at + *f.lasts, f.where, index, {}};
        for (std::size_t i = 0; i < touched.size(); ++i) {
          auto& setting = settings_[touched[i].key];
          if (setting.layers.empty()) {
            setting.before = before[i];
            setting.set = touched[i].set;
          }
          // What the entry left there: a cable or a chip is what the entry
          // said; the others are read back.
          const json left = f.fault == "cable" || f.fault == "overtemp" ? json(!before[i].get<bool>())
                           : touched[i].key.ends_with(".silent") || touched[i].key.ends_with(".cut") ? json(1)
                                                                                                    : touched[i].get(target);
          setting.layers.emplace_back(index, left);
          undo.settings.push_back(touched[i].key);
        }
        undos_.push_back(std::move(undo));
      }
      log(fmt::format("fault script {}: {} {}{}", f.where, f.fault, f.body.dump(),
                      f.lasts ? fmt::format(" for {:g} ms", std::chrono::duration<double, std::milli>(*f.lasts).count())
                              : std::string()));
    } catch (const std::exception& e) {
      log(fmt::format("fault script {}: fault \"{}\" refused: {}", f.where, f.fault, e.what()));
    }
  }
  findNext();
}

void FaultScript::end(const Undo& undo, const ApiTarget& target) {
  for (const auto& key : undo.settings) {
    const auto it = settings_.find(key);
    if (it == settings_.end()) continue;
    auto& s = it->second;
    const auto mine = std::find_if(s.layers.begin(), s.layers.end(), [&](const auto& l) { return l.first == undo.entry; });
    if (mine == s.layers.end()) continue;
    const bool onTop = std::next(mine) == s.layers.end();
    s.layers.erase(mine);
    // Only the latest entry's value is what the setting shows: an earlier
    // one that ends changes nothing there.
    if (onTop) s.set(target, s.layers.empty() ? s.before : s.layers.back().second);
    if (s.layers.empty()) settings_.erase(it);
  }
}

}  // namespace lbpkit::server
