// SPDX-License-Identifier: MIT
// libFuzzer target: the host library's discovery parser fed by a hostile
// remote. The remote's whole 64 KiB address space is the fuzz input (what is
// not given reads as 0); the PTOC and GTOC pointers and the discovery RPC's
// sizes come from its first bytes. discover() must return a description or
// throw lbpkit::Error naming what was wrong: never crash, hang (bounded by
// its limits) or read without end.
#include <cstdint>
#include <cstdlib>
#include <span>
#include <string>

#include "lbpkit/discovery.hpp"
#include "lbpkit/error.hpp"

namespace {

class HostileRemote final : public lbpkit::RemoteAccess {
 public:
  explicit HostileRemote(std::span<const std::uint8_t> memory) : memory_(memory) {}
  std::uint64_t read(std::uint16_t address, unsigned size) override {
    ++transactions_;
    if (transactions_ > kMaxTransactions) std::abort();  // discovery must stop by itself
    std::uint64_t v = 0;
    for (unsigned i = 0; i < size; ++i) {
      const std::size_t a = static_cast<std::uint16_t>(address + i);
      v |= static_cast<std::uint64_t>(a < memory_.size() ? memory_[a] : 0) << (8 * i);
    }
    return v;
  }
  void write(std::uint16_t, unsigned, std::uint64_t) override { ++transactions_; }
  std::uint8_t localRead(std::uint8_t command) override { return static_cast<std::uint8_t>(read(command, 1)); }
  void localWrite(std::uint8_t, std::uint8_t) override { ++transactions_; }
  [[nodiscard]] std::uint64_t transactions() const override { return transactions_; }
  [[nodiscard]] std::string where() const override { return "fuzzed remote"; }

 private:
  // 64 KiB read a byte at a time, twice over: far more than any table.
  static constexpr std::uint64_t kMaxTransactions = 1U << 17;
  std::span<const std::uint8_t> memory_;
  std::uint64_t transactions_ = 0;
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 6) return 0;
  const auto ptoc = static_cast<std::uint16_t>(data[0] | data[1] << 8);
  const auto gtoc = static_cast<std::uint16_t>(data[2] | data[3] << 8);
  HostileRemote remote({data, size});
  try {
    const auto d = lbpkit::discover(remote, ptoc, gtoc, data[4], data[5]);
    // What it returns is within its limits.
    if (d.processData.size() > 1024) std::abort();
  } catch (const lbpkit::Error& e) {
    if (std::string(e.what()).empty()) std::abort();  // an error says what was wrong
  }
  return 0;
}
