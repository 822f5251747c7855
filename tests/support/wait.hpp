// SPDX-License-Identifier: MIT
// Waiting for what a test looks for, up to a limit.
#pragma once

#include <chrono>
#include <exception>
#include <thread>

namespace test_support {

// True as soon as `ok()` is, false when it still is not after `limit`. A
// look that throws (a sim's API not answering in time leaves a null state to
// index) is only a look: the next one follows `interval` later. The last
// look, at the limit, lets its exception through.
template <typename F>
bool waitFor(F&& ok, std::chrono::milliseconds limit = std::chrono::seconds(10),
             std::chrono::milliseconds interval = std::chrono::milliseconds(10)) {
  const auto end = std::chrono::steady_clock::now() + limit;
  while (std::chrono::steady_clock::now() < end) {
    try {
      if (ok()) return true;
    } catch (const std::exception&) {
    }
    std::this_thread::sleep_for(interval);
  }
  return ok();
}

}  // namespace test_support
