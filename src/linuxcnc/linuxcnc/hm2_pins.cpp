// SPDX-License-Identifier: MIT
// LinuxCNC 2.9's hostmot2 naming and pin allocation rules, as facts
// (hostmot2(9), sserial(9), and what the driver does against `lbpkit sim`:
// tests/interop/pins_test.cpp compares this list with halcmd's, pin for pin).
#include "linuxcnc/hm2_pins.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>

#include "lbpkit/wire/hostmot2.hpp"
#include "lbpkit/wire/names.hpp"
#include "linuxcnc/hal_name.hpp"

namespace lbpkit::linuxcnc {

namespace tag = wire::hm2::tag;
namespace pinbits = wire::hm2::pin;

// hostmot2's default config.stepgen_width: StepGen output pins past Step and
// Dir (table mode) stay GPIO unless stepgen_width= says otherwise.
constexpr int kDefaultStepgenWidth = 2;

Origin Origin::function(std::string name) {
  Origin o("function " + name);
  o.kind = Kind::Function;
  o.name = std::move(name);
  return o;
}

Origin Origin::remote(std::string text, std::string name, unsigned port, unsigned channel) {
  Origin o(std::move(text));
  o.kind = Kind::Remote;
  o.name = std::move(name);
  o.port = port;
  o.channel = channel;
  return o;
}

Origin Origin::ioPin(std::string text, std::string function) {
  Origin o(std::move(text));
  o.kind = Kind::IoPin;
  o.name = std::move(function);
  return o;
}

std::string kindName(Kind k) { return k == Kind::Pin ? "pin" : "param"; }
std::string typeName(Type t) {
  switch (t) {
    case Type::Bit: return "bit";
    case Type::Float: return "float";
    case Type::S32: return "s32";
    case Type::U32: return "u32";
  }
  return "?";
}
std::string dirName(Dir d) {
  switch (d) {
    case Dir::In: return "IN";
    case Dir::Out: return "OUT";
    case Dir::IO: return "I/O";
    case Dir::RO: return "RO";
    case Dir::RW: return "RW";
  }
  return "?";
}

namespace {

// hostmot2(9)'s config= keys that take a count.
const char* const kCountKeys[] = {"num_encoders", "num_resolvers", "num_pwmgens", "num_rcpwmgens", "num_inmuxs",
                                  "num_inms", "num_outms", "num_oneshots", "num_ssrs", "num_xy2mods",
                                  "num_3pwmgens", "num_stepgens", "stepgen_width", "num_bspis", "num_uarts",
                                  "num_pktuarts", "num_leds", "num_dplls"};

class Builder {
 public:
  void pin(std::string name, Type t, Dir d, const Origin& origin) {
    items_.push_back({std::move(name), Kind::Pin, t, d, {}, origin});
  }
  void param(std::string name, Type t, Dir d, const Origin& origin, std::string also = {}) {
    items_.push_back({std::move(name), Kind::Param, t, d, std::move(also), origin});
  }
  std::vector<Item> take() {
    std::sort(items_.begin(), items_.end(), [](const Item& a, const Item& b) { return a.name < b.name; });
    return std::move(items_);
  }

 private:
  std::vector<Item> items_;
};

// A function exported with hal_export_funct: HAL adds its time pin and tmax
// parameters.
void function(Builder& b, const std::string& name) {
  const auto origin = Origin::function(name);
  b.pin(name + ".time", Type::S32, Dir::Out, origin);
  b.param(name + ".tmax", Type::S32, Dir::RW, origin);
  b.param(name + ".tmax-increased", Type::Bit, Dir::RO, origin);
}

int enabled(const Hm2Config& c, const char* key, unsigned available) {
  const int n = c.count(key);
  if (n < 0) return static_cast<int>(available);
  return std::min(n, static_cast<int>(available));
}

// The name hostmot2 gives a module's output pin (its secondary function).
std::optional<std::string> secondaryName(const PinInfo& p) {
  const unsigned code = p.secondaryPin & pinbits::kCodeMask;
  switch (p.secondaryTag) {
    case tag::kMuxedQCountSel:
      if (code == 1) return "sel0";
      if (code == 2) return "sel1";
      return std::nullopt;
    case tag::kSSerial:
      if (!p.output()) return std::nullopt;
      if (code >= 0x1 && code <= 0x8) return fmt::format("tx{}", code - 1);
      if (code >= 0x11 && code <= 0x18) return fmt::format("txen{}", code - 0x11);
      return std::nullopt;
    case tag::kStepGen: {
      static const char* const names[] = {"step",   "direction", "table2", "table3", "table4",
                                          "table5", "table6",    "table7", "index",  "probe"};
      if (code >= 1 && code <= 10) return names[code - 1];
      return std::nullopt;
    }
    case tag::kPwm:
      if (code == 1) return "out0";
      if (code == 2) return "out1";
      if (code == 3) return "enable";
      return std::nullopt;
    default: return std::nullopt;
  }
}

std::optional<std::string> generalName(std::uint8_t t) {
  switch (t) {
    case tag::kQCount:
    case tag::kMuxedQCount:
    case tag::kMuxedQCountSel:
    case tag::kSSerial:
    case tag::kStepGen:
    case tag::kPwm: return std::string(wire::hm2::moduleKind(t)->halWord);
    // InM, SSR and OutM have hostmot2 names, but no names for their pins'
    // functions: their output pins keep only the gpio.NNN parameters.
    default: return std::nullopt;
  }
}

void remoteItems(Builder& b, const std::string& base, const Remote& r) {
  const auto origin = Origin::remote(
      fmt::format("{} on smart-serial port {} channel {} (mode {})", r.name, r.port, r.channel, r.mode), r.name, r.port,
      r.channel);
  for (const auto& e : r.description.processData) {
    const auto name = base + "." + wire::asciiLower(e.name);
    const Dir d = e.direction == Direction::Input ? Dir::Out : e.direction == Direction::Output ? Dir::In : Dir::IO;
    switch (e.type) {
      case DataType::Bits:
        for (unsigned j = 0; j < e.bits; ++j) {
          const auto bit = fmt::format("{}-{:02d}", name, j);
          b.pin(bit, Type::Bit, d, origin);
          if (d == Dir::Out) b.pin(bit + "-not", Type::Bit, d, origin);
          if (d == Dir::In) b.param(bit + "-invert", Type::Bit, Dir::RW, origin);
        }
        break;
      case DataType::Unsigned:
      case DataType::Signed:
        b.pin(name, Type::Float, d, origin);
        b.param(name + "-scalemax", Type::Float, Dir::RW, origin);
        if (d != Dir::Out) {
          b.param(name + "-maxlim", Type::Float, Dir::RW, origin);
          b.param(name + "-minlim", Type::Float, Dir::RW, origin);
        }
        break;
      case DataType::Stream: b.pin(name, Type::U32, d, origin); break;
      case DataType::Boolean:
        b.pin(name, Type::Bit, d, origin);
        if (d == Dir::Out) b.pin(name + "-not", Type::Bit, d, origin);
        if (d == Dir::In) b.param(name + "-invert", Type::Bit, Dir::RW, origin);
        break;
      case DataType::Encoder:
        b.pin(name + ".count", Type::S32, Dir::Out, origin);
        b.pin(name + ".rawcounts", Type::S32, Dir::Out, origin);
        b.pin(name + ".position", Type::Float, Dir::Out, origin);
        b.pin(name + ".index-enable", Type::Bit, Dir::IO, origin);
        b.pin(name + ".reset", Type::Bit, Dir::IO, origin);
        b.param(name + ".scale", Type::Float, Dir::RW, origin);
        b.param(name + ".counts-per-rev", Type::U32, Dir::RW, origin);
        break;
      case DataType::Float: b.pin(name, Type::Float, d, origin); break;
      default: break;  // pad; non-volatile types never appear in a PTOC
    }
  }
  // The GTOC's data records not in the PTOC become parameters: read-only
  // when the remote only reports them (sserial(9)).
  for (const auto& e : r.description.parameters) {
    const auto name = base + "." + wire::asciiLower(e.name);
    const Dir d = e.direction == Direction::Input ? Dir::RO : Dir::RW;
    switch (e.type) {
      case DataType::Unsigned:
      case DataType::NonVolUnsigned: b.param(name, Type::U32, d, origin); break;
      case DataType::Signed:
      case DataType::NonVolSigned: b.param(name, Type::S32, d, origin); break;
      case DataType::Float:
      case DataType::NonVolFloat: b.param(name, Type::Float, d, origin); break;
      default: break;
    }
  }
}

// The HM2DPLL (dpll.c): one set of pins for the module, whatever
// num_dplls says beyond 0.
void dpllItems(Builder& b, const std::string& p) {
  struct Named {
    const char* name;
    Type type;
    Dir dir;
  };
  static const Named pins[] = {{"01.timer-us", Type::Float, Dir::In},   {"02.timer-us", Type::Float, Dir::In},
                               {"03.timer-us", Type::Float, Dir::In},   {"04.timer-us", Type::Float, Dir::In},
                               {"base-freq-khz", Type::Float, Dir::In}, {"phase-error-us", Type::Float, Dir::Out},
                               {"time-const", Type::U32, Dir::In},      {"plimit", Type::U32, Dir::In},
                               {"ddsize", Type::U32, Dir::Out},         {"prescale", Type::U32, Dir::Out}};
  for (const auto& n : pins) b.pin(p + ".dpll." + n.name, n.type, n.dir, "the HM2DPLL");
}

// StepGens (stepgen.c, hostmot2(9) "stepgen"). Version 0x42 adds
// swap_step_dir, 0xC2 also the index and probe pins. The table-data
// parameters come when a pin descriptor of the instance has a secondary pin
// code above 2; hostmot2 compares the whole code, output bit included, so
// every StepGen with Step and Dir outputs has them.
void stepgenItems(Builder& b, const std::string& p, const CardInfo& card, const ModuleInfo& m, int n, bool dpll) {
  const bool swap = m.version == 0x42 || m.version == 0xC2;
  const bool index = m.version == 0xC2;
  if (dpll) b.pin(p + ".stepgen.timer-number", Type::S32, Dir::In, "the StepGens (HM2DPLL timer)");
  for (int i = 0; i < n; ++i) {
    const auto s = hal_name::module(p, "stepgen", static_cast<unsigned>(i));
    const auto origin = fmt::format("StepGen {}", i);
    for (const char* x : {"position-cmd", "velocity-cmd"}) b.pin(s + "." + x, Type::Float, Dir::In, origin);
    for (const char* x : {"velocity-fb", "position-fb"}) b.pin(s + "." + x, Type::Float, Dir::Out, origin);
    b.pin(s + ".counts", Type::S32, Dir::Out, origin);
    for (const char* x : {"enable", "control-type", "position-reset"}) b.pin(s + "." + x, Type::Bit, Dir::In, origin);
    if (index) {
      b.pin(s + ".position-latch", Type::Float, Dir::Out, origin);
      for (const char* x : {"index-enable", "probe-enable"}) b.pin(s + "." + x, Type::Bit, Dir::IO, origin);
      for (const char* x : {"index-invert", "probe-invert"}) b.pin(s + "." + x, Type::Bit, Dir::In, origin);
    }
    for (const char* x : {"dbg_pos_minus_prev_cmd", "dbg_ff_vel", "dbg_s_to_match", "dbg_vel_error", "dbg_err_at_match"})
      b.pin(s + "." + x, Type::Float, Dir::Out, origin);
    b.pin(s + ".dbg_step_rate", Type::S32, Dir::Out, origin);
    for (const char* x : {"position-scale", "maxvel", "maxaccel"}) b.param(s + "." + x, Type::Float, Dir::RW, origin);
    for (const char* x : {"steplen", "stepspace", "dirsetup", "dirhold", "step_type"})
      b.param(s + "." + x, Type::U32, Dir::RW, origin);
    if (swap) b.param(s + ".swap_step_dir", Type::Bit, Dir::RW, origin);
    unsigned width = 0;
    for (const auto& pin : card.pins)
      if (pin.secondaryTag == tag::kStepGen && static_cast<int>(pin.secondaryUnit) == i) width = std::max<unsigned>(width, pin.secondaryPin);
    if (width > 2)
      for (int t = 0; t < 4; ++t) b.param(fmt::format("{}.table-data-{}", s, t), Type::U32, Dir::RW, origin);
  }
}

// PWMGens (pwmgen.c, hostmot2(9) "pwmgen").
void pwmgenItems(Builder& b, const std::string& p, int n) {
  for (const char* x : {"pwm_frequency", "pdm_frequency"})
    b.param(p + ".pwmgen." + x, Type::U32, Dir::RW, "the PWMGens");
  for (int i = 0; i < n; ++i) {
    const auto s = hal_name::module(p, "pwmgen", static_cast<unsigned>(i));
    const auto origin = fmt::format("PWMGen {}", i);
    b.pin(s + ".value", Type::Float, Dir::In, origin);
    b.pin(s + ".enable", Type::Bit, Dir::In, origin);
    b.param(s + ".offset-mode", Type::Bit, Dir::RW, origin);
    b.param(s + ".scale", Type::Float, Dir::RW, origin);
    b.param(s + ".output-type", Type::S32, Dir::RW, origin);
  }
}

// InM (inm.c): per instance its scan width's inputs, four MPG counters.
// hostmot2 reads the width from the control register (MaxBit + 1); lbpkit
// takes the highest input the pin descriptors wire to the instance (input
// n is secondary pin n + 1), which is the same on Mesa's firmwares.
void inmItems(Builder& b, const std::string& p, const CardInfo& card, int n) {
  for (int i = 0; i < n; ++i) {
    const auto s = hal_name::module(p, "inm", static_cast<unsigned>(i));
    const auto origin = fmt::format("InM {}", i);
    unsigned width = 0;
    for (const auto& pin : card.pins)
      if (pin.secondaryTag == tag::kInM && static_cast<int>(pin.secondaryUnit) == i)
        width = std::max<unsigned>(width, pin.secondaryPin & pinbits::kCodeMask);
    for (const char* x : {"scan_rate", "slow_scans", "fast_scans"}) b.param(s + "." + x, Type::U32, Dir::RW, origin);
    for (int e = 0; e < 4; ++e) b.param(fmt::format("{}.enc{}_4xmode", s, e), Type::Bit, Dir::RW, origin);
    b.param(s + ".scan_width", Type::U32, Dir::RO, origin);
    for (unsigned j = 0; j < width; ++j) {
      for (const char* x : {"input-{:02d}", "raw-input-{:02d}", "input-{:02d}-not", "raw-input-{:02d}-not"})
        b.pin(s + "." + fmt::format(fmt::runtime(x), j), Type::Bit, Dir::Out, origin);
      b.pin(fmt::format("{}.input-{:02d}-slow", s, j), Type::Bit, Dir::In, origin);
    }
    for (int e = 0; e < 4; ++e) {
      b.pin(fmt::format("{}.enc{}-count", s, e), Type::S32, Dir::Out, origin);
      b.pin(fmt::format("{}.enc{}-reset", s, e), Type::Bit, Dir::In, origin);
    }
  }
}

// SSR (ssr.c) and OutM (outm.c): an out-NN and invert-NN pin per output pin
// of the instance (secondary pin NN + 1; the SSR's 32nd, its internal AC
// reference, has none); the SSR also its rate.
void outputModuleItems(Builder& b, const std::string& p, const CardInfo& card, std::uint8_t t, int n) {
  const bool ssr = t == tag::kSsr;
  for (int i = 0; i < n; ++i) {
    const auto s = hal_name::module(p, ssr ? "ssr" : "outm", static_cast<unsigned>(i));
    const auto origin = fmt::format("{} {}", ssr ? "SSR" : "OutM", i);
    if (ssr) b.pin(s + ".rate", Type::U32, Dir::In, origin);
    for (const auto& pin : card.pins) {
      if (pin.secondaryTag != t || static_cast<int>(pin.secondaryUnit) != i) continue;
      const unsigned number = (pin.secondaryPin & pinbits::kCodeMask) - 1U;
      if (number >= (ssr ? 31U : 32U)) continue;
      b.pin(fmt::format("{}.out-{:02d}", s, number), Type::Bit, Dir::In, origin);
      b.pin(fmt::format("{}.invert-{:02d}", s, number), Type::Bit, Dir::In, origin);
    }
  }
}

}  // namespace

int Hm2Config::count(const std::string& key) const {
  const auto it = counts.find(key);
  return it == counts.end() ? -1 : it->second;
}

char Hm2Config::mode(unsigned port, unsigned channel) const {
  const auto it = sserialPorts.find(port);
  if (it == sserialPorts.end() || channel >= it->second.size()) return '0';
  return it->second[channel];
}

std::uint8_t Hm2Config::channelMask(unsigned port) const {
  std::uint8_t m = 0;
  for (unsigned c = 0; c < 8; ++c)
    if (mode(port, c) != 'x') m = static_cast<std::uint8_t>(m | (1U << c));
  return m;
}

std::string hm2ConfigKeys() {
  std::string s;
  for (const char* k : kCountKeys) s += std::string(k) + "=N ";
  return s + "sserial_port_N=MODES enable_raw firmware=F";
}

Hm2Config parseHm2Config(const std::string& text, std::vector<std::string>* problems) {
  Hm2Config c;
  auto problem = [&](std::string p) {
    if (problems) problems->push_back(std::move(p));
  };
  std::size_t at = 0;
  while (at < text.size()) {
    while (at < text.size() && std::isspace(static_cast<unsigned char>(text[at]))) ++at;
    if (at >= text.size()) break;
    auto end = at;
    while (end < text.size() && !std::isspace(static_cast<unsigned char>(text[end]))) ++end;
    const auto token = text.substr(at, end - at);
    at = end;
    const auto eq = token.find('=');
    const auto key = token.substr(0, eq);
    const auto value = eq == std::string::npos ? std::string() : token.substr(eq + 1);
    if (key.rfind("sserial_port_", 0) == 0) {
      const auto n = key.substr(13);
      if (n.size() != 1 || n[0] < '0' || n[0] > '3' || eq == std::string::npos) {
        problem(fmt::format("\"{}\": hostmot2 wants sserial_port_N=MODES with N 0..3", token));
        continue;
      }
      std::string modes;
      for (char ch : value) {
        if (((ch >= '0' && ch <= '9') || ch == 'x') && modes.size() < 8) modes += ch;
        else if (!(ch >= '0' && ch <= '9') && ch != 'x')
          problem(fmt::format("\"{}\": '{}' is neither a mode digit nor x (hostmot2 ignores it)", token, ch));
      }
      c.sserialPorts[static_cast<unsigned>(n[0] - '0')] = modes;
      c.sserialPortGiven = true;
      continue;
    }
    if (key == "enable_raw" || key == "firmware") continue;
    if (std::find_if(std::begin(kCountKeys), std::end(kCountKeys), [&](const char* k) { return key == k; }) ==
        std::end(kCountKeys)) {
      problem(fmt::format("\"{}\" is not a hostmot2 config= key (it knows: {})", key, hm2ConfigKeys()));
      continue;
    }
    char* stop = nullptr;
    const long v = std::strtol(value.c_str(), &stop, 0);
    if (value.empty() || *stop != '\0') {
      problem(fmt::format("\"{}\": {} wants a number", token, key));
      continue;
    }
    c.counts[key] = static_cast<int>(v);
  }
  return c;
}

std::string boardPrefix(const CardInfo& card, unsigned index) {
  std::string name = card.boardName;
  if (name.rfind("MESA", 0) == 0) name = name.substr(4);
  return hal_name::board(wire::asciiLower(name), index);
}

std::string boardPrefix(const std::string& halName, unsigned index) { return hal_name::board(halName, index); }

std::string hm2EthBoardName(const std::string& lbp16Name) {
  // hm2_eth copies four characters of most names, eight (the whole name) of
  // the 7I94, 7I95, 7I96, 7I96S and 7I97, five of the 7I76E-16; it lowers
  // the I (and a fifth letter).
  std::size_t keep = 4;
  if (lbp16Name.rfind("7I76E-16", 0) == 0) keep = 5;
  for (const char* whole : {"7I94", "7I95", "7I96", "7I96S", "7I97"})
    if (lbp16Name == whole) keep = 8;
  return wire::asciiLower(lbp16Name.substr(0, std::min(keep, lbp16Name.size())));
}

unsigned ledCount(const std::string& boardName) {
  const auto b = wire::asciiLower(boardName);
  if (b.find("5i25") != std::string::npos || b.find("6i25") != std::string::npos) return 2;
  for (const char* four : {"7i92", "7i76e", "7i96", "7i80", "7i93", "7i94", "7i95", "7i97", "7i98"})
    if (b.find(four) != std::string::npos) return 4;
  return 0;
}

std::map<std::string, unsigned> moduleInstances(const CardInfo& card) {
  std::map<std::string, unsigned> out;
  for (const auto& m : card.modules) {
    switch (m.tag) {
      case tag::kQCount:
      case tag::kMuxedQCount:
      case tag::kStepGen:
      case tag::kPwm:
      case tag::kDpll:
      case tag::kInM:
      case tag::kSsr:
      case tag::kOutM: out[std::string(wire::hm2::moduleKind(m.tag)->halWord)] = m.instances; break;
      default: break;
    }
  }
  return out;
}

std::vector<std::string> hm2CountProblems(const CardInfo& card, const Hm2Config& config) {
  struct Counted {
    const char* key;
    std::uint8_t tag;
    const char* module;
  };
  // The modules whose parse_md refuses a count above what the firmware has
  // (the HM2DPLL and the LEDs take what there is instead).
  static const Counted counted[] = {{"num_encoders", tag::kMuxedQCount, "MuxedQCount"},
                                    {"num_encoders", tag::kQCount, "QCount"},
                                    {"num_stepgens", tag::kStepGen, "StepGen"},
                                    {"num_pwmgens", tag::kPwm, "PWMGen"},
                                    {"num_inms", tag::kInM, "InM"},
                                    {"num_ssrs", tag::kSsr, "SSR"},
                                    {"num_outms", tag::kOutM, "OutM"}};
  std::vector<std::string> out;
  for (const auto& c : counted) {
    const auto* m = card.module(c.tag);
    const int n = config.count(c.key);
    if (m && n > static_cast<int>(m->instances))
      out.push_back(fmt::format("{}={}, but the firmware has {} {}{}: hostmot2 does not load (\"config.{}={}, but only "
                                "{} are available\")",
                                c.key, n, m->instances, c.module, m->instances == 1 ? "" : "s", c.key, n,
                                m->instances));
  }
  return out;
}

std::vector<Item> hostmot2Items(const CardInfo& card, const Hm2Config& config, const std::vector<Remote>& remotes,
                                Driver driver, unsigned boardIndex, const std::string& halName) {
  Builder b;
  const auto p = halName.empty() ? boardPrefix(card, boardIndex) : boardPrefix(halName, boardIndex);
  const std::string board = "the board";

  b.param(p + ".io_error", Type::Bit, Dir::RW, board);
  if (driver == Driver::Eth) {
    b.pin(p + ".packet-error", Type::Bit, Dir::Out, board);
    b.pin(p + ".packet-error-exceeded", Type::Bit, Dir::Out, board);
    b.pin(p + ".packet-error-level", Type::S32, Dir::Out, board);
    b.pin(p + ".packet-error-total", Type::U32, Dir::IO, board);
    b.param(p + ".packet-error-decrement", Type::S32, Dir::RO, board);
    b.param(p + ".packet-error-increment", Type::S32, Dir::RW, board);
    b.param(p + ".packet-error-limit", Type::S32, Dir::RW, board);
    b.param(p + ".packet-read-timeout", Type::S32, Dir::RW, board);
    function(b, p + ".read-request");  // hm2_eth splits the read
    function(b, p + ".read");
    function(b, p + ".write");
  } else {
    function(b, p + ".read");
    function(b, p + ".write");
    function(b, p + ".read_gpio");  // the PCI driver is thread-safe
    function(b, p + ".write_gpio");
  }

  if (card.module(tag::kWatchdog)) {
    b.pin(p + ".watchdog.has_bit", Type::Bit, Dir::IO, "the watchdog");
    b.param(p + ".watchdog.timeout_ns", Type::U32, Dir::RW, "the watchdog");
  }
  if (card.module(tag::kLed)) {
    const int n = enabled(config, "num_leds", ledCount(halName.empty() ? card.boardName : halName));
    for (int i = 0; i < n; ++i) b.pin(fmt::format("{}.led.CR{:02d}", p, i + 1), Type::Bit, Dir::In, "the LEDs");
  }

  // Encoders (QCount or MuxedQCount: one "encoder" set of names).
  const ModuleInfo* enc = card.module(tag::kMuxedQCount);
  const bool muxed = enc != nullptr;
  if (!enc) enc = card.module(tag::kQCount);
  const int encoders = enc ? enabled(config, "num_encoders", enc->instances) : 0;
  for (int i = 0; i < encoders; ++i) {
    const auto e = hal_name::module(p, "encoder", static_cast<unsigned>(i));
    const auto origin = fmt::format("encoder {}", i);
    for (const char* s : {"count", "count-latched", "rawcounts", "rawlatch"}) b.pin(e + "." + s, Type::S32, Dir::Out, origin);
    for (const char* s : {"input-a", "input-b", "input-index", "quad-error"}) b.pin(e + "." + s, Type::Bit, Dir::Out, origin);
    for (const char* s : {"position", "position-latched", "velocity", "velocity-rpm"})
      b.pin(e + "." + s, Type::Float, Dir::Out, origin);
    b.pin(e + ".index-enable", Type::Bit, Dir::IO, origin);
    b.pin(e + ".quad-error-enable", Type::Bit, Dir::In, origin);
    b.pin(e + ".reset", Type::Bit, Dir::In, origin);
    for (const char* s : {"counter-mode", "filter", "index-invert", "index-mask", "index-mask-invert"})
      b.param(e + "." + s, Type::Bit, Dir::RW, origin);
    b.param(e + ".scale", Type::Float, Dir::RW, origin);
    b.param(e + ".vel-timeout", Type::Float, Dir::RW, origin);
  }
  // A firmware with an HM2DPLL: hostmot2 gives the encoders and StepGens a
  // timer-number pin (when the encoder's DPLL timer register reads back 0,
  // as on the cards with one), whatever num_dplls says.
  const bool dpll = card.module(tag::kDpll) != nullptr;
  if (encoders > 0) {
    b.pin(p + ".encoder.hires-timestamp", Type::Bit, Dir::In, "the encoders");
    b.pin(p + (muxed ? ".encoder.muxed-sample-frequency" : ".encoder.sample-frequency"), Type::U32, Dir::In,
          "the encoders");
    if (dpll) b.pin(p + ".encoder.timer-number", Type::S32, Dir::In, "the encoders (HM2DPLL timer)");
  }
  if (dpll && enabled(config, "num_dplls", 1) > 0) dpllItems(b, p);
  const ModuleInfo* stepgen = card.module(tag::kStepGen);
  const int stepgens = stepgen ? enabled(config, "num_stepgens", stepgen->instances) : 0;
  if (stepgens > 0) stepgenItems(b, p, card, *stepgen, stepgens, dpll);
  const ModuleInfo* pwmgen = card.module(tag::kPwm);
  const int pwmgens = pwmgen ? enabled(config, "num_pwmgens", pwmgen->instances) : 0;
  if (pwmgens > 0) pwmgenItems(b, p, pwmgens);
  auto instances = [&](std::uint8_t t, const char* key) {
    const ModuleInfo* m = card.module(t);
    return m ? enabled(config, key, m->instances) : 0;
  };
  const int inms = instances(tag::kInM, "num_inms");
  const int ssrs = instances(tag::kSsr, "num_ssrs");
  const int outms = instances(tag::kOutM, "num_outms");
  inmItems(b, p, card, inms);
  outputModuleItems(b, p, card, tag::kSsr, ssrs);
  outputModuleItems(b, p, card, tag::kOutM, outms);

  // Smart-serial ports: those the configuration names with a mode digit
  // (all of them when it names none).
  const ModuleInfo* ss = card.module(tag::kSSerial);
  unsigned ports = ss ? ss->instances : 0;
  if (config.sserialPortGiven) {
    unsigned n = 0;
    for (const auto& [port, modes] : config.sserialPorts)
      if (modes.find_first_of("0123456789") != std::string::npos) n = std::max(n, port + 1);
    ports = std::min(ports, n);
  }
  auto remoteAt = [&](unsigned port, unsigned channel) -> const Remote* {
    for (const auto& r : remotes)
      if (r.port == port && r.channel == channel) return &r;
    return nullptr;
  };
  for (unsigned i = 0; i < ports; ++i) {
    const auto origin = fmt::format("smart-serial port {}", i);
    const auto s = fmt::format("{}.sserial.port-{}", p, i);
    b.pin(fmt::format("{}.{}.debug", p, i), Type::S32, Dir::Out, origin);
    b.pin(s + ".run", Type::Bit, Dir::In, origin);
    for (const char* n : {"port_state", "port_state2", "port_state3", "fault-count"}) b.pin(s + "." + n, Type::U32, Dir::Out, origin);
    for (const char* n : {"fault-inc", "fault-dec", "fault-lim"}) b.param(s + "." + n, Type::U32, Dir::RW, origin);
    for (const auto& r : remotes) {
      if (r.port != i || config.mode(i, r.channel) == 'x') continue;
      std::string raw = r.name;
      if (raw.size() > 1) raw[1] = static_cast<char>(raw[1] | 0x20);  // as the driver lower-cases it
      remoteItems(b, hal_name::remote(p, raw, i, r.channel), r);
    }
  }

  // IO pins: every one reads as gpio.NNN.in/in_not; a pin no enabled module
  // takes is a full GPIO; a module's output pin gets its output parameters
  // under the module's name too.
  std::vector<std::uint8_t> gtag(card.pins.size(), tag::kIoPort);
  for (std::size_t i = 0; i < card.pins.size(); ++i) {
    const auto& pin = card.pins[i];
    const unsigned unit = pin.secondaryUnit;
    const bool global = (unit & 0x80) != 0;
    auto upTo = [&](int n) { return (global && n > 0) || static_cast<int>(unit) < n; };
    bool taken = false;
    switch (pin.secondaryTag) {
      case tag::kQCount: taken = upTo(encoders); break;
      case tag::kMuxedQCount: taken = upTo((encoders + 1) / 2); break;
      case tag::kMuxedQCountSel: taken = upTo(encoders); break;
      case tag::kSSerial: {
        const unsigned ch = (pin.secondaryPin & pinbits::kSSerialChannelMask) - 1U;
        taken = unit < ports && config.mode(unit, ch) != 'x' && remoteAt(unit, ch) != nullptr;
        break;
      }
      case tag::kStepGen: {
        // Outputs past stepgen_width (table mode) stay GPIO (stepgen.c).
        const int width = config.count("stepgen_width") >= 0 ? config.count("stepgen_width") : kDefaultStepgenWidth;
        taken = (global || static_cast<int>(unit) < stepgens) &&
                !(pin.output() && static_cast<int>(pin.secondaryPin & pinbits::kCodeMask) > width);
        break;
      }
      case tag::kPwm: taken = upTo(pwmgens); break;
      case tag::kInM: taken = upTo(inms); break;
      case tag::kSsr: taken = upTo(ssrs); break;
      case tag::kOutM: taken = upTo(outms); break;
      default: break;
    }
    if (taken) gtag[i] = pin.secondaryTag;
  }
  for (std::size_t i = 0; i < card.pins.size(); ++i) {
    const auto& pin = card.pins[i];
    const auto g = hal_name::module(p, "gpio", static_cast<unsigned>(i));
    const std::string does = gtag[i] == tag::kIoPort ? std::string("GPIO") : pin.function();
    const auto origin =
        Origin::ioPin(fmt::format("IO pin {} (connector {} pin {}): {}", i, pin.connector, pin.bit, does), does);
    b.pin(g + ".in", Type::Bit, Dir::Out, origin);
    b.pin(g + ".in_not", Type::Bit, Dir::Out, origin);
    if (gtag[i] == tag::kIoPort) {
      b.pin(g + ".out", Type::Bit, Dir::In, origin);
      for (const char* n : {"invert_output", "is_opendrain", "is_output"}) b.param(g + "." + n, Type::Bit, Dir::RW, origin);
      continue;
    }
    if (!pin.output()) continue;
    const auto general = generalName(gtag[i]);
    const auto function = secondaryName(pin);
    if (!general || !function) {
      for (const char* n : {"invert_output", "is_opendrain"}) b.param(g + "." + n, Type::Bit, Dir::RW, origin);
      continue;
    }
    // Pins of one unit with the same function: numbered when more than one.
    unsigned total = 0, mine = 0;
    for (std::size_t j = 0; j < card.pins.size(); ++j) {
      if (j == i) mine = total;
      if (gtag[j] == gtag[i] && card.pins[j].secondaryUnit == pin.secondaryUnit &&
          card.pins[j].secondaryPin == pin.secondaryPin)
        ++total;
    }
    const auto alias = total == 1 ? fmt::format("{}.{}.{:02d}.{}", p, *general, pin.secondaryUnit, *function)
                                  : fmt::format("{}.{}.{:02d}.{}.{}", p, *general, pin.secondaryUnit, mine, *function);
    for (const char* n : {"invert_output", "is_opendrain"})
      b.param(alias + "." + n, Type::Bit, Dir::RW, origin, g + "." + n);
  }
  return b.take();
}

}  // namespace lbpkit::linuxcnc
