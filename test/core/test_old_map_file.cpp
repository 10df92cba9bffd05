// The map file of the format before the map store, as `lcd_db convert` reads it: every field
// comes through, and every damaged, foreign or newer file is refused with a reason.
#include <cmath>
#include <filesystem>
#include <functional>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "../../src/common/crc32c.h"
#include "../../src/database/old_map_file.h"
#include "file_bytes.h"
#include "kept_fuzz_inputs.h"
#include "keyframe_fixtures.h"
#include "old_map_file_writer.h"

using namespace landmark_loop_closure;
namespace fs = std::filesystem;

namespace {

std::vector<KeyframeRecord> makeKeyframes(int count) {
  std::vector<KeyframeRecord> keyframes;
  for (int i = 0; i < count; ++i) keyframes.push_back(makeKeyframe(10 + 3 * i, i < 2 ? 0 : 1));
  return keyframes;
}

struct ReadFile {
  OldMapFileHeader header;
  std::vector<KeyframeRecord> keyframes;
  std::string error;  ///< Empty when the file was read.
};

ReadFile readFile(const std::string& path) {
  ReadFile read;
  try {
    readOldMapFile(
        path, [&read](const OldMapFileHeader& header) { read.header = header; },
        [&read](KeyframeRecord keyframe) { read.keyframes.push_back(std::move(keyframe)); });
  } catch (const std::runtime_error& error) {
    read.error = error.what();
  }
  return read;
}

class OldMapFileTest : public ::testing::Test {
 protected:
  void SetUp() override {
    folder_ =
        fs::temp_directory_path() /
        ("lcd_old_map_file_" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()) +
         "_" + ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(folder_);
    fs::create_directories(folder_);
    path_ = (folder_ / "keyframes.lcdb").string();
  }
  void TearDown() override { fs::remove_all(folder_); }

  fs::path folder_;
  std::string path_;
};

}  // namespace

TEST_F(OldMapFileTest, EveryFieldComesThrough) {
  const std::vector<KeyframeRecord> saved = makeKeyframes(4);
  writeOldMapFile(saved, kIdentity, kDimension, path_);
  const ReadFile read = readFile(path_);
  ASSERT_EQ(read.error, "");
  EXPECT_EQ(read.header.descriptor_identity, kIdentity);
  EXPECT_EQ(read.header.global_dimension, kDimension);
  EXPECT_EQ(read.header.keyframes, 4u);
  ASSERT_EQ(read.keyframes.size(), saved.size());
  for (size_t i = 0; i < saved.size(); ++i) expectSame(saved[i], read.keyframes[i]);
}

TEST_F(OldMapFileTest, AVersion2FileWithoutRecordTableIsStillRead) {
  const std::vector<KeyframeRecord> saved = makeKeyframes(3);
  writeOldMapFile(saved, kIdentity, kDimension, path_);
  // Version 2 is version 3 without the record table (3 + 1 offsets and the count at the end).
  std::vector<char> bytes = readBytes(path_);
  constexpr size_t kHeader = 28;
  const size_t table = 8 * (3 + 2);
  bytes.resize(bytes.size() - table);
  const uint64_t payload = bytes.size() - kHeader;
  const uint32_t crc = crc32c(0, reinterpret_cast<const uint8_t*>(bytes.data()) + kHeader, payload);
  auto put = [&bytes](size_t at, uint64_t value, size_t size) {
    for (size_t i = 0; i < size; ++i) bytes[at + i] = static_cast<char>(value >> (8 * i));
  };
  put(8, 2, 4);  // version
  put(16, payload, 8);
  put(24, crc, 4);
  writeBytes(path_, bytes);
  const ReadFile read = readFile(path_);
  ASSERT_EQ(read.error, "");
  ASSERT_EQ(read.keyframes.size(), saved.size());
  for (size_t i = 0; i < saved.size(); ++i) expectSame(saved[i], read.keyframes[i]);
}

TEST_F(OldMapFileTest, AnEmptyFileOfNoKeyframesIsRead) {
  writeOldMapFile({}, kIdentity, kDimension, path_);
  const ReadFile read = readFile(path_);
  ASSERT_EQ(read.error, "");
  EXPECT_TRUE(read.keyframes.empty());
}

TEST_F(OldMapFileTest, EveryTruncationIsRefused) {
  writeOldMapFile(makeKeyframes(2), kIdentity, kDimension, path_);
  const std::vector<char> whole = readBytes(path_);
  const fs::path cut = folder_ / "cut.lcdb";
  for (size_t length = 0; length < whole.size(); ++length) {
    writeBytes(cut, std::vector<char>(whole.begin(), whole.begin() + length));
    const ReadFile read = readFile(cut.string());
    ASSERT_NE(read.error, "") << "accepted " << length << " of " << whole.size() << " bytes";
    EXPECT_NE(read.error.find(cut.string()), std::string::npos);
  }
}

TEST_F(OldMapFileTest, EveryDamagedByteIsRefused) {
  writeOldMapFile(makeKeyframes(2), kIdentity, kDimension, path_);
  const std::vector<char> whole = readBytes(path_);
  const fs::path damaged = folder_ / "damaged.lcdb";
  int said_checksum = 0;
  for (size_t i = 0; i < whole.size(); ++i) {
    std::vector<char> bytes = whole;
    bytes[i] = static_cast<char>(bytes[i] ^ 0x5A);
    writeBytes(damaged, bytes);
    const ReadFile read = readFile(damaged.string());
    ASSERT_NE(read.error, "") << "accepted a file damaged at byte " << i;
    said_checksum += read.error.find("checksum") != std::string::npos ? 1 : 0;
  }
  // Most damage lands in descriptors and pixels, where only the checksum can see it.
  EXPECT_GT(2 * said_checksum, static_cast<int>(whole.size()));
  std::vector<char> longer = whole;
  longer.push_back('x');
  writeBytes(damaged, longer);
  EXPECT_NE(readFile(damaged.string()).error, "");
}

TEST_F(OldMapFileTest, NewerOtherByteOrderForeignAndMissingFilesAreRefusedWithAReason) {
  writeOldMapFile(makeKeyframes(2), kIdentity, kDimension, path_);
  const std::vector<char> bytes = readBytes(path_);
  std::vector<char> newer = bytes;
  newer[8] = static_cast<char>(kOldMapFileVersion + 1);  // u32 after the 8-byte magic.
  writeBytes(path_, newer);
  const std::string newer_text = "version " + std::to_string(kOldMapFileVersion + 1) + " is newer";
  EXPECT_NE(readFile(path_).error.find(newer_text), std::string::npos) << readFile(path_).error;

  std::vector<char> big_endian = bytes;
  std::swap(big_endian[12], big_endian[15]);
  std::swap(big_endian[13], big_endian[14]);
  writeBytes(path_, big_endian);
  EXPECT_NE(readFile(path_).error.find("byte-order"), std::string::npos);

  writeBytes(path_, std::vector<char>{'h', 'e', 'l', 'l', 'o', '\n'});
  EXPECT_NE(readFile(path_).error, "");
  EXPECT_NE(readFile((folder_ / "none.lcdb").string()).error.find("none.lcdb"), std::string::npos);
  EXPECT_NE(readFile(folder_.string()).error.find("not a regular file"), std::string::npos);
}

TEST(OldMapFileVersion1, IsStillReadAndItsRawThumbnailsAreCompressed) {
  // Written by the version-1 build (two keyframes of six values, 4x3 raw thumbnails).
  const fs::path file = fs::path(PACKAGE_SOURCE_DIR) / "fuzz" / "seeds" / "fuzz_old_map_file" /
                        "two_keyframes_v1.lcdb";
  const ReadFile read = readFile(file.string());
  ASSERT_EQ(read.error, "");
  ASSERT_EQ(read.keyframes.size(), 2u);
  for (const KeyframeRecord& keyframe : read.keyframes) {
    EXPECT_EQ(decodeThumbnail(keyframe.thumbnail).size(), cv::Size(4, 3));
  }
}

TEST(OldMapFileFuzzSeeds, EverySeedAndKeptCrashInputIsHandled) {
  const std::vector<KeptFuzzInput> inputs = keptFuzzInputs("fuzz_old_map_file");
  for (const KeptFuzzInput& input : inputs) {
    SCOPED_TRACE(input.path.string());
    const ReadFile read = readFile(input.path.string());
    // The seeds named *.lcdb are whole files of each version.
    if (input.path.extension() == ".lcdb") {
      EXPECT_EQ(read.error, "");
      for (const KeyframeRecord& keyframe : read.keyframes)
        EXPECT_EQ(keyframe.descriptor.global.size(), 6u);
    }
  }
  EXPECT_GT(inputs.size(), 0u);
}

TEST(Crc32c, MatchesTheStandardCheckValueOnEveryPath) {
  const std::string check = "123456789";
  const auto* bytes = reinterpret_cast<const uint8_t*>(check.data());
  EXPECT_EQ(crc32c(0, bytes, check.size()), 0xE3069283u);
  EXPECT_EQ(crc32cPortable(0, bytes, check.size()), 0xE3069283u);
  // Any length and split: the CPU instruction and the table agree, and updates chain.
  std::vector<uint8_t> data(1031);
  for (size_t i = 0; i < data.size(); ++i) data[i] = static_cast<uint8_t>(i * 131 + 7);
  for (size_t length : {0, 1, 7, 8, 9, 64, 1031}) {
    EXPECT_EQ(crc32c(0, data.data(), length), crc32cPortable(0, data.data(), length)) << length;
  }
  // Large buffers take three interleaved streams on the CPU instruction.
  std::vector<uint8_t> large(3 * 4096 * 5 + 13);
  for (size_t i = 0; i < large.size(); ++i) large[i] = static_cast<uint8_t>(i * 7 + (i >> 9));
  for (size_t length : {3 * 4096 - 1, 3 * 4096, 3 * 4096 + 5, 3 * 4096 * 5 + 13}) {
    EXPECT_EQ(crc32c(0x1234u, large.data(), length), crc32cPortable(0x1234u, large.data(), length))
        << length;
  }
  const uint32_t whole = crc32c(0, data.data(), data.size());
  EXPECT_EQ(crc32c(crc32c(0, data.data(), 100), data.data() + 100, data.size() - 100), whole);
  EXPECT_EQ(crc32cPortable(crc32cPortable(0, data.data(), 13), data.data() + 13, data.size() - 13),
            whole);
  // Parts checksummed separately combine into the whole, at every split.
  for (size_t split : {0, 1, 8, 100, 1030, 1031}) {
    const uint32_t first = crc32c(0, data.data(), split);
    const uint32_t second = crc32c(0, data.data() + split, data.size() - split);
    EXPECT_EQ(crc32cCombine(first, second, data.size() - split), whole) << split;
  }
  EXPECT_NE(crc32cCombine(crc32c(0, data.data(), 100), crc32c(0, data.data() + 101, 930), 930),
            whole);
}
