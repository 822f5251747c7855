// SPDX-License-Identifier: MIT
// LinuxCNC's start-up check (LinuxCNC: lib/hallib/check_config.tcl), read
// for its facts and repeated in lbpkit's own code:
// - it reads the INI with LinuxCNC's Tcl INI reader (LinuxCNC:
//   tcl/linuxcnc.tcl.in, parse_ini): each line trimmed; "[NAME]" alone on a
//   line opens a section; a line with an "=" that no "#" comes before is
//   KEY = VALUE, both trimmed, and every value of a key repeated is kept, in
//   order, as a Tcl list. A KEY = VALUE line before the first section stops
//   the script with a Tcl error;
// - [KINS]KINEMATICS and [KINS]JOINTS must be there (else it refuses);
// - it checks only trivkins (the first word of the last KINEMATICS line):
//   coordinates=LETTERS gives joint 0 to the first letter, joint 1 to the
//   second, ... (a letter given twice, as in a gantry's XXYZ, has two
//   joints); without coordinates=, XYZABCUVW;
// - for every letter of coordinates=, each of its joints with a MIN_LIMIT
//   above the axis's MIN_LIMIT, or a MAX_LIMIT below the axis's MAX_LIMIT,
//   is refused; an axis without MIN_LIMIT/MAX_LIMIT counts as -1e99/+1e99.
//   The values are compared as Tcl's expr compares them: as numbers when
//   both are numbers to Tcl, else as text;
// - warnings: a joint below [KINS]JOINTS or an axis of coordinates= with an
//   [AXIS_L] section but no MAX_VELOCITY or MAX_ACCELERATION (LinuxCNC takes
//   1.0), a key of a [JOINT_N] or [AXIS_L] section given more than once,
//   coordinates= other than [TRAJ]COORDINATES, num_extrajoints= in
//   [EMCMOT]EMCMOT; a word of KINEMATICS that is neither the module nor
//   KEY=VALUE is printed and left alone.
// The `linuxcnc` command runs it after its [EMC]VERSION check, so only on a
// VERSION 1.1 INI (LinuxCNC: scripts/linuxcnc.in).
#include "linuxcnc/startup_check.hpp"

#include <fmt/format.h>

#include <cctype>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <map>
#include <optional>
#include <set>
#include <tuple>

namespace lbpkit::linuxcnc {
namespace startup_detail {
namespace {

// What Tcl counts as white space in a line and around a number.
bool space(char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\v' || c == '\f'; }

std::string strip(const std::string& s, bool withNul = false) {
  std::size_t b = 0, e = s.size();
  auto ws = [&](char c) { return space(c) || (withNul && c == '\0'); };
  while (b < e && ws(s[b])) ++b;
  while (e > b && ws(s[e - 1])) --e;
  return s.substr(b, e - b);
}

// A value and where it is written (the INI, or a file it includes).
struct Value {
  std::string text;
  Where at;
};

struct Section {
  Where at;  // where it is first opened
  std::map<std::string, std::vector<Value>> keys;
};

// The INI as LinuxCNC's Tcl INI reader sees it.
struct TclIni {
  std::map<std::string, Section> sections;
  Where keyBeforeSection;  // the first KEY = VALUE line before any [SECTION] (line 0: none)
  std::string keyBeforeSectionText;

  [[nodiscard]] const std::vector<Value>* values(const std::string& section, const std::string& key) const {
    const auto s = sections.find(section);
    if (s == sections.end()) return nullptr;
    const auto k = s->second.keys.find(key);
    return k == s->second.keys.end() ? nullptr : &k->second;
  }
  // A Tcl array exists once a key is set in it.
  [[nodiscard]] const Section* withKeys(const std::string& section) const {
    const auto s = sections.find(section);
    return s == sections.end() || s->second.keys.empty() ? nullptr : &s->second;
  }
};

// The INI as `linuxcnc` hands it to the check: #INCLUDE expanded
// (readIniLines), each value where it is written.
TclIni readTclIni(const std::filesystem::path& path, const std::string& shownAs) {
  TclIni ini;
  std::string section;
  bool inSection = false;
  readIniLines(path, shownAs, nullptr, [&](const std::string& raw, const std::string& file, unsigned n) {
    const Where here{file, n};
    const auto t = strip(raw, true);
    if (t.size() >= 2 && t.front() == '[' && t.back() == ']') {
      section = t.substr(1, t.size() - 2);
      inSection = true;
      ini.sections.try_emplace(section, Section{here, {}});
      return;
    }
    // KEY = VALUE: the first "=" after at least one character, with no "#"
    // before it.
    std::size_t eq = std::string::npos;
    for (std::size_t i = 0; i < t.size() && t[i] != '#'; ++i)
      if (t[i] == '=' && i > 0) {
        eq = i;
        break;
      }
    if (eq == std::string::npos) return;
    const auto key = strip(t.substr(0, eq));
    const auto value = strip(t.substr(eq + 1));
    if (!inSection) {
      if (ini.keyBeforeSection.line == 0) {
        ini.keyBeforeSection = here;
        ini.keyBeforeSectionText = key;
      }
      return;
    }
    auto& s = ini.sections[section];
    if (s.at.line == 0) s.at = here;
    s.keys[key].push_back({value, here});
  });
  return ini;
}

// One value as an element of a Tcl list, as Tcl writes it: as it is when
// nothing in it is special, in braces when they can hold it, else with a
// backslash before each special character.
std::string listElement(const std::string& v, bool first) {
  if (v.empty()) return "{}";
  static const std::string special = " \t\n\r\v\f{}[]$;\"\\";
  if (v.find_first_of(special) == std::string::npos && !(first && v[0] == '#')) return v;
  int depth = 0;
  bool balanced = true;
  for (std::size_t i = 0; i < v.size(); ++i) {
    if (v[i] == '\\' && i + 1 < v.size()) {
      ++i;
      continue;
    }
    if (v[i] == '{') ++depth;
    if (v[i] == '}' && --depth < 0) balanced = false;
  }
  balanced = balanced && depth == 0 && v.back() != '\\';
  const bool wantsBraces = v.find_first_of(" \t\n\r\v\f;$[\\") != std::string::npos || v[0] == '"' || v[0] == '{' ||
                           (first && v[0] == '#');
  if (wantsBraces && balanced) return "{" + v + "}";
  std::string out;
  for (const char c : v) {
    if (special.find(c) != std::string::npos || (first && out.empty() && c == '#')) out += '\\';
    out += c;
  }
  return out;
}

// Every value of a key, as the one Tcl string the check compares.
std::string listOf(const std::vector<Value>& values) {
  std::string out;
  for (const auto& v : values) out += (out.empty() ? "" : " ") + listElement(v.text, out.empty());
  return out;
}

// The words of a Tcl list (braces, quotes, backslashes); nullopt when Tcl
// cannot read it as one (an unmatched brace or quote).
std::optional<std::vector<std::string>> listWords(const std::string& s) {
  std::vector<std::string> words;
  std::size_t i = 0;
  while (true) {
    while (i < s.size() && space(s[i])) ++i;
    if (i >= s.size()) break;
    std::string w;
    if (s[i] == '{') {
      int depth = 1;
      std::size_t j = i + 1;
      for (; j < s.size(); ++j) {
        if (s[j] == '\\' && j + 1 < s.size()) {
          ++j;
          continue;
        }
        if (s[j] == '{') ++depth;
        if (s[j] == '}' && --depth == 0) break;
      }
      if (j >= s.size()) return std::nullopt;
      w = s.substr(i + 1, j - i - 1);
      i = j + 1;
      if (i < s.size() && !space(s[i])) return std::nullopt;
    } else if (s[i] == '"') {
      std::size_t j = i + 1;
      for (; j < s.size() && s[j] != '"'; ++j) {
        if (s[j] == '\\' && j + 1 < s.size()) ++j;
        w += s[j];
      }
      if (j >= s.size()) return std::nullopt;
      i = j + 1;
      if (i < s.size() && !space(s[i])) return std::nullopt;
    } else {
      for (; i < s.size() && !space(s[i]); ++i) {
        if (s[i] == '\\' && i + 1 < s.size()) ++i;
        w += s[i];
      }
    }
    words.push_back(std::move(w));
  }
  return words;
}

// A number as Tcl 8.6 reads an operand of expr: white space around it, a
// sign, then 0x/0o/0b digits, an integer with a leading 0 in octal, a
// decimal with a fraction or an exponent, Inf, Infinity or NaN. nullopt when
// the text is no number to Tcl. `integer`: whether it is a whole number.
std::optional<long double> tclNumber(const std::string& text, bool* integer = nullptr) {
  const auto s = strip(text);
  if (integer) *integer = false;
  std::size_t i = 0;
  bool negative = false;
  if (i < s.size() && (s[i] == '+' || s[i] == '-')) negative = s[i++] == '-';
  std::string r = s.substr(i);
  if (r.empty()) return std::nullopt;
  std::string lower;
  for (const char c : r) lower += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  const long double sign = negative ? -1.0L : 1.0L;
  if (lower == "inf" || lower == "infinity") return sign * HUGE_VALL;
  if (lower == "nan") return std::nanl("");
  auto digits = [&](std::size_t from, unsigned base) -> std::optional<long double> {
    if (from >= r.size()) return std::nullopt;
    long double v = 0;
    for (std::size_t k = from; k < r.size(); ++k) {
      const auto c = static_cast<unsigned char>(lower[k]);
      unsigned d = 0;
      if (std::isdigit(c)) d = static_cast<unsigned>(c - '0');
      else if (c >= 'a' && c <= 'f') d = static_cast<unsigned>(c - 'a') + 10U;
      else return std::nullopt;
      if (d >= base) return std::nullopt;
      v = v * base + d;
    }
    if (integer) *integer = true;
    return sign * v;
  };
  if (lower.size() >= 2 && lower[0] == '0' && lower[1] == 'x') return digits(2, 16);
  if (lower.size() >= 2 && lower[0] == '0' && lower[1] == 'o') return digits(2, 8);
  if (lower.size() >= 2 && lower[0] == '0' && lower[1] == 'b') return digits(2, 2);
  // Decimal: digits, an optional fraction, an optional exponent.
  std::size_t k = 0, mantissa = 0;
  while (k < r.size() && std::isdigit(static_cast<unsigned char>(r[k]))) ++k, ++mantissa;
  const std::size_t whole = k;
  bool fraction = false, exponent = false;
  if (k < r.size() && r[k] == '.') {
    fraction = true;
    ++k;
    while (k < r.size() && std::isdigit(static_cast<unsigned char>(r[k]))) ++k, ++mantissa;
  }
  if (mantissa == 0) return std::nullopt;
  if (k < r.size() && (r[k] == 'e' || r[k] == 'E')) {
    exponent = true;
    ++k;
    if (k < r.size() && (r[k] == '+' || r[k] == '-')) ++k;
    const std::size_t from = k;
    while (k < r.size() && std::isdigit(static_cast<unsigned char>(r[k]))) ++k;
    if (k == from) return std::nullopt;
  }
  if (k != r.size()) return std::nullopt;
  if (!fraction && !exponent) {
    if (whole > 1 && r[0] == '0') return digits(1, 8);  // a leading 0: octal
    return digits(0, 10);
  }
  return sign * std::strtold(r.c_str(), nullptr);
}

// Tcl's a > b (greater) or a < b: as numbers when both are numbers, else as
// text. `asText` says which.
bool tclAbove(const std::string& a, const std::string& b, bool greater, bool& asText) {
  const auto x = tclNumber(a), y = tclNumber(b);
  asText = !x || !y;
  if (asText) return greater ? a > b : a < b;
  return greater ? *x > *y : *x < *y;
}

std::string joinValues(const std::vector<Value>& values) {
  std::string out;
  for (const auto& v : values) out += (out.empty() ? "" : ", ") + v.text;
  return values.size() > 1 ? fmt::format("{} (given {} times)", out, values.size()) : out;
}

constexpr const char* kRefuses = "LinuxCNC's start-up check refuses it";
constexpr const char* kWarns = "LinuxCNC's start-up check warns";
// Joints the check counts that get a warning each (LinuxCNC runs 16 at most).
constexpr unsigned kJointWarnings = 64;
// A [KINS]JOINTS the check counts up to for longer than this never lets it end.
constexpr unsigned kJointCountLimit = 100000;

struct Check {
  const TclIni& ini;
  std::string file;  // the INI's name, for what has no line of its own
  std::vector<Finding> findings;

  void add(const Where& at, const char* severity, std::string name, std::string reason) {
    findings.push_back({at.file, at.line, severity, std::move(name), std::move(reason), {}});
  }
  [[nodiscard]] Where sectionAt(const std::string& section) const {
    const auto s = ini.sections.find(section);
    return s == ini.sections.end() ? Where{file, 0} : s->second.at;
  }
};

void run(Check& c) {
  const TclIni& ini = c.ini;
  if (ini.keyBeforeSection.line != 0) {
    c.add(ini.keyBeforeSection, "error", ini.keyBeforeSectionText,
          fmt::format("{} = ... comes before the first [SECTION]: LinuxCNC's start-up check cannot read the INI "
                      "(its Tcl INI reader stops at a key outside a section), so LinuxCNC does not start",
                      ini.keyBeforeSectionText));
    return;
  }

  // [KINS]KINEMATICS and [KINS]JOINTS.
  const auto* kinematics = ini.values("KINS", "KINEMATICS");
  const auto* joints = ini.values("KINS", "JOINTS");
  if (!kinematics || !joints) {
    for (const auto& [key, values] : {std::pair{"KINEMATICS", kinematics}, std::pair{"JOINTS", joints}})
      if (!values)
        c.add(c.sectionAt("KINS"), "error", fmt::format("[KINS]{}", key),
              fmt::format("no [KINS]{}: {} (it requires [KINS]KINEMATICS and [KINS]JOINTS)", key, kRefuses));
    return;
  }

  // The kinematics: the last KINEMATICS line, its first word the module,
  // KEY=VALUE words its parameters.
  const Value& kinsLine = kinematics->back();
  const auto words = listWords(kinsLine.text);
  if (!words) {
    c.add(kinsLine.at, "error", "[KINS]KINEMATICS",
          fmt::format("[KINS]KINEMATICS = {} has an unmatched brace or quote: LinuxCNC's start-up check cannot split "
                      "it into words (a Tcl error), so LinuxCNC does not start",
                      kinsLine.text));
    return;
  }
  std::map<std::string, std::string> kins;
  kins["module"] = words->empty() ? std::string() : words->front();
  for (const auto& w : *words) {
    if (const auto eq = w.find('='); eq != std::string::npos) {
      const auto next = w.find('=', eq + 1);
      kins[w.substr(0, eq)] = w.substr(eq + 1, next == std::string::npos ? std::string::npos : next - eq - 1);
    } else if (w != kins["module"]) {
      c.add(kinsLine.at, "warning", "[KINS]KINEMATICS",
            fmt::format("[KINS]KINEMATICS = {}: \"{}\" is neither the module nor KEY=VALUE, and LinuxCNC's start-up "
                        "check leaves it out",
                        kinsLine.text, w));
    }
  }
  const bool coordinatesGiven = kins.count("coordinates") != 0;
  std::vector<std::string> coordinates;
  if (coordinatesGiven) {
    for (const char ch : kins["coordinates"])
      coordinates.emplace_back(1, static_cast<char>(std::toupper(static_cast<unsigned char>(ch))));
  } else {
    for (const char ch : std::string("XYZABCUVW")) coordinates.emplace_back(1, ch);
  }
  // LinuxCNC checks trivkins only.
  if (kins["module"] != "trivkins") return;
  // Joint i moves the axis of the i-th letter (of XYZABCUVW when none are given).
  std::map<std::string, std::vector<unsigned>> jointsOf;
  {
    auto letters = coordinates;
    if (letters.empty())
      for (const char ch : std::string("XYZABCUVW")) letters.emplace_back(1, ch);
    for (unsigned j = 0; j < letters.size(); ++j) jointsOf[letters[j]].push_back(j);
  }
  const std::string jointsText = listOf(*joints);
  const Value& jointsLine = joints->front();
  auto mapping = [&](unsigned joint, const std::string& axis) {
    return coordinatesGiven
               ? fmt::format("[KINS]KINEMATICS coordinates={} makes joint {} axis {}", kins["coordinates"], joint, axis)
               : fmt::format("trivkins without coordinates= makes joint {} axis {} (joints 0 to 8 are XYZABCUVW)",
                             joint, axis);
  };

  // num_extrajoints in [EMCMOT]EMCMOT (read only when the value's Tcl text
  // has "motmod" after its first character, as the check reads it).
  if (const auto* emcmot = ini.values("EMCMOT", "EMCMOT")) {
    const auto text = listOf(*emcmot);
    const auto at = text.find("motmod");
    if (at != std::string::npos && at > 0) {
      std::optional<std::string> extra;
      const std::string& first = emcmot->front().text;
      std::size_t from = 0;
      while (from <= first.size()) {
        auto end = from;
        while (end < first.size() && !space(first[end])) ++end;
        const auto item = first.substr(from, end - from);
        const auto eq = item.find('=');
        if (item.substr(0, eq) == "num_extrajoints") {
          const auto next = eq == std::string::npos ? std::string::npos : item.find('=', eq + 1);
          extra = eq == std::string::npos ? std::string()
                                          : item.substr(eq + 1, next == std::string::npos ? next : next - eq - 1);
        }
        from = end + 1;
      }
      if (extra) {
        bool extraWhole = false, jointsWhole = false;
        (void)tclNumber(*extra, &extraWhole);
        (void)tclNumber(jointsText, &jointsWhole);
        if (!extraWhole || !jointsWhole) {
          c.add(emcmot->front().at, "error", "[EMCMOT]EMCMOT",
                fmt::format("[EMCMOT]EMCMOT gives num_extrajoints={} and [KINS]JOINTS = {}: LinuxCNC's start-up check "
                            "prints both as whole numbers and stops with a Tcl error when one is not, so LinuxCNC does "
                            "not start",
                            *extra, joinValues(*joints)));
          return;
        }
        c.add(emcmot->front().at, "warning", "[EMCMOT]EMCMOT",
              fmt::format("[EMCMOT]EMCMOT asks for {} extra joints: [KINS]JOINTS = {} must count the kinematic joints "
                          "and the extra joints ({})",
                          *extra, joinValues(*joints), kWarns));
      }
    }
  }

  // A key of a [JOINT_N] or [AXIS_L] section given more than once.
  for (const auto& [name, section] : ini.sections) {
    if (name.find("JOINT_") == std::string::npos && name.find("AXIS_") == std::string::npos) continue;
    for (const auto& [key, values] : section.keys) {
      if (values.size() < 2) continue;
      std::string lines;
      for (const auto& v : values)
        lines += v.at.file == values.front().at.file
                     ? fmt::format("{}{}", lines.empty() ? "" : ", ", v.at.line)
                     : fmt::format("{}{}:{}", lines.empty() ? "" : ", ", v.at.file, v.at.line);
      c.add(values[1].at, "warning", fmt::format("[{}]{}", name, key),
            fmt::format("[{}]{} is given {} times (lines {}): LinuxCNC itself takes the first ({}; where it compares "
                        "the key, it compares all of them as one text)",
                        name, key, values.size(), lines, kWarns));
    }
  }

  // Joints 0, 1, ... while below [KINS]JOINTS (compared as Tcl compares).
  // JOINTS is read as a number once (a value can be long).
  const auto jointsNumber = tclNumber(jointsText);
  const bool jointsAsText = !jointsNumber;
  unsigned counted = 0;
  for (;; ++counted) {
    const bool below =
        jointsAsText ? std::to_string(counted) < jointsText : static_cast<long double>(counted) < *jointsNumber;
    if (!below) break;
    if (counted < kJointCountLimit) continue;
    // A whole number of joints that large ends, if slowly: only a count that
    // never ends (text, Inf) stops LinuxCNC.
    if (!jointsAsText && std::isfinite(*jointsNumber)) break;
    c.add(jointsLine.at, "error", "[KINS]JOINTS",
          fmt::format("[KINS]JOINTS = {}: LinuxCNC's start-up check counts joints up to it{} and never ends, so "
                      "LinuxCNC never starts",
                      joinValues(*joints), jointsAsText ? " compared as text (it is not a number)" : ""));
    return;
  }
  for (unsigned j = 0; j < counted && j < kJointWarnings; ++j) {
    const auto section = fmt::format("JOINT_{}", j);
    const auto line = ini.sections.count(section) ? c.sectionAt(section) : jointsLine.at;
    for (const char* key : {"MAX_VELOCITY", "MAX_ACCELERATION"})
      if (!ini.values(section, key))
        c.add(line, "warning", fmt::format("[{}]{}", section, key),
              fmt::format("[{}] has no {}: LinuxCNC takes 1.0 ({})", section, key, kWarns));
  }

  // Each axis of coordinates=, and each joint that moves it.
  std::set<std::string> seen;
  for (const auto& axis : coordinates) {
    if (!seen.insert(axis).second) continue;
    const auto section = "AXIS_" + axis;
    if (const auto* s = ini.withKeys(section))
      for (const char* key : {"MAX_VELOCITY", "MAX_ACCELERATION"})
        if (!s->keys.count(key))
          c.add(s->at, "warning", fmt::format("[{}]{}", section, key),
                fmt::format("[{}] has no {}: LinuxCNC takes 1.0 ({})", section, key, kWarns));
    for (const auto& [key, fallback, greater] :
         {std::tuple{"MIN_LIMIT", "-1e99", true}, std::tuple{"MAX_LIMIT", "+1e99", false}}) {
      const auto* axisValues = ini.values(section, key);
      const std::string axisText = axisValues ? listOf(*axisValues) : std::string(fallback);
      for (const unsigned j : jointsOf[axis]) {
        const auto joint = fmt::format("JOINT_{}", j);
        const auto* jointValues = ini.values(joint, key);
        if (!jointValues) continue;
        bool comparedAsText = false;
        if (!tclAbove(listOf(*jointValues), axisText, greater, comparedAsText)) continue;
        const std::string axisSaid =
            axisValues ? fmt::format("[{}]{} = {}", section, key, joinValues(*axisValues))
                       : fmt::format("[{}]{}, which the INI does not give and LinuxCNC's start-up check takes as {}",
                                     section, key, fallback);
        c.add(jointValues->front().at, "error", fmt::format("[{}]{}", joint, key),
              fmt::format("[{}]{} = {} is {} {}{} ({}: a joint's limits must hold its axis's, and {})", joint, key,
                          joinValues(*jointValues), greater ? "above" : "below", axisSaid,
                          comparedAsText ? "; compared as text, as they are not both numbers" : "", kRefuses,
                          mapping(j, axis)));
      }
    }
  }

  // coordinates= against [TRAJ]COORDINATES.
  std::string given;
  for (const auto& l : coordinates) given += l;
  if (given != "XYZABCUVW") {
    const auto* traj = ini.values("TRAJ", "COORDINATES");
    std::string trajLetters;
    if (traj)
      for (const char ch : traj->front().text)
        if (ch != ' ' && ch != '\t') trajLetters += static_cast<char>(std::toupper(static_cast<unsigned char>(ch)));
    std::string noBlanks;
    for (const char ch : given)
      if (ch != ' ' && ch != '\t') noBlanks += ch;
    if (noBlanks != trajLetters)
      c.add(traj ? traj->front().at : kinsLine.at, "warning", "[TRAJ]COORDINATES",
            fmt::format("trivkins coordinates={} but [TRAJ]COORDINATES = {} ({})", kins["coordinates"],
                        traj ? traj->front().text : std::string("(none)"), kWarns));
  }
}

}  // namespace
}  // namespace startup_detail

std::vector<Finding> startupCheck(const std::filesystem::path& ini, const std::string& shownAs) {
  using namespace startup_detail;
  std::error_code ec;
  if (!std::filesystem::is_regular_file(ini, ec)) return {};
  const TclIni read = readTclIni(ini, shownAs);
  // `linuxcnc` reads [EMC]VERSION first (its first value) and converts any
  // INI not at 1.1 before the check sees it.
  const auto* version = read.values("EMC", "VERSION");
  if (!version || version->front().text != "1.1") return {};
  Check c{read, shownAs, {}};
  run(c);
  return std::move(c.findings);
}

}  // namespace lbpkit::linuxcnc
