#pragma once

#include <memory>
#include <string>
#include <vector>

#include <opencv2/dnn.hpp>
#include <opencv2/objdetect.hpp>

#include "landmark_loop_closure/common/thread_annotations.h"
#include "landmark_loop_closure/descriptors/descriptor.h"
#include "landmark_loop_closure/descriptors/landmarks.h"
#include "landmark_loop_closure/descriptors/onednn_mobilenet.h"
#include "landmark_loop_closure/descriptors/vlad.h"

namespace landmark_loop_closure {

/// How the grid of pooled cells becomes the global descriptor (always L2-normalised at the end).
enum class GridNormalisation {
  kWhole,   ///< The whole vector only: bright, busy cells dominate.
  kCells,   ///< Each cell L2-normalised first: every region counts alike, also in the dark.
  kCentred  ///< Each channel's mean over the cells subtracted (what the whole image shares, its
            ///< light, goes), then each cell normalised.
};

struct BackboneOptions {
  std::string model_path;  ///< ONNX network with the named outputs (scripts/fetch_backbone.sh).
  std::string layer = "block_12_add";  ///< Output the grid and the landmarks are described from.
  /// Output whose activations give the landmark boxes ("" = `layer`).
  std::string proposal_layer;
  cv::Size input_size{256, 144};  ///< The network's input, width x height.
  std::string colour = "rgb";     ///< Channel order the network expects: rgb, bgr or grey.
  std::vector<double> mean{0.0, 0.0, 0.0};  ///< Per channel, pixels in [0, 1]: (p - mean) / std.
  std::vector<double> std{1.0, 1.0, 1.0};
  int grid_rows = 3;  ///< The layer average-pooled into grid_rows x grid_cols cells.
  int grid_cols = 4;
  GridNormalisation normalisation = GridNormalisation::kCells;
  /// How a cell pools its map cells: 1 = mean, p > 1 = signed generalised mean (see gridPool).
  double cell_pooling_power = 1.0;
  /// Not empty: the layer's local features VLAD-aggregated against it instead of the grid.
  VladVocabulary vocabulary;
  VladOptions vlad;
  /// With a vocabulary: VLAD's share of the network's part; below 1 the grid is kept beside it.
  double vlad_weight = 1.0;
  /// Landmarks per image (0 = none): boxes from the proposal layer's activations, each
  /// described by `layer` resampled to landmark_grid x landmark_grid cells.
  int max_landmarks = 20;
  int landmark_grid = 1;
  /// Landmarks described by the HOG of their box's 32x32 patch of a 320x240 grey image instead
  /// of the layer's maps (what the package's own encoder does).
  bool hog_landmarks = false;
  double max_landmark_area = 0.5;
  ShapeWeighting weighting = ShapeWeighting::kPenalise;
  /// Final similarity = (1 - w) * global + w * landmark similarity; 0 = no re-ranking.
  double rerank_weight = 0.0;
  /// Share of a whole-image HOG's cosine in the global similarity, for images at least
  /// `min_network_width` pixels wide; narrower images (where the network sees too little) are
  /// described by the HOG alone. 0 and 0: the network alone, no HOG computed or stored.
  double hog_weight = 0.1;
  int min_network_width = 96;
  /// "auto": oneDNN runs the network where it can (a Keras MobileNetV2 whose output agrees with
  /// OpenCV's), OpenCV's dnn elsewhere; "opencv": OpenCV's dnn always.
  std::string engine = "auto";
  cv::Size hog_size{96, 72};     ///< HOG window (16x16 blocks, 8 px stride and cells, 9 bins).
  bool float16_features = true;  ///< Landmark features stored as float16.
};

/// The landmark-ConvNet on a pretrained backbone (methods.md section 1 with ImageNet features):
/// one forward pass gives a spatial grid of average-pooled cells (the global descriptor that
/// shortlists) and landmark boxes found from the activations (8-connected components, energy =
/// mean activation), each described by the same pass's maps inside its box. Landmarks are matched
/// mutually by cosine with box-shape weighting. Landmark boxes are in a 160x120 frame, the
/// keyframe thumbnails' size.
/// Where one describe() spends its time (ms), for lcd_bench_pipeline.
struct BackboneStageTimes {
  double network_input = 0.0;  ///< Resize, colour order and normalisation into the blob.
  double network = 0.0;        ///< The forward pass to both named outputs.
  double grid = 0.0;           ///< Cell pooling (or VLAD) and normalisation.
  double landmark_proposals = 0.0;
  double landmark_features = 0.0;
  double hog = 0.0;  ///< Whole-image HOG (resize included).
};

class BackboneDescriptor : public DescriptorExtractor {
 public:
  static constexpr int kBoxFrameWidth = 160;
  static constexpr int kBoxFrameHeight = 120;

  /// Throws std::runtime_error naming the file when the model cannot be loaded or lacks a layer.
  explicit BackboneDescriptor(const BackboneOptions& options);

  std::string name() const override { return "backbone"; }
  std::string describesAs(cv::Size image) const override;
  int globalDimension() const override { return global_dimension_; }
  /// `image`: 8-bit grey, BGR or BGRA, any size.
  ImageDescriptor describe(const cv::Mat& image) const override;
  /// The same, with each stage's time written to `times` when given.
  ImageDescriptor describe(const cv::Mat& image, BackboneStageTimes* times) const;
  double similarity(const ImageDescriptor& query, const ImageDescriptor& candidate) const override;
  bool reranks() const override { return options_.rerank_weight > 0.0; }
  bool wantsColour() const override { return options_.colour != "grey"; }
  /// The layer the grid is pooled from.
  FeatureMaps appearanceMaps(const cv::Mat& image) const override;

  /// Which features a VLAD vocabulary for this network must be learnt on (model, layer, input).
  std::string featureIdentity() const { return feature_identity_; }
  /// The local features a vocabulary is learnt from (localFeatures of the layer, as VLAD sees
  /// them).
  cv::Mat vladFeatures(const cv::Mat& image) const;

  /// The named outputs (layer, then proposal layer) for an image.
  std::vector<FeatureMaps> forward(const cv::Mat& image, BackboneStageTimes* times = nullptr) const;

 private:
  int gridDimension() const;  ///< The network's part: the grid, VLAD, or both.
  int cellsDimension() const;
  int hogDimension() const;

  BackboneOptions options_;
  int channels_ = 0;
  int global_dimension_ = 0;
  cv::HOGDescriptor hog_;
  mutable Mutex net_mutex_;  // Neither engine's forward is safe to call concurrently.
  mutable cv::dnn::Net net_ GUARDED_BY(net_mutex_);
  /// Null: OpenCV's dnn runs the network.
  std::unique_ptr<OneDnnMobileNet> fast_net_ PT_GUARDED_BY(net_mutex_);
  std::string engine_note_;  ///< Which engine runs it, and why.
  std::string feature_identity_;
};

/// Each channel pooled over grid_rows x grid_cols cells of the maps (cell borders split the map
/// evenly, each cell at least one map cell), cell-major: rows * cols * channels values. `power`
/// 1 is the mean; p > 1 the signed generalised mean (GeM), sign(m) |m|^(1/p) with m the mean of
/// sign(x) |x|^p, which moves towards the strongest activation as p grows and, unlike GeM,
/// stays defined for a layer's negative values.
std::vector<float> gridPool(const FeatureMaps& maps, int grid_rows, int grid_cols,
                            double power = 1.0);

}  // namespace landmark_loop_closure
