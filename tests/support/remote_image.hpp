// SPDX-License-Identifier: MIT
// A 7I77 processor's firmware file for the tests: a program of a given
// length in lbpkit's image format (remote/program_flash.hpp), made of bytes
// that are never zero, so no erase block of it is all zero (setsserial and
// lbpkit flash-remote skip such a block), and the same bytes for the same
// seed every run.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string_view>
#include <vector>

#include "remote/gtoc_parameters.hpp"
#include "remote/program_flash.hpp"

namespace test_support {

// `n` bytes of program that differ with `seed`.
inline std::vector<std::uint8_t> remoteProgram(std::size_t n, std::uint8_t seed) {
  std::vector<std::uint8_t> p(n);
  for (std::size_t i = 0; i < n; ++i) p[i] = static_cast<std::uint8_t>((i * 131 + seed) | 1);
  return p;
}

// The image of a program of `programBytes` (seeded by the revision) for the
// 7I77's field I/O processor, software revision `revision`, written to `file`.
inline void writeRemoteImage(const std::filesystem::path& file, std::size_t programBytes, std::uint8_t revision,
                             std::string_view cardName = "7I77",
                             std::uint8_t processor = lbpkit::model::remote::kFieldIoProcessor) {
  const auto image =
      lbpkit::model::remote::ProgramFlash::image(cardName, processor, revision, remoteProgram(programBytes, revision));
  std::ofstream(file, std::ios::binary)
      .write(reinterpret_cast<const char*>(image.data()), static_cast<std::streamsize>(image.size()));
}

}  // namespace test_support
