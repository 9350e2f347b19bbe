// Bitmap textures for reflectances (docs/descriptor.md §8: `bitmap` where used for
// reflectance; glTF base-colour textures), decoded with stb_image.
#pragma once

#include "scene/scene.hpp"

#include <cstddef>
#include <string>

namespace vkmech {

// Loads PNG, JPEG, BMP, TGA (8/16 bit; sRGB-decoded to linear unless `raw`,
// Mitsuba's bitmap default) or Radiance HDR (already linear). Alpha is
// dropped; grey images are expanded to RGB. Throws std::runtime_error with
// stb's reason; the caller adds file and line.
Texture load_image_texture(const std::string& path, bool raw);

// The same decoding from an encoded image in memory (glTF data URIs and
// buffer views). Texture::path is left empty for the caller to describe.
Texture decode_image_texture(const unsigned char* bytes, size_t size, bool raw);

}  // namespace vkmech
