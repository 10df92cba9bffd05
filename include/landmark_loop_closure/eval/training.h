#pragma once

#include <cstddef>
#include <functional>
#include <memory>

#include <opencv2/core.hpp>

#include "landmark_loop_closure/descriptors/backbone_descriptor.h"
#include "landmark_loop_closure/descriptors/broad_autoencoder.h"
#include "landmark_loop_closure/descriptors/cnn_global_descriptor.h"
#include "landmark_loop_closure/eval/evaluator.h"

namespace landmark_loop_closure {
namespace eval {

/// `load(i)` returns training image i (empty when it cannot be read: skipped).
using ImageLoader = std::function<cv::Mat(size_t)>;

/// PCA whitening of a network's raw features (CnnGlobalDescriptor::rawFeature) over the images.
/// Throws std::invalid_argument when fewer than 2 images can be read.
PcaWhitening fitWhitening(const CnnGlobalDescriptor& network, size_t count, const ImageLoader& load,
                          int components, double regularisation, const Progress& progress = {});

/// Any extractor whose global vector is then PCA-whitened (fitted on the images' global vectors)
/// and normalised again: methods.md section 2's step measured on other descriptors (lcd_evaluate's
/// "_pcaN" variants; `whiten` false: the centred projection alone, "_projN"). Landmarks are
/// passed through. Throws std::invalid_argument when fewer than 2 images can be read.
std::shared_ptr<const DescriptorExtractor> withFittedWhitening(
    std::shared_ptr<const DescriptorExtractor> inner, size_t count, const ImageLoader& load,
    int components, bool whiten = true, const Progress& progress = {});

/// A VLAD vocabulary of `clusters` centres: k-means of the network layer's unit local features
/// over the images (at most `samples_per_image` cells of each, spread evenly; no labels).
/// Throws std::invalid_argument when fewer local features than clusters can be read.
VladVocabulary learnVocabulary(const BackboneDescriptor& network, size_t count,
                               const ImageLoader& load, int clusters, int samples_per_image = 64,
                               const Progress& progress = {});

/// A broad autoencoder trained on the images; `training_error` (when not null) receives the
/// reconstruction's mean squared error. Throws std::invalid_argument when fewer than 2 images
/// can be read.
BroadModel trainBroad(const BroadOptions& options, size_t count, const ImageLoader& load,
                      double* training_error = nullptr, const Progress& progress = {});

}  // namespace eval
}  // namespace landmark_loop_closure
