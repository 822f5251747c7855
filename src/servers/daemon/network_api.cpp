// SPDX-License-Identifier: MIT
#include "daemon/network_api.hpp"

#include <fmt/format.h>

#include <stdexcept>

#include "daemon/request_fields.hpp"

namespace lbpkit::server {

using nlohmann::json;

namespace {

constexpr std::uint64_t kMaxDelayUs = 10'000'000;  // 10 s: far past any host's timeout
constexpr std::uint64_t kMaxSilentMs = 600'000;    // 10 minutes
constexpr std::uint64_t kMaxEvery = 1'000'000'000;

double probability(const json& j, const char* key) { return fields::number(j, key, 0, 1, "from 0 to 1"); }

json directionJson(const NetworkFaultSettings::Direction& d) {
  return {{"drop", d.drop},           {"drop_every", d.dropEvery}, {"drop_next", d.dropNext},
          {"duplicate", d.duplicate}, {"corrupt", d.corrupt},      {"reorder", d.reorder},
          {"delay_us", d.delayUs},    {"jitter_us", d.jitterUs},   {"delay_every", d.delayEvery},
          {"writes_only", d.writesOnly}};
}

json countersJson(const NetworkFaultCounters::Direction& c) {
  return {{"passed", c.passed},         {"dropped", c.dropped},     {"silenced", c.silenced},
          {"duplicated", c.duplicated}, {"corrupted", c.corrupted}, {"reordered", c.reordered},
          {"delayed", c.delayed},       {"overflowed", c.overflowed}};
}

}  // namespace

void applyNetwork(NetworkFaults& faults, const json& j, NetworkFaults::Clock::time_point now) {
  fields::onlyKnown(j, {"clear", "direction", "drop", "drop_every", "drop_next", "duplicate", "corrupt", "reorder",
                        "delay_us", "jitter_us", "delay_every", "writes_only", "silent_ms", "seed"});
  NetworkFaultSettings s = fields::flag(j, "clear", false) ? NetworkFaultSettings{} : faults.settings();
  const std::string direction = j.contains("direction") ? fields::text(j, "direction") : "both";
  if (direction != "request" && direction != "reply" && direction != "both")
    throw std::invalid_argument(
        fmt::format("\"direction\" must be \"request\", \"reply\" or \"both\", not \"{}\"", direction));
  // Every field read (and checked) before anything changes.
  auto change = [&](NetworkFaultSettings::Direction& d) {
    if (j.contains("drop")) d.drop = probability(j, "drop");
    if (j.contains("duplicate")) d.duplicate = probability(j, "duplicate");
    if (j.contains("corrupt")) d.corrupt = probability(j, "corrupt");
    if (j.contains("reorder")) d.reorder = probability(j, "reorder");
    if (j.contains("drop_every"))
      d.dropEvery = static_cast<std::uint32_t>(
          fields::whole(j, "drop_every", kMaxEvery, "from 0 (none) to 1000000000"));
    if (j.contains("drop_next"))
      d.dropNext = static_cast<std::uint32_t>(
          fields::whole(j, "drop_next", kMaxEvery, "from 0 (none) to 1000000000"));
    if (j.contains("delay_every"))
      d.delayEvery = static_cast<std::uint32_t>(
          fields::whole(j, "delay_every", kMaxEvery, "from 0 (every datagram) to 1000000000"));
    if (j.contains("delay_us"))
      d.delayUs = static_cast<std::uint32_t>(
          fields::whole(j, "delay_us", kMaxDelayUs, "from 0 to 10000000 (microseconds)"));
    if (j.contains("jitter_us"))
      d.jitterUs = static_cast<std::uint32_t>(
          fields::whole(j, "jitter_us", kMaxDelayUs, "from 0 to 10000000 (microseconds)"));
  };
  if (j.contains("writes_only")) {
    if (direction != "request")
      throw std::invalid_argument("\"writes_only\" sorts requests: it needs \"direction\": \"request\"");
    s.request.writesOnly = fields::flag(j, "writes_only");
  }
  if (direction != "reply") change(s.request);
  if (direction != "request") change(s.reply);
  if (j.contains("seed")) s.seed = fields::whole(j, "seed", UINT64_MAX, "from 0 to 2^64-1");
  const bool silent = j.contains("silent_ms");
  const auto silentMs = silent ? fields::whole(j, "silent_ms", kMaxSilentMs, "from 0 to 600000 (milliseconds)") : 0;
  if (s != faults.settings() || j.contains("seed")) faults.set(s);
  if (fields::flag(j, "clear", false) && !silent) faults.silence(std::chrono::microseconds{0}, now);
  if (silent) faults.silence(std::chrono::milliseconds(silentMs), now);
}

json toJson(const NetworkSnapshot& s) {
  return {{"set",
           {{"request", directionJson(s.settings.request)},
            {"reply", directionJson(s.settings.reply)},
            {"seed", s.settings.seed}}},
          {"did", {{"request", countersJson(s.counters.request)}, {"reply", countersJson(s.counters.reply)}}},
          {"silent_for_ms", static_cast<double>(s.silentFor.count()) / 1000.0},
          {"held", s.held}};
}

}  // namespace lbpkit::server
