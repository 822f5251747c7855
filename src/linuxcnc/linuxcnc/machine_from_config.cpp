// SPDX-License-Identifier: MIT
// The machine a configuration expects, from its INI and HAL files (the
// LinuxCNC INI documentation: [JOINT_n] and homing; hostmot2(9): encoder
// scale, analogout scalemax, stepgen position-scale; the 7I77 manual: the
// field inputs, sinking, read as on when a contact closes to field power).
#include "linuxcnc/machine_from_config.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <map>
#include <optional>
#include <set>

#include "linuxcnc/hal_name.hpp"

namespace lbpkit::linuxcnc {

bool DerivedMachine::ok() const {
  return std::none_of(findings.begin(), findings.end(), [](const Finding& f) { return f.severity == "error"; });
}

namespace {

std::vector<std::string> split(const std::string& s, char by) {
  std::vector<std::string> out;
  std::size_t from = 0;
  for (;;) {
    const auto at = s.find(by, from);
    out.push_back(s.substr(from, at == std::string::npos ? std::string::npos : at - from));
    if (at == std::string::npos) return out;
    from = at + 1;
  }
}

// A number as written, inf and nan included: the bounds each use puts on
// it (Bounds below) refuse those with the key that holds them.
std::optional<double> number(const std::string& s) {
  if (s.empty()) return std::nullopt;
  char* end = nullptr;
  const double v = std::strtod(s.c_str(), &end);
  if (end == s.c_str() || *end != '\0') return std::nullopt;
  return v;
}

// The joints LinuxCNC's motion controller has room for: EMCMOT_MAX_JOINTS
// (src/emc/motion/emcmotcfg.h, 16 since LinuxCNC 2.8); [KINS]JOINTS past it
// is refused by LinuxCNC at start.
constexpr unsigned kMaxJoints = 16;

// What a machine can have, each bound far past any real machine and inside
// what a machine file takes (src/config/config/machine_toml.cpp), so that a
// value within them gives a machine file that loads:
// - a scale (encoder counts, steps per unit): |scale| 1e-6 to 1e9, a
//   nanometre scale gives 1e6 counts/mm;
// - an analog output's scale (units/s, or rpm, at 10 V): 1e-6 to 1e9;
// - a velocity: at most 1e5 units/s (100 m/s in mm);
// - an acceleration: at most 1e7 units/s^2 (1e7 mm/s^2 is a thousand g);
// - a position (limits, HOME_OFFSET): within 1e5 mm (100 m) of 0; a rotary
//   joint's "unlimited" limits (-9999999) are taken as +-1e5 degrees.
// What a derived value must stay within (the machine file's own bounds) is
// checked where it is worked out, naming the INI keys it comes from.
struct Bound {
  double low, high;  // on |v|; low 0 allows 0
  const char* what;  // "a scale"
  const char* range;  // "|scale| between 1e-6 and 1e9 counts per unit"
};
constexpr Bound kScaleBound{1e-6, 1e9, "a scale", "|scale| between 1e-6 and 1e9 counts or steps per unit"};
constexpr Bound kOutputScaleBound{1e-6, 1e9, "an output scale",
                                  "|scale| between 1e-6 and 1e9 units/s (or rpm) at 10 V"};
constexpr Bound kVelocityBound{0.0, 1e5, "a velocity", "|velocity| at most 1e5 units/s"};
constexpr Bound kAccelerationBound{0.0, 1e7, "an acceleration", "at most 1e7 units/s^2"};
constexpr Bound kFf1Bound{0.0, 1e6, "a feed-forward", "|FF1| at most 1e6"};
constexpr double kMaxPositionMm = 1e5;

// The 7I77's and 7I76's terminals (the 7I77 manual: 32 inputs, 16 outputs,
// 6 analog outputs, the 7I92's 7I77 firmware's 6 encoders; the 7I76 manual:
// 32 inputs, 16 outputs), hostmot2's at most 16 StepGens, and a card's IO
// pins (at most 6 ports of 24).
constexpr unsigned kFieldInputs = 32, kFieldOutputs = 16, kAnalogOutputs = 6, kEncoders = 6, kStepGens = 16,
                   kCardPins = 144;

// The limits of a machine file (src/config/config/machine_toml.cpp) a
// derived value must meet.
constexpr double kMaxEncoderLines = 1e6, kMinGear = 1e-3, kMaxGear = 1e3, kMinGain = 1e-6, kMaxLimit = 1e4,
                 kMinStepsPerMm = 1e-3, kMaxStepsPerMm = 1e6, kMaxStepRate = 1e7, kMaxOvertravel = 1e4,
                 kMinRpmPerVolt = 1e-3, kMaxRpmPerVolt = 1e5, kMaxRpm = 1e6;

// A machine's name from a file's: what a machine file's name allows (1 to
// 40 letters, digits, '_' or '-'; config/toml_reader.hpp), anything else a
// '-'.
std::string machineName(const std::string& stem) {
  std::string out;
  for (const char c : stem) {
    if (out.size() == 40) break;
    out += std::isalnum(static_cast<unsigned char>(c)) != 0 && static_cast<unsigned char>(c) < 0x80 ? c
           : c == '_' || c == '-'                                                                  ? c
                                                                                                   : '-';
  }
  return out.empty() ? std::string("machine") : out;
}

// Text for a TOML comment: one line of valid UTF-8 with no control
// character (what TOML allows in a comment), each byte that is not '?'.
std::string commentText(const std::string& s) {
  std::string out;
  for (std::size_t i = 0; i < s.size();) {
    const auto c = static_cast<unsigned char>(s[i]);
    if (c < 0x80) {
      out += c < 0x20 || c == 0x7F ? (c == '\t' ? ' ' : '?') : static_cast<char>(c);
      ++i;
      continue;
    }
    // A well-formed sequence of 2 to 4 bytes (no overlong form, no
    // surrogate, nothing past U+10FFFF), copied as it is.
    const std::size_t n = c >= 0xC2 && c <= 0xDF ? 2 : c >= 0xE0 && c <= 0xEF ? 3 : c >= 0xF0 && c <= 0xF4 ? 4 : 0;
    bool good = n > 0 && i + n <= s.size();
    for (std::size_t k = 1; good && k < n; ++k) good = (static_cast<unsigned char>(s[i + k]) & 0xC0) == 0x80;
    if (good && n >= 3) {
      const auto c1 = static_cast<unsigned char>(s[i + 1]);
      good = !(c == 0xE0 && c1 < 0xA0) && !(c == 0xED && c1 >= 0xA0) && !(c == 0xF0 && c1 < 0x90) &&
             !(c == 0xF4 && c1 >= 0x90);
    }
    if (!good) {
      out += '?';
      ++i;
      continue;
    }
    out.append(s, i, n);
    i += n;
  }
  return out;
}

std::optional<unsigned> digits(const std::string& s) {
  if (s.empty() || s.size() > 3 || !std::all_of(s.begin(), s.end(), [](char c) { return std::isdigit(static_cast<unsigned char>(c)); }))
    return std::nullopt;
  return static_cast<unsigned>(std::stoul(s));
}

std::string lower(std::string s) {
  for (auto& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

bool yes(const std::string& s) {
  const auto l = lower(s);
  return l == "yes" || l == "true" || l == "1";
}

// Where a 7I77 pin sits: hm2_<card>.<n>.7i77.<port>.<channel>.<pin>. The
// 7I77 firmwares have one smart-serial port of 6 channels (docs/cards.md):
// the first 7I77 answers on channel 0 (field I/O) and 1 (analog outputs), a
// second 7I77 on 3 and 4; channels 2 and 5 are their expansion ports. A
// machine file's machine sits behind the first 7I77 (connector 0). Empty
// for a field input, output or analog output of the first 7I77 (or a pin of
// no 7I77), else why the derived machine has no such terminal.
std::string offFirst7I77(const std::string& pin) {
  const auto r = hal_name::parseRemote(pin);
  if (!r || r->remote != "7i77") return {};
  const bool analog = r->leaf.rfind("analogout", 0) == 0;
  if (!analog && r->leaf.rfind("input-", 0) != 0 && r->leaf.rfind("output-", 0) != 0) return {};
  const unsigned own = analog ? 1 : 0;
  if (r->port == 0U && r->channel == own) return {};
  if (r->port == 0U && r->channel == own + 3)
    return fmt::format("on the second 7I77 (smart-serial channel {}), and lbpkit's derived machine sits behind the first "
                       "7I77 only",
                       r->channel);
  return fmt::format("on smart-serial port {} channel {}, where no 7I77 has its {}", r->port, r->channel,
                     analog ? "analog outputs (the first 7I77's are on channel 1, a second's on 4)"
                            : "field I/O (the first 7I77's is on channel 0, a second's on 3)");
}

// A pin of a 7I77's or 7I76's field I/O: hm2_<card>.<n>.<7i77|7i76>.<port>.<channel>.<input-NN[-not]|output-NN>,
// or an input on one of the card's own IO pins.
struct FieldPin {
  std::string daughtercard;  // "7I77", "7I76", "card"
  unsigned number = 0;
  bool inverted = false;  // input-NN-not
};

std::optional<FieldPin> fieldPin(const std::string& pin, const std::string& what) {
  // An input on the card's own IO pins: hm2_<card>.<n>.gpio.NNN.in[_not]
  // (the 7I96S's TB3 inputs).
  if (const auto m = hal_name::parseModule(pin); m && m->module == "gpio") {
    if (what == "input" && (m->leaf == "in" || m->leaf == "in_not")) return FieldPin{"card", m->instance, m->leaf == "in_not"};
    return std::nullopt;
  }
  const auto r = hal_name::parseRemote(pin);
  if (!r || r->leaf.rfind(what + "-", 0) != 0 || !offFirst7I77(pin).empty()) return std::nullopt;
  auto rest = r->leaf.substr(what.size() + 1);
  FieldPin f{r->remote == "7i77" ? "7I77" : "7I76", 0, false};
  if (rest.size() > 4 && rest.ends_with("-not")) {
    f.inverted = true;
    rest.resize(rest.size() - 4);
  }
  const auto n = digits(rest);
  if (!n) return std::nullopt;
  f.number = *n;
  return f;
}

// hm2_<card>.<n>.<module>.NN.<leaf> -> NN
std::optional<unsigned> modulePin(const std::string& pin, const std::string& module, const std::string& leaf) {
  const auto m = hal_name::parseModule(pin);
  if (!m || m->module != module || m->leaf != leaf) return std::nullopt;
  return m->instance;
}

// hm2_<card>.<n>.7i77.<port>.<channel>.analogoutK -> K: the first 7I77's
// (any 7I77's with anyChannel).
std::optional<unsigned> analogOut(const std::string& pin, bool anyChannel = false) {
  const auto r = hal_name::parseRemote(pin);
  if (!r || r->remote != "7i77" || r->leaf.rfind("analogout", 0) != 0) return std::nullopt;
  if (!anyChannel && !offFirst7I77(pin).empty()) return std::nullopt;
  return digits(r->leaf.substr(9));
}

// The board a pin is on: "hm2_7i92.0", or "".
std::string cardOf(const std::string& pin) {
  const auto n = hal_name::parse(pin);
  return n ? n->prefix() : std::string();
}

std::string fmtNumber(double v) {
  if (std::abs(v - std::round(v)) < 1e-9 && std::abs(v) < 1e12) return fmt::format("{:.1f}", std::round(v));
  return fmt::format("{:.6g}", v);
}

// The encoder lines a motor turn gives `countsPerMm` on a screw of `pitch`
// mm: whole lines, and the gear ratio (motor turns per screw turn) that
// makes the counts exact where the pitch alone does not.
struct Lines {
  unsigned long lines = 1;
  double gear = 1.0;
};
Lines encoderLines(double countsPerMm, double pitch) {
  const double exact = countsPerMm * pitch / 4.0;
  if (std::abs(exact - std::round(exact)) <= 1e-6 && std::round(exact) >= 1)
    return {static_cast<unsigned long>(std::round(exact)), 1.0};
  const double lines = std::max(1.0, std::round(exact));
  return {static_cast<unsigned long>(lines), countsPerMm * pitch / (4.0 * lines)};
}

// A value the configuration gives, and where it says so: `from` for the
// machine file's comment, `said` (the key or setp as written) and `at` for
// an error (machine_from_config.hpp).
using Value = ConfigValue;

// A field input whose state reaches a pin, and whether it arrives inverted
// (an odd number of `not`s and input-NN-not on the way).
struct Source {
  std::string pin;
  FieldPin field;
  bool inverted = false;
};

struct SwitchOut {
  std::string name, kind, daughtercard, contact, axis, comment;
  unsigned input = 0;
  std::optional<double> position;
  bool tripAbove = true;
  std::string pin;  // the field pin it is on, as netted
};

struct OutputOut {
  std::string name, daughtercard, comment;
  unsigned output = 0;
};

struct AxisOut {
  std::string name, comment;
  std::vector<std::pair<std::string, std::string>> keys;  // key = value, comment
  std::string tableName;                                  // "axis.drive" or "axis.stepper"
  std::vector<std::pair<std::string, std::string>> drive;
  std::vector<std::pair<std::string, std::string>> amplifier;
  int brakeOutput = -1;
  std::string brakeDaughtercard, brakeComment;
};

class Deriver {
 public:
  Deriver(const HalConfig& hal, std::vector<Finding>& findings, std::filesystem::path ini)
      : hal_(hal), findings_(findings), ini_(std::move(ini)) {
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
          const auto n = digits(a.substr(a.find('=') + 1)).value_or(1);
          for (unsigned i = 0; i < n; ++i) instances.push_back(fmt::format("{}.{}", dashed, i));
          named = true;
        } else if (c.module == "debounce" && a.rfind("cfg=", 0) == 0) {
          // Groups of filters, debounce.G.C (at most 8 groups of 50:
          // LinuxCNC's src/hal/components/debounce.c).
          const auto groups = split(a.substr(4), ',');
          for (std::size_t g = 0; g < std::min<std::size_t>(groups.size(), 8); ++g)
            for (unsigned ch = 0; ch < std::min(digits(groups[g]).value_or(0), 50U); ++ch)
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
          if (!text.empty() && end != nullptr && *end == '\0') personality_[instances[i]] = static_cast<unsigned>(v & 0xFFFFU);
        }
        if (i < messages.size()) messageText_[instances[i]] = messages[i];
      }
    }
    for (const auto& [signal, pins] : hal_.signals)
      for (const auto& p : pins) pinSignal_.emplace(p, signal);
  }

  std::string run() {
    for (const auto& p : pinSignal_)
      if (p.first.find(".7i76.") != std::string::npos) sevenI76_ = true;
    checkPins();
    const auto joints = jointCount();
    const auto letters = coordinates();
    const auto units = hal_.ini.find("TRAJ", "LINEAR_UNITS");
    const std::string u = units ? lower(units->value) : "mm";
    inch_ = u == "inch" || u == "in" || u == "imperial";
    std::map<std::string, unsigned> seen;
    for (unsigned n = 0; n < joints; ++n) {
      const char letter = n < letters.size() ? letters[n] : '\0';
      std::string name = letter ? std::string(1, static_cast<char>(std::tolower(static_cast<unsigned char>(letter))))
                                : fmt::format("joint{}", n);
      if (const auto k = seen[name]++; k > 0) name += std::to_string(k + 1);
      joint(n, letter, name);
    }
    if (axes_.empty() && !failed_)
      error({ini_.filename().string(), 0}, "",
            "no joint drives a 7I77 analog output or a StepGen: lbpkit cannot tell what this configuration moves");
    estop();
    probe();
    permissives();
    spindle();
    outputs();
    return failed_ ? std::string() : toml();
  }

 private:
  void error(const Where& w, const std::string& name, const std::string& reason) {
    findings_.push_back({w.file, w.line, "error", name, reason, {}});
    failed_ = true;
  }
  void warning(const Where& w, const std::string& name, const std::string& reason) {
    findings_.push_back({w.file, w.line, "warning", name, reason, {}});
  }

  // Whether a value (none: nothing to check) is within `b`; an error naming
  // where it is written when not.
  bool within(const std::optional<Value>& v, const Bound& b) {
    if (!v) return true;
    const double m = std::abs(v->v);
    if (std::isfinite(v->v) && m <= b.high && (m >= b.low || (b.low == 0.0 && m == 0.0)) &&
        (b.low == 0.0 || m > 0.0))
      return true;
    error(v->at, v->said, fmt::format("{} is not {} a machine can have ({})", v->said, b.what, b.range));
    return false;
  }
  // A position (a limit, HOME_OFFSET) within kMaxPositionMm of 0; a rotary
  // joint's beyond it is taken as there, with a warning.
  bool position(std::optional<Value>& v, double mmPerUnit, bool angular) {
    if (!v || (std::isfinite(v->v) && std::abs(v->v) * mmPerUnit <= kMaxPositionMm)) return true;
    if (angular && !std::isnan(v->v)) {
      warning(v->at, v->said,
              fmt::format("{}: a rotary joint turning past {} degrees is taken as turning to there", v->said,
                          fmtNumber(kMaxPositionMm)));
      v->v = std::copysign(kMaxPositionMm, v->v);
      v->from += fmt::format(", taken as {}", fmtNumber(v->v));
      return true;
    }
    error(v->at, v->said,
          fmt::format("{} is not a position a machine can have (within 1e5 mm, 100 m, of 0)", v->said));
    return false;
  }
  // A derived value within [low, high] of a machine file, else an error at
  // `v` (the INI key or setp it mostly comes from) saying what it gives.
  bool derived(double x, double low, double high, const Value& v, const std::string& what) {
    if (std::isfinite(x) && x >= low && x <= high) return true;
    error(v.at, v.said,
          fmt::format("{}: {} {:.6g}, and lbpkit's machine files take {:g} to {:g}", v.said, what, x, low, high));
    return false;
  }

  // An encoder's lines and gearing on the assumed screw within a machine
  // file's.
  bool encoderFits(const Lines& e, const Value& scale) {
    return derived(static_cast<double>(e.lines), 1.0, kMaxEncoderLines, scale,
                   "on the assumed 5 mm screw, encoder lines a motor turn of") &&
           derived(e.gear, kMinGear, kMaxGear, scale, "on the assumed 5 mm screw, a gear ratio of");
  }

  // Every 7I77, 7I76, encoder, StepGen and card pin the nets name exists on
  // the card: a number past the terminals is a pin LinuxCNC refuses. A field
  // input, output or analog output off the first 7I77 is left out, with a
  // warning.
  void checkPins() {
    for (const auto& [pin, sig] : pinSignal_) {
      if (const auto off = offFirst7I77(pin); !off.empty()) {
        warning(where(pin), pin, fmt::format("{} is {}, so this pin is left out", pin, off));
        continue;
      }
      std::optional<unsigned> n;
      unsigned count = 0;
      std::string what;
      if (const auto f = fieldPin(pin, "input")) {
        n = f->number;
        count = f->daughtercard == "card" ? kCardPins : kFieldInputs;
        what = f->daughtercard == "card" ? "card IO pins" : "inputs";
      } else if (const auto o = fieldPin(pin, "output")) {
        n = o->number;
        count = kFieldOutputs;
        what = "outputs";
      } else if (const auto a = analogOut(pin)) {
        n = a;
        count = kAnalogOutputs;
        what = "analog outputs";
      } else if (const auto e = modulePin(pin, "encoder", "position")) {
        n = e;
        // The 7I77 firmwares' counters 6 to 11 are a second 7I77's; with a
        // 7I76, counter 6 is its spindle encoder's.
        count = sevenI76_ ? kEncoders : 2 * kEncoders;
        what = "encoders";
      } else if (const auto sg = modulePin(pin, "stepgen", "position-cmd"); sg || modulePin(pin, "stepgen", "velocity-cmd")) {
        n = sg ? sg : modulePin(pin, "stepgen", "velocity-cmd");
        count = kStepGens;
        what = "StepGens";
      }
      if (n && *n >= count)
        error(where(pin), pin,
              fmt::format("{}: no such pin (the card has {} {}, 0 to {}): LinuxCNC refuses it", pin, count, what,
                          count - 1));
    }
  }

  [[nodiscard]] std::string signal(const std::string& pin) const {
    const auto it = pinSignal_.find(pin);
    return it == pinSignal_.end() ? std::string() : it->second;
  }
  [[nodiscard]] const std::vector<std::string>& pinsOn(const std::string& signal) const {
    static const std::vector<std::string> none;
    const auto it = hal_.signals.find(signal);
    return it == hal_.signals.end() ? none : it->second;
  }
  [[nodiscard]] Where where(const std::string& pin) const {
    for (const auto& r : hal_.refs)
      if (r.name == pin) return r.at;
    return {ini_.filename().string(), 0};
  }
  // Where a pin is connected, for a message: "signal S, with A, B".
  [[nodiscard]] std::string describe(const std::string& pin) const {
    const auto s = signal(pin);
    if (s.empty()) return "it is on no signal";
    std::string others;
    for (const auto& p : pinsOn(s))
      if (p != pin) others += (others.empty() ? "" : ", ") + p;
    return fmt::format("signal {} ({}), with {}", s, at(hal_.signalFirst.count(s) ? hal_.signalFirst.at(s) : Where{}),
                       others.empty() ? "nothing else" : others);
  }
  [[nodiscard]] std::string at(const Where& w) const { return fmt::format("{}:{}", w.file, w.line); }
  [[nodiscard]] std::string moduleOf(const std::string& instance) const {
    const auto it = instanceModule_.find(instance);
    return it == instanceModule_.end() ? std::string() : it->second;
  }

  // What HAL makes of the field inputs at rest: each bit pin a configuration
  // reads, as the components between a switch and what it stops compute it
  // once the inputs have stayed as they are for a while (LinuxCNC's
  // components, src/hal/components/: not.comp, and2.comp, or2.comp,
  // xor2.comp, logic.comp, debounce.c, timedelay.comp, estop_latch.comp,
  // oneshot.comp, edge.comp, toggle.comp). A node is one of those values.
  struct Node {
    enum class Kind { Const, Input, Not, And, Or, Xor, Unknown };
    Kind kind = Kind::Unknown;
    bool value = false;         // Const
    std::string pin;            // Input: the field pin as netted
    FieldPin field;             // Input (inverted: input-NN-not)
    std::string label;          // the component it is the output of ("not.0"), for a path
    std::vector<std::size_t> kids;
    std::string why;            // Const, Unknown: what it is
  };
  static constexpr unsigned kMaxDepth = 64;       // components in a row
  static constexpr std::size_t kMaxNodes = 20000;  // values in a configuration

  std::size_t add(Node n) {
    nodes_.push_back(std::move(n));
    return nodes_.size() - 1;
  }
  std::size_t constant(bool v, std::string why) { return add({Node::Kind::Const, v, {}, {}, {}, {}, std::move(why)}); }
  std::size_t unknown(std::string why) { return add({Node::Kind::Unknown, false, {}, {}, {}, {}, std::move(why)}); }
  std::size_t gate(Node::Kind k, std::string label, std::vector<std::size_t> kids) {
    return add({k, false, {}, {}, std::move(label), std::move(kids), {}});
  }

  // A bit as HAL's `setp` and `sets` take it: 1/0, TRUE/FALSE.
  static std::optional<bool> bit(const std::string& s) {
    const auto l = lower(s);
    if (l == "1" || l == "true") return true;
    if (l == "0" || l == "false") return false;
    if (const auto v = number(s)) return *v != 0.0;
    return std::nullopt;
  }

  // The value pin `pin` (one that reads a signal) has at rest.
  std::size_t nodeFor(const std::string& pin, unsigned depth = 0) {
    if (const auto it = nodeOf_.find(pin); it != nodeOf_.end()) return it->second;
    if (depth > kMaxDepth || nodes_.size() > kMaxNodes)
      return unknown(fmt::format("{}: more than {} components in a row", pin, kMaxDepth));
    if (!building_.insert(pin).second) return unknown(fmt::format("{} reads its own output (a loop)", pin));
    const auto id = computeNode(pin, depth);
    building_.erase(pin);
    nodeOf_.emplace(pin, id);
    return id;
  }

  std::size_t computeNode(const std::string& pin, unsigned depth) {
    const auto s = signal(pin);
    if (s.empty()) {
      if (const auto* sp = hal_.setpOf(pin))
        if (const auto b = bit(sp->value)) return constant(*b, fmt::format("setp {} {} ({})", pin, sp->value, at(sp->at)));
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

  // The value of a component's output pin `p`; nullopt when `p` is no
  // output of a component followed here (another reader of the signal).
  std::optional<std::size_t> outputNode(const std::string& p, unsigned depth) {
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

  // The field inputs whose state reaches `pin`, and whether each arrives
  // inverted (an odd number of `not`s, nand, nor, fault-in and
  // input-NN-not on the way).
  void trace(const std::string& pin, bool inverted, std::vector<Source>& out) {
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

  // An input's state at rest, chosen so that an interlock reads the way the
  // machine runs, or given by the switch on it.
  struct Held {
    bool on = false;
    std::string pin;      // the field pin, as netted
    std::string through;  // the components on the way ("debounce.0.0, not.0")
    std::string reason;   // "motion.feed-inhibit to be FALSE", "the x-min switch"
    Where at;             // where that is netted
  };
  using Holds = std::map<std::string, Held>;  // "7I77:12" -> its state

  // Something that must read one way for the machine to run.
  struct Interlock {
    std::string pin;
    bool want = false;
    std::string what;  // "motion.feed-inhibit to be FALSE"
  };

  // Steps a search may take: a configuration's logic needs a few hundred;
  // one built to branch without end stops here.
  static constexpr unsigned kSteps = 20000;
  struct Search {
    Holds holds;
    const Interlock* for_ = nullptr;
    unsigned budget = kSteps;
    std::vector<std::string> path;
  };

  static std::string key(const FieldPin& f) { return fmt::format("{}:{}", f.daughtercard, f.number); }

  // Makes node `id` read `want` by choosing inputs' states in `s.holds`:
  // false when it cannot. `lax`: a value lbpkit cannot follow (a signal
  // from motion, a ladder) is taken to read as wanted.
  bool require(std::size_t id, bool want, bool lax, Search& s) {
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
  bool requireXor(const std::vector<std::size_t>& kids, std::size_t from, bool want, bool lax, Search& s) {
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

  // Holds `i` by the inputs' states, given those already held: the
  // states it adds, or nullopt (and a warning saying why) when none does.
  std::optional<Holds> hold(const Interlock& i) {
    const auto root = nodeFor(i.pin);
    for (const bool lax : {false, true}) {
      Search s{holds_, &i, kSteps, {}};
      if (require(root, i.want, lax, s)) {
        Holds added;
        for (auto& [k, h] : s.holds)
          if (!holds_.count(k)) added.emplace(k, std::move(h));
        return added;
      }
    }
    // Alone, could it be held? Then what it needs is held the other way.
    Search alone{{}, &i, kSteps, {}};
    if (require(root, i.want, true, alone)) {
      std::string clash;
      for (const auto& [k, h] : alone.holds)
        if (const auto it = holds_.find(k); it != holds_.end() && it->second.on != h.on)
          clash += fmt::format("{}{} must read {} for it{} but reads {} for {} ({})", clash.empty() ? "" : "; ", h.pin,
                               h.on ? "on" : "off", h.through.empty() ? "" : " (through " + h.through + ")",
                               it->second.on ? "on" : "off", it->second.reason, at(it->second.at));
      warning(where(i.pin), i.pin,
              fmt::format("{} cannot be held: {}; the machine may stop on it", i.what,
                          clash.empty() ? "its inputs are held the other way" : clash));
    } else if (alone.budget == 0) {
      warning(where(i.pin), i.pin,
              fmt::format("{}: its logic has more ways than lbpkit tries; not held", i.what));
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
      warning(where(i.pin), i.pin,
              fmt::format("{} cannot be: no state of the field inputs gives it ({}); the machine may stop on it", i.what,
                          why.empty() ? "nothing reaches it" : why));
    }
    return std::nullopt;
  }

  // A value from a setp of `halName`, else from the INI's [section]key.
  [[nodiscard]] std::optional<Value> value(const std::string& halName, const std::string& section,
                                           const std::string& key) const {
    if (auto v = setpValue(halName)) return v;
    return iniValue(section, key);
  }
  // A value from the last setp of `halName` (a number), else none.
  [[nodiscard]] std::optional<Value> setpValue(const std::string& halName) const {
    const auto* s = hal_.setpOf(halName);
    if (!s) return std::nullopt;
    const auto v = number(s->value);
    if (!v) return std::nullopt;
    const auto written = s->written == s->value ? s->value : fmt::format("{} = {}", s->written, s->value);
    Value out{*v, fmt::format("{}: setp {} {}", at(s->at), halName, written), fmt::format("setp {} {}", halName, written),
              s->at, s->at};
    // A setp of [SECTION]KEY: an error names the INI's line.
    if (const auto close = s->written.find(']'); s->written.starts_with("[") && close != std::string::npos)
      if (const auto* e = hal_.ini.find(s->written.substr(1, close - 1), s->written.substr(close + 1))) {
        out.said = fmt::format("{} = {}", s->written, e->value);
        out.at = {e->file, e->line};
      }
    return out;
  }
  [[nodiscard]] std::optional<Value> iniValue(const std::string& section, const std::string& key) const {
    if (const auto* e = hal_.ini.find(section, key))
      if (const auto v = number(e->value))
        return Value{*v, fmt::format("[{}]{} = {} ({}:{})", section, key, e->value, e->file, e->line),
                     fmt::format("[{}]{} = {}", section, key, e->value), Where{e->file, e->line}, {}};
    return std::nullopt;
  }
  // Where [SECTION] is: the line above its first key in the INI; for a
  // section whose keys all come from a file the INI includes, its [SECTION]
  // line.
  [[nodiscard]] Where sectionWhere(const std::string& section) const {
    unsigned first = 0;
    bool keys = false;
    if (const auto s = hal_.ini.sections.find(section); s != hal_.ini.sections.end())
      for (const auto& [k, e] : s->second) {
        keys = true;
        if (e.file == hal_.ini.file && (first == 0 || e.line < first)) first = e.line;
      }
    if (first == 0 && keys)
      if (const auto at = hal_.ini.sectionAt.find(section); at != hal_.ini.sectionAt.end()) return at->second;
    return {ini_.filename().string(), first > 0 ? first - 1 : 0};
  }

  [[nodiscard]] unsigned jointCount() {
    unsigned n = 0;
    for (const char* pins : {"joint", "axis"}) {
      for (const auto& p : pinSignal_)
        if (p.first.rfind(std::string(pins) + ".", 0) == 0)
          n = std::max(n, digits(split(p.first, '.')[1]).value_or(0) + 1);
      if (n > 0) {
        jointPins_ = pins;
        break;
      }
    }
    auto given = iniValue("KINS", "JOINTS");
    if (!given && jointPins_ == "axis") given = iniValue("TRAJ", "AXES");
    if (given) {
      if (given->v >= 1 && given->v <= kMaxJoints && given->v == std::floor(given->v))
        return static_cast<unsigned>(given->v);
      error(given->at, given->said,
            fmt::format("{} is not a number of joints LinuxCNC has: 1 to {} (EMCMOT_MAX_JOINTS)", given->said,
                        kMaxJoints));
      return 0;
    }
    if (n > kMaxJoints) {
      const auto pin = std::find_if(pinSignal_.begin(), pinSignal_.end(), [&](const auto& p) {
        return p.first.rfind(jointPins_ + ".", 0) == 0 && digits(split(p.first, '.')[1]).value_or(0) >= kMaxJoints;
      });
      error(where(pin->first), pin->first,
            fmt::format("{}: LinuxCNC has joints 0 to {} (EMCMOT_MAX_JOINTS)", pin->first, kMaxJoints - 1));
      return 0;
    }
    return n;
  }
  [[nodiscard]] std::string coordinates() const {
    std::string letters;
    if (const auto* k = hal_.ini.find("KINS", "KINEMATICS"))
      for (const auto& w : split(k->value, ' '))
        if (w.rfind("coordinates=", 0) == 0) letters = w.substr(12);
    if (letters.empty())
      if (const auto* c = hal_.ini.find("TRAJ", "COORDINATES")) letters = c->value;
    std::string out;
    for (char c : letters)
      if (std::isalpha(static_cast<unsigned char>(c))) out += static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
    return out;
  }

  // Joint n's pins: LinuxCNC 2.8 and later name them joint.N; 2.7 axis.N.
  [[nodiscard]] std::string jointPins(unsigned n) const { return fmt::format("{}.{}.", jointPins_, n); }
  // Joint n's INI section: [JOINT_N] (2.8 and later), [AXIS_N] (2.7),
  // [AXIS_L].
  [[nodiscard]] std::string sectionOf(unsigned n, char letter) const {
    std::string section = fmt::format("JOINT_{}", n);
    if (!hal_.ini.sections.count(section)) section = fmt::format("AXIS_{}", n);
    if (!hal_.ini.sections.count(section) && letter) section = std::string("AXIS_") + letter;
    return section;
  }
  // The PID between a joint's command (signal `cmdSig`) and what drives the
  // motor: the pid instance whose command is on it ("" when none).
  [[nodiscard]] std::string pidOn(const std::string& cmdSig) const {
    std::string pid;
    for (const auto& p : pinsOn(cmdSig))
      if (p.ends_with(".command") && moduleOf(p.substr(0, p.size() - 8)) == "pid") pid = p.substr(0, p.size() - 8);
    return pid;
  }
  // Joint n's drive through `pid` on the 7I77 analog output `output`.
  [[nodiscard]] AnalogDrive analogDrive(unsigned n, const std::string& section, const std::string& pid,
                                        const std::string& output) const {
    const Where iniAt = sectionWhere(section);
    auto hostmot2 = [&](const std::string& parameter, double v) {
      return setpValue(output + "-" + parameter)
          .value_or(Value{v, fmt::format("hostmot2's default {} {:g} (none set)", parameter, v), {}, where(output), {}});
    };
    AnalogDrive d;
    d.joint = n;
    d.section = section;
    d.pid = pid;
    d.output = output;
    d.outputAt = where(output);
    d.scalemax = value(output + "-scalemax", section, "OUTPUT_SCALE")
                     .value_or(Value{10.0, "hostmot2's default scalemax 10 (none set)", {}, iniAt, {}});
    d.maxlim = hostmot2("maxlim", 10.0);
    d.minlim = hostmot2("minlim", -10.0);
    d.ff1 = value(pid + ".FF1", section, "FF1");
    d.maxVelocity = iniValue(section, "MAX_VELOCITY");
    return d;
  }

 public:
  // Every joint whose PID drives an analogoutN of a 7I77 (analogDrives()).
  std::vector<AnalogDrive> analogDrives() {
    const auto joints = jointCount();
    const auto letters = coordinates();
    std::vector<AnalogDrive> out;
    for (unsigned n = 0; n < joints; ++n) {
      const auto pid = pidOn(signal(jointPins(n) + "motor-pos-cmd"));
      if (pid.empty()) continue;
      for (const auto& p : pinsOn(signal(pid + ".output")))
        if (analogOut(p, true))
          out.push_back(analogDrive(n, sectionOf(n, n < letters.size() ? letters[n] : '\0'), pid, p));
    }
    return out;
  }

 private:
  void joint(unsigned n, char letter, const std::string& name) {
    const std::string jp = jointPins(n);
    const std::string section = sectionOf(n, letter);
    const auto fbSig = signal(jp + "motor-pos-fb"), cmdSig = signal(jp + "motor-pos-cmd");
    const Where iniAt = sectionWhere(section);
    if (fbSig.empty() || cmdSig.empty()) {
      warning(iniAt, jp + "motor-pos-cmd",
              fmt::format("joint {}: {}motor-pos-cmd or -fb is on no signal: no axis for it", n, jp));
      return;
    }
    const std::string pid = pidOn(cmdSig);
    std::optional<unsigned> encoder, analog, stepgen;
    std::string board, analogPin, encoderPin, offDrive;
    bool velocityStepgen = false;
    auto encoderOn = [&](const std::string& sig) {
      for (const auto& p : pinsOn(sig))
        if (const auto e = modulePin(p, "encoder", "position")) {
          encoder = *e;
          encoderPin = p;
          board = cardOf(p);
        }
    };
    encoderOn(fbSig);
    if (!encoder && !pid.empty()) encoderOn(signal(pid + ".feedback"));
    for (const auto& p : pinsOn(cmdSig))
      if (const auto s = modulePin(p, "stepgen", "position-cmd")) {
        stepgen = *s;
        board = cardOf(p);
      }
    if (!pid.empty())
      for (const auto& p : pinsOn(signal(pid + ".output"))) {
        if (const auto a = analogOut(p)) {
          analog = *a;
          analogPin = p;
          board = cardOf(p);
        } else if (analogOut(p, true)) {
          offDrive = p;
        }
        if (const auto s = modulePin(p, "stepgen", "velocity-cmd")) {
          stepgen = *s;
          velocityStepgen = true;
          board = cardOf(p);
        }
      }
    // A drive or an encoder off the first 7I77 is on no terminal of the
    // machine's.
    if (!stepgen && !analog && !offDrive.empty()) {
      error(where(jp + "motor-pos-cmd"), jp + "motor-pos-cmd",
            fmt::format("joint {}: its PID drives {} ({}), {}, so this joint cannot be derived", n, offDrive,
                        at(where(offDrive)), offFirst7I77(offDrive)));
      return;
    }
    if (encoder && *encoder >= kEncoders && *encoder < 2 * kEncoders && !sevenI76_) {
      error(where(jp + "motor-pos-fb"), jp + "motor-pos-fb",
            fmt::format("joint {}: its feedback {} ({}) is a counter of the second 7I77 (6 to 11): lbpkit's derived "
                        "machine sits behind the first 7I77 only, so this joint cannot be derived",
                        n, encoderPin, at(where(encoderPin))));
      return;
    }
    if (!stepgen && !analog) {
      error(where(jp + "motor-pos-cmd"), jp + "motor-pos-cmd",
            fmt::format("joint {}: neither a PID whose output reaches a 7I77 analogoutN nor a StepGen takes its "
                        "command (signal {}): lbpkit cannot tell what moves it",
                        n, cmdSig));
      return;
    }
    if (analog && !encoder) {
      error(where(jp + "motor-pos-fb"), jp + "motor-pos-fb",
            fmt::format("joint {}: drives analogout{} but its feedback (signal {}) is no hm2 encoder.NN.position: "
                        "lbpkit's servo axes read an encoder",
                        n, *analog, fbSig));
      return;
    }
    // One joint to each: a second on the same output, encoder or StepGen is
    // two writers on one pin (LinuxCNC refuses it).
    for (const auto& [claimed, number, what, pin] :
         {std::tuple{&claimedAnalogs_, analog, "analogout", analogPin},
          std::tuple{&claimedEncoders_, encoder, "encoder", fmt::format("{}.encoder.{:02d}.position", board, encoder.value_or(0))},
          std::tuple{&claimedStepgens_, stepgen, "stepgen", fmt::format("{}.stepgen.{:02d}", board, stepgen.value_or(0))}})
      if (number && claimed->count(*number)) {
        error(where(jp + "motor-pos-cmd"), jp + "motor-pos-cmd",
              fmt::format("joint {}: {} {} already serves another joint ({})", n, what, *number, pin));
        return;
      }
    const bool angular = [&] {
      const auto* t = hal_.ini.find(section, "TYPE");
      return t && lower(t->value) == "angular";
    }();
    const double mmPerUnit = angular || !inch_ ? 1.0 : 25.4;
    auto minLimit = iniValue(section, "MIN_LIMIT"), maxLimit = iniValue(section, "MAX_LIMIT");
    auto homeOffset = iniValue(section, "HOME_OFFSET");
    const auto maxVel = iniValue(section, "MAX_VELOCITY");
    const auto maxAcc = iniValue(section, "MAX_ACCELERATION");
    const auto searchVel = iniValue(section, "HOME_SEARCH_VEL"), latchVel = iniValue(section, "HOME_LATCH_VEL");
    // Each checked, so that every value out of bounds is said at once.
    bool good = true;
    for (auto* p : {&minLimit, &maxLimit, &homeOffset}) good = position(*p, mmPerUnit, angular) && good;
    for (const auto* v : {&maxVel, &searchVel, &latchVel}) good = within(*v, kVelocityBound) && good;
    good = within(maxAcc, kAccelerationBound) && good;
    if (!good) return;
    if (!minLimit || !maxLimit || !(minLimit->v < maxLimit->v)) {
      error(iniAt, section, fmt::format("[{}] needs MIN_LIMIT below MAX_LIMIT: they give the axis its travel", section));
      return;
    }
    // Six significant digits in the machine file: a travel narrower than
    // they tell apart would read as none.
    if ((maxLimit->v - minLimit->v) * mmPerUnit < 1e-3 ||
        maxLimit->v - minLimit->v < 1e-4 * std::max(std::abs(minLimit->v), std::abs(maxLimit->v))) {
      error(maxLimit->at, section,
            fmt::format("[{}] MIN_LIMIT {} to MAX_LIMIT {} is no travel a machine moves over (at least 1e-3 mm, and "
                        "1e-4 of its distance from 0)",
                        section, fmtNumber(minLimit->v), fmtNumber(maxLimit->v)));
      return;
    }
    const double vmax = maxVel ? std::abs(maxVel->v) : 25.0 / mmPerUnit;
    const double amax = maxAcc && maxAcc->v > 0 ? maxAcc->v : 250.0 / mmPerUnit;
    const double sv = searchVel.value_or(Value{}).v;
    const double lv = latchVel.value_or(Value{}).v;
    const auto offset = homeOffset.value_or(Value{0.0, "LinuxCNC's default HOME_OFFSET = 0", {}, iniAt, {}});
    const auto* useIndexEntry = hal_.ini.find(section, "HOME_USE_INDEX");
    const bool useIndex = useIndexEntry && yes(useIndexEntry->value);

    AxisOut a;
    a.name = name;
    const std::string unitName = angular ? "degrees" : (inch_ ? "inch" : "mm");
    a.comment = fmt::format("joint {} ([{}], {}){}", n, section, unitName,
                            angular ? ": a rotary joint, one machine unit a degree" : "");
    if (inch_ && !angular) a.comment += ": machine files are in mm, 25.4 to the inch";
    // The screw: a configuration gives counts and volts per unit, never the
    // pitch; 5 mm (0.2 in) is assumed and the encoder's lines and the
    // gearing follow from it.
    const double pitch = inch_ && !angular ? 5.08 : 5.0;
    double gear = 1.0;
    double lead = pitch;
    if (stepgen) {
      const auto scale = value(fmt::format("{}.stepgen.{:02d}.position-scale", board, *stepgen), section, "SCALE");
      if (!scale || scale->v == 0.0) {
        error(iniAt, section, fmt::format("joint {}: no position-scale for stepgen.{:02d} (setp or [{}]SCALE)", n,
                                          *stepgen, section));
        return;
      }
      auto maxStepVel = value(fmt::format("{}.stepgen.{:02d}.maxvel", board, *stepgen), section, "STEPGEN_MAXVEL");
      if (!within(scale, kScaleBound) || !within(maxStepVel, kVelocityBound)) return;
      const double stepVel = maxStepVel && maxStepVel->v > 0 ? maxStepVel->v : vmax * 1.25;
      const double stepsPerMm = std::abs(scale->v) / mmPerUnit;
      if (!derived(stepsPerMm, kMinStepsPerMm, kMaxStepsPerMm, *scale, "steps/mm") ||
          !derived(std::ceil(stepVel * std::abs(scale->v) * 1.25), 1.0, kMaxStepRate,
                   maxStepVel && maxStepVel->v > 0 ? *maxStepVel : maxVel.value_or(*scale),
                   "with the scale, a StepGen pull-out rate (steps/s) of"))
        return;
      a.keys.emplace_back("screw_pitch", fmtNumber(pitch) + "|assumed: a configuration gives steps per unit, not the screw");
      a.tableName = "axis.stepper";
      a.drive.emplace_back("stepgen", fmt::format("{}|{}.stepgen.{:02d}{}", *stepgen, board, *stepgen,
                                                 velocityStepgen ? " (velocity mode, through " + pid + ")" : ""));
      a.drive.emplace_back("steps_per_unit", fmtNumber(stepsPerMm) + "|" + scale->from + (mmPerUnit != 1.0 ? ", / 25.4" : ""));
      a.drive.emplace_back("max_step_rate",
                           fmtNumber(std::ceil(stepVel * std::abs(scale->v) * 1.25)) + "|" +
                               fmt::format("pulls out 25 % above the StepGen's {} {}/s ({})", fmtNumber(stepVel),
                                           unitName, maxStepVel ? maxStepVel->from : "1.25 x MAX_VELOCITY"));
      a.drive.emplace_back("reversed", std::string(scale->v < 0 ? "true" : "false") + "|" +
                                           (scale->v < 0 ? "a negative scale: a forward step moves it back" : "the scale's sign"));
      if (encoder) {
        // A closed-loop stepper: LinuxCNC's feedback from an encoder.
        const auto encScale = value(fmt::format("{}.encoder.{:02d}.scale", board, *encoder), section, "ENCODER_SCALE");
        if (!encScale || encScale->v == 0.0) {
          error(iniAt, section, fmt::format("joint {}: no scale for encoder.{:02d} (setp or [{}]ENCODER_SCALE)", n,
                                            *encoder, section));
          return;
        }
        if (!within(encScale, kScaleBound)) return;
        const auto e = encoderLines(std::abs(encScale->v) / mmPerUnit, pitch);
        if (!encoderFits(e, *encScale)) return;
        gear = e.gear;
        a.keys.emplace_back("gear_ratio", fmtNumber(gear) + "|motor revolutions per screw revolution");
        a.drive.emplace_back("encoder_input", fmt::format("{}|{}.encoder.{:02d} ({}), its feedback", *encoder, board,
                                                          *encoder, at(where(fmt::format("{}.encoder.{:02d}.position", board, *encoder)))));
        a.drive.emplace_back("encoder_lines", fmt::format("{}|{} counts/{} ({}), 4 counts a line, the assumed pitch{}", e.lines,
                                                          fmtNumber(std::abs(encScale->v)), unitName, encScale->from,
                                                          gear != 1.0 ? ", and a gear ratio making the counts exact" : ""));
        a.drive.emplace_back("encoder_reversed", std::string(encScale->v < 0 ? "true" : "false") + "|the encoder scale's sign");
      }
    } else {
      const auto encScale = value(fmt::format("{}.encoder.{:02d}.scale", board, *encoder), section, "ENCODER_SCALE");
      if (!encScale || encScale->v == 0.0) {
        error(iniAt, section, fmt::format("joint {}: no scale for encoder.{:02d} (setp or [{}]ENCODER_SCALE)", n,
                                          *encoder, section));
        return;
      }
      const auto drive = analogDrive(n, section, pid, analogPin);
      const auto& outScale = drive.scalemax;
      const auto& ff1 = drive.ff1;
      if (!within(encScale, kScaleBound) || !within(outScale, kOutputScaleBound) || !within(ff1, kFf1Bound)) return;
      const auto e = encoderLines(std::abs(encScale->v) / mmPerUnit, pitch);
      if (!encoderFits(e, *encScale)) return;
      const double lines = static_cast<double>(e.lines);
      gear = e.gear;
      std::string linesWhy = fmt::format("{} counts/{} ({}), 4 counts a line, the assumed pitch", fmtNumber(std::abs(encScale->v)),
                                         unitName, encScale->from);
      if (gear != 1.0) linesWhy += ", and a gear ratio making the counts exact";
      a.keys.emplace_back("screw_pitch", fmtNumber(pitch) + "|assumed: a configuration gives counts per unit, not the screw");
      a.keys.emplace_back("gear_ratio", fmtNumber(gear) + "|motor revolutions per screw revolution");
      lead = pitch / gear;
      a.tableName = "axis.drive";
      a.drive.emplace_back("analog_output", fmt::format("{}|{} ({})", *analog, analogPin, at(where(analogPin))));
      a.drive.emplace_back("enable", fmt::format("{}|AnalogEna{}", *analog, *analog == 5 ? "/SpinEna (ENA5)" : ""));
      a.drive.emplace_back("encoder_input", fmt::format("{}|{}.encoder.{:02d} ({})", *encoder, board, *encoder,
                                                        at(where(fmt::format("{}.encoder.{:02d}.position", board, *encoder)))));
      a.drive.emplace_back("encoder_lines", fmtNumber(lines).substr(0, fmtNumber(lines).find('.')) + "|" + linesWhy);
      a.drive.emplace_back("encoder_reversed", std::string(encScale->v < 0 ? "true" : "false") + "|" +
                                                   (encScale->v < 0 ? "a negative ENCODER_SCALE: it counts down going forward"
                                                                    : "the encoder scale's sign"));
      // The PID's output is scalemax at 10 V; with FF1 the output is FF1 x
      // the commanded velocity, so the drive must give 10 V /
      // (scalemax / FF1) per unit/s for the feed-forward to be right (FF1 0
      // or none: the scale taken alone).
      const double unitsPerSecondPerVolt =
          drive.velocityAt(std::abs(outScale.v)).value_or(std::abs(outScale.v)) / 10.0;
      const double gain = unitsPerSecondPerVolt * mmPerUnit / lead;
      // The amplifier's limit is 11 V of it.
      if (!derived(gain, kMinGain, kMaxLimit / 11.0, outScale,
                   ff1 && ff1->v > 0 ? fmt::format("over FF1 {:g} ({}), a drive gain (motor rev/s per V) of",
                                                   ff1->v, at(ff1->at))
                                     : std::string("on the assumed 5 mm screw, a drive gain (motor rev/s per V) of")))
        return;
      a.amplifier.emplace_back("mode", "\"velocity\"|assumed: the PID's output is a velocity (FF1 feed-forward)");
      a.amplifier.emplace_back(
          "gain", fmtNumber(gain) + "|" +
                      fmt::format("motor rev/s per V: {} {}/s at 10 V ({}){}", fmtNumber(std::abs(outScale.v)), unitName,
                                  outScale.from,
                                  ff1 && ff1->v > 0 ? fmt::format(" over FF1 {} ({})", fmtNumber(ff1->v), ff1->from)
                                                    : std::string(", FF1 0 or none: the scale taken alone")));
      a.amplifier.emplace_back("limit", fmtNumber(gain * 11.0) + "|saturates just past the 7I77's 10 V");
      a.amplifier.emplace_back("reversed", std::string(outScale.v < 0 ? "true" : "false") + "|" +
                                               (outScale.v < 0 ? "a negative OUTPUT_SCALE: positive volts turn it backwards"
                                                               : "the output scale's sign"));
      if (10.0 * unitsPerSecondPerVolt < vmax * 0.999)
        warning(iniAt, section,
                fmt::format("joint {}: 10 V gives {} {}/s, under MAX_VELOCITY {}: the PID saturates", n,
                            fmtNumber(10.0 * unitsPerSecondPerVolt), unitName, fmtNumber(vmax)));
    }

    lead = pitch / gear;
    // Homing and the switches.
    const double leadUnits = lead / mmPerUnit;
    double lo = minLimit->v, hi = maxLimit->v;
    std::string homeComment;
    double initial = (lo + hi) / 2;
    std::optional<double> edge;
    const double latchDir = lv < 0 ? -1.0 : 1.0;
    if (sv == 0.0 && lv == 0.0) {
      initial = offset.v;
      homeComment = fmt::format("homes in place (HOME_SEARCH_VEL and HOME_LATCH_VEL 0): it starts at HOME_OFFSET ({})",
                                offset.from);
    } else if (sv == 0.0) {
      initial = useIndex ? offset.v - latchDir * leadUnits / 2 : offset.v;
      homeComment = fmt::format("homes on the next index (HOME_SEARCH_VEL 0): it starts half a motor turn before "
                                "HOME_OFFSET ({})",
                                offset.from);
    } else {
      // The edge the latch finds; with the index, half a motor turn before
      // the index LinuxCNC calls HOME_OFFSET (the index comes at every whole
      // motor turn of the machine's position).
      edge = useIndex ? offset.v - latchDir * leadUnits / 2 : offset.v;
      homeComment = fmt::format("home switch edge where HOME_OFFSET ({}) falls{}", offset.from,
                                useIndex ? ", on the next index (HOME_USE_INDEX) half a motor turn on" : "");
      if (useIndex && std::abs(offset.v / leadUnits - std::round(offset.v / leadUnits)) > 1e-6)
        homeComment += fmt::format(" (HOME_OFFSET is no whole number of motor turns: LinuxCNC's coordinates are the "
                                   "machine's shifted by up to {} {})",
                                   fmtNumber(leadUnits), unitName);
      lo = std::min(lo, *edge);
      hi = std::max(hi, *edge);
      // Powered up two seconds' search from its home switch (at least 5
      // mm), within the travel: where the machine is at power-up is the one
      // thing no configuration says, and a search that long runs homing's
      // every phase (search, back-off, latch) as a longer one would.
      const double away = std::min(std::max(5.0 / mmPerUnit, 2.0 * std::abs(sv)), 0.4 * (hi - lo));
      initial = std::clamp(*edge - (sv > 0 ? away : -away), lo, hi);
      if (useIndex) {
        // The encoder's index comes at whole motor turns from where the
        // machine powered up (QuadratureEncoder): it starts a whole number
        // of turns from the index LinuxCNC calls HOME_OFFSET, so that the
        // index the latch finds half a turn past the edge is that one.
        const double side = initial < offset.v ? -1.0 : 1.0;
        const double turns = std::ceil(std::abs(offset.v - initial) / leadUnits - 1e-9);
        initial = offset.v + side * turns * leadUnits;
        if (initial < lo || initial > hi) initial = offset.v + side * (turns - 1) * leadUnits;
      }
      const double start = std::abs(*edge - initial);
      homeComment += fmt::format("; it starts {} {} from the switch, {} s of HOME_SEARCH_VEL", fmtNumber(start), unitName,
                                 fmtNumber(start / std::abs(sv)));
    }
    const double stopDistance = sv * sv / (2 * amax);
    const double marginLow = 2.0 / mmPerUnit + leadUnits + (sv < 0 ? stopDistance : 0.0);
    const double marginHigh = 2.0 / mmPerUnit + leadUnits + (sv > 0 ? stopDistance : 0.0);
    const double stopAtSpeed = vmax * vmax / (2 * amax);
    const double overtravel = std::max(marginLow, marginHigh) * mmPerUnit + std::max(3.0, stopAtSpeed * mmPerUnit + 1.0);
    if (!derived(overtravel, 0.0, kMaxOvertravel,
                 maxAcc && maxAcc->v > 0 ? *maxAcc : maxVel ? *maxVel : searchVel.value_or(offset),
                 "stopping from MAX_VELOCITY or HOME_SEARCH_VEL, hard stops (mm) past the travel at"))
      return;
    a.keys.emplace_back("travel", fmt::format("[{}, {}]|{} to {}", fmtNumber(lo * mmPerUnit), fmtNumber(hi * mmPerUnit),
                                              minLimit->from, maxLimit->from));
    a.keys.emplace_back("overtravel", fmtNumber(std::ceil(overtravel)) +
                                          "|hard stops past the limit switches, and past a stop from MAX_VELOCITY");
    a.keys.emplace_back("initial_position", fmtNumber(initial * mmPerUnit) + "|" +
                                                (sv == 0.0 ? homeComment
                                                           : fmt::format("{} {} from its home switch, on the side "
                                                                         "HOME_SEARCH_VEL searches from",
                                                                         fmtNumber(std::abs(*edge - initial)), unitName)));

    // Which inputs the joint's switches are on.
    struct Role {
      std::string pin;
      const char* kind;
    };
    for (const Role& r : {Role{"home-sw-in", "home"}, Role{"neg-lim-sw-in", "min_limit"}, Role{"pos-lim-sw-in", "max_limit"}}) {
      std::vector<Source> sources;
      trace(jp + r.pin, false, sources);
      for (const auto& s : sources) {
        const auto key = fmt::format("{}:{}", s.field.daughtercard, s.field.number);
        auto& sw = switchAt_[key];
        const std::string kind = r.kind;
        if (kind == "home" && sv == 0.0) {
          if (sw.kind.empty()) homeInPlaceInputs_.insert(key);
          continue;
        }
        if (!sw.kind.empty()) {
          if (sw.axis == name && sw.kind == "home") {
            sw.comment += fmt::format("; also {}{} ({})", jp, r.pin, at(where(jp + r.pin)));
          } else {
            warning(where(jp + r.pin), jp + r.pin,
                    fmt::format("{} input {} also serves {}{}: a machine file has one switch per input, so {} has "
                                "none of its own",
                                s.field.daughtercard, s.field.number, jp, r.pin, jp + r.pin));
          }
          continue;
        }
        sw.name = fmt::format("{}-{}", name, kind == "home" ? "home" : kind == "min_limit" ? "min" : "max");
        sw.kind = kind;
        sw.daughtercard = s.field.daughtercard;
        sw.input = s.field.number;
        sw.contact = s.inverted ? "nc" : "no";
        sw.axis = name;
        sw.pin = s.pin;
        if (kind == "home") {
          sw.position = *edge * mmPerUnit;
          sw.tripAbove = sv > 0;
          sw.comment = fmt::format("{} ({}), {} the edge: HOME_SEARCH_VEL {} searches {}; {}", s.pin, at(where(s.pin)),
                                   sv > 0 ? "closed at and above" : "closed at and below", fmtNumber(sv),
                                   sv > 0 ? "up" : "down", homeComment);
        } else if (kind == "min_limit") {
          sw.position = (lo - marginLow) * mmPerUnit;
          sw.tripAbove = false;
          sw.comment = fmt::format("{} ({}), past the travel by 2 mm, a motor turn and the homing search's stop", s.pin,
                                   at(where(s.pin)));
        } else {
          sw.position = (hi + marginHigh) * mmPerUnit;
          sw.tripAbove = true;
          sw.comment = fmt::format("{} ({}), past the travel by 2 mm, a motor turn and the homing search's stop", s.pin,
                                   at(where(s.pin)));
        }
        sw.comment += s.inverted ? "; NC: the net takes the inverted input" : "; NO: the net takes the input as it is";
        switchOrder_.push_back(key);
      }
    }
    if (sv != 0.0) {
      std::vector<Source> homes;
      trace(jp + "home-sw-in", false, homes);
      if (homes.empty())
        error(iniAt, section,
              fmt::format("joint {}: HOME_SEARCH_VEL is {} but {}home-sw-in reaches no 7I77, 7I76 or card input ({}): "
                          "there is no home switch to place",
                          n, fmtNumber(sv), jp, describe(jp + "home-sw-in")));
    }
    // A brake on this joint: an output whose signal its amp-enable writes
    // and whose name says brake.
    for (const auto& [sig, pins] : hal_.signals) {
      if (lower(sig).find("brake") == std::string::npos || lower(sig).find("spindle") != std::string::npos) continue;
      const bool ours = std::find(pins.begin(), pins.end(), jp + "amp-enable-out") != pins.end() ||
                        lower(sig).find(name) != std::string::npos;
      if (!ours) continue;
      for (const auto& p : pins)
        if (const auto o = fieldPin(p, "output")) {
          a.brakeOutput = static_cast<int>(o->number);
          a.brakeDaughtercard = o->daughtercard;
          a.brakeComment = fmt::format("{} ({}) on signal {}: on releases it", p, at(where(p)), sig);
        }
    }
    if (stepgen) claimedStepgens_.insert(*stepgen);
    if (encoder) claimedEncoders_.insert(*encoder);
    if (analog) claimedAnalogs_.insert(*analog);
    axes_.push_back(std::move(a));
  }

  // The switches placed so far as inputs' states at rest: a NC contact
  // reads on, a NO one off, until it trips.
  void seedHolds() {
    for (const auto& key : switchOrder_) {
      const auto& sw = switchAt_.at(key);
      if (sw.kind.empty() || sw.kind == "held-off") continue;
      holds_.emplace(key, Held{sw.contact == "nc", sw.pin, {}, fmt::format("the {} switch", sw.name),
                               sw.pin.empty() ? Where{ini_.filename().string(), 0} : where(sw.pin)});
    }
  }

  static std::string via(const std::string& through) { return through.empty() ? "" : " (through " + through + ")"; }

  // The E-stop chain: every input reaching iocontrol.0.emc-enable-in is an
  // E-stop switch, its contact what keeps emc-enable-in TRUE until pressed.
  void estop() {
    seedHolds();
    std::vector<Source> sources;
    trace("iocontrol.0.emc-enable-in", false, sources);
    std::optional<Holds> chosen;
    if (!sources.empty())
      chosen = hold({"iocontrol.0.emc-enable-in", true, "iocontrol.0.emc-enable-in to be TRUE (the E-stop chain)"});
    unsigned k = 0;
    for (const auto& s : sources) {
      const auto key = fmt::format("{}:{}", s.field.daughtercard, s.field.number);
      auto& sw = switchAt_[key];
      if (!sw.kind.empty()) continue;
      // On at rest where the chain needs it on (the inputs that decide
      // it), else as the `not`s on the way say.
      const auto it = chosen ? chosen->find(key) : Holds::iterator{};
      const bool on = chosen && it != chosen->end() ? it->second.on : !s.inverted;
      sw = {k++ == 0 ? "estop" : fmt::format("estop{}", k), "estop", s.field.daughtercard, on ? "nc" : "no", "", {},
            s.field.number, std::nullopt, true, s.pin};
      sw.comment = fmt::format("{} ({}) reaches iocontrol.0.emc-enable-in{}{}: {}", s.pin, at(where(s.pin)),
                               s.inverted ? " inverted" : "",
                               chosen && it != chosen->end() ? via(it->second.through) : std::string(),
                               on ? "NC, the input on while all is well" : "NO, the input on while pressed");
      switchOrder_.push_back(key);
    }
  }

  void probe() {
    std::vector<Source> sources;
    trace("motion.probe-input", false, sources);
    for (const auto& s : sources) {
      const auto key = fmt::format("{}:{}", s.field.daughtercard, s.field.number);
      auto& sw = switchAt_[key];
      if (!sw.kind.empty()) continue;
      sw = {"probe", "probe", s.field.daughtercard, s.inverted ? "nc" : "no", "", {}, s.field.number, std::nullopt, true,
            s.pin};
      sw.comment = fmt::format("{} ({}) reaches motion.probe-input: trips when told (POST /api/machine)", s.pin,
                               at(where(s.pin)));
      switchOrder_.push_back(key);
      break;
    }
  }

  // Every interlock and permissive that must read one way for the machine
  // to run (LinuxCNC's motion, spindle, joint, halui and iocontrol pins;
  // a `message` that would fire), held that way by the resting state of
  // the inputs that decide it: an input that must read on gets a switch
  // held closed, one that must read off nothing.
  void permissives() {
    seedHolds();
    std::vector<Interlock> list;
    static const std::pair<const char*, bool> kMustBe[] = {
        {"motion.feed-inhibit", false},     {"motion.feed-hold", false},        {"motion.enable", true},
        {"motion.spindle-inhibit", false},  {"motion.spindle-at-speed", true},  {"motion.homing-inhibit", false},
        {"motion.jog-inhibit", false},      {"motion.jog-stop", false},         {"motion.jog-stop-immediate", false},
        {"halui.program.pause", false},     {"halui.program.stop", false},      {"halui.abort", false},
        {"halui.estop.activate", false},    {"halui.machine.off", false}};
    auto mustBe = [](const std::string& pin, bool want) {
      return Interlock{pin, want, fmt::format("{} to be {}", pin, want ? "TRUE" : "FALSE")};
    };
    for (const auto& [pin, want] : kMustBe) list.push_back(mustBe(pin, want));
    // Per spindle and per joint: spindle.N.inhibit and at-speed,
    // joint.N.amp-fault-in (axis.N. in 2.7), halui.spindle.N.stop.
    for (const auto& [pin, sig] : pinSignal_) {
      const auto p = split(pin, '.');
      if (p.size() == 3 && p[0] == "spindle" && digits(p[1]) && (p[2] == "inhibit" || p[2] == "at-speed"))
        list.push_back(mustBe(pin, p[2] == "at-speed"));
      else if (p.size() == 3 && (p[0] == "joint" || p[0] == "axis") && digits(p[1]) && p[2] == "amp-fault-in")
        list.push_back(mustBe(pin, false));
      else if (p.size() == 4 && p[0] == "halui" && p[1] == "spindle" && digits(p[2]) && p[3] == "stop")
        list.push_back(mustBe(pin, false));
    }
    // A message fires when its trigger reaches its edge's state (TRUE
    // unless `edge` is set FALSE): held the other way (LinuxCNC:
    // src/hal/components/message.comp).
    for (const auto& [instance, module] : instanceModule_) {
      if (module != "message") continue;
      bool edge = true;
      if (const auto* sp = hal_.setpOf(instance + ".edge"))
        if (const auto b = bit(sp->value)) edge = *b;
      const auto text = messageText_.count(instance) ? messageText_.at(instance) : std::string();
      list.push_back({instance + ".trigger", !edge,
                      fmt::format("{}.trigger to be {} (message {}{} fires when it goes {})", instance,
                                  edge ? "FALSE" : "TRUE", instance, text.empty() ? "" : " \"" + text + "\"",
                                  edge ? "TRUE" : "FALSE")});
    }
    for (const auto& i : list) {
      if (signal(i.pin).empty()) continue;
      const auto added = hold(i);
      if (!added) continue;
      for (const auto& [key, h] : *added) {
        holds_[key] = h;
        auto& sw = switchAt_[key];
        if (!sw.kind.empty()) continue;
        const auto colon = key.find(':');
        const auto number = static_cast<unsigned>(std::stoul(key.substr(colon + 1)));
        if (!h.on) {
          sw.kind = "held-off";  // nothing to wire: an input with no switch reads off
          heldOff_.push_back(fmt::format("{} ({}) must read off for {}{}: nothing closes it", h.pin, at(where(h.pin)),
                                         h.reason, via(h.through)));
          continue;
        }
        sw = {fmt::format("held-{}", number), "other", key.substr(0, colon), "nc", "", {}, number, std::nullopt, true,
              h.pin};
        sw.comment = fmt::format("{} ({}) must read on for {}{}: held closed", h.pin, at(where(h.pin)), h.reason,
                                 via(h.through));
        switchOrder_.push_back(key);
      }
    }
  }

  void spindle() {
    std::optional<unsigned> analog;
    std::string pin;
    bool on7I76 = false;
    for (const auto& [p, sig] : pinSignal_) {
      if (const auto a = analogOut(p); a && !claimedAnalogs_.count(*a) && (!analog || *a == 5)) {
        analog = *a;
        pin = p;
      }
      if (p.ends_with(".7i76.0.0.spinout") && !analog) {
        on7I76 = true;
        pin = p;
      }
    }
    if (!analog && !on7I76) return;
    const auto scale = value(pin + "-scalemax", "SPINDLE_0", "OUTPUT_SCALE")
                           .value_or(Value{10.0, "hostmot2's default scalemax 10 (none set)", {}, where(pin), {}});
    if (!within(scale, kOutputScaleBound) ||
        !derived(std::abs(scale.v), std::max(1.0, 10.0 * kMinRpmPerVolt), std::min(kMaxRpm, 10.0 * kMaxRpmPerVolt), scale,
                 "the spindle's rpm at 10 V"))
      return;
    spindle_.emplace_back("daughtercard", on7I76 ? "\"7I76\"|the 7I76's SpinOut, SpinEna, SpinDir" : "\"7I77\"|");
    if (!on7I76) {
      spindle_.emplace_back("analog_output", fmt::format("{}|{} ({})", *analog, pin, at(where(pin))));
      spindle_.emplace_back("enable", fmt::format("{}|{}", *analog, *analog == 5 ? "ENA5 follows spinena" : "AnalogEna"));
    }
    spindle_.emplace_back("rpm_per_volt", fmtNumber(std::abs(scale.v) / 10.0) + "|" + scale.from + " rpm at 10 V");
    spindle_.emplace_back("max_rpm", fmtNumber(std::abs(scale.v)) + "|10 V");
    // Its encoder: one on the spindle's feedback signals that no joint reads.
    std::optional<unsigned> encoder;
    std::string board, encoderPin;
    for (const char* feedback : {"spindle.0.revs", "spindle.0.speed-in", "spindle.0.index-enable", "motion.spindle-revs",
                                 "motion.spindle-speed-in", "motion.spindle-index-enable"})
      for (const auto& p : pinsOn(signal(feedback))) {
        const auto parts = split(p, '.');
        if (parts.size() == 5 && parts[2] == "encoder" && !encoder) {
          if (const auto e = digits(parts[3]); e && !claimedEncoders_.count(*e)) {
            encoder = *e;
            encoderPin = p;
            board = cardOf(p);
          }
        }
      }
    if (encoder && *encoder >= kEncoders && !sevenI76_) {
      warning(where(encoderPin), encoderPin,
              fmt::format("{} is a counter of the second 7I77 (6 to 11): lbpkit's derived machine sits behind the "
                          "first 7I77 only, so the spindle's encoder is left out",
                          encoderPin));
      spindle_.emplace_back("encoder_input", fmt::format("-1|{}.encoder.{:02d} is the second 7I77's", board, *encoder));
      return;
    }
    if (!encoder) {
      spindle_.emplace_back("encoder_input", "-1|no encoder on spindle.0.revs or speed-in");
      return;
    }
    const auto encScale = value(fmt::format("{}.encoder.{:02d}.scale", board, *encoder), "SPINDLE_0", "ENCODER_SCALE")
                              .value_or(Value{4096.0, "assumed 1024 lines (no scale set)", {}, where(pin), {}});
    if (!within(encScale, kScaleBound) ||
        !derived(std::max(1.0, std::round(std::abs(encScale.v) / 4.0)), 1.0, kMaxEncoderLines, encScale,
                 "the spindle encoder's lines (counts a revolution / 4)"))
      return;
    const bool encoderOn7I76 = sevenI76_ && *encoder == 6;
    spindle_.emplace_back("encoder_daughtercard", encoderOn7I76 ? "\"7I76\"|muxed counter 6 is the 7I76's" : "\"7I77\"|");
    spindle_.emplace_back("encoder_input", fmt::format("{}|{}.encoder.{:02d}", encoderOn7I76 ? 0 : *encoder, board, *encoder));
    spindle_.emplace_back("encoder_lines",
                          fmt::format("{}|{} counts a revolution ({})",
                                      static_cast<long>(std::max(1.0, std::round(std::abs(encScale.v) / 4.0))),
                                      fmtNumber(std::abs(encScale.v)), encScale.from));
    spindle_.emplace_back("encoder_reversed", std::string(encScale.v < 0 ? "true" : "false") + "|the scale's sign");
  }

  // Every field output a net drives, once: an output on two signals (a
  // second `net` after an `unlinkp`, two files naming it) is one output
  // whose comment names each.
  void outputs() {
    struct Found {
      FieldPin o;
      std::vector<std::pair<std::string, std::string>> nets;  // pin, signal
    };
    std::vector<Found> found;
    std::map<std::string, std::size_t> index;
    for (const auto& [sig, pins] : hal_.signals)
      for (const auto& p : pins)
        if (const auto o = fieldPin(p, "output")) {
          const auto [it, fresh] = index.emplace(fmt::format("{}:{}", o->daughtercard, o->number), found.size());
          if (fresh) found.push_back({*o, {}});
          found[it->second].nets.emplace_back(p, sig);
        }
    for (const auto& f : found) {
      const auto& sig = f.nets.front().second;
      // A machine name from the signal's (at most 40 characters), made
      // unique where two signals give the same.
      std::string name = machineName(sig);
      for (unsigned k = 2; std::any_of(outputs_.begin(), outputs_.end(), [&](const OutputOut& x) { return x.name == name; }); ++k) {
        const auto suffix = fmt::format("-{}", k);
        name = machineName(sig).substr(0, 40 - suffix.size()) + suffix;
      }
      std::string comment;
      for (const auto& [p, s] : f.nets)
        comment += fmt::format("{}{} ({}), signal {}", comment.empty() ? "" : "; also ", p, at(whereOn(p, s)), s);
      if (f.nets.size() > 1) comment += ": one output";
      outputs_.push_back({name, f.o.daughtercard, comment, f.o.number});
    }
  }
  // Where `pin` is put on `signal`.
  [[nodiscard]] Where whereOn(const std::string& pin, const std::string& signal) const {
    for (const auto& r : hal_.refs)
      if (r.name == pin && r.signal == signal) return r.at;
    return where(pin);
  }

  [[nodiscard]] static std::string line(const std::string& indent, const std::string& key, const std::string& valueAndWhy) {
    const auto bar = valueAndWhy.find('|');
    const auto v = valueAndWhy.substr(0, bar);
    const auto why = bar == std::string::npos ? std::string() : valueAndWhy.substr(bar + 1);
    auto text = fmt::format("{}{} = {}", indent, key, v);
    if (!why.empty())
      text += fmt::format("{}# {}", std::string(text.size() < 30 ? 30 - text.size() : 1, ' '), commentText(why));
    return text + "\n";
  }

  [[nodiscard]] std::string toml() const {
    std::string t;
    t += fmt::format("# The machine {} expects, derived from it by lbpkit machine --from-config\n",
                     commentText(ini_.filename().string()));
    t += fmt::format("# (read: {}).\n", commentText([&] {
      std::string files;
      for (const auto& f : hal_.files) files += (files.empty() ? "" : ", ") + std::filesystem::path(f).filename().string();
      return files;
    }()));
    t += "# Each value says where it came from. Assumed, because a configuration cannot say: the screw's\n"
         "# pitch (5 mm, 0.2 in), the masses, inertias and friction (the schema's defaults,\n"
         "# examples/machines/mill.toml), that drives are velocity-mode and that no axis is vertical.\n\n";
    t += fmt::format("name = \"{}\"\n\n", machineName(ini_.stem().string()));
    for (const auto& a : axes_) {
      t += fmt::format("# {}\n[[axis]]\nname = \"{}\"\n", commentText(a.comment), a.name);
      for (const auto& [k, v] : a.keys) t += line("", k, v);
      if (a.brakeOutput >= 0) {
        t += line("", "brake_output", fmt::format("{}|{}", a.brakeOutput, a.brakeComment));
        t += line("", "brake_daughtercard", fmt::format("\"{}\"|", a.brakeDaughtercard));
        t += line("", "brake_torque", "4.0|assumed: holds what a drive's peak torque can");
      }
      if (a.tableName == "axis.stepper") {
        t += "  [axis.stepper]\n";
        for (const auto& [k, v] : a.drive) t += line("  ", k, v);
      } else {
        t += "  [[axis.drive]]\n";
        for (const auto& [k, v] : a.drive) t += line("  ", k, v);
        t += "  [axis.drive.amplifier]\n";
        for (const auto& [k, v] : a.amplifier) t += line("  ", k, v);
      }
      t += "\n";
    }
    if (!spindle_.empty()) {
      t += "[spindle]\n";
      for (const auto& [k, v] : spindle_) t += line("", k, v);
      t += "\n";
    }
    // Names are unique in a machine file: a second switch of one kind on an
    // axis (two inputs reach its home-sw-in through or2), or held on a 7I77
    // and a 7I76 input of one number, is numbered.
    std::set<std::string> switchNames;
    for (const auto& key : switchOrder_) {
      const auto& s = switchAt_.at(key);
      if (s.kind == "held-off") continue;
      std::string name = s.name;
      for (unsigned k = 2; !switchNames.insert(name).second; ++k) name = fmt::format("{}-{}", s.name, k);
      t += fmt::format("# {}\n[[switch]]\nname = \"{}\"\nkind = \"{}\"\ndaughtercard = \"{}\"\ninput = {}\ncontact = \"{}\"\n",
                       commentText(s.comment), name, s.kind, s.daughtercard, s.input, s.contact);
      if (!s.axis.empty()) {
        t += fmt::format("axis = \"{}\"\nposition = {}\ntrip_above = {}\n", s.axis, fmtNumber(*s.position),
                         s.tripAbove ? "true" : "false");
      }
      t += "\n";
    }
    for (const auto& h : heldOff_) t += "# " + commentText(h) + "\n";
    for (const auto& key : homeInPlaceInputs_)
      if (switchAt_.at(key).kind.empty())
        t += fmt::format("# {} input {}: a home switch its joint never searches for (it homes in place)\n",
                         key.substr(0, key.find(':')), key.substr(key.find(':') + 1));
    for (const auto& o : outputs_) {
      t += fmt::format("# {}\n[[output]]\nname = \"{}\"\ndaughtercard = \"{}\"\noutput = {}\n\n", commentText(o.comment), o.name,
                       o.daughtercard, o.output);
    }
    return t;
  }

  const HalConfig& hal_;
  std::vector<Finding>& findings_;
  std::filesystem::path ini_;
  std::map<std::string, std::string> instanceModule_;
  std::map<std::string, unsigned> personality_;      // logic instance -> its personality
  std::map<std::string, std::string> messageText_;   // message instance -> what it shows
  std::vector<Node> nodes_;
  std::map<std::string, std::size_t> nodeOf_;        // pin -> its value at rest
  std::set<std::string> building_;
  Holds holds_;                                      // the inputs' states at rest, so far
  std::map<std::string, std::string> pinSignal_;
  bool inch_ = false, sevenI76_ = false, failed_ = false;
  std::string jointPins_ = "joint";
  std::vector<AxisOut> axes_;
  std::map<std::string, SwitchOut> switchAt_;  // "7I77:3" -> the switch on that input
  std::vector<std::string> switchOrder_;
  std::vector<std::string> heldOff_;
  std::set<std::string> homeInPlaceInputs_;
  std::vector<std::pair<std::string, std::string>> spindle_;
  std::vector<OutputOut> outputs_;
  std::set<unsigned> claimedStepgens_, claimedEncoders_, claimedAnalogs_;
};

}  // namespace

std::optional<double> AnalogDrive::velocityAt(double pidOutput) const {
  if (!ff1 || !(ff1->v > 0)) return std::nullopt;
  return pidOutput / ff1->v;
}

std::vector<AnalogDrive> analogDrives(const HalConfig& hal, const std::filesystem::path& ini) {
  std::vector<Finding> unused;  // what a machine derived from it would say: not asked here
  return Deriver(hal, unused, ini).analogDrives();
}

DerivedMachine machineFromConfig(const std::filesystem::path& ini) {
  DerivedMachine m;
  if (ini.extension() != ".ini") {
    m.findings.push_back({ini.string(), 0, "error", {}, "a machine comes from a configuration's INI file (.ini)", {}});
    return m;
  }
  const auto hal = readConfiguration(ini, m.findings);
  if (!m.ok()) return m;
  m.toml = Deriver(hal, m.findings, ini).run();
  return m;
}

}  // namespace lbpkit::linuxcnc
