// lcd_evaluate's command line: its options with a line each, and the details --help prints
// after them (every source, ground truth, mode and descriptor variant).
#pragma once

#include <vector>

#include "command_line.h"

namespace landmark_loop_closure {
namespace tools {

inline constexpr char kEvaluateDetails[] = R"(
IN DETAIL: lcd_evaluate SOURCE [GROUND TRUTH] [OPTIONS]

SOURCE, one of:
  --images DIR                  one sequence (images sorted by name, numbers as numbers:
                                2.jpg before 10.jpg), matched against itself
  --database DIR --queries DIR  two traversals: each query against every database image
      [--as-sequence]           ...or played one after the other as one sequence (the second
                                traversal's images then close loops with the first's)
  --corridor LAPS               the generated corridor (ground truth from its true poses);
      [--aliasing]              ...its aliasing form: bays that look alike every 4 m (door,
                                lockers, notice board) through a wide lens
      [--odometry-jump-at L]    ...tracking lost after L laps: the odometry jumps into another
                                frame (40 m, -25 m, 90 degrees away) for the detector to notice
  --bag FILE                    the keyframes a node would keep from a bag (images + odometry,
                                keyframe rule of config/default.yaml); topics: --image-topic
                                (/camera/image_raw), --odom-topic (/odom), --truth-topic (none);
                                ground truth from the truth topic's poses, else the odometry's

DETECTOR MODE (--images, --as-sequence, --corridor, --bag):
  --detector           the frames go through the LoopDetector the node runs (keyframe rule,
                       search, acceptance, temporal consistency or sequence matching, odometry gate,
                       geometric check when the source has intrinsics) and the loops it publishes
                       are scored: precision, recall and R@100P over a sweep of
                       advanced/acceptance/min_score, refusals by stage, time per keyframe
  --config FILE        the node's parameters (default: the built-in defaults = config/default.yaml);
                       --descriptors then replaces its descriptor (default: the config's own)
  --sweep-steps N      thresholds on the sweep's grid (default 16; 0 = the configured threshold
                       alone, no sweep)
  --still-threshold G  image folders without poses: an image whose grey picture (64 px wide)
                       differs from the last moving one's by less than G levels on average
                       stands still and adds no keyframe (default 5; 0 = every image moves)
  --still-joint        --as-sequence with --gt-aligned and --gt-stops G: the traversals show the
                       same place at the same frame, so a frame stands still exactly where both
                       stand (the stops --gt-stops finds), instead of where each one's own
                       picture barely changes (--still-threshold); one step per frame elsewhere
  --protocol P         --as-sequence or --corridor, how the two traversals (laps) meet:
                       one-sequence (default: one session; image folders have no odometry, the
                       odometry gate off; the corridor plays its own), sessions (as a robot
                       runs: each traversal its own session with its own odometry, one step a
                       frame, its heading drifting by --odometry-drift rad per step, default
                       0.01, as a random walk; loops within a traversal meet the odometry gate,
                       loops into the first skip it, as loops into a loaded map do), one-run (as
                       a robot that comes back: one session and one odometry throughout, the
                       route a closed loop of the first traversal's steps, drifting all the way
                       round; loops into the first traversal meet the odometry gate; needs
                       --still-threshold 0 or --still-joint), or localisation (the
                       first traversal mapped, the second searched in it, nothing stored: mode
                       localization)
  --camera-info FILE   image folders: the camera's intrinsics as a ROS camera_info YAML
                       (image_width, image_height, camera_matrix), scaled to the played size
                       (another aspect ratio than the images' stops the run); the geometric
                       check then runs (bench/cameras/ has Gardens Point's); used by
                       --detector and --appearance-check only
  Image folders have no odometry: images are 1 s and 1 m apart (standing still, see
  --still-threshold, adds no keyframe), the odometry gate is off. The corridor plays its drifting odometry and camera intrinsics; a bag plays every image
  with its odometry and camera_info, as the node receives them.
  Where true poses are known besides the odometry (the corridor, a bag with --truth-topic), the
  keyframes' trajectory RMSE is reported too: the odometry's, and after the reference pose graph
  (pose_graph node, default config/pose_graph.yaml) took the published metric loops.
  --pose-graph-config FILE   that pose graph's parameters (config/pose_graph.yaml's layout)

GROUND TRUTH, one of:
  --gt-mat FILE [--gt-var NAME] N x N matrix in a MATLAB .mat file, v5 to v7.3 (nonzero =
                                same place)
  --gt-aligned N                traversals: query i is database i +- N
      [--gt-stops G]            --as-sequence: frames where both traversals stand still (the
                                grey picture, 64 px wide, differs from the frame before by
                                less than G levels in each) show the place of the frame before:
                                a train's station stop is one place, +- N counts moving frames
  --gt-poses FILE --gt-times FILE   KITTI poses; same place = within --gt-distance metres
                                (default 5), --gt-angle degrees (default 0 = any heading) and
                                at least --gt-gap seconds apart (default 30)
  --no-ground-truth             none: every query's best match goes to matches_<name>.csv and the
                                --contact-sheet N best-scoring pairs (default 24) to
                                contact_<name>.png, to look at

OPTIONS:
  --descriptors LIST   comma-separated (default backbone,pixels,hog,hog_whole): backbone (the
                       node's default), pixels, hog, hog_whole,
                       calc, landmarks, and variants of landmarks: landmarks_paper (the paper's
                       shape weighting), landmarks_conv (landmarks described by conv2 crops),
                       landmarks_conv3 (conv3 crops), landmarks_gridN (crop grid N),
                       landmarks_per_landmark (one network pass per landmark), landmarks_mN
                       (N landmarks), landmarks_wN (working width N, height 3N/4),
                       landmarks_patchN (HOG patch side), landmarks_areaP (largest box P % of
                       the image), landmarks_f32 (landmark features stored as float32)
                       cnn_pca: a CNN layer with PCA whitening (methods.md section 2; the
                       package's encoder's conv3 unless --cnn-model), variants cnn_pca_raw (no
                       whitening), cnn_pca_cosine, cnn_pca_cN (N whitened dimensions, default
                       256); broad: the broad autoencoder (section 3), broad_eN (N enhancement
                       nodes, default 2000)
                       backbone: the landmark-ConvNet on the pretrained backbone (README), variants
                       backbone_gRxC (grid), _mN (landmarks), _rP (re-rank weight P %), _hP
                       (HOG weight P %), _nW (HOG alone below W px wide), _iWxH (input), _bN
                       (layer block_N_add), _pN (landmark boxes from block_N_add), _lgN
                       (landmark grid), _hoglm (landmarks described by HOG), _pcaN (the global
                       vector PCA-whitened to N dimensions, fitted on the training images),
                       _projN (PCA projection to N dimensions, not whitened), _whole / _centred
                       (grid normalisation), _paper (the paper's shape weighting), _vladK (VLAD
                       over a vocabulary of K centres learnt on the training images instead of
                       the grid), _softN (each local feature shared by its N nearest centres),
                       _vraw (local features not normalised), _vwP (the grid kept beside VLAD,
                       VLAD's share P %), _gemN (cells pooled by the signed generalised mean
                       of power N/10; gem30 = p 3)
  --model FILE         ONNX encoder for calc and landmarks (default: the package's)
  --backbone-model FILE   backbone's network (default: the package's model/mobilenet_v2.onnx)
  --vocabulary FILE    backbone's VLAD vocabulary (lcd_train vocabulary; default: none, the grid)
  --cnn-model FILE --cnn-whitening FILE   cnn_pca's network (advanced/descriptor/cnn defaults otherwise)
                       and whitening; without a whitening file it is fitted on the training
                       images and written to the output folder
  --broad-model FILE   broad's model; without one it is trained on the training images
  --train-images DIR   training images of cnn_pca, broad, _pcaN and _vladK variants (no labels)
  --train-on-eval      train them on the evaluation images themselves instead (flatters them)
  --contact-sheet N    also draw the N best-scoring pairs (green right, red wrong)
  --top-k N            candidates a re-ranking descriptor re-scores (default 10)
  --exclude-recent N   sequence mode: the N images before a query are never matched (default 50)
  --image-width W      scale every image to W px wide first (aspect kept, area averaging):
                       how a smaller camera sees the same route
  --condition-window N standardise each traversal's global vectors as the node does
                       (advanced/descriptor/condition_window: less the mean of the last N, in list order;
                       the database's first N-1 by its first full window's, as a mapping run
                       stores them; a query standardised to zeros matches nothing, a miss);
                       default 0, the descriptors as described (VPR-Bench's way)
  --appearance-check   each best match also goes through the node's checks of a loop (of
                       --config, default config/default.yaml): with --camera-info ORB's
                       geometric check (verification/) first, as the node checks a loop with
                       camera intrinsics; where ORB does not confirm the place, or without
                       --camera-info, the appearance check (advanced/verification/appearance) on the
                       thumbnails the node keeps. A match they refuse ranks below every other
                       (the node would not publish it); recall@1 is unchanged. Inliers and
                       refusals go to matches_<name>.csv
  --skip N             leave out the first N images of each folder (then --limit applies):
                       --skip 50 --limit 50 is images 50-99, the second half of a 100
  --limit N            use the first N images of each folder
  --output DIR         where results go (default lcd_results)
  --name TEXT          dataset name written into the results
  --matrix-size N      largest side of the similarity pictures (default 1000)
  --dry-run            read the arguments, the config, the images' list, the ground truth and
                       --camera-info (against the first image), say what would be evaluated, and
                       stop (a test runs the README's commands so)
)";

inline const std::vector<TextOption> kEvaluateOptions = {
    // Sources.
    {"--images", "DIR: one sequence, matched against itself"},
    {"--database", "DIR: the first traversal (with --queries)"},
    {"--queries", "DIR: the second traversal, each image against every database image"},
    {"--as-sequence", "--database then --queries played as one sequence", true},
    {"--corridor", "LAPS: the generated corridor"},
    {"--aliasing", "the corridor's look-alike bays through a wide lens", true},
    {"--odometry-jump-at", "L: the corridor's odometry jumps into another frame after L laps"},
    {"--bag", "FILE: the keyframes a node would keep from a bag"},
    {"--image-topic", "the bag's image topic (default /camera/image_raw)"},
    {"--odom-topic", "the bag's odometry topic (default /odom)"},
    {"--truth-topic", "the bag's ground-truth topic (default none)"},
    // Detector mode.
    {"--detector", "the frames go through the node's LoopDetector", true},
    {"--config", "FILE: the node's parameters (default: the built-in defaults)"},
    {"--sweep-steps", "N: thresholds on the sweep's grid (default 16)"},
    {"--still-threshold", "G: grey levels below which an image stands still (default 5)"},
    {"--still-joint", "frames stand still where both traversals' stops meet", true},
    {"--protocol", "one-sequence, sessions, one-run, localisation or robots"},
    {"--odometry-drift", "rad a step: the sessions protocol's heading drift (default 0.01)"},
    {"--camera-info", "FILE: the camera's intrinsics (ROS camera_info YAML)"},
    {"--pose-graph-config", "FILE: the reference pose graph's parameters"},
    {"--name-suffix", "TEXT: appended to each descriptor's name in the results"},
    // Ground truth.
    {"--gt-mat", "FILE: N x N matrix in a MATLAB .mat file (v5 to v7.3)"},
    {"--gt-var", "NAME: the matrix's variable (default: the first 2-D numeric one)"},
    {"--gt-aligned", "N: traversals: query i is database i +- N"},
    {"--gt-stops", "G: stops of both traversals are one place"},
    {"--gt-poses", "FILE: KITTI poses (with --gt-times)"},
    {"--gt-times", "FILE: KITTI times"},
    {"--gt-distance", "metres: same place within this distance (default 5)"},
    {"--gt-angle", "degrees: ...and this heading difference (default 0 = any)"},
    {"--gt-gap", "seconds: ...at least this far apart (default 30)"},
    {"--no-ground-truth", "none: best matches to a CSV and a contact sheet", true},
    // Options.
    {"--descriptors", "LIST: comma-separated descriptors and variants (below)"},
    {"--model", "FILE: ONNX encoder for calc and landmarks"},
    {"--backbone-model", "FILE: the backbone's network"},
    {"--vocabulary", "FILE: the backbone's VLAD vocabulary"},
    {"--cnn-model", "FILE: cnn_pca's network"},
    {"--cnn-whitening", "FILE: cnn_pca's whitening"},
    {"--broad-model", "FILE: broad's model"},
    {"--train-images", "DIR: training images of the learned descriptors (no labels)"},
    {"--train-on-eval", "train them on the evaluation images themselves", true},
    {"--contact-sheet", "N: also draw the N best-scoring pairs"},
    {"--top-k", "N: candidates a re-ranking descriptor re-scores (default 10)"},
    {"--exclude-recent", "N: the N images before a query are never matched (default 50)"},
    {"--image-width", "W: scale every image to W px wide first"},
    {"--condition-window", "N: standardise global vectors as the node does (default 0)"},
    {"--appearance-check", "each best match also goes through the node's checks", true},
    {"--skip", "N: leave out the first N images of each folder"},
    {"--limit", "N: use the first N images of each folder"},
    {"--output", "DIR: where results go (default lcd_results)"},
    {"--name", "TEXT: dataset name written into the results"},
    {"--matrix-size", "N: largest side of the similarity pictures (default 1000)"},
    {"--dry-run", "say what would be evaluated, and stop", true},
};

}  // namespace tools
}  // namespace landmark_loop_closure
