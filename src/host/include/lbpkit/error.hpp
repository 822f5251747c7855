// SPDX-License-Identifier: MIT
// lbpkit's one exception type: what failed, and where to look.
#pragma once

#include <stdexcept>
#include <string>

namespace lbpkit {

class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace lbpkit
