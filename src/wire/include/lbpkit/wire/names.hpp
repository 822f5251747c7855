// SPDX-License-Identifier: MIT
#pragma once
// How names compare, on both sides. Names on the wire (a remote's PTOC and
// GTOC records, the IDROM's module and pin names, HTTP's header names) are
// ASCII, so they compare in ASCII and never in the user's locale: LinuxCNC's
// hostmot2 names a pin with the lower case of the name a remote or the IDROM
// gives. A misspelt name is answered with the nearest that exists, nearest
// by edit distance (how many characters inserted, removed or changed turn
// one into the other), as check-config and the machine-file reader do.
#include <algorithm>
#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

namespace lbpkit::wire {

// `s` with A..Z as a..z; every other byte as it is.
[[nodiscard]] inline std::string asciiLower(std::string_view s) {
  std::string out(s);
  for (auto& c : out)
    if (c >= 'A' && c <= 'Z') c = static_cast<char>(c - 'A' + 'a');
  return out;
}

// Levenshtein distance between `a` and `b`, in one row of |b| + 1 counts.
[[nodiscard]] inline std::size_t editDistance(std::string_view a, std::string_view b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diagonal = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t up = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0U : 1U)});
      diagonal = up;
    }
  }
  return row[b.size()];
}

}  // namespace lbpkit::wire
