#include "landmark_loop_closure/eval/report.h"

#include "landmark_loop_closure/common/durable_file.h"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <sstream>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace landmark_loop_closure {
namespace eval {

namespace {

void writePercentiles(std::ostream& out, const char* name, const Percentiles& p) {
  out << "      " << jsonString(name) << ": {\"median\": " << p.median << ", \"p99\": " << p.p99
      << "},\n";
}

cv::Mat similarityPicture(const cv::Mat& similarity) {
  // Colours span the 5th percentile to the maximum: most pairs are unrelated places, and a
  // min-max scale would spend the colour range on them.
  const cv::Mat valid = similarity > -1.0f;
  std::vector<float> values;
  for (int r = 0; r < similarity.rows; ++r) {
    for (int c = 0; c < similarity.cols; ++c) {
      if (valid.at<uchar>(r, c)) values.push_back(similarity.at<float>(r, c));
    }
  }
  cv::Mat colour(similarity.size(), CV_8UC3, cv::Scalar(0, 0, 0));
  if (values.empty()) return colour;
  std::nth_element(values.begin(), values.begin() + values.size() / 20, values.end());
  const double low = values[values.size() / 20];
  const double high = *std::max_element(values.begin(), values.end());
  const double scale = 255.0 / std::max(1e-6, high - low);
  cv::Mat scaled;
  similarity.convertTo(scaled, CV_8U, scale, -low * scale);
  cv::applyColorMap(scaled, colour, cv::COLORMAP_VIRIDIS);
  colour.setTo(cv::Scalar(0, 0, 0), ~valid);
  return colour;
}

}  // namespace

void writeContactSheet(const std::string& path, const std::vector<QueryOutcome>& outcomes,
                       const std::function<cv::Mat(size_t)>& load_query,
                       const std::function<cv::Mat(size_t)>& load_database, bool judge, int pairs) {
  std::vector<const QueryOutcome*> ranked;
  for (const QueryOutcome& outcome : outcomes) {
    if (outcome.match >= 0) ranked.push_back(&outcome);
  }
  std::stable_sort(ranked.begin(), ranked.end(), [](const QueryOutcome* a, const QueryOutcome* b) {
    return a->score > b->score;
  });
  if (ranked.size() > static_cast<size_t>(std::max(0, pairs))) ranked.resize(std::max(0, pairs));
  const cv::Size tile(200, 150);
  constexpr int kLabel = 22;
  constexpr int kBorder = 4;
  constexpr int kColumns = 3;
  const int cell_width = 2 * tile.width + 3 * kBorder;
  const int cell_height = tile.height + kLabel + 2 * kBorder;
  const int rows = std::max<int>(1, (static_cast<int>(ranked.size()) + kColumns - 1) / kColumns);
  cv::Mat sheet(rows * cell_height, kColumns * cell_width, CV_8UC3, cv::Scalar(30, 30, 30));
  const auto fitted = [&tile](const cv::Mat& image) {
    cv::Mat colour(tile, CV_8UC3, cv::Scalar(0, 0, 0));
    if (image.empty()) return colour;
    cv::Mat bgr;
    if (image.channels() == 1) {
      cv::cvtColor(image, bgr, cv::COLOR_GRAY2BGR);
    } else {
      bgr = image;
    }
    cv::resize(bgr, colour, tile, 0, 0, cv::INTER_AREA);
    return colour;
  };
  for (size_t k = 0; k < ranked.size(); ++k) {
    const QueryOutcome& outcome = *ranked[k];
    const int x = static_cast<int>(k % kColumns) * cell_width;
    const int y = static_cast<int>(k / kColumns) * cell_height;
    const cv::Scalar frame = !judge            ? cv::Scalar(160, 160, 160)
                             : outcome.correct ? cv::Scalar(60, 200, 60)
                                               : cv::Scalar(60, 60, 230);
    cv::rectangle(sheet, cv::Rect(x, y, cell_width, cell_height), frame, cv::FILLED);
    fitted(load_query(outcome.query))
        .copyTo(sheet(cv::Rect(x + kBorder, y + kBorder, tile.width, tile.height)));
    fitted(load_database(static_cast<size_t>(outcome.match)))
        .copyTo(
            sheet(cv::Rect(x + 2 * kBorder + tile.width, y + kBorder, tile.width, tile.height)));
    std::ostringstream label;
    label << "query " << outcome.query << " -> " << outcome.match << "  score " << std::fixed
          << std::setprecision(3) << outcome.score;
    cv::putText(sheet, label.str(), cv::Point(x + kBorder + 2, y + cell_height - 8),
                cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  }
  const std::filesystem::path parent = std::filesystem::path(path).parent_path();
  if (!parent.empty()) std::filesystem::create_directories(parent);
  writeImageDurably(path, sheet);
}

std::string jsonString(const std::string& text) {
  std::string out = "\"";
  for (const char c : text) {
    if (c == '"' || c == '\\') out += '\\';
    out += c;
  }
  return out + "\"";
}

size_t peakResidentBytes() {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind("VmHWM:", 0) == 0) {
      std::istringstream fields(line.substr(6));
      size_t kilobytes = 0;
      fields >> kilobytes;
      return kilobytes * 1024;
    }
  }
  return 0;
}

std::string writeReport(const std::string& folder, const RunDescription& run,
                        const std::vector<Evaluation>& evaluations, const GroundTruth& truth,
                        int matrix_size) {
  namespace fs = std::filesystem;
  fs::create_directories(folder);
  const fs::path base(folder);
  const std::string results_path = (base / "results.json").string();
  DurableText json(results_path);
  json << std::setprecision(6);
  json << "{\n  \"dataset\": " << jsonString(run.dataset)
       << ",\n  \"mode\": " << jsonString(run.mode)
       << ",\n  \"ground_truth\": " << jsonString(run.ground_truth)
       << ",\n  \"database_images\": " << run.database_images
       << ",\n  \"query_images\": " << run.query_images
       << ",\n  \"ground_truth_positives\": " << truth.count()
       << ",\n  \"peak_rss_bytes\": " << peakResidentBytes() << ",\n  \"configurations\": [\n";
  for (size_t k = 0; k < evaluations.size(); ++k) {
    const Evaluation& e = evaluations[k];
    const Metrics& m = e.metrics;
    json << "    {\n      \"name\": " << jsonString(e.name) << ",\n"
         << "      \"recall_at_100_precision\": " << m.recall_at_100_precision << ",\n"
         << "      \"threshold_at_100_precision\": " << m.threshold_at_100_precision << ",\n"
         << "      \"auc\": " << m.auc << ",\n"
         << "      \"average_precision\": " << m.average_precision << ",\n"
         << "      \"recall_at_1\": " << m.recall_at_1 << ",\n"
         << "      \"vprbench\": {\"recall_at_100_precision\": "
         << m.vprbench.recall_at_100_precision << ", \"auc\": " << m.vprbench.auc
         << ", \"correct_matches\": " << m.vprbench.correct_matches << "},\n"
         << "      \"training_source\": " << jsonString(e.training_source) << ",\n"
         << "      \"queries\": " << m.queries << ",\n"
         << "      \"queries_with_truth\": " << m.queries_with_truth << ",\n"
         << "      \"unmatched_queries_with_truth\": " << m.unmatched_with_truth << ",\n"
         << "      \"match_checks\": " << jsonString(e.match_checks) << ",\n"
         << "      \"undecodable_images\": " << e.undecodable << ",\n"
         << "      \"bytes_per_image\": " << e.bytes_per_image << ",\n";
    writePercentiles(json, "describe_ms", e.describe_ms);
    writePercentiles(json, "query_ms", e.query_ms);
    json << "      \"pr_curve\": " << jsonString("pr_" + e.name + ".csv") << "\n    }"
         << (k + 1 < evaluations.size() ? "," : "") << "\n";

    DurableText curve(base / ("pr_" + e.name + ".csv"));
    curve << "threshold,precision,recall\n" << std::setprecision(6);
    for (const PrPoint& point : m.curve) {
      curve << point.threshold << "," << point.precision << "," << point.recall << "\n";
    }
    curve.commit();
    DurableText vpr_curve(base / ("pr_vprbench_" + e.name + ".csv"));
    vpr_curve << "threshold,precision,recall\n" << std::setprecision(6);
    for (const PrPoint& point : m.vprbench.curve) {
      vpr_curve << point.threshold << "," << point.precision << "," << point.recall << "\n";
    }
    vpr_curve.commit();
    DurableText matches(base / ("matches_" + e.name + ".csv"));
    matches << "query,match,score,correct,query_has_place,accepted_at_100p,geometry_inliers,"
               "appearance_inliers,refused\n"
            << std::setprecision(6);
    for (const QueryOutcome& o : e.outcomes) {
      const bool accepted = o.match >= 0 && m.recall_at_100_precision > 0.0 &&
                            o.score >= m.threshold_at_100_precision;
      matches << o.query << "," << o.match << "," << o.score << "," << o.correct << ","
              << o.has_truth << "," << accepted << "," << o.geometry_inliers << ","
              << o.appearance_inliers << "," << o.refused << "\n";
    }
    matches.commit();
    if (!e.similarity.empty()) {
      writeImageDurably((base / ("similarity_" + e.name + ".png")).string(),
                        similarityPicture(e.similarity));
    }
  }
  json << "  ]\n}\n";
  json.commit();
  if (!run.trajectory.empty()) {
    DurableText trajectory(base / "trajectory.csv");
    trajectory << "index,x,y,z\n" << std::setprecision(9);
    for (size_t i = 0; i < run.trajectory.size(); ++i) {
      const Eigen::Vector3d& p = run.trajectory[i].position;
      trajectory << i << "," << p.x() << "," << p.y() << "," << p.z() << "\n";
    }
    trajectory.commit();
  }
  writeImageDurably((base / "ground_truth.png").string(), groundTruthPicture(truth, matrix_size));
  return results_path;
}

}  // namespace eval
}  // namespace landmark_loop_closure
