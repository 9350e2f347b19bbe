// stb_image's implementation comes from Debian's libstb.so (linked by
// vkmech_core); no copy is compiled here.
#include <stb/stb_image.h>

#include "scene/image_texture.hpp"

#include "io/exr.hpp"
#include "scene/file_read.hpp"
#include "scene/text_parse.hpp"

#include <climits>
#include <cmath>
#include <filesystem>
#include <memory>
#include <stdexcept>
#include <vector>

namespace vkmech {

namespace {

// IEC 61966-2-1 sRGB transfer function, inverse.
float srgb_to_linear(float c) { return c <= 0.04045f ? c / 12.92f : std::pow((c + 0.055f) / 1.055f, 2.4f); }

// An image's header may claim any size; stb would try to allocate it.
constexpr int kMaxImageSide = 16384;
constexpr long long kMaxImagePixels = 1ll << 26;  // 8192 x 8192: 768 MiB of float RGB

void check_image_size(const unsigned char* bytes, int len) {
    int w = 0, h = 0, channels = 0;
    if (!stbi_info_from_memory(bytes, len, &w, &h, &channels))
        throw std::runtime_error(stbi_failure_reason() ? stbi_failure_reason() : "cannot decode image");
    if (w > kMaxImageSide || h > kMaxImageSide || static_cast<long long>(w) * h > kMaxImagePixels)
        throw std::runtime_error("the image claims " + std::to_string(w) + " x " + std::to_string(h) +
                                 " pixels, more than the loader accepts (" + std::to_string(kMaxImageSide) +
                                 " per side and " + std::to_string(kMaxImagePixels >> 20) +
                                 " Mpixels); scale the texture down");
}

}  // namespace

Texture decode_image_texture(const unsigned char* bytes, size_t size, bool raw) {
    if (size == 0) throw std::runtime_error("the image is empty");
    if (size > static_cast<size_t>(INT_MAX)) throw std::runtime_error("the image is larger than 2 GiB");
    int len = static_cast<int>(size);
    check_image_size(bytes, len);
    Texture t;
    int w = 0, h = 0, channels = 0;
    if (stbi_is_hdr_from_memory(bytes, len)) {
        std::unique_ptr<float, void (*)(void*)> px(stbi_loadf_from_memory(bytes, len, &w, &h, &channels, 3),
                                                   stbi_image_free);
        if (!px) throw std::runtime_error(stbi_failure_reason() ? stbi_failure_reason() : "cannot decode image");
        t.rgb.assign(px.get(), px.get() + static_cast<size_t>(w) * h * 3);
    } else {
        // 16-bit PNGs keep their precision; 8-bit images go through the same path.
        std::unique_ptr<stbi_us, void (*)(void*)> px(stbi_load_16_from_memory(bytes, len, &w, &h, &channels, 3),
                                                     stbi_image_free);
        if (!px) throw std::runtime_error(stbi_failure_reason() ? stbi_failure_reason() : "cannot decode image");
        size_t n = static_cast<size_t>(w) * h * 3;
        t.rgb.resize(n);
        for (size_t i = 0; i < n; ++i) {
            float c = static_cast<float>(px.get()[i]) / 65535.0f;
            t.rgb[i] = raw ? c : srgb_to_linear(c);
        }
    }
    t.width = w;
    t.height = h;
    return t;
}

Texture load_image_texture(const std::string& path, bool raw) {
    Texture t;
    if (text::lower(std::filesystem::path(path).extension().string()) == ".exr") {
        // OpenEXR holds linear values: R, G, B (or a single Y) as they are.
        require_regular_file(path, "image file");
        ExrImage img = read_exr_channels(path);
        auto pick = [&](const char* a, const char* b) -> const std::vector<float>* {
            if (img.channels.count(a)) return &img.channels.at(a);
            if (img.channels.count(b)) return &img.channels.at(b);
            return nullptr;
        };
        const std::vector<float>* rgb[3] = {pick("R", "Y"), pick("G", "Y"), pick("B", "Y")};
        if (!rgb[0] || !rgb[1] || !rgb[2]) throw std::runtime_error("the EXR file has no R, G, B or Y channels");
        t.width = img.width;
        t.height = img.height;
        size_t n = static_cast<size_t>(img.width) * img.height;
        t.rgb.resize(3 * n);
        for (size_t i = 0; i < n; ++i)
            for (int c = 0; c < 3; ++c) t.rgb[3 * i + c] = (*rgb[c])[i];
        t.path = path;
        return t;
    }
    const std::string bytes = read_regular_file(path, "image file");
    t = decode_image_texture(reinterpret_cast<const unsigned char*>(bytes.data()), bytes.size(), raw);
    t.path = path;
    return t;
}

}  // namespace vkmech
