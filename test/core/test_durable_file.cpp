// Every file the package writes goes through durable_file.h (issue 80 point 5): a write that fails
// on the way (a full disk) or only when the file is closed (its tail flushed) is reported, and the
// file written before is left whole. The pose graph's file and a model are checked through it.
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "landmark_loop_closure/backend/pose_graph_file.h"
#include "landmark_loop_closure/common/durable_file.h"
#include "landmark_loop_closure/descriptors/pca_whitening.h"
#include "temporary_folder.h"

namespace landmark_loop_closure {
namespace {

class DurableFileTest : public test::TemporaryFolderTest {
 protected:
  DurableFileTest() : TemporaryFolderTest("durable_file_") {}
  void TearDown() override {
    clearWriteFaults();
    TemporaryFolderTest::TearDown();
  }
  static std::string contents(const std::string& path) {
    std::ifstream file(path, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(file), std::istreambuf_iterator<char>());
  }
  // Only the files named: no temporary left behind.
  size_t filesInFolder() const {
    return static_cast<size_t>(std::distance(std::filesystem::directory_iterator(directory_),
                                             std::filesystem::directory_iterator()));
  }
};

TEST_F(DurableFileTest, AWriteThatFailsOnCloseIsReportedAndLeavesTheEarlierFile) {
  const std::string path = this->path("table.csv");
  ASSERT_EQ(writeFileDurably(path, std::string("earlier\n")), "");
  WriteFaults faults;
  faults.fail_on_close = true;
  setWriteFaults(faults);
  const std::string error = writeFileDurably(path, std::string("later\n"));
  EXPECT_NE(error.find("cannot close"), std::string::npos) << error;
  EXPECT_NE(error.find("left as it was"), std::string::npos) << error;
  EXPECT_EQ(contents(path), "earlier\n");
  EXPECT_EQ(filesInFolder(), 1u);
  clearWriteFaults();
  EXPECT_EQ(writeFileDurably(path, std::string("later\n")), "");
  EXPECT_EQ(contents(path), "later\n");
}

TEST_F(DurableFileTest, ADiskThatFillsMidWriteIsReportedAndLeavesTheEarlierFile) {
  const std::string path = this->path("report.json");
  const std::string earlier(100000, 'a');
  ASSERT_EQ(writeFileDurably(path, earlier), "");
  WriteFaults faults;
  faults.bytes_until_full = 4096;
  setWriteFaults(faults);
  DurableText text(path);
  text << std::string(100000, 'b');
  try {
    text.commit();
    FAIL() << "a full disk was not reported";
  } catch (const std::runtime_error& error) {
    EXPECT_NE(std::string(error.what()).find("No space left"), std::string::npos) << error.what();
  }
  EXPECT_EQ(contents(path), earlier);
  EXPECT_EQ(filesInFolder(), 1u);
}

TEST_F(DurableFileTest, ThePoseGraphFileAndAModelReportAFailedCloseAndKeepTheirEarlierFile) {
  const std::string graph = path("map.lcdb-pose_graph");
  GraphKeyframe keyframe;
  keyframe.id = 1;
  keyframe.map_id = 7;
  keyframe.stamp_ns = 1000;
  keyframe.odometry_frame = "odom";
  ASSERT_EQ(saveGraphFile(graph, {keyframe}), "");
  const std::string graph_before = contents(graph);

  const std::string model = path("whitening.bin");
  Eigen::MatrixXf samples = Eigen::MatrixXf::Random(40, 6);
  const PcaWhitening whitening = PcaWhitening::fit(samples, 3);
  whitening.save(model, "features");
  const std::string model_before = contents(model);

  WriteFaults faults;
  faults.fail_on_close = true;
  setWriteFaults(faults);
  keyframe.id = 2;
  EXPECT_NE(saveGraphFile(graph, {keyframe, keyframe}), "");
  EXPECT_THROW(whitening.save(model, "other features"), std::runtime_error);
  EXPECT_EQ(contents(graph), graph_before);
  EXPECT_EQ(contents(model), model_before);
  EXPECT_EQ(filesInFolder(), 2u);
}

}  // namespace
}  // namespace landmark_loop_closure
