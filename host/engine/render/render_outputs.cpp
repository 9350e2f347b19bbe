#include "render/render_outputs.hpp"
#include "io/invariant.hpp"

#include "io/atomic_file.hpp"
#include "io/exr.hpp"
#include "io/interrupt.hpp"
#include "io/json.hpp"
#include "io/png.hpp"

#include <stb/stb_easy_font.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <sstream>

namespace fs = std::filesystem;

namespace vkmech {

std::vector<std::string> exr_channel_names(bool capture, bool direct_glossy) {
    std::vector<std::string> names = {"R", "G", "B"};
    if (capture) {
        for (const char* b : kBucketNames)
            for (const char* c : {".R", ".G", ".B"}) names.push_back(std::string("bucket.") + b + c);
        for (const char* b : kBucketNames) names.push_back(std::string("lum.") + b);
        if (direct_glossy) names.push_back("lum.direct_glossy");
        for (const char* c : {"dominant", "purity", "glossy_frac", "caustic_frac", "depth"}) names.push_back(c);
        for (const char* b : kBucketNames) names.push_back(std::string("frac.") + b);
    }
    for (const char* c : {"lum_mean", "lum_var", "spp", "nonfinite"}) names.push_back(c);
    return names;
}

namespace {

void fill_rect(std::vector<uint8_t>& img, int w, int h, int x0, int y0, int x1, int y1,
               const std::array<uint8_t, 3>& c) {
    for (int y = std::max(0, y0); y < std::min(h, y1); ++y)
        for (int x = std::max(0, x0); x < std::min(w, x1); ++x)
            for (int k = 0; k < 3; ++k) img[3 * (static_cast<size_t>(y) * w + x) + k] = c[k];
}

// Rasterizes stb_easy_font's axis-aligned quads.
void draw_text(std::vector<uint8_t>& img, int w, int h, int x, int y, const char* text) {
    static char buffer[60000];
    int quads = stb_easy_font_print(static_cast<float>(x), static_cast<float>(y), const_cast<char*>(text), nullptr,
                                    buffer, sizeof(buffer));
    const float* v = reinterpret_cast<const float*>(buffer);
    for (int q = 0; q < quads; ++q) {
        const float* p = v + q * 16;  // 4 vertices of (x, y, z, color)
        int qx0 = static_cast<int>(p[0]), qy0 = static_cast<int>(p[1]);
        int qx1 = static_cast<int>(p[8]), qy1 = static_cast<int>(p[9]);
        fill_rect(img, w, h, std::min(qx0, qx1), std::min(qy0, qy1), std::max(qx0, qx1), std::max(qy0, qy1),
                  {255, 255, 255});
    }
}

}  // namespace

std::vector<uint8_t> categorical_map_with_legend(int width, int height, const std::vector<uint8_t>& cls,
                                                 const std::vector<std::array<uint8_t, 3>>& colors,
                                                 const std::vector<std::string>& names, const std::string& none_name,
                                                 int* out_w, int* out_h) {
    const int row = 14, panel = 130;
    int n = static_cast<int>(names.size());
    int w = width + panel;
    int h = std::max(height, (n + 1) * row + 6);
    std::vector<uint8_t> img(static_cast<size_t>(w) * h * 3, 0);
    for (int y = 0; y < height; ++y)
        for (int x = 0; x < width; ++x) {
            uint8_t b = cls[static_cast<size_t>(y) * width + x];
            if (b >= colors.size()) continue;  // black: none
            fill_rect(img, w, h, x, y, x + 1, y + 1, colors[b]);
        }
    int x0 = width + 6;
    for (int b = 0; b < n; ++b) {
        int y0 = 4 + b * row;
        fill_rect(img, w, h, x0, y0, x0 + 10, y0 + 10, colors[b]);
        draw_text(img, w, h, x0 + 14, y0 + 1, names[b].c_str());
    }
    int y0 = 4 + n * row;
    fill_rect(img, w, h, x0, y0, x0 + 10, y0 + 10, {0, 0, 0});
    fill_rect(img, w, h, x0, y0, x0 + 10, y0 + 1, {90, 90, 90});
    draw_text(img, w, h, x0 + 14, y0 + 1, none_name.c_str());
    *out_w = w;
    *out_h = h;
    return img;
}

std::vector<uint8_t> dominant_map_with_legend(const Descriptor& d, int* out_w, int* out_h) {
    std::vector<std::array<uint8_t, 3>> colors(kBucketColors.begin(), kBucketColors.end());
    const std::vector<std::string>& names = d.class_names;
    colors.resize(names.size());
    return categorical_map_with_legend(d.width, d.height, d.dominant, colors, names, "none (no energy)", out_w, out_h);
}

double clipped_share(const std::vector<float>& rgb, float exposure_ev) {
    if (rgb.empty()) return 0.0;
    const double scale = std::exp2(static_cast<double>(exposure_ev));
    size_t clipped = 0;
    for (size_t i = 0; i + 2 < rgb.size(); i += 3) {
        bool c = false;
        for (int k = 0; k < 3; ++k) c = c || !(static_cast<double>(rgb[i + k]) * scale <= 1.0);
        clipped += c;
    }
    return static_cast<double>(clipped) / static_cast<double>(rgb.size() / 3);
}

std::vector<std::string> render_warnings(const Frame& frame, const DescriptorSummary* s) {
    std::vector<std::string> out;
    uint64_t nonfinite = 0;
    bool black = true;
    for (const auto& p : frame.pixels) {
        nonfinite += static_cast<uint64_t>(p.nonfinite);
        for (double c : p.rgb_sum) black = black && c == 0.0;
    }
    const std::string causes =
        "likely causes: no emitter visible or reachable from the camera (emitters facing away, zero radiance or zero "
        "area, all occluded), the camera inside geometry or not framing it (its transform or fov), or a scene scale "
        "that puts the geometry out of view";
    if (black && !frame.pixels.empty())
        out.push_back("the image is black: every pixel's radiance is 0 (" + std::to_string(frame.pixels.size()) +
                      " pixels); " + causes);
    if (s && s->labelled_pixels == 0 && !frame.pixels.empty())
        out.push_back("no pixel has a label (zero bucket energy everywhere: the dominant map is empty); " + causes);
    if (nonfinite > 0)
        out.push_back(std::to_string(nonfinite) +
                      " non-finite samples (NaN or inf radiance, or a sample that would overflow float sums) were "
                      "excluded from the estimates; the EXR's nonfinite channel has them per pixel");
    return out;
}

std::string summary_json(const RenderInfo& info, const Frame& frame, const DescriptorSummary* s,
                         uint64_t nonfinite_outputs) {
    std::ostringstream o;
    o.precision(9);
    double paths_per_s = frame.seconds > 0 ? static_cast<double>(frame.samples) / frame.seconds : 0.0;
    uint64_t nonfinite = 0;
    for (const auto& p : frame.pixels) nonfinite += static_cast<uint64_t>(p.nonfinite);
    o << "{\n";
    o << "  \"scene\": \"" << json_escape(info.scene_name) << "\",\n";
    o << "  \"scene_path\": \"" << json_escape(info.scene_path) << "\",\n";
    o << "  \"width\": " << frame.width << ",\n  \"height\": " << frame.height << ",\n";
    o << "  \"spp\": " << info.spp << ",\n  \"seed\": " << info.seed << ",\n";
    o << "  \"estimator\": \"" << info.estimator << "\",\n";
    o << "  \"light_selection\": \"" << info.light_selection << "\",\n";
    o << "  \"end_vertex\": \"" << info.end_vertex << "\",\n";
    o << "  \"traversal\": \"" << info.traversal << "\",\n";
    if (!info.kernel.empty()) o << "  \"kernel\": \"" << info.kernel << "\",\n";
    o << "  \"features\": \"" << json_escape(info.features) << "\",\n";
    o << "  \"device\": \"" << json_escape(info.device) << "\",\n";
    o << "  \"wall_seconds\": " << frame.seconds << ",\n";
    if (info.pipeline_seconds >= 0) {
        // Not part of wall_seconds nor of paths_per_second.
        o << "  \"pipeline_creation_seconds\": " << info.pipeline_seconds << ",\n";
        o << "  \"pipeline_cache\": \"" << json_escape(info.pipeline_cache) << "\",\n";
    }
    o << "  \"paths_per_second\": " << paths_per_s << ",\n";
    o << "  \"nonfinite_samples\": " << nonfinite << ",\n";
    o << "  \"nonfinite_output_values\": " << nonfinite_outputs << ",\n";
    o << "  \"preview_exposure_ev\": " << info.exposure_ev << ",\n";
    o << "  \"preview_clipped_pixel_share\": " << clipped_share(frame.rgb_mean(), info.exposure_ev) << ",\n";
    auto list = [&](const char* key, const std::vector<std::string>& v) {
        o << "  \"" << key << "\": [";
        for (size_t i = 0; i < v.size(); ++i) o << (i ? ", " : "") << "\"" << json_escape(v[i]) << "\"";
        o << "]";
    };
    list("warnings", info.warnings);
    o << ",\n";
    list("substitutions", info.substitutions);
    if (!info.lights_at_infinity.empty())
        o << ",\n  \"lights_at_infinity\": \"" << json_escape(info.lights_at_infinity) << "\"";
    if (const Provenance& p = info.provenance; !p.version.empty()) {
        auto strings = [&](const std::vector<std::string>& v) {
            std::string out = "[";
            for (size_t i = 0; i < v.size(); ++i) out += (i ? ", \"" : "\"") + json_escape(v[i]) + "\"";
            return out + "]";
        };
        o << ",\n  \"provenance\": {\"version\": \"" << json_escape(p.version) << "\", \"code_digest\": \""
          << p.code_digest << "\", \"scene_sha256\": \"" << p.scene_sha256
          << "\", \"scene_files\": " << strings(p.scene_files) << ", \"defines\": " << strings(p.defines)
          << ", \"sample_range\": \"" << p.sample_range << "\", \"driver\": \"" << json_escape(p.driver)
          << "\", \"date_utc\": \"" << p.date_utc << "\"}";
    }
    if (!info.taxonomy.empty()) o << ",\n  \"taxonomy\": " << info.taxonomy;
    for (const auto& [key, value] : info.extra_json) o << ",\n  \"" << json_escape(key) << "\": " << value;
    if (s) {
        o << ",\n  \"labelled_pixels\": " << s->labelled_pixels << ",\n";
        o << "  \"other_energy\": " << s->other_energy << ",\n";
        o << "  \"max_bucket_sum_relative_error\": " << s->max_bucket_sum_error << ",\n";
        o << "  \"buckets\": {\n";
        const size_t classes = s->class_names.size();
        for (size_t b = 0; b < classes; ++b) {
            o << "    \"" << json_escape(s->class_names[b]) << "\": {\"pixel_share\": " << s->pixel_share[b]
              << ", \"energy_share\": " << s->energy_share[b] << "}" << (b + 1 < classes ? "," : "") << "\n";
        }
        o << "  },\n  \"dominant_legend\": " << dominant_legend_json(s->class_names);
        if (s->has_direct_glossy)
            o << ",\n  \"direct_glossy\": {\"energy_share\": " << s->direct_glossy_energy_share
              << ", \"share_of_direct\": " << s->direct_glossy_share_of_direct << "}";
    }
    o << "\n}\n";
    return o.str();
}

std::string dominant_legend_json(const std::vector<std::string>& class_names) {
    const std::vector<std::string> buckets(kBucketNames.begin(), kBucketNames.end());
    const std::vector<std::string>& names = class_names.empty() ? buckets : class_names;
    std::string s = "{";
    for (size_t b = 0; b < names.size(); ++b)
        s += (b ? ", \"" : "\"") + std::to_string(b) + "\": \"" + json_escape(names[b]) + "\"";
    return s + ", \"" + std::to_string(kNoLabel) + "\": \"unlabelled\"}";
}

SampleRange parse_sample_range(const std::string& text) {
    const size_t colon = text.find(':');
    auto number = [&](const std::string& t) -> uint32_t {
        if (t.empty() || t.size() > 10 || t.find_first_not_of("0123456789") != std::string::npos)
            throw std::invalid_argument("sample range '" + text + "': expected A:B, two whole numbers");
        const unsigned long long v = std::stoull(t);
        if (v > UINT32_MAX) throw std::invalid_argument("sample range '" + text + "': " + t + " is past 2^32 - 1");
        return static_cast<uint32_t>(v);
    };
    if (colon == std::string::npos) throw std::invalid_argument("sample range '" + text + "': expected A:B");
    SampleRange r{number(text.substr(0, colon)), number(text.substr(colon + 1))};
    if (r.end <= r.begin)
        throw std::invalid_argument("sample range '" + text + "': it must end after it begins (A < B)");
    if (r.end - r.begin > (1u << 20))
        throw std::invalid_argument("sample range '" + text + "': more than 2^20 samples per pixel in one render");
    return r;
}

PixelBounds parse_pixel_bounds(const std::string& text, uint32_t width, uint32_t height) {
    uint32_t v[4];
    size_t at = 0;
    for (int k = 0; k < 4; ++k) {
        const size_t end = k < 3 ? text.find(',', at) : text.size();
        const std::string t = end == std::string::npos ? std::string() : text.substr(at, end - at);
        if (t.empty() || t.size() > 9 || t.find_first_not_of("0123456789") != std::string::npos)
            throw std::invalid_argument("pixel bounds '" + text + "': expected x0,x1,y0,y1, four whole numbers");
        v[k] = static_cast<uint32_t>(std::stoul(t));
        at = end + 1;
    }
    const PixelBounds b{v[0], v[1], v[2], v[3]};
    if (!(b.x0 < b.x1 && b.x1 <= width && b.y0 < b.y1 && b.y1 <= height))
        throw std::invalid_argument("pixel bounds '" + text + "': need x0 < x1 <= " + std::to_string(width) +
                                    " and y0 < y1 <= " + std::to_string(height) + " (the film)");
    return b;
}

std::vector<ExrChannel> render_channels(const Frame& frame, const Descriptor* d) {
    const size_t n = frame.pixels.size();
    std::vector<float> rgb = frame.rgb_mean();
    std::vector<ExrChannel> ch;
    auto channel = [&](const std::string& name, auto&& value) {
        ExrChannel c{name, std::vector<float>(n), false};
        for (size_t i = 0; i < n; ++i) c.data[i] = static_cast<float>(value(i));
        ch.push_back(std::move(c));
    };
    for (int c = 0; c < 3; ++c) channel(std::string(1, "RGB"[c]), [&](size_t i) { return rgb[3 * i + c]; });
    if (d) {
        // Each bucket's linear RGB: the seven add up to R, G, B (the same mean over the finite samples).
        // Every render with the capture has them; a frame without them (the render cache keeps the
        // luminance only) is not an output to write.
        VKM_ASSERT(frame.bucket_rgb_sum.size() == n * Frame::kBucketRgb,
                   "render_channels: the frame has no per-bucket RGB (a frame from the render "
                   "cache, or merged with one) and cannot be written as a render's EXR");
        const size_t classes = d->class_names.size();
        for (size_t b = 0; b < classes; ++b)
            for (int c = 0; c < 3; ++c)
                channel("bucket." + d->class_names[b] + "." + "RGB"[c], [&](size_t i) {
                    const double count = frame.pixels[i].count;
                    return count > 0 ? frame.bucket_rgb_sum[i * Frame::kBucketRgb + 3 * b + c] / count : 0.0;
                });
        for (size_t b = 0; b < classes; ++b)
            channel("lum." + d->class_names[b], [&](size_t i) { return d->bucket_energy[i][b]; });
        if (!d->direct_glossy.empty()) channel("lum.direct_glossy", [&](size_t i) { return d->direct_glossy[i]; });
        channel("dominant", [&](size_t i) { return static_cast<float>(d->dominant[i]); });
        channel("purity", [&](size_t i) { return d->purity[i]; });
        channel("glossy_frac", [&](size_t i) { return d->glossy_frac[i]; });
        if (!d->taxonomy) channel("caustic_frac", [&](size_t i) { return d->caustic_frac[i]; });
        channel("depth", [&](size_t i) { return d->depth[i]; });
        // A taxonomy's classes do not say which energy `depth` averages over (every event but the
        // camera's direct view of an emitter: the built-in cascade's all but emitter_direct), so its
        // renders write that energy, per sample, for `vkmech merge` to weigh depth by.
        if (d->taxonomy)
            channel("depth_energy", [&](size_t i) {
                const PixelStats& p = frame.pixels[i];
                return p.count > 0 ? p.depth_weight / p.count : 0.0;
            });
        for (size_t b = 0; b < classes; ++b)
            channel("frac." + d->class_names[b], [&](size_t i) {
                return d->total_energy[i] > 0 ? d->bucket_energy[i][b] / d->total_energy[i] : 0.0f;
            });
    }
    channel("lum_mean", [&](size_t i) { return frame.pixels[i].lum_mean; });
    channel("lum_var", [&](size_t i) { return frame.pixels[i].lum_var(); });
    channel("spp", [&](size_t i) { return frame.pixels[i].count + frame.pixels[i].nonfinite; });
    channel("nonfinite", [&](size_t i) { return frame.pixels[i].nonfinite; });
    return ch;
}

std::map<std::string, std::vector<std::string>> render_attributes(const RenderInfo& info,
                                                                  const std::vector<std::string>& warnings,
                                                                  const std::string& run_id, const Descriptor* d) {
    std::map<std::string, std::vector<std::string>> attrs = {{"vkmech.scene", {info.scene_path}},
                                                             {"vkmech.estimator", {info.estimator}},
                                                             {"vkmech.lightSelection", {info.light_selection}},
                                                             {"vkmech.endVertex", {info.end_vertex}},
                                                             {"vkmech.spp", {std::to_string(info.spp)}},
                                                             {"vkmech.seed", {std::to_string(info.seed)}},
                                                             {"vkmech.device", {info.device}},
                                                             {"vkmech.features", {info.features}},
                                                             {"vkmech.warnings", warnings},
                                                             {"vkmech.substitutions", info.substitutions}};
    if (!run_id.empty()) attrs["vkmech.runId"] = {run_id};
    if (!info.lights_at_infinity.empty()) attrs["vkmech.lightsAtInfinity"] = {info.lights_at_infinity};
    if (d) attrs["vkmech.dominantLegend"] = {dominant_legend_json(d->class_names)};
    if (!info.taxonomy.empty()) attrs["vkmech.taxonomy"] = {info.taxonomy};
    if (!info.queries.empty()) attrs["vkmech.lpe"] = {info.queries};
    if (const Provenance& p = info.provenance; !p.version.empty()) {
        attrs["vkmech.version"] = {p.version};
        attrs["vkmech.codeDigest"] = {p.code_digest};
        attrs["vkmech.sceneSha256"] = {p.scene_sha256};
        attrs["vkmech.sceneFiles"] = p.scene_files;
        attrs["vkmech.defines"] = p.defines;
        attrs["vkmech.sampleRange"] = {p.sample_range};
        if (!p.pixel_bounds.empty()) {
            attrs["vkmech.pixelBounds"] = {p.pixel_bounds};
            attrs["vkmech.filmSize"] = {p.film_size};
        }
        attrs["vkmech.driver"] = {p.driver};
        attrs["vkmech.traversal"] = {info.traversal};
        attrs["vkmech.kernel"] = {info.kernel};
        attrs[kCapDateAttribute] = {p.date_utc};
    }
    return attrs;
}

WrittenFiles write_render_outputs(OutputSet& set, const RenderInfo& info, const Frame& frame, const Descriptor* d,
                                  const DescriptorSummary* s) {
    const int w = frame.width, h = frame.height;
    const std::vector<float> rgb = frame.rgb_mean();
    std::vector<ExrChannel> ch = render_channels(frame, d);
    ch.insert(ch.end(), info.extra_channels.begin(), info.extra_channels.end());

    // Nothing non-finite reaches a file unreported: a value beyond float's
    // range (lum_var of radiance ~1e30 is ~1e60) is counted and warned of.
    WrittenFiles out;
    out.warnings = render_warnings(frame, s);
    uint64_t nonfinite_outputs = 0;
    std::string nonfinite_channels;
    for (const auto& c : ch) {
        size_t bad = std::count_if(c.data.begin(), c.data.end(), [](float v) { return !std::isfinite(v); });
        if (bad == 0) continue;
        nonfinite_outputs += bad;
        nonfinite_channels += (nonfinite_channels.empty() ? "" : ", ") + c.name + " (" + std::to_string(bad) + ")";
    }
    if (nonfinite_outputs > 0)
        out.warnings.push_back(std::to_string(nonfinite_outputs) +
                               " EXR values are not finite (inf or NaN): " + nonfinite_channels +
                               "; a value beyond float's range means an extreme radiance scale (rescale the "
                               "emitters)");
    RenderInfo reported = info;
    reported.warnings.insert(reported.warnings.end(), out.warnings.begin(), out.warnings.end());

    const std::string& name = info.scene_name;
    // Each file is staged, then its final path recorded; a signal stops between files.
    auto stage = [&](std::string& final_path, const std::string& file, auto&& write) {
        throw_if_interrupted();
        write(set.staged(file));
        final_path = set.final_path(file);
        fault_point(("staged-" + file.substr(name.size())).c_str());
    };
    const auto attrs = render_attributes(info, reported.warnings, set.run_id(), d);
    stage(out.exr, name + ".exr", [&](const std::string& p) { write_exr_layers(p, w, h, ch, attrs); });
    stage(out.png, name + ".png", [&](const std::string& p) {
        write_png_rgb8(p, w, h,
                       tonemap_srgb(rgb, static_cast<float>(std::exp2(static_cast<double>(info.exposure_ev)))));
    });
    if (d) {
        stage(out.dominant_png, name + "_dominant.png", [&](const std::string& p) {
            int lw = 0, lh = 0;
            auto map = dominant_map_with_legend(*d, &lw, &lh);
            write_png_rgb8(p, lw, lh, map);
        });
        stage(out.purity_png, name + "_purity.png",
              [&](const std::string& p) { write_png_rgb8(p, w, h, grey_to_rgb8(d->purity, 0.0f, 1.0f)); });
    }
    stage(out.json, name + ".json",
          [&](const std::string& p) { write_file_atomic(p, summary_json(reported, frame, s, nonfinite_outputs)); });
    return out;
}

}  // namespace vkmech
