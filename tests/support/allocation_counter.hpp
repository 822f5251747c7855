// SPDX-License-Identifier: MIT
// Counts heap allocations, for the tests that prove a real-time path does
// none: it replaces the global operator new, so include it in exactly one
// source file of a test executable.
#pragma once

#include <atomic>
#include <cstdint>
#include <cstdlib>
#include <new>

namespace testing_alloc {
inline std::atomic<std::uint64_t> gAllocations{0};
// This thread's own: a test with a server or writer thread counts only its
// own thread's.
inline thread_local std::uint64_t tAllocations = 0;
}  // namespace testing_alloc

void* operator new(std::size_t n) {
  ++testing_alloc::gAllocations;
  ++testing_alloc::tAllocations;
  if (void* p = std::malloc(n ? n : 1)) return p;
  throw std::bad_alloc();
}
// Not inlined: GCC would see free() on what it takes for a builtin
// operator new's pointer (std::thread's state) and warn of a mismatch.
[[gnu::noinline]] void operator delete(void* p) noexcept { std::free(p); }
[[gnu::noinline]] void operator delete(void* p, std::size_t) noexcept { std::free(p); }
