// SPDX-License-Identifier: MIT
// `lbpkit sim --record FILE.csv`: the machine's servo-cycle trace
// (trace_ring.hpp) written to a CSV file, header first, by a thread of its
// own. The card thread only fills the ring; this thread drains it a few
// times a second, so the card thread never waits on the disk.
#pragma once

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "daemon/drain_thread.hpp"
#include "daemon/trace_ring.hpp"

namespace lbpkit::server {

class TraceFile {
 public:
  using Report = std::function<void(const std::string&)>;
  // Creates (or truncates) `path` and writes the header: throws
  // std::runtime_error naming the file and why when it cannot. `warn` hears
  // of rows lost (the writer a whole ring behind) and of write errors, once
  // each; it runs on the writer's thread.
  // The file is opened as daemon/output_file.hpp says (`own`: the files it
  // must never be).
  TraceFile(const TraceRing& ring, std::string path, Report warn, const std::vector<std::filesystem::path>& own = {});
  // Writes what is left and closes the file.
  ~TraceFile();
  TraceFile(const TraceFile&) = delete;
  TraceFile& operator=(const TraceFile&) = delete;

  [[nodiscard]] const std::string& path() const { return path_; }

 private:
  void drain();

  const TraceRing& ring_;
  std::string path_;
  Report warn_;
  std::FILE* file_ = nullptr;
  std::uint64_t next_ = 0;  // the next row to write
  bool lostSaid_ = false;
  bool errorSaid_ = false;
  std::unique_ptr<DrainThread> thread_;  // last: it calls drain() until it goes
};

}  // namespace lbpkit::server
