// SPDX-License-Identifier: MIT
#include "daemon/trace_file.hpp"

#include "daemon/output_file.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <utility>
#include <vector>

namespace lbpkit::server {

TraceFile::TraceFile(const TraceRing& ring, std::string path, Report warn, const std::vector<std::filesystem::path>& own)
    : ring_(ring), path_(std::move(path)), warn_(std::move(warn)) {
  file_ = openOutputFile("--record", path_, isRecord, own);
  std::string header;
  for (const auto& c : ring_.columns()) header += (header.empty() ? "" : ",") + c;
  header += '\n';
  if (std::fputs(header.c_str(), file_) < 0 || std::fflush(file_) != 0) {
    const int e = errno;
    std::fclose(file_);
    throw std::runtime_error(fmt::format("--record {}: {}", path_, std::strerror(e)));
  }
  // Only rows from now on: the ring is new, this is row 0.
  next_ = ring_.pushed();
  // A few times a second: a 1 kHz servo thread's 250 rows at a time.
  thread_ = std::make_unique<DrainThread>(std::chrono::milliseconds(250), [this] { drain(); });
}

TraceFile::~TraceFile() {
  thread_.reset();  // joins, then writes the rows of the last moments
  std::fclose(file_);
}

void TraceFile::drain() {
  std::vector<double> row(ring_.width());
  const std::uint64_t end = ring_.pushed();
  std::string text;
  for (; next_ < end; ++next_) {
    if (!ring_.read(next_, row)) {
      // Overwritten before it was written out: a whole ring behind.
      const std::uint64_t oldest = ring_.oldest();
      if (!lostSaid_ && warn_)
        warn_(fmt::format("--record {}: the writer fell {} rows behind; rows {} to {} are lost", path_,
                          ring_.capacity(), next_, oldest));
      lostSaid_ = true;
      next_ = std::max(next_, oldest);
      if (next_ >= end) break;
      if (!ring_.read(next_, row)) continue;
    }
    for (std::size_t i = 0; i < row.size(); ++i) {
      if (i > 0) text += ',';
      if (std::isfinite(row[i])) text += fmt::format("{:.12g}", row[i]);
    }
    text += '\n';
  }
  if (text.empty()) return;
  if ((std::fputs(text.c_str(), file_) < 0 || std::fflush(file_) != 0) && !errorSaid_) {
    errorSaid_ = true;
    if (warn_) warn_(fmt::format("--record {}: cannot write: {}", path_, std::strerror(errno)));
  }
}

}  // namespace lbpkit::server
