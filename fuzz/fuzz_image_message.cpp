// libFuzzer target: image and depth messages with any header and buffer go through the node's
// checks and conversions without crashing. Run by scripts/fuzz.sh.
#include <cstdint>
#include <string>

#include "../src/messages/ros_conversions.h"
#include "image_message_input.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace landmark_loop_closure;
  const sensor_msgs::Image image = fuzz::imageFromBytes(data, size);
  if (!checkImageMessage(image)) {
    const cv::Mat grey = toGrey(image);
    if (grey.type() != CV_8UC1 || grey.cols != static_cast<int>(image.width)) __builtin_trap();
  }
  std::string error;
  const cv::Mat depth = toDepth(image, &error);
  if (depth.empty() == error.empty()) __builtin_trap();
  return 0;
}
