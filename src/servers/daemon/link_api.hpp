// SPDX-License-Identifier: MIT
// The RS-422 link faults' face on the control API: POST /api/link
// sets them on one smart-serial channel, GET /api/link shows, per channel,
// what is set, what the cable did, and what the two ends made of it: the
// SSLBP channel's judged errors (manual: CS REGISTER AFTER START, byte 0,
// sticky until STOP) and the remote's own CRC error count (LBP local 0xC3).
// A fault script's "link" entries are the same request at a set time.
#pragma once

#include <array>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>

#include "hostmot2/sslbp.hpp"

namespace lbpkit::server {

// What GET /api/link shows of one channel, taken on the card thread.
struct LinkSnapshot {
  unsigned channel = 0;
  model::hm2::SerialLink::RateSettings rates;
  bool connected = true;
  double cutForMs = 0;  // simulated time until a cut cable is back
  model::hm2::Sslbp::State::Channel sslbp;
  std::optional<unsigned> remoteCrcErrors;  // absent: no model remote on it
};
struct LinkSnapshots {
  unsigned channels = 0;
  std::array<LinkSnapshot, model::hm2::Sslbp::kMaxChannels> channel{};
};

LinkSnapshots takeLinkSnapshots(model::hm2::Sslbp& sserial, model::lbp::SimTime now);

// Applies a request body to one channel's link: all of it or, when any
// field is wrong, none of it (std::invalid_argument naming the field). Keys:
//   channel (required)   the SSLBP channel (0: the 7I77's field I/O, 1: analog)
//   clear: true          a good cable first (rates 0, plugged in, no cut)
//   direction            "to_remote", "from_remote" or "both" (the default):
//                        where the rates below apply
//   bit_error_rate       probability 0..1 that each data bit is flipped
//   drop_rate, extra_rate   per character, 0..1: lost, or followed by noise
//   break_rate           per reply, 0..1: the reply ends in a break
//   break: true          one break, on the next reply
//   cut_ms               the cable out for this long of simulated time from
//                        now, then back (0: back now)
//   connected            the cable plugged in or pulled (as POST /api/cable)
//   seed                 the rates' random sequence (repeatable runs)
void applyLink(model::hm2::Sslbp& sserial, const nlohmann::json& body, model::lbp::SimTime now);
nlohmann::json toJson(const LinkSnapshots& s);

}  // namespace lbpkit::server
