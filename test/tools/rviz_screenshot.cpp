// Takes a screenshot of the X display rviz runs on (Xvfb in the test) and checks what a user sees:
// no display in rviz's Displays tree shows an error (rviz writes a display's name in its status
// colour: error red, warning orange, ok blue), and with --final: no warning either, green loops
// drawn in the 3D view and the match view showing an accepted loop.
//   rviz_screenshot OUT.png [--final]
// The regions are those of the shipped config (config/rviz/loop_closure.rviz) on a 1400x900
// screen, the size the test's Xvfb has.
#include <X11/Xlib.h>
#include <X11/Xutil.h>

#include <cstdio>
#include <cstring>
#include <functional>
#include <string>

#include <opencv2/imgcodecs.hpp>

namespace {

cv::Mat grabScreen() {
  Display* display = XOpenDisplay(nullptr);
  if (display == nullptr) return {};
  const Window root = DefaultRootWindow(display);
  XWindowAttributes attributes;
  XGetWindowAttributes(display, root, &attributes);
  XImage* image =
      XGetImage(display, root, 0, 0, attributes.width, attributes.height, AllPlanes, ZPixmap);
  cv::Mat screen(attributes.height, attributes.width, CV_8UC3);
  for (int y = 0; y < attributes.height; ++y) {
    for (int x = 0; x < attributes.width; ++x) {
      const unsigned long pixel = XGetPixel(image, x, y);
      screen.at<cv::Vec3b>(y, x) =
          cv::Vec3b(pixel & 0xff, (pixel >> 8) & 0xff, (pixel >> 16) & 0xff);
    }
  }
  XDestroyImage(image);
  XCloseDisplay(display);
  return screen;
}

int countPixels(const cv::Mat& screen, const cv::Rect& region,
                const std::function<bool(int r, int g, int b)>& wanted) {
  int count = 0;
  const cv::Rect inside = region & cv::Rect(0, 0, screen.cols, screen.rows);
  for (int y = inside.y; y < inside.y + inside.height; ++y) {
    for (int x = inside.x; x < inside.x + inside.width; ++x) {
      const cv::Vec3b p = screen.at<cv::Vec3b>(y, x);
      count += wanted(p[2], p[1], p[0]) ? 1 : 0;
    }
  }
  return count;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: rviz_screenshot OUT.png [--final]\n");
    return 2;
  }
  const bool final_state = argc > 2 && std::strcmp(argv[2], "--final") == 0;
  const cv::Mat screen = grabScreen();
  if (screen.empty()) {
    std::fprintf(stderr, "FAIL: no X display to take a screenshot of (DISPLAY unset?)\n");
    return 1;
  }
  cv::imwrite(argv[1], screen);
  // The names in the Displays tree (below the match view in the left dock), past the icons (the
  // markers icon is red too).
  const cv::Rect tree(44, 560, 230, 190);
  // The 3D view, and the match view (its verdict band).
  const cv::Rect view(585, 65, 800, 800);
  const cv::Rect match_panel(0, 60, 560, 480);
  const int errors = countPixels(screen, tree, [](int r, int g, int b) {
    return r > 140 && g < 80 && b < 100 && r - g > 80;  // rviz's error red, (178, 23, 46).
  });
  const int warnings = countPixels(screen, tree, [](int r, int g, int b) {
    return r > 160 && g > 100 && g < 160 && b < 60;  // rviz's warning orange, (192, 128, 0).
  });
  const int loop_green = countPixels(screen, view, [](int r, int g, int b) {
    return g > 180 && r < 140 && b < 140 && g - r > 60;
  });
  const int band_green = countPixels(screen, match_panel, [](int r, int g, int b) {
    return std::abs(r - 40) < 20 && std::abs(g - 150) < 25 && std::abs(b - 40) < 20;
  });
  std::printf(
      "screenshot %s: error pixels %d, warning pixels %d, green loop pixels %d, match "
      "view verdict band %d\n",
      argv[1], errors, warnings, loop_green, band_green);
  bool pass = errors < 5;
  if (!pass) std::printf("FAIL: a display in rviz reports an error\n");
  if (final_state) {
    if (warnings >= 5) std::printf("FAIL: a display in rviz reports a warning at the end\n");
    if (loop_green < 300) std::printf("FAIL: no green loops in the 3D view\n");
    if (band_green < 500) std::printf("FAIL: the match view does not show an accepted loop\n");
    pass = pass && warnings < 5 && loop_green >= 300 && band_green >= 500;
  }
  return pass ? 0 : 1;
}
