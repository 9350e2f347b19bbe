// Everything a render writes (docs/descriptor.md §3, issue "outputs"): one multi-layer EXR,
// PNG previews (image, dominant-class map with legend, purity) and a JSON
// summary, staged in an OutputSet that the caller commits (io/output_set.hpp:
// the files appear as a set, with a manifest written last).
#pragma once

#include "io/exr.hpp"
#include "io/output_set.hpp"
#include "render/descriptor.hpp"
#include "render/frame.hpp"

#include <map>
#include <string>
#include <utility>
#include <vector>

namespace vkmech {

// Where an output came from: in the EXR header (vkmech.* attributes and
// OpenEXR's capDate/utcOffset) and the JSON's "provenance"; `vkmech verify
// outputs` checks that the two agree.
struct Provenance {
    std::string version;                   // vkmech's version and `git describe` when it was built
    std::string code_digest;               // the path tracer's code digest (the studies' render cache key)
    std::string scene_sha256;              // the scene file's SHA-256
    std::vector<std::string> scene_files;  // "<sha256> <path>" of every other file the scene read
    std::vector<std::string> defines;      // every -D name=value
    std::string sample_range;              // "A:B": samples [A, B) of the seed's stream (per pixel)
    // render --pixel-bounds: "x0,x1,y0,y1", the window [x0, x1) x [y0, y1) of a film of film_size
    // ("WxH") that the image is; both empty for the whole film.
    std::string pixel_bounds, film_size;
    std::string driver;    // the Vulkan driver's name and version
    std::string date_utc;  // "YYYY:MM:DD HH:MM:SS" (EXR capDate), UTC
};

// Samples [begin, end) of a seed's stream (Provenance::sample_range "A:B").
struct SampleRange {
    uint32_t begin = 0, end = 0;
};
// "A:B" with A < B and B - A at most 2^20 samples; throws std::invalid_argument saying what is wrong.
SampleRange parse_sample_range(const std::string& text);

// PixelBounds (render/frame.hpp) from "x0,x1,y0,y1" with x0 < x1 <= width and y0 < y1 <= height; throws
// std::invalid_argument saying what is wrong.
PixelBounds parse_pixel_bounds(const std::string& text, uint32_t width, uint32_t height);

struct RenderInfo {
    std::string scene_name;
    std::string scene_path;
    std::string device;
    std::string traversal;
    std::string estimator;
    std::string features;
    uint32_t spp = 0;
    uint32_t seed = 0;
    bool capture = true;
    std::string light_selection = "uniform";   // docs/descriptor.md §1
    std::string end_vertex = "last-nondelta";  // docs/descriptor.md §2 reading
    float exposure_ev = 0.0f;                  // PNG preview exposure (the EXR is never scaled)
    std::vector<std::string> warnings;         // the loader's (Scene::warnings)
    std::vector<std::string> substitutions;    // user-requested substitutions (Scene::substitutions)
    std::string lights_at_infinity;            // describe_lights_at_infinity(scene); "" for none
    // Creating (and compiling) the pipeline, outside the render time; < 0: not measured.
    double pipeline_seconds = -1.0;
    std::string pipeline_cache;  // vk::pipeline_cache_outcome
    // Further top-level members of the JSON summary, each a key and its value
    // as JSON text, written after "substitutions" (render --adaptive: "adaptive").
    std::vector<std::pair<std::string, std::string>> extra_json;
    // Further EXR channels, written after the moments (render --noise-threshold: err).
    std::vector<ExrChannel> extra_channels;
    std::string kernel;  // the device-class kernel (vk::KernelClass): cpu or gpu; empty: not recorded
    // render --taxonomy: the taxonomy's record (taxonomy_json: file, lines, classes, states), in the JSON
    // ("taxonomy") and the EXR header (vkmech.taxonomy), so that `vkmech merge` knows the classes.
    std::string taxonomy;
    // render --lpe: the queries' record (queries_json without the pass's seconds) for the EXR header
    // (vkmech.lpe), so that `vkmech merge` knows the query channels and refuses parts of other queries.
    std::string queries;
    Provenance provenance;  // empty version: not recorded
};

struct WrittenFiles {
    std::string exr, png, dominant_png, purity_png, json;
    // What the render itself warns of (render_warnings, and EXR values that
    // are not finite); recorded with the loader's in the JSON and the EXR
    // header. The CLI prints them on stderr.
    std::vector<std::string> warnings;
};

// The EXR channel names, in file order (documented in README.md); `direct_glossy`: with
// `render --extra-output direct_glossy` (lum.direct_glossy after the seven lum.* channels).
std::vector<std::string> exr_channel_names(bool capture, bool direct_glossy = false);

// The EXR's channels, in the file's order (R G B, the descriptor's when `d`, the moments).
std::vector<ExrChannel> render_channels(const Frame& frame, const Descriptor* d);
// The EXR's header attributes (io/exr.hpp): how the image was made, its
// warnings, provenance, run id (when not empty), the dominant legend (with the descriptor `d`).
std::map<std::string, std::vector<std::string>> render_attributes(const RenderInfo& info,
                                                                  const std::vector<std::string>& warnings,
                                                                  const std::string& run_id, const Descriptor* d);

// The `dominant` channel's legend as JSON, {"0": "emitter_direct", ..., "255": "unlabelled"}:
// in the EXR header (vkmech.dominantLegend) and the JSON (dominant_legend). `class_names`: a
// descriptor's (a user taxonomy's classes); empty: the seven buckets.
std::string dominant_legend_json(const std::vector<std::string>& class_names = {});

// Stages the files in `set` (their final paths are returned); checks for
// SIGINT/SIGTERM between files (throws Interrupted). The caller adds any
// files of its own and commits.
WrittenFiles write_render_outputs(OutputSet& set, const RenderInfo& info, const Frame& frame,
                                  const Descriptor* descriptor, const DescriptorSummary* summary);

// The dominant-class map with a legend panel to its right, as 8-bit RGB.
// A class map (values >= colors.size() drawn black, named `none_name`) with a
// legend panel on the right.
std::vector<uint8_t> categorical_map_with_legend(int width, int height, const std::vector<uint8_t>& cls,
                                                 const std::vector<std::array<uint8_t, 3>>& colors,
                                                 const std::vector<std::string>& names, const std::string& none_name,
                                                 int* out_w, int* out_h);
std::vector<uint8_t> dominant_map_with_legend(const Descriptor& d, int* out_width, int* out_height);

// Never silent garbage (docs/reliability.md): a black image, a label map without a
// single label, and excluded non-finite samples, each with its likely causes.
std::vector<std::string> render_warnings(const Frame& frame, const DescriptorSummary* summary);

// nonfinite_outputs: values written to the EXR as inf or NaN (a lum_var
// beyond float's range), reported beside the non-finite samples.
std::string summary_json(const RenderInfo& info, const Frame& frame, const DescriptorSummary* summary,
                         uint64_t nonfinite_outputs = 0);

// Share of pixels whose preview at `exposure_ev` clips (a channel above 1 or
// non-finite).
double clipped_share(const std::vector<float>& rgb, float exposure_ev);

}  // namespace vkmech
