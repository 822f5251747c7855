// SPDX-License-Identifier: MIT
// A file the sim or a tool writes a record into (`--trace FILE.pcap`,
// `--record FILE.csv`), opened so that it can destroy nothing the user did
// not name as output: never through a symbolic link, never a FIFO, a device
// or a directory (a FIFO would block the sim before it starts), never one of
// the sim's own files (its EEPROMs, its flash) nor a file another process
// holds locked (a running sim's EEPROM), and an existing file only
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

namespace lbpkit::server {

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

// Text: what a machine file (TOML) holds, and an EEPROM image, a flash
// image or a capture does not (no control byte but tab, CR and LF).
bool isText(std::string_view head);

// The same checks for a file that is to be replaced by another (renamed
// over it) rather than written in place: nothing when `path` does not
// exist; throws as openOutputFile does when it is a link, not a regular
// file, one of `own`, not of `kind`, or locked by a process (a running
// sim's EEPROM): its running owner would lose what it writes next.
void checkReplaceable(const std::string& option, const std::string& path, const OutputKind& kind,
                      const std::vector<std::filesystem::path>& own = {});

}  // namespace lbpkit::server
