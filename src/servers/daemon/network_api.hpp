// SPDX-License-Identifier: MIT
// The network faults' face on the control API: POST /api/network
// sets them, GET /api/network shows what is set and what it did. A fault
// script's "network" entries are the same request at a set time.
#pragma once

#include <chrono>
#include <nlohmann/json.hpp>

#include "lbp16/network_faults.hpp"

namespace lbpkit::server {

// What GET /api/network shows, taken on the card thread.
struct NetworkSnapshot {
  NetworkFaultSettings settings;
  NetworkFaultCounters counters;
  std::chrono::microseconds silentFor{0};
  unsigned held = 0;  // datagrams held back (delayed or reordered) now
};

// Applies a request body to `faults`: all of it or, when any field is
// wrong, none of it (std::invalid_argument naming the field). Keys:
//   clear: true          everything back to a good network first
//   direction            "request", "reply" or "both" (the default): where
//                        the following apply
//   drop, duplicate, corrupt, reorder   probabilities 0..1
//   drop_every           every Nth datagram lost (0: none)
//   drop_next            the next N datagrams lost (one read timeout: 1)
//   delay_us, jitter_us  a fixed delay plus up to jitter more
//   delay_every          that delay for every Nth datagram only (spikes; 0: all)
//   writes_only          with "direction": "request": the request settings
//                        apply only to requests that ask for no reply
//   silent_ms            the cable out for this long from now (0: back in)
//   seed                 the random sequence's seed (repeatable runs)
void applyNetwork(NetworkFaults& faults, const nlohmann::json& body, NetworkFaults::Clock::time_point now);
nlohmann::json toJson(const NetworkSnapshot& s);

}  // namespace lbpkit::server
