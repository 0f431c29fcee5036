// RGBA8 images and PNG files (written with zlib; no other image library). The renderer's frames,
// screenshots and the golden images of the render tests.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "shatter/core/error.h"

namespace shatter::render {

/// 8-bit RGBA pixels, row 0 at the top.
struct Image {
  int width = 0;
  int height = 0;
  std::vector<std::uint8_t> rgba;  ///< width x height x 4

  Image() = default;
  Image(int w, int h) : width(w), height(h), rgba(static_cast<std::size_t>(w) * static_cast<std::size_t>(h) * 4, 0) {}
  [[nodiscard]] std::uint8_t* pixel(int x, int y) {
    return rgba.data() +
           (static_cast<std::size_t>(y) * static_cast<std::size_t>(width) + static_cast<std::size_t>(x)) * 4;
  }
  [[nodiscard]] const std::uint8_t* pixel(int x, int y) const {
    return rgba.data() +
           (static_cast<std::size_t>(y) * static_cast<std::size_t>(width) + static_cast<std::size_t>(x)) * 4;
  }
};

/// The PNG file of an image (8-bit RGB, or RGBA when `alpha`).
std::string encode_png(const Image& image, bool alpha = false);
/// Write a PNG atomically (a failed write leaves any earlier file as it was).
Result<void> write_png(const std::string& path, const Image& image, bool alpha = false);
/// Decode a PNG of 8-bit grey, grey+alpha, RGB or RGBA, not interlaced (what this project and
/// common tools write). Errors name the file and what is not supported.
Result<Image> decode_png(const std::string& bytes, const std::string& name = "png");
/// Read a PNG file (as decode_png).
Result<Image> read_png(const std::string& path);

/// Mean absolute difference of the RGB channels of two images of one size, 0..255 (infinity when
/// the sizes differ), and the fraction of pixels whose largest channel difference exceeds `tol`.
struct ImageDifference {
  double mean_abs = 0;
  double fraction_over = 0;
};
ImageDifference compare_images(const Image& a, const Image& b, int tol = 32);

}  // namespace shatter::render
