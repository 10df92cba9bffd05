// The keyframe database on disk: every field survives a round trip, and every damaged, foreign or
// newer file is refused with a reason, never half-loaded.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <limits>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "../../src/common/crc32c.h"
#include "keyframe_fixtures.h"
#include "landmark_loop_closure/database/database_file.h"
#include "landmark_loop_closure/descriptors/descriptor.h"
#include "landmark_loop_closure/sim/corridor_world.h"

using namespace landmark_loop_closure;
namespace fs = std::filesystem;

namespace {

constexpr int kDimension = 6;
const std::string kIdentity = "type=test dimension=6";

KeyframeDatabase makeDatabase(int keyframes) {
  KeyframeDatabase database(kDimension);
  for (int i = 0; i < keyframes; ++i) database.add(makeKeyframe(10 + 3 * i, i < 2 ? 0 : 1));
  return database;
}

std::vector<char> readBytes(const fs::path& path) {
  std::ifstream file(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(file), std::istreambuf_iterator<char>()};
}

void writeBytes(const fs::path& path, const std::vector<char>& bytes) {
  std::ofstream file(path, std::ios::binary | std::ios::trunc);
  file.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

class DatabaseFileTest : public ::testing::Test {
 protected:
  void SetUp() override {
    folder_ =
        fs::temp_directory_path() /
        ("lcd_database_file_" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()) +
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

TEST_F(DatabaseFileTest, EveryFieldSurvivesARoundTrip) {
  const KeyframeDatabase saved = makeDatabase(4);
  ASSERT_EQ(saveDatabase(saved, kIdentity, path_), "");
  EXPECT_FALSE(fs::exists(path_ + ".tmp"));
  const LoadedDatabase loaded = loadDatabase(path_, kIdentity, kDimension);
  ASSERT_TRUE(loaded.database) << loaded.error;
  ASSERT_EQ(loaded.database->size(), saved.size());
  for (size_t i = 0; i < saved.size(); ++i)
    expectSame(*saved.record(i), *loaded.database->record(i));
  EXPECT_NE(loaded.database->findSummary(19), nullptr);
}

TEST_F(DatabaseFileTest, KeyframesReadOnSeveralThreadsAreTheSameAsOnOne) {
  const KeyframeDatabase saved = makeDatabase(50);
  ASSERT_EQ(saveDatabase(saved, kIdentity, path_), "");
  // More threads than keyframes too: every keyframe is read once, in order.
  for (int threads : {1, 2, 3, 7, 64}) {
    SCOPED_TRACE(threads);
    const LoadedDatabase loaded = loadDatabase(path_, kIdentity, kDimension, {}, threads);
    ASSERT_TRUE(loaded.database) << loaded.error;
    ASSERT_EQ(loaded.database->size(), saved.size());
    for (size_t i = 0; i < saved.size(); ++i) {
      expectSame(*saved.record(i), *loaded.database->record(i));
    }
  }
}

TEST_F(DatabaseFileTest, AVersion2FileWithoutRecordTableIsStillRead) {
  const KeyframeDatabase saved = makeDatabase(3);
  ASSERT_EQ(saveDatabase(saved, kIdentity, path_), "");
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
  const LoadedDatabase loaded = loadDatabase(path_, kIdentity, kDimension);
  ASSERT_TRUE(loaded.database) << loaded.error;
  ASSERT_EQ(loaded.database->size(), saved.size());
  for (size_t i = 0; i < saved.size(); ++i)
    expectSame(*saved.record(i), *loaded.database->record(i));
}

TEST_F(DatabaseFileTest, AnEmptyDatabaseRoundTrips) {
  ASSERT_EQ(saveDatabase(KeyframeDatabase(kDimension), kIdentity, path_), "");
  const LoadedDatabase loaded = loadDatabase(path_, kIdentity, kDimension);
  ASSERT_TRUE(loaded.database) << loaded.error;
  EXPECT_TRUE(loaded.database->empty());
}

TEST_F(DatabaseFileTest, EveryTruncationIsRefused) {
  ASSERT_EQ(saveDatabase(makeDatabase(2), kIdentity, path_), "");
  const std::vector<char> whole = readBytes(path_);
  const fs::path cut = folder_ / "cut.lcdb";
  for (size_t length = 0; length < whole.size(); ++length) {
    writeBytes(cut, std::vector<char>(whole.begin(), whole.begin() + length));
    for (int threads : {1, 2}) {
      const LoadedDatabase loaded = loadDatabase(cut.string(), kIdentity, kDimension, {}, threads);
      ASSERT_FALSE(loaded.database) << "accepted " << length << " of " << whole.size() << " bytes";
      EXPECT_NE(loaded.error.find(cut.string()), std::string::npos);
    }
  }
}

TEST_F(DatabaseFileTest, EveryDamagedByteIsRefused) {
  ASSERT_EQ(saveDatabase(makeDatabase(2), kIdentity, path_), "");
  const std::vector<char> whole = readBytes(path_);
  const fs::path damaged = folder_ / "damaged.lcdb";
  int said_checksum = 0;
  for (size_t i = 0; i < whole.size(); ++i) {
    std::vector<char> bytes = whole;
    bytes[i] = static_cast<char>(bytes[i] ^ 0x5A);
    writeBytes(damaged, bytes);
    for (int threads : {1, 2}) {
      const LoadedDatabase loaded =
          loadDatabase(damaged.string(), kIdentity, kDimension, {}, threads);
      ASSERT_FALSE(loaded.database) << "accepted a file damaged at byte " << i;
      said_checksum += loaded.error.find("checksum") != std::string::npos ? 1 : 0;
    }
  }
  // Most damage lands in descriptors and pixels, where only the checksum can see it.
  EXPECT_GT(said_checksum, static_cast<int>(whole.size()));
  // Appended bytes too.
  std::vector<char> longer = whole;
  longer.push_back('x');
  writeBytes(damaged, longer);
  EXPECT_FALSE(loadDatabase(damaged.string(), kIdentity, kDimension).database);
}

TEST_F(DatabaseFileTest, ForeignNewerAndOtherByteOrderFilesAreRefusedWithAReason) {
  ASSERT_EQ(saveDatabase(makeDatabase(2), kIdentity, path_), "");
  const LoadedDatabase other_model =
      loadDatabase(path_, "type=test dimension=6 model=2", kDimension);
  EXPECT_FALSE(other_model.database);
  EXPECT_NE(other_model.error.find("other descriptors"), std::string::npos) << other_model.error;
  const LoadedDatabase other_dimension = loadDatabase(path_, kIdentity, kDimension + 1);
  EXPECT_FALSE(other_dimension.database);
  EXPECT_NE(other_dimension.error.find("6 values"), std::string::npos) << other_dimension.error;

  std::vector<char> bytes = readBytes(path_);
  std::vector<char> newer = bytes;
  newer[8] = static_cast<char>(kDatabaseFileVersion + 1);  // u32 after the 8-byte magic.
  writeBytes(path_, newer);
  const LoadedDatabase from_future = loadDatabase(path_, kIdentity, kDimension);
  EXPECT_FALSE(from_future.database);
  const std::string newer_text =
      "version " + std::to_string(kDatabaseFileVersion + 1) + " is newer";
  EXPECT_NE(from_future.error.find(newer_text), std::string::npos) << from_future.error;

  std::vector<char> big_endian = bytes;
  std::swap(big_endian[12], big_endian[15]);
  std::swap(big_endian[13], big_endian[14]);
  writeBytes(path_, big_endian);
  const LoadedDatabase swapped = loadDatabase(path_, kIdentity, kDimension);
  EXPECT_FALSE(swapped.database);
  EXPECT_NE(swapped.error.find("byte-order"), std::string::npos) << swapped.error;

  writeBytes(path_, std::vector<char>{'h', 'e', 'l', 'l', 'o', '\n'});
  EXPECT_FALSE(loadDatabase(path_, kIdentity, kDimension).database);
  const LoadedDatabase missing =
      loadDatabase((folder_ / "none.lcdb").string(), kIdentity, kDimension);
  EXPECT_FALSE(missing.database);
  EXPECT_NE(missing.error.find("none.lcdb"), std::string::npos) << missing.error;
}

TEST_F(DatabaseFileTest, AFailedSaveLeavesThePreviousFileWhole) {
  ASSERT_EQ(saveDatabase(makeDatabase(2), kIdentity, path_), "");
  // The temporary file cannot be created (a folder is in its way): the save fails, says why, and
  // the previous file still loads with its two keyframes.
  fs::create_directories(path_ + ".tmp");
  const std::string error = saveDatabase(makeDatabase(4), kIdentity, path_);
  EXPECT_NE(error.find(path_ + ".tmp"), std::string::npos) << error;
  const LoadedDatabase previous = loadDatabase(path_, kIdentity, kDimension);
  ASSERT_TRUE(previous.database) << previous.error;
  EXPECT_EQ(previous.database->size(), 2u);
  fs::remove_all(path_ + ".tmp");
  // A temporary file left by a crash mid-write changes nothing, and the next save replaces it.
  writeBytes(path_ + ".tmp", std::vector<char>(100, 'x'));
  EXPECT_EQ(loadDatabase(path_, kIdentity, kDimension).database->size(), 2u);
  ASSERT_EQ(saveDatabase(makeDatabase(4), kIdentity, path_), "");
  EXPECT_EQ(loadDatabase(path_, kIdentity, kDimension).database->size(), 4u);
}

TEST_F(DatabaseFileTest, RealDescriptorsCompareTheSameAfterLoading) {
  const DescriptorOptions options;
  const auto extractor = makeDescriptorExtractor(options);
  const sim::CorridorWorld world;
  KeyframeDatabase database(extractor->globalDimension());
  for (int i = 0; i < 3; ++i) {
    KeyframeRecord keyframe;
    keyframe.id = static_cast<uint64_t>(i);
    keyframe.descriptor = extractor->describe(
        world.render(world.poseAt(4.0 + 1.5 * i, 0.0), sim::CameraModel{}, sim::Lighting{}, 1));
    database.add(std::move(keyframe));
  }
  const std::string identity = descriptorIdentity(options);
  ASSERT_EQ(saveDatabase(database, identity, path_), "");
  const LoadedDatabase loaded = loadDatabase(path_, identity, extractor->globalDimension());
  ASSERT_TRUE(loaded.database) << loaded.error;
  for (int a = 0; a < 3; ++a) {
    for (int b = 0; b < 3; ++b) {
      EXPECT_EQ(
          extractor->similarity(database.record(a)->descriptor, database.record(b)->descriptor),
          extractor->similarity(loaded.database->record(a)->descriptor,
                                loaded.database->record(b)->descriptor));
    }
  }
}

TEST(DescriptorIdentity, ChangesWithEverySettingThatShapesDescriptorsAndWithTheModel) {
  DescriptorOptions defaults;
  defaults.type = "landmarks";
  const std::string identity = descriptorIdentity(defaults);
  EXPECT_EQ(identity, descriptorIdentity(defaults));
  DescriptorOptions fewer = defaults;
  fewer.max_landmarks = 20;
  EXPECT_NE(descriptorIdentity(fewer), identity);
  DescriptorOptions storage = defaults;
  storage.landmark_storage = "float32";
  EXPECT_NE(descriptorIdentity(storage), identity);
  DescriptorOptions hog = defaults;
  hog.type = "hog";
  EXPECT_NE(descriptorIdentity(hog), identity);

  // Same settings, a model file one byte different.
  const fs::path copy = fs::temp_directory_path() / "lcd_identity_model.onnx";
  std::vector<char> model = readBytes(defaultModelPath());
  ASSERT_FALSE(model.empty());
  writeBytes(copy, model);
  DescriptorOptions copied = defaults;
  copied.model = copy.string();
  EXPECT_EQ(descriptorIdentity(copied), identity);
  model.back() = static_cast<char>(model.back() ^ 1);
  writeBytes(copy, model);
  EXPECT_NE(descriptorIdentity(copied), identity);

  // The backbone: its own settings and its network's bytes.
  DescriptorOptions backbone;
  backbone.type = "backbone";
  backbone.backbone.model = copy.string();
  const std::string backbone_identity = descriptorIdentity(backbone);
  for (const auto& change : std::vector<std::function<void(DescriptorOptions::Backbone*)>>{
           [](DescriptorOptions::Backbone* b) { b->layer = "block_5_add"; },
           [](DescriptorOptions::Backbone* b) { b->grid_cols = 6; },
           [](DescriptorOptions::Backbone* b) { b->normalisation = "whole"; },
           [](DescriptorOptions::Backbone* b) { b->input_width = 320; },
           [](DescriptorOptions::Backbone* b) { b->max_landmarks = 10; },
           [](DescriptorOptions::Backbone* b) { b->hog_weight = 0.2; },
           [](DescriptorOptions::Backbone* b) { b->min_network_width = 0; },
           [](DescriptorOptions::Backbone* b) { b->mean = "0.5 0.5 0.5"; }}) {
    DescriptorOptions changed = backbone;
    change(&changed.backbone);
    EXPECT_NE(descriptorIdentity(changed), backbone_identity) << descriptorIdentity(changed);
  }
  model.back() = static_cast<char>(model.back() ^ 1);
  writeBytes(copy, model);
  EXPECT_NE(descriptorIdentity(backbone), backbone_identity);
  fs::remove(copy);
}

TEST(DatabaseFileVersion1, IsStillReadAndItsThumbnailsBecomeJpeg) {
  // Written by the version-1 build (two keyframes of six values, 4x3 raw thumbnails).
  const fs::path file = fs::path(PACKAGE_SOURCE_DIR) / "fuzz" / "seeds" / "fuzz_database_file" /
                        "two_keyframes_v1.lcdb";
  const LoadedDatabase loaded = loadDatabase(file.string(), "fuzz", 6);
  ASSERT_TRUE(loaded.database) << loaded.error;
  ASSERT_EQ(loaded.database->size(), 2u);
  EXPECT_TRUE(loaded.graph_rebuilt);
  for (size_t i = 0; i < 2; ++i) {
    const cv::Mat thumbnail = decodeThumbnail(loaded.database->record(i)->thumbnail_jpeg);
    EXPECT_EQ(thumbnail.size(), cv::Size(4, 3)) << i;
  }
}

TEST(DatabaseFileFuzzSeeds, EverySeedAndKeptCrashInputIsHandled) {
  // scripts/fuzz.sh starts from these files and keeps inputs that once crashed the loader here.
  const fs::path folder = fs::path(PACKAGE_SOURCE_DIR) / "fuzz" / "seeds" / "fuzz_database_file";
  ASSERT_TRUE(fs::is_directory(folder));
  int files = 0;
  for (const auto& entry : fs::directory_iterator(folder)) {
    SCOPED_TRACE(entry.path().string());
    for (int threads : {1, 2}) {
      const LoadedDatabase loaded = loadDatabase(entry.path().string(), "fuzz", 6, {}, threads);
      EXPECT_TRUE(loaded.database || !loaded.error.empty());
      // The seeds named *.lcdb are whole files of each version.
      if (entry.path().extension() == ".lcdb") {
        EXPECT_TRUE(loaded.database) << loaded.error;
      }
    }
    ++files;
  }
  EXPECT_GT(files, 0);
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
