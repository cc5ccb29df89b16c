#pragma once
// An 8-bit RGB image as read back from a render, and PNG input/output.

#include <cstdint>
#include <filesystem>
#include <vector>

namespace palpa::render {

/// Pixels row by row, top row first, 3 bytes (R, G, B) per pixel.
struct Image {
  int width = 0;
  int height = 0;
  std::vector<std::uint8_t> rgb;

  /// Pixel (x, y) with y counted from the top row.
  const std::uint8_t* at(int x, int y) const { return rgb.data() + 3 * (static_cast<std::size_t>(y) * width + x); }
  std::uint8_t* at(int x, int y) { return rgb.data() + 3 * (static_cast<std::size_t>(y) * width + x); }
  /// Grey level (R + G + B) / 3 of pixel (x, y), 0..255.
  double grey(int x, int y) const {
    const auto* p = at(x, y);
    return (p[0] + p[1] + p[2]) / 3.0;
  }
};

/// Writes an RGB PNG. Writes to a temporary file and renames it, so an
/// existing file is never left half-written. Throws RenderError:
/// "FILE: cannot write PNG (REASON)".
void write_png(const Image& image, const std::filesystem::path& path);

/// Reads a PNG as RGB (grey and RGBA are converted). Throws RenderError:
/// "FILE: cannot read PNG".
Image read_png(const std::filesystem::path& path);

}  // namespace palpa::render
