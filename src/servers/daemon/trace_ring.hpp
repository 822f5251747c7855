// SPDX-License-Identifier: MIT
// The machine's servo-cycle trace: a bounded ring of rows, one
// per host cycle, filled on the card thread and read by others (the API's
// GET /api/machine/trace, the --record CSV writer).
//
// The card thread must never wait for a reader nor allocate per row: the
// storage is allocated once, rows are written with atomic (release) stores,
// and readers check afterwards (a sequence lock) that the row they copied
// was not overwritten meanwhile. A reader that falls a whole ring behind
// loses the rows it missed, never the card thread its time.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

namespace lbpkit::server {

class TraceRing {
 public:
  // `capacity` rows of columns.size() values each (both above 0).
  TraceRing(std::vector<std::string> columns, std::size_t capacity);

  [[nodiscard]] const std::vector<std::string>& columns() const { return columns_; }
  [[nodiscard]] std::size_t width() const { return columns_.size(); }
  [[nodiscard]] std::size_t capacity() const { return capacity_; }

  // The one writer (the card thread): appends a row of width() values
  // (missing ones read 0, extra ones are dropped).
  void push(std::span<const double> row);

  // Rows pushed so far: the next row's number. Row n is in the ring while
  // n >= oldest().
  [[nodiscard]] std::uint64_t pushed() const { return pushed_.load(std::memory_order_acquire); }
  [[nodiscard]] std::uint64_t oldest() const;
  // Any thread: copies row `n` into `out` (width() values); false when it is
  // not pushed yet or no longer in the ring.
  bool read(std::uint64_t n, std::span<double> out) const;
  // The first row whose first column (time_s) is above `t`, among those in
  // the ring: pushed() when there is none.
  [[nodiscard]] std::uint64_t firstAfter(double t) const;

 private:
  std::vector<std::string> columns_;
  std::size_t capacity_;
  std::unique_ptr<std::atomic<double>[]> values_;
  std::atomic<std::uint64_t> started_{0};  // rows the writer has begun
  std::atomic<std::uint64_t> pushed_{0};   // rows it has finished
};

}  // namespace lbpkit::server
