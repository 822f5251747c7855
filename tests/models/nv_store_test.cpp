// SPDX-License-Identifier: MIT
#include <fcntl.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <array>
#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <thread>
#include <vector>

#include "remote/nv_store.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace remote = lbpkit::model::remote;

namespace {

using Image = std::vector<std::uint8_t>;

std::filesystem::path tempFile(const char* name) {
  auto p = std::filesystem::temp_directory_path() / (std::string("lbpkit-") + name + "-" + std::to_string(::getpid()));
  std::filesystem::remove(p);
  return p;
}

TEST(NvStore, CommitThenLoadFromFile) {
  const auto file = tempFile("nv1");
  {
    remote::NvStore nv(8, file);
    EXPECT_FALSE(nv.load());  // no file yet
    ASSERT_TRUE(nv.commit(Image{1, 2, 3, 4, 5, 6, 7, 8}));
    ASSERT_TRUE(nv.commit(Image{9, 9, 9, 9, 9, 9, 9, 9}));
  }
  remote::NvStore again(8, file);
  ASSERT_TRUE(again.load());
  EXPECT_EQ(Image(again.image().begin(), again.image().end()), (Image{9, 9, 9, 9, 9, 9, 9, 9}));
  std::filesystem::remove(file);
}

// A power cut after every possible number of bytes of a write, on a file and
// in memory: the next power-up sees the old image or the new one, never a mix.
TEST(NvStore, PowerCutAtAnyByteLeavesOldOrNew) {
  const Image oldImage{0x11, 0x22, 0x33, 0x44, 0x55, 0x66};
  const Image newImage{0xA1, 0xB2, 0xC3, 0xD4, 0xE5, 0xF6};
  for (bool onFile : {false, true}) {
    const auto file = onFile ? tempFile("nvcut") : std::filesystem::path{};
    remote::NvStore probe(oldImage.size());
    for (std::size_t cut = 0; cut <= probe.slotBytes(); ++cut) {
      if (onFile) std::filesystem::remove(file);
      remote::NvStore nv(oldImage.size(), file);
      ASSERT_TRUE(nv.commit(Image{0, 0, 0, 0, 0, 0}));
      ASSERT_TRUE(nv.commit(oldImage));  // both slots used: the next write overwrites a good one
      nv.cutPowerAfter(cut);
      const bool completed = nv.commit(newImage);
      EXPECT_EQ(completed, cut >= probe.slotBytes());
      if (!onFile) {
        // In memory the medium is the store itself: reload it.
        ASSERT_TRUE(nv.load());
        const Image seen(nv.image().begin(), nv.image().end());
        EXPECT_TRUE(seen == oldImage || seen == newImage) << "cut after " << cut;
        EXPECT_EQ(seen == newImage, completed) << "cut after " << cut;
        continue;
      }
      remote::NvStore after(oldImage.size(), file);
      ASSERT_TRUE(after.load()) << "cut after " << cut;
      const Image seen(after.image().begin(), after.image().end());
      EXPECT_TRUE(seen == oldImage || seen == newImage) << "cut after " << cut;
      EXPECT_EQ(seen == newImage, completed) << "cut after " << cut;
    }
    if (onFile) std::filesystem::remove(file);
  }
}

TEST(NvStore, CorruptFileIsReportedNotTrusted) {
  const auto file = tempFile("nvbad");
  {
    remote::NvStore nv(8, file);
    ASSERT_TRUE(nv.commit(Image{1, 2, 3, 4, 5, 6, 7, 8}));
  }
  {
    std::fstream f(file, std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(12);
    f.put('\x55');  // a flipped byte in the only slot: its CRC no longer matches
  }
  remote::NvStore nv(8, file);
  EXPECT_FALSE(nv.load());
  EXPECT_NE(nv.lastError().find("no valid image"), std::string::npos) << nv.lastError();
  EXPECT_TRUE(nv.commit(Image{8, 7, 6, 5, 4, 3, 2, 1}));  // it is ours: a write repairs it
  std::filesystem::remove(file);
}

// --- What the store refuses to write over --------------------

std::string contents(const std::filesystem::path& p) {
  std::ifstream f(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
}

TEST(NvStore, RefusesASymlinkAndLeavesItsTargetAlone) {
  const auto target = tempFile("nvtarget");
  const auto link = tempFile("nvlink");
  { std::ofstream(target) << "precious notes\n"; }
  std::filesystem::create_symlink(target, link);
  {
    remote::NvStore nv(8, link);
    EXPECT_FALSE(nv.load());
    EXPECT_FALSE(nv.commit(Image{1, 2, 3, 4, 5, 6, 7, 8}));
    EXPECT_NE(nv.lastError().find(link.string() + ": is a symbolic link; lbpkit will not follow it"), std::string::npos)
        << nv.lastError();
  }
  EXPECT_EQ(contents(target), "precious notes\n");
  // A dangling one is not followed to create its target either.
  std::filesystem::remove(target);
  {
    remote::NvStore nv(8, link);
    EXPECT_FALSE(nv.commit(Image{1, 2, 3, 4, 5, 6, 7, 8}));
  }
  EXPECT_FALSE(std::filesystem::exists(target));
  std::filesystem::remove(link);
}

TEST(NvStore, RefusesAFileThatIsNotAnEepromImage) {
  const auto file = tempFile("nvtoml");
  const std::string toml = "[[daughtercard]]\ntype = \"7I77\"\nfield_voltage = 24.0\n";
  { std::ofstream(file) << toml; }
  {
    remote::NvStore nv(8, file);
    EXPECT_FALSE(nv.load());
    EXPECT_FALSE(nv.commit(Image{1, 2, 3, 4, 5, 6, 7, 8}));
    EXPECT_NE(nv.lastError().find(file.string() + ": is not an lbpkit EEPROM image (" + std::to_string(toml.size()) +
                                  " bytes of something else); refusing to overwrite it"),
              std::string::npos)
        << nv.lastError();
  }
  EXPECT_EQ(contents(file), toml);
  std::filesystem::remove(file);
}

TEST(NvStore, AnEmptyFileIsANewEeprom) {
  const auto file = tempFile("nvempty");
  { std::ofstream{file}; }
  remote::NvStore nv(8, file);
  EXPECT_FALSE(nv.load());
  EXPECT_TRUE(nv.commit(Image{1, 2, 3, 4, 5, 6, 7, 8})) << nv.lastError();
  std::filesystem::remove(file);
}

TEST(NvStore, RefusesADirectoryAndAMissingDirectory) {
  const auto dir = tempFile("nvdir");
  std::filesystem::create_directory(dir);
  {
    remote::NvStore nv(8, dir);
    EXPECT_FALSE(nv.commit(Image{1, 2, 3, 4, 5, 6, 7, 8}));
    EXPECT_NE(nv.lastError().find(dir.string() + ": is a directory"), std::string::npos) << nv.lastError();
  }
  const auto missing = dir / "no" / "such" / "eeprom";
  {
    remote::NvStore nv(8, missing);
    EXPECT_FALSE(nv.commit(Image{1, 2, 3, 4, 5, 6, 7, 8}));
    EXPECT_NE(nv.lastError().find("directory " + (dir / "no" / "such").string() + " does not exist"), std::string::npos)
        << nv.lastError();
  }
  EXPECT_FALSE(std::filesystem::exists(dir / "no"));  // not created behind the user's back
  std::filesystem::remove_all(dir);
}

// A FIFO given as the EEPROM neither hangs the start nor is written to.
TEST(NvStore, RefusesAFifoWithoutHanging) {
  const auto fifo = tempFile("nvfifo");
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  std::atomic<bool> done{false};
  std::string error;
  std::thread t([&] {
    remote::NvStore nv(8, fifo);
    nv.load();
    nv.commit(Image{1, 2, 3, 4, 5, 6, 7, 8});
    error = nv.lastError();
    done = true;
  });
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(3);
  while (!done && std::chrono::steady_clock::now() < deadline) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  const bool hung = !done;
  // Free a store blocked in open() (both ends at once), so the test ends either way.
  while (!done) {
    const int fd = ::open(fifo.c_str(), O_RDWR | O_NONBLOCK);
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    char drain[256];
    while (fd >= 0 && ::read(fd, drain, sizeof drain) > 0) {
    }
    if (fd >= 0) ::close(fd);
  }
  t.join();
  EXPECT_FALSE(hung) << "opening a FIFO as the EEPROM blocked";
  EXPECT_NE(error.find(fifo.string() + ": is a FIFO"), std::string::npos) << error;
  std::filesystem::remove(fifo);
}

// Two processes on one file would lose each other's acknowledged writes: the
// second is refused while the first holds it.
TEST(NvStore, ASecondProcessIsRefusedWhileTheFirstHoldsTheFile) {
  const auto file = tempFile("nvlock");
  remote::NvStore first(8, file);
  ASSERT_TRUE(first.commit(Image{1, 2, 3, 4, 5, 6, 7, 8}));
  const pid_t child = ::fork();
  if (child == 0) {
    remote::NvStore second(8, file);
    const bool wrote = second.commit(Image{9, 9, 9, 9, 9, 9, 9, 9});
    const bool named = second.lastError().find("in use by another lbpkit") != std::string::npos;
    ::_exit(!wrote && named ? 0 : 1);
  }
  int status = -1;
  ::waitpid(child, &status, 0);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << "the second process was not refused";
  ASSERT_TRUE(first.load());
  EXPECT_EQ(Image(first.image().begin(), first.image().end()), (Image{1, 2, 3, 4, 5, 6, 7, 8}));
  std::filesystem::remove(file);
}

// --- Sequence numbers wrap --------------------------------------

// A slot record as nv_store.cpp lays it out: magic, sequence, length, image, CRC-32.
Image slotRecord(std::uint32_t sequence, const Image& image) {
  Image v{'L', 'B', 'N', 'V'};
  for (int i = 0; i < 4; ++i) v.push_back(static_cast<std::uint8_t>(sequence >> (8 * i)));
  v.push_back(static_cast<std::uint8_t>(image.size()));
  v.push_back(static_cast<std::uint8_t>(image.size() >> 8));
  v.insert(v.end(), image.begin(), image.end());
  const std::uint32_t crc = remote::crc32(v);
  for (int i = 0; i < 4; ++i) v.push_back(static_cast<std::uint8_t>(crc >> (8 * i)));
  return v;
}

TEST(NvStore, SequenceNumbersCompareWithWrapAround) {
  const Image before{1, 1, 1, 1, 1, 1, 1, 1};  // written at sequence 0xFFFFFFFF
  const Image after{2, 2, 2, 2, 2, 2, 2, 2};   // the next write: sequence 0 after the wrap
  const auto file = tempFile("nvwrap");
  for (bool wrappedFirst : {false, true}) {
    {
      std::ofstream f(file, std::ios::binary | std::ios::trunc);
      const auto a = slotRecord(0xFFFFFFFFU, before);
      const auto b = slotRecord(0x00000000U, after);
      for (const auto* s : wrappedFirst ? std::array{&b, &a} : std::array{&a, &b})
        f.write(reinterpret_cast<const char*>(s->data()), static_cast<std::streamsize>(s->size()));
    }
    {
      remote::NvStore nv(8, file);
      ASSERT_TRUE(nv.load());
      EXPECT_EQ(Image(nv.image().begin(), nv.image().end()), after) << "wrapped slot first: " << wrappedFirst;
      // The next write replaces the older slot (0xFFFFFFFF) and wins in turn.
      ASSERT_TRUE(nv.commit(Image{3, 3, 3, 3, 3, 3, 3, 3}));
    }
    remote::NvStore again(8, file);
    ASSERT_TRUE(again.load());
    EXPECT_EQ(Image(again.image().begin(), again.image().end()), (Image{3, 3, 3, 3, 3, 3, 3, 3}));
  }
  std::filesystem::remove(file);
}

}  // namespace
