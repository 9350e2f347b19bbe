// Multi-channel scanline OpenEXR output (docs/descriptor.md §3, issue "outputs").
//
// One file holds every per-pixel output as a separate channel. Channel names
// may contain dots to form layers ("bucket.direct", "frac.delta"), which tev
// and Blender display as groups. ZIP compression, INCREASING_Y line order,
// data window = display window = [0,w-1]x[0,h-1].
//
// OpenEXR always stores channels sorted by name, so the caller's order is kept
// in the string-vector header attribute "vkmech.channelOrder"; read_exr_channels
// returns it in ExrImage::order.
#pragma once

#include <map>
#include <set>
#include <string>
#include <vector>

namespace vkmech {

struct ExrChannel {
    std::string name;
    std::vector<float> data;  // width*height, row-major, top row first
    bool half = false;        // store as 16-bit half instead of 32-bit float
};

// Writes one multi-channel scanline EXR atomically (temp + fsync + rename; see
// io/atomic_file.hpp). Throws std::runtime_error (message names the path and
// the reason) when the dimensions are not positive, a channel's data size is
// not width*height, a name is empty or repeated, or any I/O step fails; no
// temporary file is left behind.
// `attributes` become string-vector header attributes (e.g. "vkmech.estimator"),
// so a viewer's header panel and `exrheader` show how the image was made;
// "capDate" (kCapDateAttribute, one "YYYY:MM:DD HH:MM:SS" in UTC) becomes
// OpenEXR's standard capDate with utcOffset 0.
void write_exr_layers(const std::string& path, int width, int height, const std::vector<ExrChannel>& channels,
                      const std::map<std::string, std::vector<std::string>>& attributes = {});

inline constexpr const char* kCapDateAttribute = "capDate";

struct ExrImage {
    int width = 0, height = 0;
    std::map<std::string, std::vector<float>> channels;          // every channel, converted to float
    std::vector<std::string> order;                              // write order if recorded, else file (sorted) order
    std::set<std::string> half_channels;                         // channels stored as HALF in the file
    std::map<std::string, std::vector<std::string>> attributes;  // string and string-vector header attributes
};

// Reads every channel of a single-part scanline or tiled EXR as float.
// Throws std::runtime_error with the path and the reason on failure.
ExrImage read_exr_channels(const std::string& path);
// The header's string and string-vector attributes only (no pixels).
std::map<std::string, std::vector<std::string>> read_exr_attributes(const std::string& path);

}  // namespace vkmech
