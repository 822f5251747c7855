// SPDX-License-Identifier: MIT
// A configuration's HAL signal graph and the values its bit pins rest at
// (hal_graph.hpp; LinuxCNC's halcmd(1) and src/hal/components/).
#include "linuxcnc/hal_graph.hpp"

#include "linuxcnc/hal_name.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cstdlib>
#include <utility>

namespace lbpkit::linuxcnc::detail {

HalGraph::HalGraph(const HalConfig& hal, std::filesystem::path ini) : hal_(hal), ini_(std::move(ini)) {
  for (const auto& c : hal_.components) {
    std::string dashed = c.module;
    std::replace(dashed.begin(), dashed.end(), '_', '-');
    std::vector<std::string> instances, personalities, messages;
    bool named = false;
    for (const auto& a : c.arguments) {
      if (a.rfind("names=", 0) == 0) {
        for (const auto& n : split(a.substr(6), ',')) instances.push_back(n);
        named = true;
      } else if (a.rfind("count=", 0) == 0 || a.rfind("num_chan=", 0) == 0) {
        const auto n = hal_name::number(a.substr(a.find('=') + 1)).value_or(1);
        for (unsigned i = 0; i < n; ++i) instances.push_back(fmt::format("{}.{}", dashed, i));
        named = true;
      } else if (c.module == "debounce" && a.rfind("cfg=", 0) == 0) {
        // Groups of filters, debounce.G.C (at most 8 groups of 50:
        // LinuxCNC's src/hal/components/debounce.c).
        const auto groups = split(a.substr(4), ',');
        for (std::size_t g = 0; g < std::min<std::size_t>(groups.size(), 8); ++g)
          for (unsigned ch = 0; ch < std::min(hal_name::number(groups[g]).value_or(0), 50U); ++ch)
            instances.push_back(fmt::format("debounce.{}.{}", g, ch));
        named = true;
      } else if (a.rfind("personality=", 0) == 0) {
        personalities = split(a.substr(12), ',');
      } else if (a.rfind("messages=", 0) == 0) {
        messages = split(a.substr(9), ',');
      }
    }
    if (!named) instances.push_back(dashed + ".0");
    for (std::size_t i = 0; i < instances.size(); ++i) {
      instanceModule_[instances[i]] = c.module;
      if (i < personalities.size()) {
        // A number as the module parameter takes it: 0x.. hexadecimal.
        const auto& text = personalities[i];
        char* end = nullptr;
        const auto v = std::strtoul(text.c_str(), &end, 0);
        if (!text.empty() && end != nullptr && *end == '\0')
          personality_[instances[i]] = static_cast<unsigned>(v & 0xFFFFU);
      }
      if (i < messages.size()) messageText_[instances[i]] = messages[i];
    }
  }
  for (const auto& [signal, pins] : hal_.signals)
    for (const auto& p : pins) pinSignal_.emplace(p, signal);
}

std::string HalGraph::messageText(const std::string& instance) const {
  const auto it = messageText_.find(instance);
  return it == messageText_.end() ? std::string() : it->second;
}

std::string HalGraph::signal(const std::string& pin) const {
  const auto it = pinSignal_.find(pin);
  return it == pinSignal_.end() ? std::string() : it->second;
}

const std::vector<std::string>& HalGraph::pinsOn(const std::string& signal) const {
  static const std::vector<std::string> none;
  const auto it = hal_.signals.find(signal);
  return it == hal_.signals.end() ? none : it->second;
}

Where HalGraph::where(const std::string& pin) const {
  for (const auto& r : hal_.refs)
    if (r.name == pin) return r.at;
  return {ini_.filename().string(), 0};
}

Where HalGraph::whereOn(const std::string& pin, const std::string& signal) const {
  for (const auto& r : hal_.refs)
    if (r.name == pin && r.signal == signal) return r.at;
  return where(pin);
}

// Where a pin is connected, for a message: "signal S, with A, B".
std::string HalGraph::describe(const std::string& pin) const {
  const auto s = signal(pin);
  if (s.empty()) return "it is on no signal";
  std::string others;
  for (const auto& p : pinsOn(s))
    if (p != pin) others += (others.empty() ? "" : ", ") + p;
  return fmt::format("signal {} ({}), with {}", s, at(hal_.signalFirst.count(s) ? hal_.signalFirst.at(s) : Where{}),
                     others.empty() ? "nothing else" : others);
}

std::string HalGraph::moduleOf(const std::string& instance) const {
  const auto it = instanceModule_.find(instance);
  return it == instanceModule_.end() ? std::string() : it->second;
}

std::size_t HalGraph::add(Node n) {
  nodes_.push_back(std::move(n));
  return nodes_.size() - 1;
}

std::size_t HalGraph::constant(bool v, std::string why) {
  return add({Node::Kind::Const, v, {}, {}, {}, {}, std::move(why)});
}

std::size_t HalGraph::unknown(std::string why) {
  return add({Node::Kind::Unknown, false, {}, {}, {}, {}, std::move(why)});
}

std::size_t HalGraph::gate(Node::Kind k, std::string label, std::vector<std::size_t> kids) {
  return add({k, false, {}, {}, std::move(label), std::move(kids), {}});
}

std::optional<bool> HalGraph::bit(const std::string& s) {
  const auto l = lower(s);
  if (l == "1" || l == "true") return true;
  if (l == "0" || l == "false") return false;
  if (const auto v = number(s)) return *v != 0.0;
  return std::nullopt;
}

std::size_t HalGraph::nodeFor(const std::string& pin, unsigned depth) {
  if (const auto it = nodeOf_.find(pin); it != nodeOf_.end()) return it->second;
  if (depth > kMaxDepth || nodes_.size() > kMaxNodes)
    return unknown(fmt::format("{}: more than {} components in a row", pin, kMaxDepth));
  if (!building_.insert(pin).second) return unknown(fmt::format("{} reads its own output (a loop)", pin));
  const auto id = computeNode(pin, depth);
  building_.erase(pin);
  nodeOf_.emplace(pin, id);
  return id;
}

std::size_t HalGraph::computeNode(const std::string& pin, unsigned depth) {
  const auto s = signal(pin);
  if (s.empty()) {
    if (const auto* sp = hal_.setpOf(pin))
      if (const auto b = bit(sp->value))
        return constant(*b, fmt::format("setp {} {} ({})", pin, sp->value, at(sp->at)));
    // estop_latch's ok-in rests TRUE unconnected (LinuxCNC:
    // src/hal/components/estop_latch.comp); every other input FALSE.
    const bool dflt = moduleOf(pin.substr(0, pin.rfind('.'))) == "estop_latch" && pin.ends_with(".ok-in");
    return constant(dflt, fmt::format("{} is on no signal: {}", pin, dflt ? "TRUE" : "FALSE"));
  }
  const auto& pins = pinsOn(s);
  for (const auto& p : pins)
    if (p != pin)
      if (const auto f = fieldPin(p, "input")) return add({Node::Kind::Input, false, p, *f, {}, {}, {}});
  for (const auto& p : pins)
    if (p != pin)
      if (const auto id = outputNode(p, depth)) return *id;
  for (auto it = hal_.signalSets.rbegin(); it != hal_.signalSets.rend(); ++it)
    if (it->name == s)
      if (const auto b = bit(it->value)) return constant(*b, fmt::format("sets {} {} ({})", s, it->value, at(it->at)));
  std::string others;
  for (const auto& p : pins)
    if (p != pin) others += (others.empty() ? "" : ", ") + p;
  const auto first = hal_.signalFirst.count(s) ? at(hal_.signalFirst.at(s)) : std::string("?");
  if (others.empty()) return constant(false, fmt::format("signal {} ({}) has no writer: FALSE", s, first));
  return unknown(fmt::format("signal {} ({}) comes from {}", s, first, others));
}

std::optional<std::size_t> HalGraph::outputNode(const std::string& p, unsigned depth) {
  const auto dot = p.rfind('.');
  if (dot == std::string::npos) return std::nullopt;
  const auto instance = p.substr(0, dot), leaf = p.substr(dot + 1);
  const auto module = moduleOf(instance);
  auto in = [&](const std::string& name) { return nodeFor(instance + "." + name, depth + 1); };
  using K = Node::Kind;
  if (module == "not" && leaf == "out") return gate(K::Not, instance, {in("in")});
  if (module == "and2" && leaf == "out") return gate(K::And, instance, {in("in0"), in("in1")});
  if (module == "or2" && leaf == "out") return gate(K::Or, instance, {in("in0"), in("in1")});
  if (module == "xor2" && leaf == "out") return gate(K::Xor, instance, {in("in0"), in("in1")});
  // debounce and timedelay: the output follows the input once it has
  // stayed for the filter's samples or the delay.
  if ((module == "debounce" || module == "timedelay") && leaf == "out") return gate(K::And, instance, {in("in")});
  if (module == "estop_latch" && (leaf == "ok-out" || leaf == "fault-out")) {
    // OK (after a reset) while ok-in is TRUE and fault-in FALSE.
    const auto ok = gate(K::And, instance, {in("ok-in"), gate(K::Not, {}, {in("fault-in")})});
    return leaf == "ok-out" ? ok : gate(K::Not, {}, {ok});
  }
  if (module == "logic" && (leaf == "and" || leaf == "or" || leaf == "xor" || leaf == "nand" || leaf == "nor")) {
    const auto it = personality_.find(instance);
    if (it == personality_.end())
      return unknown(fmt::format("{}: logic {} has no personality= on its loadrt", p, instance));
    // The low byte is the number of inputs (at most 16), in-00 on.
    std::vector<std::size_t> ins;
    for (unsigned i = 0; i < std::min(it->second & 0xFFU, 16U); ++i) ins.push_back(in(fmt::format("in-{:02d}", i)));
    const auto k = leaf == "xor" ? K::Xor : leaf == "and" || leaf == "nand" ? K::And : K::Or;
    const auto g = gate(k, instance, std::move(ins));
    return leaf == "nand" || leaf == "nor" ? gate(K::Not, {}, {g}) : g;
  }
  // A pulse on an edge of the input, or a flip on each press: at rest
  // the pulse is over and the flip where it started.
  if ((module == "oneshot" && (leaf == "out" || leaf == "out-not")) ||
      (module == "edge" && (leaf == "out" || leaf == "out-invert")))
    return constant(leaf != "out", fmt::format("{} pulses on an edge of its input only: {} at rest", p,
                                               leaf != "out" ? "TRUE" : "FALSE"));
  if (module == "toggle" && leaf == "out")
    return constant(false, fmt::format("{} flips on each press of its input: FALSE as it starts", p));
  return std::nullopt;
}

void HalGraph::trace(const std::string& pin, bool inverted, std::vector<Source>& out) {
  std::set<std::pair<std::size_t, bool>> seen;
  std::vector<std::pair<std::size_t, bool>> todo{{nodeFor(pin), inverted}};
  while (!todo.empty()) {
    const auto [id, inv] = todo.back();
    todo.pop_back();
    if (!seen.insert({id, inv}).second) continue;
    const auto& n = nodes_[id];
    if (n.kind == Node::Kind::Input) out.push_back({n.pin, n.field, inv != n.field.inverted});
    for (const auto k : n.kids) todo.emplace_back(k, n.kind == Node::Kind::Not ? !inv : inv);
  }
  // In the order the nets give them.
  std::reverse(out.begin(), out.end());
}

std::string HalGraph::key(const FieldPin& f) { return fmt::format("{}:{}", f.daughtercard, f.number); }

bool HalGraph::require(std::size_t id, bool want, bool lax, Search& s) {
  if (s.budget == 0) return false;
  --s.budget;
  const auto& n = nodes_[id];
  using K = Node::Kind;
  const bool labelled = !n.label.empty();
  if (labelled) s.path.push_back(n.label);
  struct Pop {
    Search& s;
    bool on;
    ~Pop() {
      if (on) s.path.pop_back();
    }
  } pop{s, labelled};
  switch (n.kind) {
    case K::Const: return n.value == want;
    case K::Unknown: return lax;
    case K::Input: {
      const bool on = want != n.field.inverted;
      const auto k = key(n.field);
      if (const auto it = s.holds.find(k); it != s.holds.end()) return it->second.on == on;
      // From the input on, as the signal goes.
      std::string through;
      for (auto p = s.path.rbegin(); p != s.path.rend(); ++p) through += (through.empty() ? "" : ", ") + *p;
      s.holds[k] = {on, n.pin, through, s.for_->what, where(s.for_->pin)};
      return true;
    }
    case K::Not: return require(n.kids[0], !want, lax, s);
    case K::And:
    case K::Or: {
      // Every input one way (AND TRUE, OR FALSE), or any one the other.
      if ((n.kind == K::And) == want) {
        for (const auto k : n.kids)
          if (!require(k, want, lax, s)) return false;
        return true;
      }
      for (const bool tryLax : {false, true}) {
        if (tryLax && !lax) break;
        for (const auto k : n.kids) {
          Search trial = s;
          if (require(k, want, tryLax, trial)) {
            s = std::move(trial);
            return true;
          }
          s.budget = trial.budget;
        }
      }
      return false;
    }
    case K::Xor: return requireXor(n.kids, 0, want, lax, s);
  }
  return false;
}

bool HalGraph::requireXor(const std::vector<std::size_t>& kids, std::size_t from, bool want, bool lax, Search& s) {
  if (from == kids.size()) return !want;
  for (const bool v : {false, true}) {
    Search trial = s;
    if (require(kids[from], v, lax, trial) && requireXor(kids, from + 1, want != v, lax, trial)) {
      s = std::move(trial);
      return true;
    }
    s.budget = trial.budget;
  }
  return false;
}

std::optional<Holds> HalGraph::hold(const Interlock& i, const Holds& current, Diagnostics& diag) {
  const auto root = nodeFor(i.pin);
  for (const bool lax : {false, true}) {
    Search s{current, &i, kSteps, {}};
    if (require(root, i.want, lax, s)) {
      Holds added;
      for (auto& [k, h] : s.holds)
        if (!current.count(k)) added.emplace(k, std::move(h));
      return added;
    }
  }
  // Alone, could it be held? Then what it needs is held the other way.
  Search alone{{}, &i, kSteps, {}};
  if (require(root, i.want, true, alone)) {
    std::string clash;
    for (const auto& [k, h] : alone.holds)
      if (const auto it = current.find(k); it != current.end() && it->second.on != h.on)
        clash += fmt::format("{}{} must read {} for it{} but reads {} for {} ({})", clash.empty() ? "" : "; ", h.pin,
                             h.on ? "on" : "off", h.through.empty() ? "" : " (through " + h.through + ")",
                             it->second.on ? "on" : "off", it->second.reason, at(it->second.at));
    diag.warning(where(i.pin), i.pin,
                 fmt::format("{} cannot be held: {}; the machine may stop on it", i.what,
                             clash.empty() ? "its inputs are held the other way" : clash));
  } else if (alone.budget == 0) {
    diag.warning(where(i.pin), i.pin, fmt::format("{}: its logic has more ways than lbpkit tries; not held", i.what));
  } else {
    std::string why;
    std::set<std::size_t> seen;
    std::vector<std::size_t> todo{root};
    while (!todo.empty() && seen.size() < 64) {
      const auto id = todo.back();
      todo.pop_back();
      if (!seen.insert(id).second) continue;
      if (!nodes_[id].why.empty() && why.size() < 400) why += (why.empty() ? "" : "; ") + nodes_[id].why;
      for (const auto k : nodes_[id].kids) todo.push_back(k);
    }
    diag.warning(where(i.pin), i.pin,
                 fmt::format("{} cannot be: no state of the field inputs gives it ({}); the machine may stop on it",
                             i.what, why.empty() ? "nothing reaches it" : why));
  }
  return std::nullopt;
}

}  // namespace lbpkit::linuxcnc::detail
