// SPDX-License-Identifier: MIT
// Reads a LinuxCNC configuration as halcmd would (hostmot2(9), halcmd(1):
// INI substitution, loadrt, net, setp, sets, link*, addf) and checks every
// hostmot2 name against what the driver creates (hm2_pins.hpp).
#include "linuxcnc/config_check.hpp"

#include "linuxcnc/board_address.hpp"
#include "linuxcnc/hal_name.hpp"
#include "linuxcnc/machine_from_config.hpp"
#include "linuxcnc/startup_check.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <optional>
#include <regex>
#include <set>
#include "lbpkit/wire/names.hpp"

namespace lbpkit::linuxcnc {

namespace {

constexpr std::size_t kHalNameLen = 47;  // HAL_NAME_LEN, LinuxCNC 2.9 (hal.h)

// The checker: the configuration as read, and where its findings go.
struct Checker {
  const HalConfig& hal;
  std::vector<Finding>* findings = nullptr;

  void error(const Where& w, std::string name, std::string reason, std::string suggestion = {},
             const char* severity = "error") {
    findings->push_back({w.file, w.line, severity, std::move(name), std::move(reason), std::move(suggestion)});
  }
};

const Item* find(const std::vector<Item>& items, const std::string& name) {
  const auto it = std::lower_bound(items.begin(), items.end(), name,
                                   [](const Item& i, const std::string& n) { return i.name < n; });
  if (it != items.end() && it->name == name) return &*it;
  for (const auto& i : items)
    if (i.alsoNamed == name) return &i;
  return nullptr;
}

std::string nearest(const Board& b, const std::string& name, std::optional<Kind> kind) {
  std::size_t best = std::string::npos;
  std::string out;
  for (const auto& i : b.items) {
    if (kind && i.kind != *kind) continue;
    const auto d = wire::editDistance(name, i.name);
    if (d < best) {
      best = d;
      out = i.name;
    }
  }
  return out;
}

// The board a hostmot2 name is on: "hm2_7i92.0" (hal_name.hpp), or "".
std::string boardOf(const std::string& name) {
  const auto n = hal_name::parse(name);
  return n ? n->prefix() : std::string();
}

std::string upper(std::string s) {
  for (auto& c : s) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return s;
}

bool isEthernet(const std::string& prefix) {
  const auto n = hal_name::parse(prefix);
  return n && hal_name::isEthernetBoard(n->board);
}

std::string sserialSummary(const Hm2Config& c) {
  std::string s;
  for (const auto& [port, modes] : c.sserialPorts) s += fmt::format(" sserial_port_{}={}", port, modes);
  return s.empty() ? "no sserial_port_N (every channel in mode 0)" : trim(s);
}

// Why a module's name (stepgen.05.enable, dpll.01.timer-us,
// stepgen.timer-number) is not there: no such module in the firmware, not
// that many instances, left out by the config= string, or no HM2DPLL.
std::string moduleReason(const Board& b, const std::string& module, const std::string& number, const std::string& rest,
                         const Hm2Config& config) {
  static const std::map<std::string, std::string> names = {{"stepgen", "StepGen"}, {"pwmgen", "PWMGen"},
                                                           {"inm", "InM"},         {"ssr", "SSR"},
                                                           {"outm", "OutM"},       {"encoder", "encoder"},
                                                           {"dpll", "HM2DPLL"}};
  const auto& name = names.at(module);
  const auto key = module == "dpll" ? std::string("num_dplls") : "num_" + module + "s";
  const auto at = b.modules.find(module);
  const unsigned available = at == b.modules.end() ? 0 : at->second;
  const bool dpll = b.modules.count("dpll") != 0;
  const auto given = config.count(key) >= 0 ? fmt::format("{}={}", key, config.count(key)) : std::string("no " + key);
  if (available == 0) {
    if (module == "dpll")
      return fmt::format("the {} has no HM2DPLL, so no dpll pins (Mesa's \"d\" firmwares have one)", b.model);
    return fmt::format("the {} has no {}: no {} names", b.model, name, module);
  }
  // The instances hostmot2 makes names for (NN in <board>.<module>.NN.*).
  std::set<std::string> enabled;
  const auto head = b.prefix + "." + module + ".";
  for (const auto& i : b.items)
    if (i.name.rfind(head, 0) == 0 && i.name.size() > head.size() + 3 && std::isdigit(static_cast<unsigned char>(i.name[head.size()])) &&
        i.name[head.size() + 2] == '.')
      enabled.insert(i.name.substr(head.size(), 2));
  if (rest == "timer-number" && number.empty() && !dpll)
    return fmt::format("{}.timer-number exists only on a firmware with an HM2DPLL: the {} has none", module, b.model);
  if (module == "dpll") {
    if (config.count(key) == 0) return fmt::format("{} leaves the HM2DPLL out: no dpll pins", given);
    return fmt::format("the HM2DPLL has no {}", rest);
  }
  if (number.empty()) {
    if (enabled.empty()) return fmt::format("no {} is enabled ({}): no {} names", name, given, module);
    return fmt::format("{} creates no {}.{}", b.prefix, module, rest);
  }
  const auto n = std::stoul(number);
  if (n >= available)
    return fmt::format("no {} {:02d}: the {} has {} {}{} ({:02d}..{:02d})", name, n, b.model, available, name,
                       available == 1 ? "" : "s", 0, available - 1);
  if (!enabled.count(number))
    return fmt::format("{} {:02d} is left out: {} enables {} of the firmware's {}", name, n, given, enabled.size(),
                       available);
  return fmt::format("{} {:02d} has no {}", name, n, rest);
}

// Every reference checked against the boards chosen (boardIndex: prefix ->
// index in `boards`); the findings go to r.findings.
void evaluate(Checker& r, const std::vector<const Board*>& boards, const std::map<std::string, std::size_t>& boardIndex,
              unsigned& references) {
  for (const auto* b : boards)
    for (const auto& problem : b->loadProblems) r.error(Where{b->file, b->line}, "config", problem);
  // Every reference.
  std::map<std::string, std::string> pinSignal;  // pin -> the signal it joined
  for (const auto& ref : r.hal.refs) {
    // HAL's names are at most HAL_NAME_LEN (47) characters (LinuxCNC 2.9:
    // hal.h); halcmd finds no pin or parameter by a longer one.
    if (ref.name.size() > kHalNameLen) {
      r.error(ref.at, ref.name.substr(0, kHalNameLen) + "...",
              fmt::format("a name of {} characters: HAL's are at most {} (HAL_NAME_LEN), so halcmd finds no such pin "
                          "or parameter",
                          ref.name.size(), kHalNameLen));
      continue;
    }
    const bool hm2 = hal_name::isHostMot2(ref.name);
    if (ref.use == Use::Net || ref.use == Use::Link) {
      const auto [it, fresh] = pinSignal.emplace(ref.name, ref.signal);
      if (!fresh && it->second != ref.signal)
        r.error(ref.at, ref.name,
                fmt::format("{} is already on signal {}: a pin joins one signal (halcmd refuses)", ref.name, it->second));
    }
    if (!hm2) continue;
    const auto prefix = boardOf(ref.name);
    const auto bi = boardIndex.find(prefix);
    if (bi == boardIndex.end()) continue;  // reported above
    ++references;
    const auto& b = *boards[bi->second];
    const auto config = parseHm2Config(b.config);
    if (ref.use == Use::Addf) {
      if (find(b.items, ref.name + ".time")) continue;
      std::string functions;
      for (const auto& i : b.items)
        if (i.origin.kind == Origin::Kind::Function && i.kind == Kind::Pin) functions += " " + i.origin.name;
      r.error(ref.at, ref.name,
              fmt::format("no function {}: {} exports{}", ref.name, prefix, functions),
              [&] {
                std::string best;
                std::size_t d = std::string::npos;
                for (const auto& i : b.items)
                  if (i.origin.kind == Origin::Kind::Function && i.kind == Kind::Pin &&
                      wire::editDistance(ref.name, i.origin.name) < d) {
                    d = wire::editDistance(ref.name, i.origin.name);
                    best = i.origin.name;
                  }
                return best;
              }());
      continue;
    }
    const Item* item = find(b.items, ref.name);
    const std::optional<Kind> wantKind =
        ref.use == Use::Setp ? std::nullopt : std::optional<Kind>(Kind::Pin);
    if (!item) {
      std::string reason;
      static const std::regex remote(R"(^hm2_[^.]+\.\d+\.([0-9a-z]+)\.(\d+)\.(\d+)\.(.+)$)");
      static const std::regex encoder(R"(^hm2_[^.]+\.\d+\.encoder\.(\d+)\..+$)");
      static const std::regex gpio(R"(^hm2_[^.]+\.\d+\.gpio\.(\d+)\..+$)");
      static const std::regex instance(R"(^hm2_[^.]+\.\d+\.(stepgen|pwmgen|inm|ssr|outm)\.(\d+)\.(.+)$)");
      static const std::regex global(R"(^hm2_[^.]+\.\d+\.(stepgen|pwmgen|encoder|dpll)()\.(.+)$)");
      std::smatch m;
      if (std::regex_match(ref.name, m, remote) && m[1] != "sserial" && m[1] != "encoder" && m[1] != "gpio") {
        const unsigned port = static_cast<unsigned>(std::stoul(m[2]));
        const unsigned channel = static_cast<unsigned>(std::stoul(m[3]));
        // Which remote answers on that channel (from the items' origins).
        const Origin* onChannel = nullptr;
        for (const auto& i : b.items)
          if (i.origin.kind == Origin::Kind::Remote && i.origin.port == port && i.origin.channel == channel) {
            onChannel = &i.origin;
            break;
          }
        std::string wrongMode;
        for (const auto& [digit, items] : b.itemsInMode)
          if (digit != config.mode(port, channel) && find(items, ref.name)) wrongMode += digit;
        if (port > 3 || channel > 7) {
          reason = fmt::format("no smart-serial port {} channel {}", port, channel);
        } else if (config.mode(port, channel) == 'x') {
          reason = fmt::format("smart-serial port {} channel {} is left out: 'x' in {}", port, channel,
                               sserialSummary(config));
        } else if (onChannel == nullptr) {
          std::string where;
          std::set<std::string> seen;
          for (const auto& i : b.items)
            if (i.origin.kind == Origin::Kind::Remote && seen.insert(i.origin.text).second)
              where += (where.empty() ? "" : "; ") + i.origin.text;
          reason = fmt::format("no remote answers on smart-serial port {} channel {} ({})", port, channel,
                               where.empty() ? "no remote found at all" : "found: " + where);
        } else if (onChannel->name != upper(m[1])) {
          reason = fmt::format("the remote on smart-serial port {} channel {} is {}: no {}", port, channel,
                               onChannel->name, std::string(m[1]));
        } else if (!wrongMode.empty()) {
          std::string modes;
          for (char c : wrongMode) modes += (modes.empty() ? "" : ", ") + std::string(1, c);
          reason = fmt::format("wrong mode: {} exists only in mode {} of the {} on port {} channel {}, and {} runs it "
                               "in mode {}",
                               m[4].str(), modes, onChannel->name, port, channel,
                               sserialSummary(config), config.mode(port, channel));
        } else {
          reason = fmt::format("the {} on port {} channel {} has no {} in mode {}", onChannel->name, port, channel,
                               m[4].str(),
                               config.mode(port, channel));
        }
      } else if (std::regex_match(ref.name, m, encoder)) {
        const auto n = std::stoul(m[1]);
        unsigned enabled = 0;
        for (const auto& i : b.items)
          if (i.name.size() > prefix.size() + 9 && i.name.compare(prefix.size(), 9, ".encoder.") == 0 &&
              i.name.ends_with(".count"))
            ++enabled;
        reason = n >= enabled ? fmt::format("no such channel: encoder {:02d}, and {} enables {} encoder{} ({})", n,
                                            b.driver, enabled, enabled == 1 ? "" : "s",
                                            config.count("num_encoders") >= 0
                                                ? fmt::format("num_encoders={}", config.count("num_encoders"))
                                                : "all the firmware has")
                              : fmt::format("encoder {:02d} has no {}", n, ref.name.substr(ref.name.rfind('.') + 1));
      } else if (std::regex_match(ref.name, m, instance) || std::regex_match(ref.name, m, global)) {
        reason = moduleReason(b, m[1], m[2], m[3], config);
      } else if (std::regex_match(ref.name, m, gpio)) {
        const auto in = fmt::format("{}.gpio.{:03d}.in", prefix, std::stoul(m[1]));
        const auto* p = find(b.items, in);
        reason = p ? fmt::format("IO pin {} is not a plain GPIO ({}): only its .in and .in_not exist", m[1].str(),
                                 p->origin.name)
                   : fmt::format("no IO pin {} on {}", m[1].str(), prefix);
      } else {
        reason = fmt::format("{} creates no {} of that name", prefix,
                             ref.use == Use::Setp ? "pin or parameter" : "pin");
      }
      r.error(ref.at, ref.name, reason, nearest(b, ref.name, wantKind));
      continue;
    }
    if (ref.use == Use::Setp) {
      if (item->kind == Kind::Param && item->dir == Dir::RO)
        r.error(ref.at, ref.name, fmt::format("{} is a read-only parameter: setp cannot change it", ref.name));
      else if (item->kind == Kind::Pin && item->dir == Dir::Out)
        r.error(ref.at, ref.name, fmt::format("{} is an output pin ({} writes it): setp cannot set it", ref.name, prefix));
      else if (item->kind == Kind::Pin && pinSignal.count(ref.name))
        r.error(ref.at, ref.name,
                fmt::format("{} is on signal {}: setp cannot set a connected pin (use sets on the signal)", ref.name,
                            pinSignal[ref.name]));
    } else if (item->kind == Kind::Param) {
      r.error(ref.at, ref.name, fmt::format("{} is a parameter: net and link* connect pins (give it a value with setp)",
                                            ref.name),
              nearest(b, ref.name, Kind::Pin));
    }
  }

  // Signals: what LinuxCNC refuses (two outputs, an output with a
  // bidirectional pin, mixed types) and inputs nothing writes.
  for (const auto& [sig, pins] : r.hal.signals) {
    std::vector<std::pair<std::string, const Item*>> known;
    bool allKnown = true;
    for (const auto& pin : pins) {
      const auto bi = boardIndex.find(boardOf(pin));
      const Item* item = bi == boardIndex.end() || !hal_name::isHostMot2(pin) ? nullptr
                                                                            : find(boards[bi->second]->items, pin);
      if (item && item->kind == Kind::Pin) known.emplace_back(pin, item);
      else allKnown = false;
    }
    const Where at = r.hal.signalFirst.count(sig) ? r.hal.signalFirst.at(sig) : Where{};
    const std::string& signal = sig;  // clang 14 cannot capture a structured binding (C++20 allows it)
    auto lineOf = [&](const std::string& pin) {
      for (const auto& ref : r.hal.refs)
        if (ref.name == pin && ref.signal == signal) return ref.at;
      return at;
    };
    std::vector<std::string> outs, ios;
    for (const auto& [pin, item] : known) {
      if (item->dir == Dir::Out) outs.push_back(pin);
      if (item->dir == Dir::IO) ios.push_back(pin);
    }
    if (outs.size() >= 2)
      r.error(lineOf(outs[1]), sig,
              fmt::format("two outputs on signal {}: {} and {} (halcmd refuses the second)", sig, outs[0], outs[1]));
    else if (!outs.empty() && !ios.empty())
      r.error(lineOf(ios[0]), sig,
              fmt::format("signal {} has an output ({}) and a bidirectional pin ({}): halcmd refuses", sig, outs[0], ios[0]));
    for (std::size_t i = 1; i < known.size(); ++i)
      if (known[i].second->type != known[0].second->type) {
        r.error(lineOf(known[i].first), sig,
                fmt::format("signal {} joins {} {} and {} {}: HAL signals have one type", sig,
                            typeName(known[0].second->type), known[0].first, typeName(known[i].second->type),
                            known[i].first));
        break;
      }
    // LinuxCNC loads such a signal (its inputs read 0), and a file checked
    // alone (custom.hal) often nets what another file writes: a warning.
    if (allKnown && !known.empty() && outs.empty() && ios.empty() && !r.hal.sets.count(sig))
      r.error(at, sig,
              fmt::format("signal {} has no writer: {} is an input and nothing on the signal drives it (no output "
                          "pin, no sets); LinuxCNC loads it and the input reads 0",
                          sig, known[0].first),
              {}, "warning");
  }
}

// A servo joint that the limits of its 7I77 analog output hold under its
// MAX_VELOCITY. hostmot2 holds the value of an analogoutN to [minlim,
// maxlim] before it scales it by scalemax (LinuxCNC:
// src/hal/drivers/mesa-hostmot2/sserial.c), and with FF1 the PID's output
// is FF1 x the commanded velocity (AnalogDrive::velocityAt), so the fastest
// the output can command is min(maxlim, -minlim) / FF1. LinuxCNC starts,
// and every move faster than that ends in "joint N following error": a
// warning, at the setp of the limit that holds it (at the output's first
// line when hostmot2's default does). PNCconf writes limits of +-10 whatever
// OUTPUT_SCALE it writes.
void outputLimitWarnings(const HalConfig& hal, const std::filesystem::path& ini, std::vector<Finding>& findings) {
  for (const auto& d : analogDrives(hal, ini)) {
    if (!d.maxVelocity) continue;
    const bool byMax = d.maxlim.v <= -d.minlim.v;
    const ConfigValue& limit = byMax ? d.maxlim : d.minlim;
    const auto fastest = d.velocityAt(std::max(0.0, byMax ? d.maxlim.v : -d.minlim.v));
    const double maxVelocity = std::abs(d.maxVelocity->v);
    if (!fastest || !std::isfinite(*fastest) || !std::isfinite(maxVelocity) || *fastest >= maxVelocity * (1 - 1e-9))
      continue;
    const auto name = d.output + (byMax ? "-maxlim" : "-minlim");
    const Where at = limit.setp.line != 0 ? limit.setp : d.outputAt;
    // Limits of +-10 on a larger scalemax: PNCconf's when a setp gives the
    // one that holds it, else hostmot2's own.
    const bool tenOnLarger = d.maxlim.v == 10.0 && d.minlim.v == -10.0 && std::abs(d.scalemax.v) > 10.0;
    findings.push_back(
        {at.file, at.line, "warning", name,
         fmt::format("joint {}: {} {:g}{} holds its PID's output to {:g} ({:g} units/s at FF1 {:g}), under "
                     "[{}]MAX_VELOCITY {:g} ({}:{}): a move faster than that ends in a following error{}",
                     d.joint, name, limit.v, limit.setp.line == 0 ? " (hostmot2's default: none set)" : "", limit.v,
                     *fastest, d.ff1->v, d.section, d.maxVelocity->v, d.maxVelocity->at.file, d.maxVelocity->at.line,
                     !tenOnLarger ? ""
                     : limit.setp.line != 0 ? "; PNCconf's default limits of +-10 suit an OUTPUT_SCALE of 10 only"
                                  : "; hostmot2's default limits of +-10 suit a scalemax of 10 only"),
         {}});
  }
}

}  // namespace

bool CheckResult::ok() const {
  return std::none_of(findings.begin(), findings.end(), [](const Finding& f) { return f.severity == "error"; });
}

CheckResult checkConfig(const std::filesystem::path& file, const BoardModel& model) {
  CheckResult result;
  result.hal = readConfiguration(file, result.findings);
  const HalConfig& hal = result.hal;
  result.files = hal.files;
  Checker r{hal, &result.findings};

  // What LinuxCNC's start-up check refuses in the INI (startup_check.hpp):
  // `linuxcnc` runs it before it loads anything.
  if (hal.hasIni)
    for (auto& f : startupCheck(file, hal.ini.file)) result.findings.push_back(std::move(f));

  // A servo joint its analog output's limits hold under its MAX_VELOCITY
  // (a warning: LinuxCNC starts).
  if (hal.hasIni) outputLimitWarnings(hal, file, result.findings);

  // An INI whose HAL files gave lbpkit no HAL command to check (Tcl it does
  // not read, ...) has had nothing checked: that is no pass, though LinuxCNC
  // may well load it. (A HAL file that is missing is an error of its own.)
  if (hal.hasIni && hal.halFilesNamed > 0 && hal.commands == 0 && result.ok()) {
    const IniEntry* first = nullptr;
    for (const char* key : {"HALFILE", "POSTGUI_HALFILE", "SHUTDOWN"})
      if (first == nullptr) first = hal.ini.find("HAL", key);
    r.error(first ? Where{first->file, first->line} : Where{hal.ini.file, 0}, {},
            fmt::format("lbpkit read no HAL command in the {} HAL file{} the INI names (the warnings say why): nothing "
                        "was checked, so this is no pass",
                        hal.halFilesNamed, hal.halFilesNamed == 1 ? "" : "s"));
  }

  // hm2_eth's board_ip=: each board's address a card can have (board_address.hpp),
  // reported where it is written: the INI's line for board_ip=[HM2]IPADDRESS.
  for (const auto& d : hal.drivers) {
    if (d.module != "hm2_eth" || !d.boardIpFound) continue;
    const bool fromIni = d.boardIpAt.file != d.at.file || d.boardIpAt.line != d.at.line;
    std::size_t from = 0;
    for (unsigned board = 0;; ++board) {
      const auto comma = d.boardIps.find(',', from);
      const std::string address = d.boardIps.substr(from, comma == std::string::npos ? std::string::npos : comma - from);
      if (auto problem = boardAddressProblem(address)) {
        const std::string which = comma == std::string::npos && from == 0 ? "" : fmt::format(" (board {})", board);
        // A loopback address is no card's, but `lbpkit sim` on this PC
        // answers there, for a LinuxCNC whose hm2_eth takes it: a warning.
        const auto ip = parseIpv4(address);
        const bool loopback = ip && (ip->value >> 24) == 127;
        if (loopback)
          *problem += "; only an lbpkit sim on this PC answers there, and lbpkit linuxcnc needs the card's own address";
        r.error(d.boardIpAt, "board_ip",
                fromIni ? fmt::format("board_ip={}{} at {}:{}: {}", d.boardIpWritten, which, d.at.file, d.at.line,
                                      *problem)
                        : fmt::format("board_ip{}: {}", which, *problem),
                {}, loopback ? "warning" : "error");
      }
      if (comma == std::string::npos) break;
      from = comma + 1;
    }
  }

  // The boards: each hostmot2 prefix the configuration names, made by the
  // driver that loads that kind of card.
  std::set<std::string> prefixes;
  for (const auto& ref : r.hal.refs)
    if (hal_name::isHostMot2(ref.name) && !boardOf(ref.name).empty()) prefixes.insert(boardOf(ref.name));
  std::map<std::string, std::size_t> boardIndex;
  std::vector<std::vector<Board>> candidates;  // per board, what it may be
  std::set<std::string> unknownBoards;
  for (const auto& prefix : prefixes) {
    const std::string want = isEthernet(prefix) ? "hm2_eth" : "hm2_pci";
    const DriverLine* d = nullptr;
    for (const auto& dr : r.hal.drivers)
      if (dr.module == want) d = &dr;
    const Reference* first = nullptr;
    for (const auto& ref : r.hal.refs)
      if (boardOf(ref.name) == prefix) {
        first = &ref;
        break;
      }
    if (!d) {
      std::string loaded;
      for (const auto& dr : r.hal.drivers) loaded += " " + dr.module;
      r.error(first->at, prefix,
              fmt::format("no board {}: it is made by {}, which the configuration does not load{}", prefix, want,
                          loaded.empty() ? std::string() : " (it loads" + loaded + ")"));
      unknownBoards.insert(prefix);
      continue;
    }
    std::vector<std::string> problems;
    const auto config = parseHm2Config(d->config, &problems);
    for (const auto& p : problems) r.error(d->at, "config", p);
    unsigned sevenI77s = 1;
    for (const auto& ref : r.hal.refs)
      if (ref.name.rfind(prefix + ".7i77.0.3.", 0) == 0 || ref.name.rfind(prefix + ".7i77.0.4.", 0) == 0) sevenI77s = 2;
    Board b;
    b.prefix = prefix;
    b.driver = d->module;
    b.config = d->config;
    b.boardIp = d->boardIp;
    b.file = d->at.file;
    b.line = d->at.line;
    std::string why;
    auto options = model(b, config, sevenI77s, why);
    if (options.empty()) {
      r.error(first->at, prefix, fmt::format("lbpkit does not know the board {}: {}", prefix, why));
      unknownBoards.insert(prefix);
      continue;
    }
    boardIndex[prefix] = candidates.size();
    candidates.push_back(std::move(options));
  }

  // Each board with more than one candidate (cards of one LinuxCNC name,
  // their firmwares): the one under which the configuration has the fewest
  // errors, the first of them on a tie; boards one after the other.
  std::vector<std::size_t> choice(candidates.size(), 0);
  auto chosen = [&] {
    std::vector<const Board*> boards;
    for (std::size_t k = 0; k < candidates.size(); ++k) boards.push_back(&candidates[k][choice[k]]);
    return boards;
  };
  auto run = [&](std::vector<Finding>& findings, unsigned& references) {
    r.findings = &findings;
    evaluate(r, chosen(), boardIndex, references);
    r.findings = &result.findings;
  };
  for (std::size_t k = 0; k < candidates.size(); ++k) {
    if (candidates[k].size() < 2) continue;
    std::size_t best = 0, fewest = std::string::npos;
    for (std::size_t c = 0; c < candidates[k].size(); ++c) {
      choice[k] = c;
      std::vector<Finding> findings;
      unsigned references = 0;
      run(findings, references);
      const auto errors = static_cast<std::size_t>(
          std::count_if(findings.begin(), findings.end(), [](const Finding& f) { return f.severity == "error"; }));
      if (errors < fewest) {
        fewest = errors;
        best = c;
      }
    }
    choice[k] = best;
  }
  run(result.findings, result.references);
  for (std::size_t k = 0; k < candidates.size(); ++k) {
    result.boards.push_back(candidates[k][choice[k]]);
    result.boards.back().candidates = candidates[k].size();
  }

  std::stable_sort(result.findings.begin(), result.findings.end(), [](const Finding& a, const Finding& b) {
    return a.file == b.file ? a.line < b.line : false;
  });
  return result;
}

}  // namespace lbpkit::linuxcnc
