#pragma once

#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "landmark_loop_closure/common/parameter_table.h"
#include "landmark_loop_closure/descriptors/landmarks.h"

namespace landmark_loop_closure {

struct CnnGlobalOptions;

/// What a descriptor extractor says about one image.
struct ImageDescriptor {
  /// Whole-image vector, L2-normalised; the database shortlists by its cosine similarity.
  std::vector<float> global;
  /// Optional per-landmark descriptors: one box (image pixels of the working resolution) and one
  /// row of `landmark_features` (CV_32F, L2-normalised rows) per landmark.
  std::vector<cv::Rect2f> landmark_boxes;
  cv::Mat landmark_features;

  bool empty() const { return global.empty(); }
  /// Heap bytes held by this descriptor.
  size_t bytes() const;
};

/// Cosine similarity of two L2-normalised vectors of equal length (their dot product).
double cosineSimilarity(const std::vector<float>& a, const std::vector<float>& b);

/// Turns an image into an ImageDescriptor and compares two of them.
/// Implementations are immutable after construction: describe() and similarity() may run
/// concurrently.
class DescriptorExtractor {
 public:
  virtual ~DescriptorExtractor() = default;

  virtual std::string name() const = 0;
  /// Length of ImageDescriptor::global.
  virtual int globalDimension() const = 0;
  /// `image`: 8-bit grey (CV_8UC1), or BGR when wantsColour(), any size; implementations resize
  /// to their working size.
  virtual ImageDescriptor describe(const cv::Mat& image) const = 0;
  /// Final similarity, higher is more alike. The default is globalScore() of the global
  /// vectors' cosine; landmark descriptors override it to re-rank a shortlist.
  virtual double similarity(const ImageDescriptor& query, const ImageDescriptor& candidate) const;
  /// The method's similarity for a global cosine (monotone; the identity unless the method
  /// defines its score another way, e.g. from the Euclidean distance).
  virtual double globalScore(double cosine) const { return cosine; }
  /// True when similarity() is more than the global cosine, so re-ranking is worth its time.
  virtual bool reranks() const { return false; }
  /// True when describe() wants the camera's colour (8-bit BGR) rather than grey.
  virtual bool wantsColour() const { return false; }
  /// One line saying how images of this size are described (which path, and why when a size
  /// rule picks it), for the node to log once at its first image.
  virtual std::string describesAs(cv::Size image) const {
    return name() + ": " + std::to_string(image.width) + "x" + std::to_string(image.height) +
           " images, " + std::to_string(globalDimension()) + " values per global vector";
  }
  /// The feature maps the appearance check compares cell by cell, for an 8-bit grey or BGR
  /// image; empty when the descriptor has none (only the backbone has).
  virtual FeatureMaps appearanceMaps(const cv::Mat& /*image*/) const { return {}; }
};

/// Parameters that choose and shape the descriptor.
struct DescriptorOptions {
  /// "landmarks": the ONNX encoder's output (calc) shortlists, landmark matching re-ranks;
  /// "calc": the encoder's output alone (1064 values); "hog": HOG with CALC's settings (3648);
  /// "hog_whole": one 9-bin HOG window over the whole image (9576); "pixels": 32x24 grey (768);
  /// "cnn_pca": a CNN layer with PCA whitening (options in `cnn`); "broad": the broad
  /// autoencoder's output layer (`broad`).
  std::string type = "backbone";
  std::string model;                         ///< ONNX encoder; empty = the package's model.
  int max_landmarks = 50;                    ///< Landmarks per image (landmarks).
  int landmark_grid = 2;                     ///< Cells per side of a landmark's crop (landmarks).
  std::string landmark_layer = "conv2";      ///< Layer the crops are cut from: "conv2" or "conv3".
  std::string shape_weighting = "penalise";  ///< "penalise" or "paper" (methods.md).
  /// "hog" of the box's patch of the working image, "conv": the shared pass's maps cropped,
  /// "conv_per_landmark": one network pass per box.
  std::string landmark_features = "hog";
  int working_width = 320;  ///< Image the landmark patches are cut from.
  int working_height = 240;
  int landmark_patch = 32;                   ///< Side of a landmark's HOG patch, a multiple of 4.
  double max_landmark_area = 0.5;            ///< Largest landmark box, as a fraction of the image.
  std::string landmark_storage = "float16";  ///< "float16" or "float32".
  /// Global vectors standardised against the mean of the last N keyframes (ConditionStandardiser);
  /// 0 = off. Part of the identity: maps store the standardised vectors.
  int condition_window = 10;

  /// cnn_pca: any ONNX CNN's layer, pooled, PCA-whitened (methods.md section 2). The defaults
  /// run the package's encoder; README.md shows the settings for a ResNet-50.
  struct Cnn {
    std::string model;            ///< "" = the package's encoder.
    std::string layer = "conv3";  ///< Output read; "" = the network's last layer.
    int input_width = 160;
    int input_height = 120;
    std::string colour = "grey";  ///< Channel order the network expects: rgb, bgr or grey.
    std::string mean = "0";       ///< Per channel, pixels in [0, 1]: (pixel - mean) / std.
    std::string std = "1";
    std::string pooling = "none";  ///< "average", "max" or "none" (the whole layer).
    /// lcd_fit_whitening's file; "" = the model's path + ".whitening" when that exists;
    /// "none" = no whitening.
    std::string whitening;
    std::string similarity = "distance";  ///< "distance" (1 - D / 2, the paper's) or "cosine".

    static const ParameterTable<Cnn>& parameters();  ///< Keys under advanced/descriptor/cnn/.
    static const ParameterTable<Cnn>& evaluationParameters();  ///< lcd_evaluate's (below).
  } cnn;

  /// backbone: the landmark-ConvNet on a pretrained network (scripts/fetch_backbone.sh converts
  /// an ImageNet MobileNetV2; any ONNX network with named feature-map outputs works).
  struct Backbone {
    std::string model;                   ///< "" = the package's model/mobilenet_v2.onnx.
    std::string layer = "block_12_add";  ///< Output the grid and the landmarks are described from.
    std::string proposal_layer;          ///< Output the landmark boxes come from; "" = layer.
    int input_width = 256;
    int input_height = 144;
    std::string colour = "rgb";  ///< rgb, bgr or grey.
    std::string mean = "0 0 0";  ///< Per channel, pixels in [0, 1]: (pixel - mean) / std.
    std::string std = "1 1 1";
    int grid_rows = 3;  ///< Global descriptor: the layer average-pooled over rows x cols cells.
    int grid_cols = 4;
    std::string normalisation = "cells";  ///< "cells", "whole" or "centred" (see below).
    double cell_pooling_power = 1.0;      ///< 1 = mean; p > 1 = signed generalised mean.
    std::string vocabulary;    ///< VLAD vocabulary file (lcd_train vocabulary); "" = the grid.
    int vlad_assignments = 1;  ///< Nearest centres a local feature is shared between (1 = hard).
    std::string vlad_features = "unit";  ///< "unit" (normalised) or "raw" local features.
    double vlad_weight = 1.0;            ///< VLAD's share; below 1 the grid is kept beside it.
    int max_landmarks = 20;              ///< Landmarks per image; 0 = none.
    int landmark_grid = 1;               ///< Cells per side a landmark's box is resampled to.
    std::string landmark_features = "backbone";  ///< "backbone" (the layer's maps) or "hog".
    double rerank_weight = 0;     ///< Share of the landmark similarity in the final score.
    double hog_weight = 0.1;      ///< Share of a whole-image HOG's cosine in the global score.
    int min_network_width = 96;   ///< Narrower images are described by the HOG alone.
    std::string engine = "auto";  ///< auto: oneDNN where it runs the network, else OpenCV.
    int hog_width = 96;           ///< The HOG window the image is resized to.
    int hog_height = 72;

    static const ParameterTable<Backbone>&
    parameters();  ///< Keys under advanced/descriptor/backbone/.
    static const ParameterTable<Backbone>& evaluationParameters();  ///< lcd_evaluate's (below).
  } backbone;

  /// broad: FLCD-BA's broad autoencoder (methods.md section 3).
  struct Broad {
    std::string model;  ///< File written by `lcd_train broad`; required.

    static const ParameterTable<Broad>& parameters();  ///< Keys under advanced/descriptor/broad/.
  } broad;

  /// Keys under descriptor/, documented in config/default.yaml. The type's own keys are checked
  /// only when that type is chosen.
  static const ParameterTable<DescriptorOptions>& parameters();
  /// Options measured and not kept (landmark features, VLAD, GeM, re-ranking, ...): not the
  /// node's parameters; lcd_evaluate --config reads them under their names of then
  /// ("descriptor/backbone/vocabulary"), and validate() checks them for its variants.
  static const ParameterTable<DescriptorOptions>& evaluationParameters();
  std::string validate() const;
  /// True when the chosen descriptor re-ranks its shortlist with a second similarity
  /// (DescriptorExtractor::reranks() of what these options build).
  bool reranks() const;
};

/// The ONNX encoder shipped with the package (calc_encoder.onnx in modelDirectory()).
std::string defaultModelPath();

/// The pretrained backbone scripts/fetch_backbone.sh converts (mobilenet_v2.onnx in
/// modelDirectory()).
std::string defaultBackbonePath();

/// backbone: the model file (the package's backbone when options.model is empty).
std::string backboneModelPath(const DescriptorOptions::Backbone& backbone);

/// When `options` asks for the package's backbone and it was never fetched, the options of the
/// package's own encoder (type landmarks) and, in `warning`, one line that says so; else
/// `options` unchanged and `warning` empty.
DescriptorOptions withBackboneFallback(const DescriptorOptions& options, std::string* warning);

/// Every value DescriptorOptions::type accepts.
const std::vector<std::string>& descriptorTypes();

/// Everything that decides what descriptors look like: every DescriptorOptions value and, for the
/// ConvNet types, a hash of the model file's bytes. Descriptors with different identities cannot
/// be compared, so a saved database carries it and a load checks it.
std::string descriptorIdentity(const DescriptorOptions& options);

/// cnn_pca: the model file (the package's encoder when options.model is empty), the whitening
/// file in use ("" = none) and the extractor's options.
std::string cnnModelPath(const DescriptorOptions::Cnn& cnn);
std::string whiteningPathFor(const DescriptorOptions::Cnn& cnn);
CnnGlobalOptions cnnGlobalOptions(const DescriptorOptions::Cnn& cnn);

/// Builds the extractor named by options.type; throws std::invalid_argument for an unknown type.
std::shared_ptr<const DescriptorExtractor> makeDescriptorExtractor(
    const DescriptorOptions& options);

}  // namespace landmark_loop_closure
