#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <vector>

#include "remote/nv_store.hpp"

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
  { std::ofstream(file) << "this is not an EEPROM image at all, just text"; }
  remote::NvStore nv(8, file);
  EXPECT_FALSE(nv.load());
  EXPECT_NE(nv.lastError().find("no valid image"), std::string::npos);
  std::filesystem::remove(file);
}

}  // namespace
