// SPDX-License-Identifier: MIT
#include "daemon/trace_ring.hpp"

#include <algorithm>
#include <stdexcept>
#include <utility>

namespace lbpkit::server {

TraceRing::TraceRing(std::vector<std::string> columns, std::size_t capacity)
    : columns_(std::move(columns)), capacity_(capacity) {
  if (columns_.empty() || capacity_ == 0) throw std::invalid_argument("a trace needs columns and room for rows");
  values_ = std::make_unique<std::atomic<double>[]>(capacity_ * columns_.size());
}

void TraceRing::push(std::span<const double> row) {
  const std::uint64_t n = pushed_.load(std::memory_order_relaxed);
  // Said before the row's slot changes, so a reader copying the row this
  // one replaces sees that it may have: each value is stored with release,
  // so a reader that acquires one of the new values also sees this store.
  // (Release stores and acquire loads, not fences: as cheap on x86, and
  // ThreadSanitizer understands them.)
  started_.store(n + 1, std::memory_order_relaxed);
  std::atomic<double>* slot = &values_[(n % capacity_) * width()];
  for (std::size_t i = 0; i < width(); ++i) slot[i].store(i < row.size() ? row[i] : 0.0, std::memory_order_release);
  pushed_.store(n + 1, std::memory_order_release);
}

std::uint64_t TraceRing::oldest() const {
  const std::uint64_t p = pushed();
  return p > capacity_ ? p - capacity_ : 0;
}

bool TraceRing::read(std::uint64_t n, std::span<double> out) const {
  if (n >= pushed() || out.size() < width()) return false;
  const std::atomic<double>* slot = &values_[(n % capacity_) * width()];
  for (std::size_t i = 0; i < width(); ++i) out[i] = slot[i].load(std::memory_order_acquire);
  // Row m's write replaces row m - capacity: row n is whole unless a row
  // past n + capacity - 1 has been begun.
  return started_.load(std::memory_order_relaxed) <= n + capacity_;
}

std::uint64_t TraceRing::firstAfter(double t) const {
  // Times only grow along the ring: a binary search. A row overwritten while
  // it is looked at is older than any still there.
  std::vector<double> row(width());
  std::uint64_t lo = oldest(), hi = pushed();
  while (lo < hi) {
    const std::uint64_t mid = lo + (hi - lo) / 2;
    if (!read(mid, row) || row[0] <= t)
      lo = mid + 1;
    else
      hi = mid;
  }
  return lo;
}

}  // namespace lbpkit::server
