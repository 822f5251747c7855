// SPDX-License-Identifier: MIT
// The field outputs (output_deriver.hpp; the 7I77 and 7I76 manuals: 16
// sourcing outputs; hostmot2(9): output-NN).
#include "linuxcnc/output_deriver.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <map>
#include <string>
#include <utility>
#include <vector>

namespace lbpkit::linuxcnc::detail {

// Every field output a net drives, once: an output on two signals (a
// second `net` after an `unlinkp`, two files naming it) is one output
// whose comment names each.
void deriveOutputs(DeriveContext& c) {
  struct Found {
    FieldPin o;
    std::vector<std::pair<std::string, std::string>> nets;  // pin, signal
  };
  std::vector<Found> found;
  std::map<std::string, std::size_t> index;
  for (const auto& [sig, pins] : c.hal.signals)
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
    for (unsigned k = 2;
         std::any_of(c.out.outputs.begin(), c.out.outputs.end(), [&](const OutputOut& x) { return x.name == name; });
         ++k) {
      const auto suffix = fmt::format("-{}", k);
      name = machineName(sig).substr(0, 40 - suffix.size()) + suffix;
    }
    std::string comment;
    for (const auto& [p, s] : f.nets)
      comment += fmt::format("{}{} ({}), signal {}", comment.empty() ? "" : "; also ", p, at(c.graph.whereOn(p, s)), s);
    if (f.nets.size() > 1) comment += ": one output";
    c.out.outputs.push_back({name, f.o.daughtercard, comment, f.o.number});
  }
}

}  // namespace lbpkit::linuxcnc::detail
