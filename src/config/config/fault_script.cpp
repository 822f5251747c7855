// SPDX-License-Identifier: MIT
#include "config/fault_script.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include "config/toml_reader.hpp"

namespace lbpkit::config {

namespace {

// A script runs for at most a day of simulated time: a typo like "25000s"
// for "2.5s" is still taken, "1e300" is not.
constexpr double kMaxSeconds = 86400;

std::chrono::nanoseconds seconds(double s) {
  return std::chrono::nanoseconds(static_cast<std::int64_t>(std::llround(s * 1e9)));
}

std::string place(const std::string& path, const toml::node& n) {
  const auto& s = n.source().begin;
  return fmt::format("{}:{}:{}", path, s.line, s.column);
}

}  // namespace

std::chrono::nanoseconds parseDuration(const std::string& text) {
  const std::string what =
      fmt::format("\"{}\" is not a duration: a number with s, ms or us (\"2.5s\", \"200ms\"), from 0 to 1 day", text);
  // A decimal number only: std::stod alone would also take "0x1p3",
  // "inf", "nan" and leading spaces.
  const std::size_t numberEnd = text.find_first_not_of("0123456789.eE+-");
  const std::string number = text.substr(0, numberEnd);
  if (number.empty() || (std::isdigit(static_cast<unsigned char>(number[0])) == 0 && number[0] != '.'))
    throw std::invalid_argument(what);
  std::size_t used = 0;
  double v = 0;
  try {
    v = std::stod(number, &used);
  } catch (const std::exception&) {
    throw std::invalid_argument(what);
  }
  if (used != number.size()) throw std::invalid_argument(what);
  const std::string unit = text.substr(number.size());
  double scale = 0;
  if (unit == "s" || unit.empty())
    scale = 1;
  else if (unit == "ms")
    scale = 1e-3;
  else if (unit == "us")
    scale = 1e-6;
  const double s = v * scale;
  if (scale == 0 || !std::isfinite(s) || s < 0 || s > kMaxSeconds) throw std::invalid_argument(what);
  return seconds(s);
}

std::vector<ScriptedFault> loadFaultScript(const std::string& path, bool scriptOnly) {
  const toml::table t = parseFile(path, scriptOnly ? "a TOML fault script" : "a TOML configuration file");
  const ConfigReader r(path);
  if (scriptOnly) r.onlyKeys(t, "", {"fault"});
  std::vector<ScriptedFault> script;
  const toml::array* entries = r.tables(t, "", "fault");
  if (entries == nullptr) return script;
  for (std::size_t i = 0; i < entries->size(); ++i) {
    const toml::table& e = r.element(*entries, "fault", i);
    const std::string prefix = fmt::format("fault[{}].", i);
    ScriptedFault f;
    f.where = place(path, e);
    auto duration = [&](std::string_view key) {
      const toml::node& n = r.required(e, prefix, key);
      try {
        if (const auto* s = n.as_string()) return parseDuration(s->get());
        if (n.is_number()) {
          const double v = n.value<double>().value_or(-1);
          if (v >= 0 && v <= kMaxSeconds) return seconds(v);
        }
        throw std::invalid_argument("a duration is a number of seconds or a string such as \"200ms\"");
      } catch (const std::invalid_argument& x) {
        r.fail(&n, prefix + std::string(key), x.what());
      }
    };
    f.at = duration("at");
    f.fault = r.text(e, prefix, "fault", "", {"network", "link", "cable", "input", "output", "overtemp", "field",
                                               "encoder", "machine"});
    if (e.contains("for")) {
      if (std::find(std::begin(kUndoableFaultKinds), std::end(kUndoableFaultKinds), f.fault) ==
          std::end(kUndoableFaultKinds))
        r.fail(e.get("for"), prefix + "for",
               fmt::format("a \"{}\" fault does not end by itself: only network, link, cable and overtemp faults "
                           "take \"for\" (end it with an entry of its own)",
                           f.fault));
      f.lasts = duration("for");
    }
    // The rest of the entry is the request's body, checked by the API's own
    // code when the sim starts.
    toml::table body = e;
    body.erase("at");
    body.erase("fault");
    body.erase("for");
    std::ostringstream json;
    json << toml::json_formatter{body};
    f.body = json.str();
    script.push_back(std::move(f));
  }
  std::stable_sort(script.begin(), script.end(),
                   [](const ScriptedFault& a, const ScriptedFault& b) { return a.at < b.at; });
  return script;
}

}  // namespace lbpkit::config
