// Pipeline benchmark: the time one keyframe costs the worker thread (describe and standardise,
// shortlist from the database, re-rank, sequence scoring, the thumbnail kept), stage by stage, on
// one core, with a database of N keyframes, and the database's bytes per keyframe; and apart, the
// appearance check that a loop candidate ORB cannot confirm costs (two network passes over
// thumbnails).
//   lcd_bench_pipeline [--database DIR] [--queries DIR] [--keyframes 10000] [--top-k 10]
//                      [--repeat 2] [--descriptor backbone|landmarks|landmarks_conv]
//                      [--engine auto|opencv]  (the backbone's network: oneDNN where it can run it)
// The landmark descriptors' describe time is split into its stages; the backbone's is one.
// The database holds the descriptors of the images of --database, repeated until it has N
// keyframes (search time does not depend on the content; re-ranking sees real landmark sets);
// each query is then inserted as the detector inserts its keyframe, and that time counted.
// --coarse-from N, --coarse-candidates K: advanced/database/index/ (the rows' projections); an
// approximate shortlist is compared with exact search's, outside the clock (its recall@top-K).
// --distinct: each stored keyframe a view of its own (the images cropped and brightened at
// random) rather than the images repeated, for that recall on rows that all differ.
// Without folders, views of the generated corridor are used.
// --fleet-rows N: four other robots' N rows kept in a fleet matcher, each robot driving a
// synthetic route from its own start (lcd_bench_fleet's: vectors spread like the backbone's of
// real images); each keyframe's row, a view of the route's next place, is handed to the fleet's
// searcher, whose thread searches them beside the worker (issue 81): the worker's time with N
// rows against none, and the search's time on its own thread. --fleet-approximate-from R:
// advanced/fleet/approximate_from (0: every row read, as before the graph).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <mutex>
#include <optional>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "bench_workload.h"
#include "command_line.h"
#include "landmark_loop_closure/common/image_helpers.h"
#include "landmark_loop_closure/common/stopwatch.h"
#include "landmark_loop_closure/core/appearance_check.h"
#include "landmark_loop_closure/core/condition_standardiser.h"
#include "landmark_loop_closure/core/false_alarms.h"
#include "landmark_loop_closure/core/sequence_matching.h"
#include "landmark_loop_closure/database/keyframe_database.h"
#include "landmark_loop_closure/database/quantized_vectors.h"
#include "landmark_loop_closure/descriptors/backbone_descriptor.h"
#include "landmark_loop_closure/descriptors/convnet_descriptor.h"
#include "landmark_loop_closure/eval/evaluator.h"
#include "landmark_loop_closure/eval/metrics.h"
#include "landmark_loop_closure/eval/report.h"
#include "landmark_loop_closure/fleet/fleet_searcher.h"
#include "landmark_loop_closure/sim/corridor_world.h"

namespace {

using namespace landmark_loop_closure;

std::vector<cv::Mat> loadImages(const std::string& folder, double corridor_offset) {
  std::vector<cv::Mat> images;
  if (folder.empty()) {
    const sim::CorridorWorld world;
    for (int i = 0; i < 100; ++i) {
      images.push_back(world.render(world.poseAt(corridor_offset + 1.3 * i, corridor_offset * 0.02),
                                    sim::CameraModel{}, sim::Lighting{}, 1));
    }
    return images;
  }
  for (const std::string& path : eval::listImages(folder)) {
    cv::Mat image = cv::imread(path, cv::IMREAD_COLOR);
    if (!image.empty()) images.push_back(image);
  }
  return images;
}

// Stage times in the order the stages were first added (the order they run).
struct Stages {
  std::vector<std::pair<std::string, std::vector<double>>> times;
  void add(const std::string& stage, double milliseconds) {
    auto found = std::find_if(times.begin(), times.end(),
                              [&stage](const auto& entry) { return entry.first == stage; });
    if (found == times.end()) found = times.insert(times.end(), {stage, {}});
    found->second.push_back(milliseconds);
  }
  const std::vector<double>* find(const std::string& stage) const {
    for (const auto& [name, values] : times) {
      if (name == stage) return &values;
    }
    return nullptr;
  }
};

}  // namespace

int main(int argc, char** argv) {
  std::string database_folder, query_folder, variant = "backbone", engine = "auto";
  size_t keyframes = 10000;
  int top_k = 10, repeat = 2;
  size_t fleet_rows = 0;
  bool distinct = false;
  int fleet_approximate_from = FleetOptions{}.approximate_from;
  IndexOptions index_options;
  CLI::App app{"Time per keyframe of each stage of the node's pipeline, on one thread."};
  app.add_option("--database", database_folder, "images stored as keyframes (used in turn)")
      ->required();
  app.add_option("--queries", query_folder, "query images")->required();
  app.add_option("--keyframes", keyframes, "keyframes in the map")->capture_default_str();
  app.add_option("--top-k", top_k, "candidates the search returns")->capture_default_str();
  app.add_option("--repeat", repeat, "passes over the queries")->capture_default_str();
  app.add_option("--fleet-rows", fleet_rows, "other robots' rows searched beside the worker")
      ->capture_default_str();
  app.add_option("--fleet-approximate-from", fleet_approximate_from,
                 "advanced/fleet/approximate_from (0: every row read)")
      ->capture_default_str();
  app.add_option("--coarse-candidates", index_options.coarse_candidates,
                 "advanced/database/index/coarse_candidates")
      ->capture_default_str();
  app.add_option("--coarse-from", index_options.coarse_from,
                 "advanced/database/index/coarse_from (0: every keyframe scored exactly)")
      ->capture_default_str();
  app.add_flag("--distinct", distinct,
               "each keyframe a view of its own (a random crop and brightness of a --database "
               "image) instead of the images repeated");
  app.add_option("--descriptor", variant, "the descriptor")
      ->check(CLI::IsMember({"backbone", "landmarks", "landmarks_conv"}))
      ->capture_default_str();
  app.add_option("--engine", engine, "the network's engine: auto (oneDNN) or opencv")
      ->check(CLI::IsMember({"auto", "opencv"}))
      ->capture_default_str();
  if (const auto exit_code = tools::parseCommandLine(&app, argc, argv)) return *exit_code;
  cv::setNumThreads(1);
  DescriptorOptions descriptor_options;
  descriptor_options.type = variant == "backbone" ? "backbone" : "landmarks";
  descriptor_options.backbone.engine = engine;
  if (variant == "landmarks_conv") {
    descriptor_options.landmark_features = "conv";
  } else if (variant != "landmarks" && variant != "backbone") {
    std::fprintf(stderr,
                 "lcd_bench_pipeline: --descriptor must be backbone, landmarks or "
                 "landmarks_conv\n");
    return 2;
  }
  const auto extractor = makeDescriptorExtractor(descriptor_options);
  const auto* convnet = dynamic_cast<const ConvNetDescriptor*>(extractor.get());
  const auto* backbone = dynamic_cast<const BackboneDescriptor*>(extractor.get());

  std::vector<cv::Mat> database_images = loadImages(database_folder, 0.0);
  const std::vector<cv::Mat> query_images = loadImages(query_folder, 0.6);
  if (database_images.empty() || query_images.empty()) {
    std::fprintf(stderr, "lcd_bench_pipeline: no readable images\n");
    return 1;
  }
  std::vector<ImageDescriptor> described;
  std::vector<std::vector<uint8_t>> thumbnails;
  for (const cv::Mat& image : database_images) {
    described.push_back(extractor->describe(image));
    thumbnails.push_back(encodeThumbnail(toWorkingImage(image, 160, 120)));
  }
  if (distinct) {
    // Every keyframe its own view: the image cropped to 80-100 % at a random place and its
    // brightness scaled by 0.8-1.2, so that no two rows are equal (repeated rows span only the
    // images' few directions, which a projection learned from the map would capture whole).
    std::mt19937 random(5);
    std::uniform_real_distribution<double> share(0.8, 1.0), gain(0.8, 1.2), place(0.0, 1.0);
    const size_t images = described.size();
    described.clear();
    for (size_t id = 0; id < keyframes; ++id) {
      const cv::Mat& image = database_images[id % images];
      const double s = share(random);
      const cv::Size crop(std::max(8, static_cast<int>(image.cols * s)),
                          std::max(8, static_cast<int>(image.rows * s)));
      const cv::Rect area(static_cast<int>(place(random) * (image.cols - crop.width)),
                          static_cast<int>(place(random) * (image.rows - crop.height)), crop.width,
                          crop.height);
      cv::Mat view;
      cv::resize(image(area), view, image.size(), 0, 0, cv::INTER_LINEAR);
      view.convertTo(view, -1, gain(random), 0.0);
      described.push_back(extractor->describe(view));
    }
  }
  const cv::Size input = database_images.front().size();
  database_images.clear();  // Decoded images are not part of the database's memory.

  KeyframeDatabase database(extractor->globalDimension(), index_options);
  for (size_t id = 0; id < keyframes; ++id) {
    KeyframeRecord keyframe;
    keyframe.id = id;
    keyframe.stamp = static_cast<double>(id);
    keyframe.descriptor = described[id % described.size()];
    // Own copies, so that the peak RSS is that of a real database.
    keyframe.descriptor.landmark_features = keyframe.descriptor.landmark_features.clone();
    database.add(std::move(keyframe));
  }
  DatabaseOptions database_options;
  database_options.top_k = top_k;
  database_options.index = index_options;
  database_options.min_size = 1;

  // The fleet: four peers' rows, each peer driving the route from its own start, searched on the
  // searcher's own thread.
  FleetOptions fleet_options;
  fleet_options.approximate_from = fleet_approximate_from;
  FleetMatcher fleet_matcher(fleet_options, "bench descriptor", extractor->globalDimension());
  Mutex fleet_mutex;
  std::mutex fleet_times_mutex;
  std::vector<double> fleet_search_ms;
  size_t fleet_candidates = 0;
  bench::Route route(extractor->globalDimension(), 11, bench::RouteShape::kMeasured);
  const size_t route_places = std::max<size_t>(1, fleet_rows / 4);
  std::vector<std::vector<float>> places;
  if (fleet_rows > 0) {
    for (size_t k = 0; k < route_places; ++k) places.push_back(route.next());
  }
  for (size_t i = 0; i < fleet_rows; ++i) {
    const size_t peer = i % 4;
    SharedKeyframe row;
    row.robot = "peer_" + std::to_string(peer);
    row.map_id = peer + 1;
    row.id = i / 4;
    row.stamp_ns = static_cast<int64_t>(row.id) * 100000000;
    row.pose.position.x() = 5.0 * static_cast<double>(row.id);
    row.odometry_frame = row.robot + "/odom";
    row.descriptor_fingerprint = descriptorFingerprint("bench descriptor");
    row.global_row = QuantizedVectors::encode(
        route.revisit(places[(row.id + peer * route_places / 4) % route_places]));
    fleet_matcher.addRow(row, 0.0, 0);
  }
  // The rows this robot's keyframes hand to the searcher: views of the route's places, made
  // before the clock runs.
  std::vector<std::vector<uint8_t>> own_rows;
  if (fleet_rows > 0) {
    for (size_t k = 0; k < query_images.size() * static_cast<size_t>(std::max(repeat, 1)); ++k) {
      own_rows.push_back(QuantizedVectors::encode(route.revisit(places[k % route_places])));
    }
  }
  std::optional<FleetSearcher> searcher;
  if (fleet_rows > 0) {
    searcher.emplace(
        fleet_matcher, fleet_mutex, 8,
        [&](const FleetSearcher::Search&, std::optional<FleetCandidate> candidate, double ms) {
          std::lock_guard<std::mutex> lock(fleet_times_mutex);
          fleet_search_ms.push_back(ms);
          if (candidate) ++fleet_candidates;
        });
  }
  uint64_t own_id = 0;
  uint64_t next_keyframe_id = keyframes;
  DatabaseOptions exact_options = database_options;
  exact_options.index.type = "exact";
  size_t shortlist_found = 0;
  size_t shortlist_wanted = 0;

  Stages stages;
  ConditionStandardiser standardiser(descriptor_options.condition_window);
  SequenceMatcher sequences{SequenceMatchingOptions{}};
  const AppearanceCheckOptions appearance_options;
  for (int r = 0; r < repeat; ++r) {
    for (const cv::Mat& image : query_images) {
      const Clock::time_point start = Clock::now();
      DescribeStageTimes describe_times;
      BackboneStageTimes backbone_times;
      ImageDescriptor query = convnet    ? convnet->describe(image, &describe_times)
                              : backbone ? backbone->describe(image, &backbone_times)
                                         : extractor->describe(image);
      const Clock::time_point standardise_start = Clock::now();
      query.global = standardiser.apply(query.global);
      const double standardise_ms = millisecondsSince(standardise_start);
      const double describe_ms = millisecondsSince(start);
      const Clock::time_point shortlist_start = Clock::now();
      const QueryResult result = database.query(query.global, 1e12, database_options);
      const double shortlist_ms = millisecondsSince(shortlist_start);
      double unclocked_ms = 0.0;
      if (result.approximate) {
        // The shortlist against every keyframe scored exactly (taken out of the total): a
        // candidate counts when it scores at least the exact K-th (copies of a database image
        // tie).
        const Clock::time_point exact_start = Clock::now();
        const QueryResult exact = database.query(query.global, 1e12, exact_options);
        if (!exact.candidates.empty()) {
          const double kth = exact.candidates.back().global_score;
          for (const Candidate& candidate : result.candidates) {
            shortlist_found += candidate.global_score >= kth - 1e-6;
          }
          shortlist_wanted += exact.candidates.size();
        }
        unclocked_ms = millisecondsSince(exact_start);
      }
      const Clock::time_point rerank_start = Clock::now();
      double best = -1.0;
      for (const Candidate& candidate : result.candidates) {
        best = std::max(best,
                        extractor->similarity(query, database.record(candidate.index)->descriptor));
      }
      const double rerank_ms = millisecondsSince(rerank_start);
      if (best < -1.0) return 1;  // Keeps the re-rank from being optimised away.
      const Clock::time_point sequence_start = Clock::now();
      sequences.push(query);
      std::vector<SequenceCandidate> sequence_candidates;
      for (const Candidate& candidate : result.candidates) {
        SequenceCandidate scored;
        scored.index = candidate.index;
        scored.image_score = extractor->globalScore(candidate.global_score);
        sequence_candidates.push_back(scored);
      }
      sequences.score(
          database, *extractor, [](size_t) { return true; }, &sequence_candidates);
      const double sequence_ms = millisecondsSince(sequence_start);
      // advanced/acceptance/max_false_alarms (on by default): the map's places scored as candidates
      // and the tail fitted to them.
      const Clock::time_point calibration_start = Clock::now();
      const ScoreBackground background =
          sequences.background(database, *extractor, [](size_t) { return true; });
      const ScoreTail tail = fitScoreTail(background.score);
      const double calibration_ms = millisecondsSince(calibration_start);
      if (tail.mean_excess < 0.0) return 1;  // Keeps the fit from being optimised away.
      const Clock::time_point thumbnail_start = Clock::now();
      const std::vector<uint8_t> thumbnail = encodeThumbnail(toWorkingImage(image, 160, 120));
      const double thumbnail_ms = millisecondsSince(thumbnail_start);
      // With peers: the keyframe's row (as sharedKeyframeOf makes it) handed to the searcher.
      const Clock::time_point fleet_start = Clock::now();
      if (searcher) {
        FleetSearcher::Search own;
        own.row.robot = "bench";
        own.row.id = own_id++;
        own.row.descriptor_fingerprint = descriptorFingerprint("bench descriptor");
        own.row.global_row = own_rows[own.row.id % own_rows.size()];
        own.map_id = 99;
        searcher->hand(std::move(own));
      }
      const double fleet_ms = millisecondsSince(fleet_start);
      // The keyframe joins the map as the detector adds it: its 8-bit row, the search graph's
      // links (advanced/database/index/type auto keeps the graph from the first keyframe).
      const Clock::time_point insert_start = Clock::now();
      {
        KeyframeRecord keyframe;
        keyframe.id = next_keyframe_id++;
        keyframe.stamp = static_cast<double>(keyframe.id);
        keyframe.descriptor = query;
        keyframe.thumbnail = thumbnail;
        database.add(std::move(keyframe));
      }
      const double insert_ms = millisecondsSince(insert_start);
      const double total_ms = millisecondsSince(start) - unclocked_ms;
      // Not every keyframe: only one whose candidate passed the threshold and the consistency
      // check and which ORB could not confirm.
      const Clock::time_point appearance_start = Clock::now();
      const size_t match = result.candidates.empty() ? 0 : result.candidates.front().index;
      const AppearanceCheckResult appearance = checkAppearance(
          cellFeatures(extractor->appearanceMaps(decodeThumbnail(thumbnail))),
          cellFeatures(
              extractor->appearanceMaps(decodeThumbnail(thumbnails[match % thumbnails.size()]))),
          appearance_options);
      const double appearance_ms = millisecondsSince(appearance_start);
      if (appearance.inliers < 0) return 1;
      if (convnet) {
        stages.add("prepare (grey, resize)", describe_times.prepare);
        stages.add("network pass", describe_times.network);
        stages.add("landmark proposals", describe_times.proposals);
        stages.add("landmark descriptors", describe_times.landmark_features);
      }
      if (backbone) {
        stages.add("describe: network input (resize, colour, normalise)",
                   backbone_times.network_input);
        stages.add("describe: network pass", backbone_times.network);
        stages.add("describe: grid pooling", backbone_times.grid);
        stages.add("describe: landmark proposals", backbone_times.landmark_proposals);
        stages.add("describe: landmark descriptors", backbone_times.landmark_features);
        stages.add("describe: whole-image HOG", backbone_times.hog);
        stages.add("describe: condition standardisation", standardise_ms);
      }
      stages.add(convnet ? "describe (the above)"
                         : "describe (resize, network, grid, landmarks, HOG, standardise)",
                 describe_ms);
      stages.add(result.approximate ? "shortlist (approximate search)" : "shortlist (exact search)",
                 shortlist_ms);
      stages.add("re-rank top-K", rerank_ms);
      stages.add("sequence scoring (advanced/acceptance/sequence_length)", sequence_ms);
      stages.add("thumbnail (WebP)", thumbnail_ms);
      stages.add("calibrated decision's background (advanced/acceptance/max_false_alarms)",
                 calibration_ms);
      if (searcher) stages.add("fleet: the row handed to the searcher", fleet_ms);
      stages.add("insert into the map (8-bit row, search graph)", insert_ms);
      stages.add("total per keyframe", total_ms);
      stages.add("appearance check, when a candidate reaches it", appearance_ms);
    }
  }
  if (searcher) {
    searcher->drain();
    std::lock_guard<std::mutex> lock(fleet_times_mutex);
    for (const double ms : fleet_search_ms) {
      stages.add("fleet search of " + std::to_string(fleet_matcher.rows()) +
                     " rows (its own thread; not in the total)",
                 ms);
    }
    std::printf(
        "fleet: %zu rows of 4 peers (approximate_from %d), %lu searches, %lu dropped (the "
        "searcher behind), %zu candidates\n",
        fleet_matcher.rows(), fleet_approximate_from,
        static_cast<unsigned long>(searcher->searched()),
        static_cast<unsigned long>(searcher->dropped()), fleet_candidates);
  }
  std::printf(
      "descriptor %s (%s), input %dx%d, %zu keyframes (%zu after the queries' insertion), top-K "
      "%d, %zu queries, one thread\n\n",
      variant.c_str(), extractor->reranks() ? "re-ranked" : "no re-ranking", input.width,
      input.height, keyframes, database.size(), database_options.top_k,
      stages.times.begin()->second.size());
  std::printf("%s\n\n", extractor->describesAs(input).c_str());
  std::printf("| stage | median (ms) | p99 (ms) |\n|---|---|---|\n");
  for (const auto& [stage, times] : stages.times) {
    const eval::Percentiles p = eval::percentiles(times);
    std::printf("| %s | %.2f | %.2f |\n", stage.c_str(), p.median, p.p99);
  }
  // The figure a user compares with other detectors: what the pipeline costs beyond its network.
  const std::vector<double>* network =
      stages.find(convnet ? "network pass" : "describe: network pass");
  const std::vector<double>* total = stages.find("total per keyframe");
  if (network && total) {
    const eval::Percentiles pass = eval::percentiles(*network);
    const eval::Percentiles whole = eval::percentiles(*total);
    if (pass.median > 0.0) {
      std::printf(
          "\nthe total per keyframe is %.1fx the network pass (median %.2f / %.2f ms), p99 %.1fx "
          "the pass's median\n",
          whole.median / pass.median, whole.median, pass.median, whole.p99 / pass.median);
    }
  }
  if (shortlist_wanted > 0) {
    std::printf("\nshortlist recall@%d against every keyframe scored exactly: %.4f (%zu of %zu)\n",
                database_options.top_k,
                static_cast<double>(shortlist_found) / static_cast<double>(shortlist_wanted),
                shortlist_found, shortlist_wanted);
  }
  std::printf(
      "\nbytes per keyframe: %.0f (database accounting), peak RSS %.0f MB (the process, query "
      "images included)\n",
      static_cast<double>(database.bytes()) / database.size(), eval::peakResidentBytes() / 1e6);
  return 0;
}
