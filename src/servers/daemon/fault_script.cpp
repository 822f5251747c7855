#include "daemon/fault_script.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <stdexcept>

#include "daemon/network_api.hpp"
#include "daemon/sim_clock.hpp"

namespace servers {

using nlohmann::json;

namespace {

// How to undo an entry that has `for`, taken just before it is carried
// out: network faults go back to what was set (and the cable back in), a
// cable back to the other state, a chip back to the other temperature.
std::function<void(const ApiTarget&)> undoFor(const ScriptedFault& f, const ApiTarget& t) {
  if (f.fault == "network") {
    const auto before = t.udp != nullptr ? t.udp->faults().settings() : NetworkFaultSettings{};
    return [before](const ApiTarget& target) {
      if (target.udp == nullptr) return;
      target.udp->faults().set(before);
      target.udp->faults().silence(std::chrono::microseconds{0}, NetworkFaults::Clock::now());
    };
  }
  if (f.fault == "link") {
    // The channel's cable as it was: its rates, plugged in or not, no cut.
    // (A bad "channel" is refused by the entry itself, just after this.)
    const json& channel = f.body.contains("channel") ? f.body.at("channel") : json();
    if (!channel.is_number_integer() || channel.get<std::int64_t>() < 0 ||
        channel.get<std::int64_t>() >= static_cast<std::int64_t>(t.card.part<hm2::SmartSerial>().channels()))
      return nullptr;
    const auto ch = channel.get<unsigned>();
    const auto& link = t.card.part<hm2::SmartSerial>().link(ch);
    return [ch, rates = link.rates(), connected = link.connected()](const ApiTarget& target) {
      auto& l = target.card.part<hm2::SmartSerial>().link(ch);
      l.setRates(rates);
      l.setConnected(connected);
      l.cut(target.card.now(), target.card.now());
    };
  }
  json back = f.body;
  if (f.fault == "cable") back["connected"] = !f.body.value("connected", true);
  if (f.fault == "overtemp") back["hot"] = !f.body.value("hot", true);
  return [kind = f.fault, back](const ApiTarget& target) { applyAction(target, kind, back); };
}

}  // namespace

FaultScript::FaultScript(std::vector<ScriptedFault> entries, const hm2::HostMot2Card::Options& card,
                         const std::optional<machine::MachineDescription>& machine)
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
  hm2::HostMot2Card scratch(options);
  SimClock clock(1.0, true);
  std::unique_ptr<machine::Machine> m;
  if (machine) m = std::make_unique<machine::Machine>(*machine, scratch, scratch.now(), 0);
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
  next_ = done_ < entries_.size() ? entries_[done_].at : lbp::SimTime::max();
  for (const auto& u : undos_) next_ = std::min(next_, u.at);
}

void FaultScript::run(lbp::SimTime now, const ApiTarget& target, const std::function<void(const std::string&)>& log) {
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
        undo.act(target);
        log(fmt::format("fault script {}: ended", undo.where));
      } catch (const std::exception& e) {
        log(fmt::format("fault script {}: could not end it: {}", undo.where, e.what()));
      }
      continue;
    }
    if (done_ >= entries_.size() || entries_[done_].at > now) break;
    const auto& f = entries_[done_++];
    try {
      auto undo = f.lasts ? undoFor(f, target) : nullptr;
      applyAction(target, f.fault, f.body);
      if (undo) undos_.push_back({f.at + *f.lasts, f.where, std::move(undo)});
      log(fmt::format("fault script {}: {} {}{}", f.where, f.fault, f.body.dump(),
                      f.lasts ? fmt::format(" for {:g} ms", std::chrono::duration<double, std::milli>(*f.lasts).count())
                              : std::string()));
    } catch (const std::exception& e) {
      log(fmt::format("fault script {}: fault \"{}\" refused: {}", f.where, f.fault, e.what()));
    }
  }
  findNext();
}

}  // namespace servers
