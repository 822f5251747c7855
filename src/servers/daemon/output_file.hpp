// A file the sim or a tool writes a record into (`--trace FILE.pcap`,
// `--record FILE.csv`), opened so that it can destroy nothing the user did
// not name as output: never through a symbolic link, never a FIFO, a device
// or a directory (a FIFO would block the sim before it starts), never one of
// the sim's own files (its EEPROMs, its flash), and an existing file only
// when it holds what this option writes (a capture, an lbpkit record) — the
// output of an earlier run, replaced. Anything else is refused with the path
// and the reason.
#pragma once

#include <cstdio>
#include <filesystem>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

namespace servers {

// Whether the first bytes of an existing file are what the option writes.
using OutputKind = std::function<bool(std::string_view head)>;

// A pcap capture (either byte order, micro- or nanosecond times).
bool isCapture(std::string_view head);
// An lbpkit machine record: a CSV whose first column is time_s.
bool isRecord(std::string_view head);

// `path` opened for `option` to write from its start (an existing file of
// `kind` is truncated): the stream, which the caller closes. Throws
// std::runtime_error "OPTION PATH: why" when it may not be written;
// `own` are the files it must never be (compared as files, whatever the path).
std::FILE* openOutputFile(const std::string& option, const std::string& path, const OutputKind& kind,
                          const std::vector<std::filesystem::path>& own = {});

}  // namespace servers
