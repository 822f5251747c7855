// SPDX-License-Identifier: MIT
#include "daemon/link_api.hpp"

#include <fmt/format.h>

#include <chrono>
#include <stdexcept>
#include <string>

#include "daemon/request_fields.hpp"

namespace lbpkit::server {

using nlohmann::json;

namespace {

constexpr std::uint64_t kMaxCutMs = 600'000;  // 10 minutes of simulated time

double rate(const json& j, const char* key) { return fields::number(j, key, 0, 1, "from 0 to 1"); }

json ratesJson(const model::hm2::SerialLink::Rates& r) {
  return {{"bit_error_rate", r.bitErrorRate}, {"drop_rate", r.dropRate}, {"extra_rate", r.extraRate}};
}

}  // namespace

LinkSnapshots takeLinkSnapshots(model::hm2::Sslbp& sserial, model::lbp::SimTime now) {
  LinkSnapshots out;
  const auto state = sserial.state();
  out.channels = state.channels;
  for (unsigned ch = 0; ch < state.channels; ++ch) {
    auto& link = sserial.link(ch);
    auto& s = out.channel[ch];
    s.channel = ch;
    s.rates = link.rates();
    s.connected = link.connected();
    s.cutForMs = link.cutUntil() > now ? std::chrono::duration<double, std::milli>(link.cutUntil() - now).count() : 0;
    s.sslbp = state.channel[ch];
    if (const auto* remote = link.remote(); remote != nullptr && !link.external())
      s.remoteCrcErrors = remote->crcErrorCount();
  }
  return out;
}

void applyLink(model::hm2::Sslbp& sserial, const json& j, model::lbp::SimTime now) {
  fields::onlyKnown(j, {"channel", "clear", "direction", "bit_error_rate", "drop_rate", "extra_rate", "break_rate",
                        "break", "cut_ms", "connected", "seed"});
  if (!j.contains("channel")) throw std::invalid_argument("missing \"channel\" (the smart-serial channel, from 0)");
  auto& link = sserial.link(fields::index(j, "channel", sserial.channels()));
  const bool clear = fields::flag(j, "clear", false);
  auto s = clear ? model::hm2::SerialLink::RateSettings{} : link.rates();
  const std::string direction = j.contains("direction") ? fields::text(j, "direction") : "both";
  if (direction != "to_remote" && direction != "from_remote" && direction != "both")
    throw std::invalid_argument(
        fmt::format("\"direction\" must be \"to_remote\", \"from_remote\" or \"both\", not \"{}\"", direction));
  // Every field read (and checked) before anything changes.
  auto change = [&](model::hm2::SerialLink::Rates& r) {
    if (j.contains("bit_error_rate")) r.bitErrorRate = rate(j, "bit_error_rate");
    if (j.contains("drop_rate")) r.dropRate = rate(j, "drop_rate");
    if (j.contains("extra_rate")) r.extraRate = rate(j, "extra_rate");
  };
  if (direction != "from_remote") change(s.toRemote);
  if (direction != "to_remote") change(s.fromRemote);
  if (j.contains("break_rate")) s.breakRate = rate(j, "break_rate");
  if (j.contains("seed")) s.seed = fields::whole(j, "seed", UINT64_MAX, "from 0 to 2^64-1");
  const bool oneBreak = fields::flag(j, "break", false);
  const bool cut = j.contains("cut_ms");
  const auto cutMs = cut ? fields::whole(j, "cut_ms", kMaxCutMs, "from 0 to 600000 (milliseconds)") : 0;
  const bool plug = j.contains("connected");
  const bool connected = plug ? fields::flag(j, "connected") : true;

  if (s != link.rates() || j.contains("seed")) link.setRates(s);
  if (clear) {
    link.setConnected(true);
    link.cut(now, now);
  }
  if (plug) link.setConnected(connected);
  if (cut) link.cut(now, now + std::chrono::milliseconds(cutMs));
  if (oneBreak) link.breakNext();
}

json toJson(const LinkSnapshots& s) {
  json chans = json::array();
  for (unsigned ch = 0; ch < s.channels; ++ch) {
    const auto& c = s.channel[ch];
    const auto& l = c.sslbp.link;
    const auto& e = c.sslbp.errors;
    chans.push_back(
        {{"channel", c.channel},
         {"set",
          {{"to_remote", ratesJson(c.rates.toRemote)},
           {"from_remote", ratesJson(c.rates.fromRemote)},
           {"break_rate", c.rates.breakRate},
           {"seed", c.rates.seed}}},
         {"connected", c.connected},
         {"cut_for_ms", c.cutForMs},
         {"did",
          {{"characters_to_remote", l.toRemote},
           {"characters_from_remote", l.fromRemote},
           {"bits_flipped", l.bitErrors},
           {"characters_corrupted", l.corrupted},
           {"characters_dropped", l.dropped},
           {"characters_added", l.added},
           {"breaks", l.breaks}}},
         {"sslbp",
          {{"cs", fmt::format("0x{:08X}", c.sslbp.cs)},
           {"running", c.sslbp.running},
           {"errors",
            {{"crc", e.crc},
             {"invalid_cookie", e.invalidCookie},
             {"overrun", e.overrun},
             {"timeout", e.timeout},
             {"extra_character", e.extraCharacter},
             {"serial_break", e.serialBreak},
             {"remote_fault", e.remoteFault}}}}},
         {"remote_crc_errors", c.remoteCrcErrors ? json(*c.remoteCrcErrors) : json(nullptr)}});
  }
  return {{"channels", chans}};
}

}  // namespace lbpkit::server
