// SPDX-License-Identifier: MIT
// The words and numbers of a LinuxCNC configuration as lbpkit machine
// --from-config reads them (the INI documentation's values; hostmot2(9)'s
// pin names for the 7I77's and 7I76's field I/O, analog outputs, encoders
// and StepGens), and the sink its findings go to.
#include "linuxcnc/derive_common.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>

#include "linuxcnc/hal_name.hpp"

namespace lbpkit::linuxcnc::detail {

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

std::optional<double> number(const std::string& s) {
  if (s.empty()) return std::nullopt;
  char* end = nullptr;
  const double v = std::strtod(s.c_str(), &end);
  if (end == s.c_str() || *end != '\0') return std::nullopt;
  return v;
}

std::string machineName(const std::string& stem) {
  std::string out;
  for (const char c : stem) {
    if (out.size() == 40) break;
    out += std::isalnum(static_cast<unsigned char>(c)) != 0 && static_cast<unsigned char>(c) < 0x80 ? c
           : c == '_' || c == '-'                                                                   ? c
                                                                                                    : '-';
  }
  return out.empty() ? std::string("machine") : out;
}

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

std::string lower(std::string s) {
  for (auto& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

bool yes(const std::string& s) {
  const auto l = lower(s);
  return l == "yes" || l == "true" || l == "1";
}

std::string offFirst7I77(const std::string& pin) {
  const auto r = hal_name::parseRemote(pin);
  if (!r || r->remote != "7i77") return {};
  const bool analog = r->leaf.rfind("analogout", 0) == 0;
  if (!analog && r->leaf.rfind("input-", 0) != 0 && r->leaf.rfind("output-", 0) != 0) return {};
  const unsigned own = analog ? 1 : 0;
  if (r->port == 0U && r->channel == own) return {};
  if (r->port == 0U && r->channel == own + 3)
    return fmt::format(
        "on the second 7I77 (smart-serial channel {}), and lbpkit's derived machine sits behind the first "
        "7I77 only",
        r->channel);
  return fmt::format("on smart-serial port {} channel {}, where no 7I77 has its {}", r->port, r->channel,
                     analog ? "analog outputs (the first 7I77's are on channel 1, a second's on 4)"
                            : "field I/O (the first 7I77's is on channel 0, a second's on 3)");
}

std::optional<FieldPin> fieldPin(const std::string& pin, const std::string& what) {
  // An input on the card's own IO pins: hm2_<card>.<n>.gpio.NNN.in[_not]
  // (the 7I96S's TB3 inputs).
  if (const auto m = hal_name::parseModule(pin); m && m->module == "gpio") {
    if (what == "input" && (m->leaf == "in" || m->leaf == "in_not"))
      return FieldPin{"card", m->instance, m->leaf == "in_not"};
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
  const auto n = hal_name::number(rest);
  if (!n) return std::nullopt;
  f.number = *n;
  return f;
}

std::optional<unsigned> modulePin(const std::string& pin, const std::string& module, const std::string& leaf) {
  const auto m = hal_name::parseModule(pin);
  if (!m || m->module != module || m->leaf != leaf) return std::nullopt;
  return m->instance;
}

std::optional<unsigned> analogOut(const std::string& pin, bool anyChannel) {
  const auto r = hal_name::parseRemote(pin);
  if (!r || r->remote != "7i77" || r->leaf.rfind("analogout", 0) != 0) return std::nullopt;
  if (!anyChannel && !offFirst7I77(pin).empty()) return std::nullopt;
  return hal_name::number(r->leaf.substr(9));
}

std::string cardOf(const std::string& pin) {
  const auto n = hal_name::parse(pin);
  return n ? n->prefix() : std::string();
}

std::string fmtNumber(double v) {
  if (std::abs(v - std::round(v)) < 1e-9 && std::abs(v) < 1e12) return fmt::format("{:.1f}", std::round(v));
  return fmt::format("{:.6g}", v);
}

Lines encoderLines(double countsPerMm, double pitch) {
  const double exact = countsPerMm * pitch / 4.0;
  if (std::abs(exact - std::round(exact)) <= 1e-6 && std::round(exact) >= 1)
    return {static_cast<unsigned long>(std::round(exact)), 1.0};
  const double lines = std::max(1.0, std::round(exact));
  return {static_cast<unsigned long>(lines), countsPerMm * pitch / (4.0 * lines)};
}

std::string at(const Where& w) { return fmt::format("{}:{}", w.file, w.line); }

void Diagnostics::error(const Where& w, const std::string& name, const std::string& reason) {
  findings_.push_back({w.file, w.line, "error", name, reason, {}});
  failed_ = true;
}

void Diagnostics::warning(const Where& w, const std::string& name, const std::string& reason) {
  findings_.push_back({w.file, w.line, "warning", name, reason, {}});
}

}  // namespace lbpkit::linuxcnc::detail
