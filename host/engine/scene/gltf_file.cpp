// glTF 2.0 files, docs/descriptor.md §8: reading .gltf (external or embedded buffers) and
// .glb through tinygltf, the extensions a file requires, and accessors
// validated against their buffer views and buffers.
#include "scene/gltf_loader.hpp"

#include "scene/file_read.hpp"

#include <algorithm>
#include <cctype>
#include <climits>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <new>
#include <sstream>

namespace fs = std::filesystem;

namespace vkmech {

namespace {

// tinygltf's image callback: keep the encoded bytes (decoded later, with
// vkmech's sRGB handling). Images in buffer views are read later from the
// validated view: the pointer tinygltf passes for them is not range-checked.
bool keep_encoded_image(tinygltf::Image* image, const int, std::string*, std::string*, int, int,
                        const unsigned char* bytes, int size, void*) {
    if (image->bufferView < 0 && bytes && size > 0) image->image.assign(bytes, bytes + size);
    return true;
}

uint32_t read_u32(const std::vector<unsigned char>& b, size_t at) {
    uint32_t v;
    std::memcpy(&v, b.data() + at, 4);  // GLB is little-endian, as is every supported host
    return v;
}

// glTF's sizes are 32-bit: no file of it can be larger.
constexpr uint64_t kMaxGltfFileBytes = UINT_MAX;

// tinygltf's reader of external buffers and images, through the loader's
// (regular files only: a buffer URI naming a FIFO must not block).
bool read_referenced_file(std::vector<unsigned char>* out, std::string* err, const std::string& path, void*) {
    try {
        const std::string bytes = read_regular_file(path, "file", kMaxGltfFileBytes);
        out->assign(bytes.begin(), bytes.end());
        return true;
    } catch (const SceneError& e) {
        if (err) *err += e.what();
        return false;
    }
}

// tinygltf's JSON parser recurses once per nesting level: 200,000 '['
// overflow the stack. glTF itself nests a few levels (extras some more).
constexpr int kMaxJsonNesting = 256;

void check_json_nesting(const unsigned char* json, size_t size, const std::string& path) {
    int depth = 0;
    bool in_string = false;
    for (size_t i = 0; i < size; ++i) {
        const unsigned char c = json[i];
        if (in_string) {
            if (c == '\\')
                ++i;
            else if (c == '"')
                in_string = false;
        } else if (c == '"') {
            in_string = true;
        } else if (c == '[' || c == '{') {
            if (++depth > kMaxJsonNesting)
                throw SceneError(path, 1 + static_cast<int>(std::count(json, json + i, '\n')),
                                 "JSON nested deeper than " + std::to_string(kMaxJsonNesting) +
                                     " levels (a corrupt or generated file?)");
        } else if (c == ']' || c == '}') {
            --depth;
        }
    }
}

// The GLB container (glTF 2.0 §4.4), checked before tinygltf sees it: the
// header's length against the file, and every chunk inside that length.
// Returns the length to parse.
size_t check_glb(const std::vector<unsigned char>& b, const std::string& path) {
    auto fail = [&](const std::string& what) { throw SceneError(path, 0, what); };
    if (b.size() < 20) fail("truncated .glb: " + std::to_string(b.size()) + " bytes, less than a header and a chunk");
    uint32_t version = read_u32(b, 4), length = read_u32(b, 8);
    if (version != 2) fail("unsupported .glb container version " + std::to_string(version) + " (expected 2)");
    if (length > b.size())
        fail("truncated .glb: the header says " + std::to_string(length) + " bytes, the file has " +
             std::to_string(b.size()));
    // The JSON chunk is required: the chunk loop below must see it (its
    // length is then known to lie inside the file).
    if (length < 20) fail("malformed .glb: the header's length " + std::to_string(length) + " leaves no JSON chunk");
    size_t at = 12;
    for (int chunk = 0; at < length; ++chunk) {
        if (length - at < 8) fail("truncated .glb: chunk " + std::to_string(chunk) + " has no complete header");
        uint32_t clen = read_u32(b, at), ctype = read_u32(b, at + 4);
        if (clen > length - at - 8)
            fail("truncated .glb: chunk " + std::to_string(chunk) + " (" + std::to_string(clen) + " bytes at offset " +
                 std::to_string(at) + ") runs past the end of the file");
        if (chunk == 0 && ctype != 0x4E4F534Au) fail("malformed .glb: the first chunk is not JSON");
        at += 8 + static_cast<size_t>(clen);
    }
    return length;
}

int component_size(int type) {
    switch (type) {
        case TINYGLTF_COMPONENT_TYPE_BYTE:
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE:
            return 1;
        case TINYGLTF_COMPONENT_TYPE_SHORT:
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT:
            return 2;
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT:
        case TINYGLTF_COMPONENT_TYPE_FLOAT:
            return 4;
        default:
            return 0;  // INT and DOUBLE are not glTF 2.0 accessor types
    }
}

const char* type_name(int type) {
    switch (type) {
        case TINYGLTF_TYPE_SCALAR:
            return "SCALAR";
        case TINYGLTF_TYPE_VEC2:
            return "VEC2";
        case TINYGLTF_TYPE_VEC3:
            return "VEC3";
        case TINYGLTF_TYPE_VEC4:
            return "VEC4";
        case TINYGLTF_TYPE_MAT2:
            return "MAT2";
        case TINYGLTF_TYPE_MAT3:
            return "MAT3";
        case TINYGLTF_TYPE_MAT4:
            return "MAT4";
        default:
            return "unknown";
    }
}

// One component as a float; normalized integers as glTF 2.0 §3.11 maps them.
float component(const unsigned char* p, int type, bool normalized) {
    switch (type) {
        case TINYGLTF_COMPONENT_TYPE_BYTE: {
            int8_t v;
            std::memcpy(&v, p, 1);
            return normalized ? std::max(v / 127.0f, -1.0f) : v;
        }
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE:
            return normalized ? p[0] / 255.0f : p[0];
        case TINYGLTF_COMPONENT_TYPE_SHORT: {
            int16_t v;
            std::memcpy(&v, p, 2);
            return normalized ? std::max(v / 32767.0f, -1.0f) : v;
        }
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
            uint16_t v;
            std::memcpy(&v, p, 2);
            return normalized ? v / 65535.0f : v;
        }
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: {
            uint32_t v;
            std::memcpy(&v, p, 4);
            return static_cast<float>(v);
        }
        default: {
            float v;
            std::memcpy(&v, p, 4);
            return v;
        }
    }
}

// An accessor without a buffer view is all zeros; its size is bounded so a
// hostile count cannot allocate without limit.
constexpr size_t kMaxZeroAccessor = size_t(1) << 24;

}  // namespace

// ---- the file ----

void GltfLoader::parse() {
    std::vector<unsigned char> bytes;
    {
        const std::string text = read_regular_file(path_, "scene file", kMaxGltfFileBytes);
        bytes.assign(text.begin(), text.end());
    }

    tinygltf::TinyGLTF gltf;
    gltf.SetImageLoader(&keep_encoded_image, nullptr);
    gltf.SetFsCallbacks(
        {&tinygltf::FileExists, &tinygltf::ExpandFilePath, &read_referenced_file, &tinygltf::WriteWholeFile, nullptr});
    std::string err, warn_text;
    std::string base_dir = fs::path(path_).parent_path().string();
    bool binary = bytes.size() >= 4 && std::memcmp(bytes.data(), "glTF", 4) == 0;
    std::string ext = fs::path(path_).extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
    if (ext == ".glb" && !binary) fail("not a binary glTF: a .glb file starts with the magic 'glTF'");
    bool ok = false;
    try {
        if (binary) {
            size_t length = check_glb(bytes, path_);
            check_json_nesting(bytes.data() + 20, read_u32(bytes, 12), path_);
            ok = gltf.LoadBinaryFromMemory(&model_, &err, &warn_text, bytes.data(), static_cast<unsigned>(length),
                                           base_dir);
        } else {
            check_json_nesting(bytes.data(), bytes.size(), path_);
            ok = gltf.LoadASCIIFromString(&model_, &err, &warn_text, reinterpret_cast<const char*>(bytes.data()),
                                          static_cast<unsigned>(bytes.size()), base_dir);
        }
    } catch (const SceneError&) {
        throw;
    } catch (const std::bad_alloc&) {
        // Seen with a malformed image URI ("%!QAAAQAAA5"): tinygltf's decoder
        // asks for an absurd allocation.
        fail(
            "cannot load the glTF file: tinygltf ran out of memory decoding it, which means a malformed URI or "
            "buffer (check the file with the Khronos glTF validator)");
    } catch (const std::exception& e) {
        // tinygltf throws on some malformed input (e.g. an empty data URI).
        fail(std::string("cannot load the glTF file: ") + e.what());
    }
    auto lines = [](const std::string& s) {
        std::vector<std::string> out;
        std::istringstream is(s);
        for (std::string l; std::getline(is, l);)
            if (!l.empty()) out.push_back(l);
        return out;
    };
    if (!ok) {
        std::string why;
        for (const auto& l : lines(err)) why += (why.empty() ? "" : "; ") + l;
        fail("cannot load the glTF file: " + (why.empty() ? std::string("tinygltf gave no reason") : why));
    }
    for (const auto& l : lines(warn_text)) warn("tinygltf: " + l);
}

// docs/descriptor.md §8: extensions vkmech reads (KHR_lights_punctual only to refuse or
// substitute it; KHR_mesh_quantization's integer attributes are read like
// any other accessor).
void GltfLoader::check_extensions() {
    static const std::set<std::string> handled = {"KHR_materials_transmission", "KHR_materials_ior",
                                                  "KHR_materials_clearcoat",    "KHR_materials_emissive_strength",
                                                  "KHR_lights_punctual",        "KHR_mesh_quantization"};
    std::string missing;
    for (const auto& e : model_.extensionsRequired)
        if (!handled.count(e)) missing += (missing.empty() ? "" : ", ") + e;
    if (!missing.empty())
        fail("the file requires the extension(s) " + missing +
             ", which vkmech does not support (docs/descriptor.md §8: KHR_materials_transmission, _ior, _clearcoat, "
             "_emissive_strength, KHR_lights_punctual, KHR_mesh_quantization)");
    for (const auto& e : model_.extensionsUsed) {
        // Material and texture extensions are reported where a material uses them.
        if (handled.count(e) || e.rfind("KHR_materials_", 0) == 0 || e == "KHR_texture_transform") continue;
        warn("extension " + e + " is not supported and is ignored");
    }
    if (!model_.animations.empty())
        warn(std::to_string(model_.animations.size()) +
             " animation(s) ignored: the scene is loaded in its static pose");
}

// ---- accessors ----

std::pair<const unsigned char*, size_t> GltfLoader::view_bytes(int view, const std::string& what) const {
    if (view < 0 || static_cast<size_t>(view) >= model_.bufferViews.size())
        fail(what + " refers to bufferView " + std::to_string(view) + ", which does not exist (the file has " +
             std::to_string(model_.bufferViews.size()) + ")");
    const auto& v = model_.bufferViews[view];
    if (v.buffer < 0 || static_cast<size_t>(v.buffer) >= model_.buffers.size())
        fail(labelled("bufferView", view, v.name) + " refers to buffer " + std::to_string(v.buffer) +
             ", which does not exist");
    const auto& data = model_.buffers[v.buffer].data;
    if (v.byteOffset > data.size() || v.byteLength > data.size() - v.byteOffset)
        fail(labelled("bufferView", view, v.name) + " (bytes " + std::to_string(v.byteOffset) + " to " +
             std::to_string(v.byteOffset + v.byteLength) + ") runs past the end of buffer " + std::to_string(v.buffer) +
             " (" + std::to_string(data.size()) + " bytes)");
    return {data.data() + v.byteOffset, v.byteLength};
}

GltfLoader::AccessorData GltfLoader::accessor(int index, int type, const std::string& what) const {
    if (index < 0 || static_cast<size_t>(index) >= model_.accessors.size())
        fail(what + " refers to accessor " + std::to_string(index) + ", which does not exist (the file has " +
             std::to_string(model_.accessors.size()) + ")");
    const auto& a = model_.accessors[index];
    std::string name = what + " (" + labelled("accessor", index, a.name) + ")";
    if (a.sparse.isSparse)
        fail(name + " is sparse; sparse accessors are not supported (re-export the file without them)");
    if (a.type != type) fail(name + " has type " + type_name(a.type) + ", expected " + type_name(type));
    int csize = component_size(a.componentType);
    if (csize == 0)
        fail(name + " has component type " + std::to_string(a.componentType) + ", which glTF 2.0 does not allow");
    AccessorData d;
    d.component_type = a.componentType;
    d.components = tinygltf::GetNumComponentsInType(static_cast<uint32_t>(type));
    d.normalized = a.normalized;
    d.count = a.count;
    size_t elem = static_cast<size_t>(csize) * d.components;
    if (a.bufferView < 0) {
        if (a.count > kMaxZeroAccessor) fail(name + " has no bufferView and an implausible count");
        d.stride = elem;
        return d;
    }
    auto [bytes, size] = view_bytes(a.bufferView, name);
    const auto& view = model_.bufferViews[a.bufferView];
    d.stride = view.byteStride ? view.byteStride : elem;
    if (d.stride < elem)
        fail(name + ": the byteStride " + std::to_string(view.byteStride) +
             " of its bufferView is shorter than an element (" + std::to_string(elem) + " bytes)");
    if (a.count == 0) return d;
    // The last element must end inside the view: offset + stride (count - 1)
    // + elem <= size, written so that nothing overflows.
    if (a.byteOffset > size || elem > size - a.byteOffset || (a.count - 1) > (size - a.byteOffset - elem) / d.stride)
        fail(name + " (" + std::to_string(a.count) + " elements from byte " + std::to_string(a.byteOffset) +
             ") runs past the end of its bufferView (" + std::to_string(size) + " bytes)");
    d.base = bytes + a.byteOffset;
    return d;
}

template <int N>
std::vector<glm::vec<N, float>> GltfLoader::read_vec(int index, const std::string& what) const {
    AccessorData d = accessor(index,
                              N == 4   ? TINYGLTF_TYPE_VEC4
                              : N == 3 ? TINYGLTF_TYPE_VEC3
                                       : TINYGLTF_TYPE_VEC2,
                              what);
    std::vector<glm::vec<N, float>> out(d.count, glm::vec<N, float>(0.0f));
    int cs = component_size(d.component_type);
    if (d.base)
        for (size_t i = 0; i < d.count; ++i)
            for (int c = 0; c < N; ++c)
                out[i][c] = component(d.base + i * d.stride + c * cs, d.component_type, d.normalized);
    return out;
}

std::vector<glm::vec3> GltfLoader::read_vec3(int index, const std::string& what) const {
    return read_vec<3>(index, what);
}
std::vector<glm::vec2> GltfLoader::read_vec2(int index, const std::string& what) const {
    return read_vec<2>(index, what);
}
std::vector<glm::vec4> GltfLoader::read_vec4(int index, const std::string& what) const {
    return read_vec<4>(index, what);
}

std::vector<uint32_t> GltfLoader::read_indices(int index, const std::string& what) const {
    AccessorData d = accessor(index, TINYGLTF_TYPE_SCALAR, what);
    if (d.component_type != TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE &&
        d.component_type != TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT &&
        d.component_type != TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT)
        fail(what + ": indices must be unsigned integers (glTF 2.0 §3.7.2.1)");
    std::vector<uint32_t> out(d.count, 0u);
    if (!d.base) return out;
    // As integers: a float holds them exactly only up to 2^24.
    for (size_t i = 0; i < d.count; ++i) {
        const unsigned char* p = d.base + i * d.stride;
        if (d.component_type == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE) {
            out[i] = p[0];
        } else if (d.component_type == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT) {
            uint16_t v;
            std::memcpy(&v, p, 2);
            out[i] = v;
        } else {
            std::memcpy(&out[i], p, 4);
        }
    }
    return out;
}

}  // namespace vkmech
