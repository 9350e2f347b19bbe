// 8-bit PNG previews (issue "outputs"): the tone-mapped image, the
// dominant-class map and the purity map. Written atomically (io/atomic_file.hpp).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace vkmech {

// Writes a w x h RGB8 PNG (rgb: 3*w*h bytes, row-major, top row first).
// Throws std::runtime_error naming the path and the reason on bad arguments,
// encoding or I/O failure; no temporary file is left behind.
void write_png_rgb8(const std::string& path, int w, int h, const std::vector<uint8_t>& rgb);

// Linear RGB (3 floats per pixel) -> sRGB8: each channel is multiplied by
// `exposure`, clamped to [0,1], passed through the sRGB OETF and rounded.
// A pixel with any non-finite component becomes the marker 255,0,255 (magenta).
// rgb.size() is a multiple of 3 (every caller passes RGB; else InternalError).
std::vector<uint8_t> tonemap_srgb(const std::vector<float>& rgb, float exposure = 1.0f);

// Scalar -> grey RGB8, linear in v: lo -> 0, hi -> 255, clamped outside.
// Non-finite values become magenta (255,0,255). If hi <= lo, values >= hi are
// 255 and the rest 0.
std::vector<uint8_t> grey_to_rgb8(const std::vector<float>& v, float lo, float hi);

}  // namespace vkmech
