#include "io/png.hpp"

#include "io/atomic_file.hpp"
#include "io/invariant.hpp"

// The stb_image_write implementation comes from Debian's libstb.so (link
// `stb`, pkg-config module "stb"); STB_IMAGE_WRITE_IMPLEMENTATION is
// deliberately not defined here.
#include <stb/stb_image_write.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace vkmech {

namespace {

void append_bytes(void* context, void* data, int size) {
    if (size > 0) static_cast<std::string*>(context)->append(static_cast<const char*>(data), static_cast<size_t>(size));
}

uint8_t to_byte(double v01) { return static_cast<uint8_t>(std::lround(std::clamp(v01, 0.0, 1.0) * 255.0)); }

double srgb_oetf(double v) { return v <= 0.0031308 ? 12.92 * v : 1.055 * std::pow(v, 1.0 / 2.4) - 0.055; }

void put_magenta(uint8_t* p) {
    p[0] = 255;
    p[1] = 0;
    p[2] = 255;
}

}  // namespace

void write_png_rgb8(const std::string& path, int w, int h, const std::vector<uint8_t>& rgb) {
    auto fail = [&](const std::string& why) { throw std::runtime_error("cannot write '" + path + "': " + why); };
    if (w <= 0 || h <= 0) fail("invalid size " + std::to_string(w) + "x" + std::to_string(h));
    if (w > (1 << 24) / 3 || h > (1 << 24)) fail("image too large");
    const size_t expected = 3 * static_cast<size_t>(w) * static_cast<size_t>(h);
    if (rgb.size() != expected)
        fail("pixel buffer has " + std::to_string(rgb.size()) + " bytes, expected " + std::to_string(expected));
    std::string png;
    if (stbi_write_png_to_func(append_bytes, &png, w, h, 3, rgb.data(), 3 * w) == 0 || png.empty())
        fail("PNG encoding failed");
    write_file_atomic(path, png);
}

std::vector<uint8_t> tonemap_srgb(const std::vector<float>& rgb, float exposure) {
    VKM_ASSERT(rgb.size() % 3 == 0, "tonemap_srgb: size is not a multiple of 3");
    std::vector<uint8_t> out(rgb.size());
    for (size_t i = 0; i < rgb.size(); i += 3) {
        if (!std::isfinite(rgb[i]) || !std::isfinite(rgb[i + 1]) || !std::isfinite(rgb[i + 2]) ||
            !std::isfinite(exposure)) {
            put_magenta(&out[i]);
            continue;
        }
        for (size_t c = 0; c < 3; ++c) {
            const double v = std::clamp(static_cast<double>(rgb[i + c]) * exposure, 0.0, 1.0);
            out[i + c] = to_byte(srgb_oetf(v));
        }
    }
    return out;
}

std::vector<uint8_t> grey_to_rgb8(const std::vector<float>& v, float lo, float hi) {
    std::vector<uint8_t> out(3 * v.size());
    const double range = static_cast<double>(hi) - static_cast<double>(lo);
    for (size_t i = 0; i < v.size(); ++i) {
        uint8_t* p = &out[3 * i];
        if (!std::isfinite(v[i])) {
            put_magenta(p);
            continue;
        }
        uint8_t g;
        if (range > 0.0 && std::isfinite(range))
            g = to_byte((static_cast<double>(v[i]) - lo) / range);
        else
            g = v[i] >= hi ? 255 : 0;
        p[0] = p[1] = p[2] = g;
    }
    return out;
}

}  // namespace vkmech
