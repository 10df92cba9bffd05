// How far the published loops land from the truth: lcd_evaluate --detector's offset line.
#include <algorithm>
#include <cmath>
#include <sstream>
#include <string>
#include <vector>

#include "evaluate_detector.h"

namespace landmark_loop_closure {
namespace tools {

double framesFromTruth(const eval::GroundTruth& truth, size_t query, size_t match,
                       double tolerance) {
  if (query >= truth.rows() || truth.positives(query).empty()) return NAN;
  const std::vector<uint32_t>& positives = truth.positives(query);
  // The run of consecutive true frames nearest to the match: its centre is the place.
  size_t nearest = 0;
  for (size_t i = 1; i < positives.size(); ++i) {
    const auto gap = [&](size_t k) {
      return std::abs(static_cast<double>(positives[k]) - static_cast<double>(match));
    };
    if (gap(i) < gap(nearest)) nearest = i;
  }
  size_t first = nearest;
  size_t last = nearest;
  while (first > 0 && positives[first - 1] + 1 == positives[first]) --first;
  while (last + 1 < positives.size() && positives[last] + 1 == positives[last + 1]) ++last;
  const double centre = 0.5 * (static_cast<double>(positives[first]) + positives[last]);
  const double from = static_cast<double>(positives[first]) + tolerance;
  const double to = static_cast<double>(positives[last]) - tolerance;
  if (from >= to) return std::abs(static_cast<double>(match) - centre);
  // A stop: every frame of it is the place.
  const double position = static_cast<double>(match);
  return position < from ? from - position : position > to ? position - to : 0.0;
}

std::string offsetHistogram(const std::vector<eval::PublishedLoop>& loops,
                            const DetectorSource& source) {
  if (!source.offset || loops.empty()) return "";
  const bool metres = source.offset_unit == "m";
  const double bin = metres ? 0.5 : 1.0;
  // Frames: 0, 1, ..., the tolerance; metres: half-metre bins up to the tolerance.
  const int bins = static_cast<int>(std::ceil(source.offset_tolerance / bin)) + (metres ? 0 : 1);
  std::vector<size_t> counts(static_cast<size_t>(bins) + 1, 0);  // The last: beyond.
  std::vector<double> offsets;
  size_t without_truth = 0;
  for (const eval::PublishedLoop& loop : loops) {
    const double offset = source.offset(loop.query_frame, loop.match_frame);
    if (std::isnan(offset)) {
      ++without_truth;
      continue;
    }
    offsets.push_back(offset);
    const int index = static_cast<int>(std::floor(offset / bin + 1e-9));
    ++counts[static_cast<size_t>(std::min(index, bins))];
  }
  std::ostringstream line;
  line.precision(metres ? 2 : 1);
  line << std::fixed << "  offset from the truth (" << source.offset_unit
       << ", a loop is true within " << source.offset_tolerance << "):";
  for (int i = 0; i < bins; ++i) {
    if (metres) {
      line << " [" << i * bin << "," << (i + 1) * bin << ") " << counts[static_cast<size_t>(i)];
    } else {
      line << " " << i << ": " << counts[static_cast<size_t>(i)];
    }
  }
  line << " beyond: " << counts.back();
  if (!offsets.empty()) {
    std::sort(offsets.begin(), offsets.end());
    line << "; median " << offsets[offsets.size() / 2] << ", largest " << offsets.back();
  }
  if (without_truth > 0) line << "; " << without_truth << " without a true place";
  return line.str();
}

}  // namespace tools
}  // namespace landmark_loop_closure
