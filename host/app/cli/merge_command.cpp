// `vkmech merge OUT IN...`: renders of one scene and seed on disjoint sample
// ranges (render --sample-range A:B) or windows (--pixel-bounds), or both,
// combined into the render of their union (each window placed in the film):
// sums by each pixel's sample count, the luminance moments by Chan's formula
// (Frame::merge), then the descriptor (dominant, purity, fractions) derived
// again from the merged buckets. The EXR holds every pixel's means, so each
// input is turned back into the sums it came from; float storage makes the
// result equal the single render to about 1e-7 relative, not bit for bit.
// Renders with a user taxonomy (render --taxonomy) merge by its classes, named
// by the header's vkmech.taxonomy record; the query channels of render --lpe
// (named by vkmech.lpe) by each pixel's finite samples, as the image.
#include "cli/commands.hpp"

#include "io/exr.hpp"
#include "io/json_value.hpp"
#include "io/output_set.hpp"
#include "render/descriptor.hpp"
#include "render/frame.hpp"
#include "render/render_outputs.hpp"
#include "render/taxonomy.hpp"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <tuple>
#include <vector>

namespace fs = std::filesystem;

namespace vkmech {

namespace {

struct MergeOptions {
    std::string out;
    std::vector<std::string> inputs;
};

struct MergeInput {
    std::string path;
    ExrImage exr;
    SampleRange range;
    uint32_t film_w = 0, film_h = 0;  // the whole film (vkmech.filmSize, else the image)
    PixelBounds window;               // the part of it the image is (vkmech.pixelBounds, else all of it)
    // render --taxonomy: the record (vkmech.taxonomy), its classes (the slots' names) and its lines as
    // "name = expression" text; all empty for the built-in buckets.
    std::string taxonomy;
    std::vector<std::string> classes;
    std::string taxonomy_lines;
    // render --lpe: the queries' record (vkmech.lpe), its queries as "name = expression" lines and the query
    // channels it names, in the render's order; empty for a render without queries.
    std::string queries;
    std::string query_lines;
    std::vector<std::string> query_channels;
};

// An EXR, or an output directory holding exactly one.
std::string input_exr(const std::string& in) {
    std::error_code ec;
    if (!fs::is_directory(in, ec)) return in;
    std::vector<std::string> found;
    for (const auto& e : fs::directory_iterator(in, ec))
        if (e.path().extension() == ".exr") found.push_back(e.path().string());
    if (found.size() != 1)
        throw UsageError("merge: " + in + " holds " + std::to_string(found.size()) +
                         " EXR files; name the render's EXR itself");
    return found[0];
}

std::string attribute(const MergeInput& in, const std::string& key) {
    auto it = in.exr.attributes.find(key);
    if (it == in.exr.attributes.end()) return {};
    std::string joined;
    for (const auto& v : it->second) joined += (joined.empty() ? "" : "\n") + v;
    return joined;
}

// A render --taxonomy's record from its header: the classes name the EXR's slots.
void read_taxonomy(MergeInput& m) {
    m.taxonomy = attribute(m, "vkmech.taxonomy");
    const bool rendered_with = (" " + attribute(m, "vkmech.features") + " ").find(" taxonomy ") != std::string::npos;
    if (!rendered_with && m.taxonomy.empty()) return;
    if (m.taxonomy.empty())
        throw UsageError("merge: " + m.path +
                         " was rendered with --taxonomy by a vkmech that did not record the taxonomy in the EXR "
                         "header (vkmech.taxonomy, since 2026-11-27): render it again to merge it");
    std::string why;
    const std::optional<JsonValue> j = parse_json(m.taxonomy, &why);
    const JsonValue* classes = j ? j->find("classes") : nullptr;
    const JsonValue* lines = j ? j->find("lines") : nullptr;
    const bool sound = classes && lines && classes->kind == JsonValue::Array && lines->kind == JsonValue::Array &&
                       !classes->array.empty() && classes->array.size() <= kBucketCount;
    if (!sound)
        throw UsageError("merge: " + m.path + ": its vkmech.taxonomy is not a taxonomy's record (" +
                         (j ? std::string("no classes or lines, or more classes than slots") : why) + ")");
    for (const JsonValue& c : classes->array) {
        if (c.kind != JsonValue::String || c.string.empty())
            throw UsageError("merge: " + m.path + ": its vkmech.taxonomy names a class that is not a name");
        m.classes.push_back(c.string);
    }
    if (m.classes.size() != lines->array.size() + 1)
        throw UsageError("merge: " + m.path + ": its vkmech.taxonomy has " + std::to_string(m.classes.size()) +
                         " classes for " + std::to_string(lines->array.size()) + " lines (one per line and `other`)");
    for (const JsonValue& l : lines->array) {
        const JsonValue* name = l.find("name");
        const JsonValue* expression = l.find("expression");
        m.taxonomy_lines += (name ? name->string : "?") + " = " + (expression ? expression->string : "?") + "\n";
    }
}

// A render --lpe's record from its header: its queries name the lpe.* channels (each query's, then _rest's and
// _overlap's, R, G, B).
void read_queries(MergeInput& m) {
    m.queries = attribute(m, "vkmech.lpe");
    const bool has_channels = std::any_of(m.exr.channels.begin(), m.exr.channels.end(),
                                          [](const auto& c) { return c.first.rfind("lpe.", 0) == 0; });
    if (m.queries.empty()) {
        if (has_channels)
            throw UsageError("merge: " + m.path +
                             " has query channels (lpe.*) but no record of its queries in the EXR header (vkmech.lpe): "
                             "render it again with this vkmech to merge it");
        return;
    }
    std::string why;
    const std::optional<JsonValue> j = parse_json(m.queries, &why);
    const JsonValue* queries = j ? j->find("queries") : nullptr;
    if (!queries || queries->kind != JsonValue::Array || queries->array.empty())
        throw UsageError("merge: " + m.path + ": its vkmech.lpe is not a record of --lpe queries (" +
                         (j ? std::string("no queries") : why) + ")");
    std::vector<std::string> names;
    for (const JsonValue& q : queries->array) {
        const JsonValue* name = q.find("name");
        if (!name || name->kind != JsonValue::String || name->string.empty())
            throw UsageError("merge: " + m.path + ": its vkmech.lpe names a query that is not a name");
        const JsonValue* expression = q.find("expression");
        if (!expression || expression->kind != JsonValue::String)
            throw UsageError("merge: " + m.path + ": its vkmech.lpe has a query without an expression (" +
                             name->string + ")");
        names.push_back(name->string);
        m.query_lines += name->string + " = " + expression->string + "\n";
    }
    m.query_channels = query_channel_names(names);
}

// Refuses inputs that are not parts of one render: a different film, channels,
// scene, seed, estimator or code, each said with both values.
void check_same_render(const MergeInput& a, const MergeInput& b) {
    if (a.film_w != b.film_w || a.film_h != b.film_h)
        throw UsageError("merge: " + b.path + " is " + std::to_string(b.film_w) + "x" + std::to_string(b.film_h) +
                         ", " + a.path + " " + std::to_string(a.film_w) + "x" + std::to_string(a.film_h));
    if (a.queries.empty() != b.queries.empty())
        throw UsageError("merge: " + (a.queries.empty() ? b : a).path + " was rendered with --lpe queries and " +
                         (a.queries.empty() ? a : b).path + " without: different outputs");
    if (a.query_lines != b.query_lines)  // the queries, not the record's text
        throw UsageError("merge: " + b.path + " and " + a.path +
                         " were rendered with different --lpe queries: their query channels are not the same paths");
    for (const auto* pair : {&a, &b}) {
        const MergeInput& x = *pair;
        const MergeInput& y = pair == &a ? b : a;
        for (const auto& [name, plane] : x.exr.channels)
            if (!y.exr.channels.count(name))
                throw UsageError("merge: " + y.path + " has no channel '" + name + "' (" + x.path +
                                 " has): different outputs (--capture, --extra-output)");
    }
    if (a.taxonomy_lines != b.taxonomy_lines)
        throw UsageError("merge: " + b.path + " and " + a.path +
                         " were rendered with different taxonomies (--taxonomy): their classes are not the same "
                         "paths");
    static const std::pair<const char*, const char*> keys[] = {{"vkmech.sceneSha256", "scene (SHA-256)"},
                                                               {"vkmech.sceneFiles", "scene's files"},
                                                               {"vkmech.defines", "-D values"},
                                                               {"vkmech.seed", "seed"},
                                                               {"vkmech.estimator", "estimator"},
                                                               {"vkmech.lightSelection", "light selection"},
                                                               {"vkmech.endVertex", "end-vertex reading"},
                                                               {"vkmech.codeDigest", "path tracer's code digest"},
                                                               {"vkmech.features", "pipeline features"}};
    for (const auto& [key, what] : keys) {
        const std::string x = attribute(a, key), y = attribute(b, key);
        if (x != y)
            throw UsageError("merge: " + b.path + " differs from " + a.path + " in the " + what + ": '" + y +
                             "' against '" + x + "'");
    }
}

// The sums a render's EXR holds as means (render_channels), per pixel.
Frame frame_from_exr(const MergeInput& in) {
    const ExrImage& e = in.exr;
    const size_t n = static_cast<size_t>(e.width) * e.height;
    auto plane = [&](const std::string& name) -> const std::vector<float>& {
        auto it = e.channels.find(name);
        if (it == e.channels.end() || it->second.size() != n)
            throw UsageError("merge: " + in.path + " has no channel '" + name + "': not a vkmech render's EXR");
        return it->second;
    };
    Frame f;
    f.width = e.width;
    f.height = e.height;
    f.pixels.resize(n);
    const auto &spp = plane("spp"), &nonfinite = plane("nonfinite"), &lum_mean = plane("lum_mean"),
               &lum_var = plane("lum_var");
    const std::vector<float>* rgb[3] = {&plane("R"), &plane("G"), &plane("B")};
    const bool capture = e.channels.count("dominant") > 0;
    const uint32_t expected = in.range.end - in.range.begin;
    for (size_t i = 0; i < n; ++i) {
        PixelStats& p = f.pixels[i];
        if (spp[i] != static_cast<float>(expected))
            throw UsageError("merge: " + in.path + " pixel " + std::to_string(i) + " took " + std::to_string(spp[i]) +
                             " samples, not the " + std::to_string(expected) +
                             " of its sample range (an adaptive render?)");
        p.nonfinite = nonfinite[i];
        p.count = spp[i] - nonfinite[i];
        for (int c = 0; c < 3; ++c) p.rgb_sum[c] = static_cast<double>((*rgb[c])[i]) * p.count;
        p.lum_mean = lum_mean[i];
        p.lum_m2 = p.count > 1.0 ? static_cast<double>(lum_var[i]) * (p.count - 1.0) : 0.0;
    }
    f.samples = static_cast<uint64_t>(expected) * n;
    if (!capture) return f;
    f.bucket_rgb_sum.assign(n * Frame::kBucketRgb, 0.0);
    // The slots' names: the seven buckets, or the taxonomy's classes (the slots beyond them stay 0).
    std::vector<std::string> names = in.classes;
    if (names.empty()) names.assign(kBucketNames.begin(), kBucketNames.end());
    for (uint32_t b = 0; b < names.size(); ++b) {
        const auto& lum = plane("lum." + names[b]);
        for (size_t i = 0; i < n; ++i) f.pixels[i].bucket_sum[b] = static_cast<double>(lum[i]) * f.pixels[i].count;
        for (int c = 0; c < 3; ++c) {
            const auto& ch = plane("bucket." + names[b] + "." + "RGB"[c]);
            for (size_t i = 0; i < n; ++i)
                f.bucket_rgb_sum[i * Frame::kBucketRgb + 3 * b + c] = static_cast<double>(ch[i]) * f.pixels[i].count;
        }
    }
    // The side fields: the glossy share and the mean depth are over the energy of the events
    // (depth: those with n >= 1, all but emitter_direct's; a taxonomy's render writes that energy,
    // depth_energy, since its classes do not say it), so each is weighted back by it.
    const auto &glossy = plane("glossy_frac"), &depth = plane("depth");
    const std::vector<float>* depth_energy = in.classes.empty() ? nullptr : &plane("depth_energy");
    for (size_t i = 0; i < n; ++i) {
        PixelStats& p = f.pixels[i];
        double total = 0.0;
        for (uint32_t b = 0; b < gpu::BUCKET_COUNT; ++b) total += p.bucket_sum[b];
        p.glossy_sum = static_cast<double>(glossy[i]) * total;
        p.depth_weight = depth_energy ? static_cast<double>((*depth_energy)[i]) * p.count
                                      : total - p.bucket_sum[gpu::BUCKET_EMITTER_DIRECT];
        p.depth_weighted_sum = static_cast<double>(depth[i]) * p.depth_weight;
    }
    if (in.classes.empty() && e.channels.count("lum.direct_glossy")) {  // a class may be named direct_glossy
        const auto& dg = plane("lum.direct_glossy");
        f.direct_glossy_sum.resize(n);
        for (size_t i = 0; i < n; ++i) f.direct_glossy_sum[i] = static_cast<double>(dg[i]) * f.pixels[i].count;
    }
    return f;
}

// Two inputs whose windows and sample ranges both intersect would count their common samples twice.
void check_disjoint(const std::vector<MergeInput>& in) {
    for (size_t a = 0; a < in.size(); ++a)
        for (size_t b = a + 1; b < in.size(); ++b) {
            const MergeInput &x = in[a], &y = in[b];
            const bool pixels = x.window.x0 < y.window.x1 && y.window.x0 < x.window.x1 && x.window.y0 < y.window.y1 &&
                                y.window.y0 < x.window.y1;
            const bool samples = x.range.begin < y.range.end && y.range.begin < x.range.end;
            if (pixels && samples)
                throw UsageError("merge: the sample ranges of " + x.path + " (" + attribute(x, "vkmech.sampleRange") +
                                 ") and " + y.path + " (" + attribute(y, "vkmech.sampleRange") +
                                 ") overlap on common pixels: their common samples would count twice");
        }
}

// The union of the inputs' ranges: "A:B" when contiguous, else "A:B,C:D,...".
std::string merged_range(const std::vector<MergeInput>& in) {
    std::vector<std::pair<uint32_t, uint32_t>> r;
    for (const auto& m : in) r.emplace_back(m.range.begin, m.range.end);
    std::sort(r.begin(), r.end());
    std::string text;
    uint32_t begin = r[0].first, end = r[0].second;
    for (size_t k = 1; k <= r.size(); ++k) {
        if (k < r.size() && r[k].first <= end) {
            end = std::max(end, r[k].second);
            continue;
        }
        text += (text.empty() ? "" : ",") + std::to_string(begin) + ":" + std::to_string(end);
        if (k < r.size()) std::tie(begin, end) = r[k];
    }
    return text;
}

// An input's window frame placed in the whole film (no samples elsewhere).
Frame in_film(const Frame& part, const MergeInput& in) {
    Frame f;
    f.width = static_cast<int>(in.film_w);
    f.height = static_cast<int>(in.film_h);
    f.samples = part.samples;
    const size_t n = static_cast<size_t>(in.film_w) * in.film_h;
    f.pixels.assign(n, PixelStats{});
    if (!part.bucket_rgb_sum.empty()) f.bucket_rgb_sum.assign(n * Frame::kBucketRgb, 0.0);
    if (!part.direct_glossy_sum.empty()) f.direct_glossy_sum.assign(n, 0.0);
    const uint32_t w = in.window.x1 - in.window.x0;
    for (uint32_t y = in.window.y0; y < in.window.y1; ++y)
        for (uint32_t x = in.window.x0; x < in.window.x1; ++x) {
            const size_t to = static_cast<size_t>(y) * in.film_w + x;
            const size_t from = static_cast<size_t>(y - in.window.y0) * w + (x - in.window.x0);
            f.pixels[to] = part.pixels[from];
            if (!f.bucket_rgb_sum.empty())
                std::copy_n(&part.bucket_rgb_sum[from * Frame::kBucketRgb], Frame::kBucketRgb,
                            &f.bucket_rgb_sum[to * Frame::kBucketRgb]);
            if (!f.direct_glossy_sum.empty()) f.direct_glossy_sum[to] = part.direct_glossy_sum[from];
        }
    return f;
}

// render --lpe's query channels in the merged film: each part's means weighted back by its pixels' finite samples
// (the query pass renders the image's samples again), summed, and divided by the film's.
std::vector<ExrChannel> merged_query_channels(const std::vector<MergeInput>& in, const std::vector<Frame>& parts,
                                              const Frame& film) {
    std::vector<ExrChannel> out;
    const size_t n = film.pixels.size();
    std::vector<double> sum(n);
    for (const std::string& name : in[0].query_channels) {
        std::fill(sum.begin(), sum.end(), 0.0);
        for (size_t k = 0; k < in.size(); ++k) {
            const MergeInput& m = in[k];
            auto it = m.exr.channels.find(name);
            if (it == m.exr.channels.end() || it->second.size() != parts[k].pixels.size())
                throw UsageError("merge: " + m.path + " has no channel '" + name + "' that its vkmech.lpe names");
            const uint32_t w = m.window.x1 - m.window.x0;
            for (size_t from = 0; from < it->second.size(); ++from) {
                const size_t to = (m.window.y0 + from / w) * m.film_w + m.window.x0 + from % w;
                sum[to] += static_cast<double>(it->second[from]) * parts[k].pixels[from].count;
            }
        }
        ExrChannel c{name, std::vector<float>(n), false};
        for (size_t i = 0; i < n; ++i)
            c.data[i] = film.pixels[i].count > 0.0 ? static_cast<float>(sum[i] / film.pixels[i].count) : 0.0f;
        out.push_back(std::move(c));
    }
    return out;
}

// Every pixel of the merged film must have the same samples: the parts cover it evenly.
uint32_t even_spp(const Frame& f) {
    const PixelStats& p0 = f.pixels[0];
    for (size_t i = 1; i < f.pixels.size(); ++i) {
        const PixelStats& p = f.pixels[i];
        if (p.count + p.nonfinite != p0.count + p0.nonfinite)
            throw UsageError("merge: the parts do not cover the film evenly: pixel (" +
                             std::to_string(i % static_cast<size_t>(f.width)) + ", " +
                             std::to_string(i / static_cast<size_t>(f.width)) + ") has " +
                             std::to_string(static_cast<uint64_t>(p.count + p.nonfinite)) + " samples, pixel (0, 0) " +
                             std::to_string(static_cast<uint64_t>(p0.count + p0.nonfinite)));
    }
    return static_cast<uint32_t>(p0.count + p0.nonfinite);
}

RenderInfo merged_info(const MergeInput& first, const std::string& name, const std::string& range, uint32_t spp) {
    RenderInfo info;
    info.scene_name = name;
    info.scene_path = attribute(first, "vkmech.scene");
    info.device = attribute(first, "vkmech.device");
    info.traversal = attribute(first, "vkmech.traversal");
    info.kernel = attribute(first, "vkmech.kernel");
    info.estimator = attribute(first, "vkmech.estimator");
    info.features = attribute(first, "vkmech.features");
    info.light_selection = attribute(first, "vkmech.lightSelection");
    info.end_vertex = attribute(first, "vkmech.endVertex");
    info.spp = spp;
    info.seed = static_cast<uint32_t>(std::stoul("0" + attribute(first, "vkmech.seed")));
    info.capture = first.exr.channels.count("dominant") > 0;
    info.taxonomy = first.taxonomy;
    info.lights_at_infinity = attribute(first, "vkmech.lightsAtInfinity");
    auto list = [&](const char* key) {
        auto it = first.exr.attributes.find(key);
        return it == first.exr.attributes.end() ? std::vector<std::string>{} : it->second;
    };
    info.substitutions = list("vkmech.substitutions");
    Provenance& p = info.provenance;
    p.version = attribute(first, "vkmech.version");
    p.code_digest = attribute(first, "vkmech.codeDigest");
    p.scene_sha256 = attribute(first, "vkmech.sceneSha256");
    p.scene_files = list("vkmech.sceneFiles");
    p.defines = list("vkmech.defines");
    p.sample_range = range;
    p.driver = attribute(first, "vkmech.driver");
    p.date_utc = attribute(first, kCapDateAttribute);
    return info;
}

int cmd_merge(const MergeOptions& o) {
    std::vector<MergeInput> in;
    for (const auto& arg : o.inputs) {
        MergeInput m;
        m.path = input_exr(arg);
        try {
            m.exr = read_exr_channels(m.path);
        } catch (const std::exception& e) {
            throw UsageError(std::string("merge: ") + e.what());
        }
        const std::string range = attribute(m, "vkmech.sampleRange");
        try {
            m.range = parse_sample_range(range);
        } catch (const std::invalid_argument& e) {
            throw UsageError("merge: " + m.path + " is not one sample range of a render (vkmech.sampleRange '" + range +
                             "': " + e.what() + "); an adaptive render's per-pixel ranges do not merge");
        }
        m.film_w = static_cast<uint32_t>(m.exr.width);
        m.film_h = static_cast<uint32_t>(m.exr.height);
        m.window = PixelBounds{0, m.film_w, 0, m.film_h};
        if (const std::string bounds = attribute(m, "vkmech.pixelBounds"); !bounds.empty()) {
            const std::string film = attribute(m, "vkmech.filmSize");
            if (std::sscanf(film.c_str(), "%ux%u", &m.film_w, &m.film_h) != 2)
                throw UsageError("merge: " + m.path + ": vkmech.filmSize '" + film + "' is not WxH");
            try {
                m.window = parse_pixel_bounds(bounds, m.film_w, m.film_h);
            } catch (const std::invalid_argument& e) {
                throw UsageError("merge: " + m.path + ": " + e.what());
            }
            if (m.window.x1 - m.window.x0 != static_cast<uint32_t>(m.exr.width) ||
                m.window.y1 - m.window.y0 != static_cast<uint32_t>(m.exr.height))
                throw UsageError("merge: " + m.path + " is not the size of its pixel bounds " + bounds);
        }
        read_taxonomy(m);
        read_queries(m);
        in.push_back(std::move(m));
    }
    for (size_t k = 1; k < in.size(); ++k) check_same_render(in[0], in[k]);
    check_disjoint(in);
    const std::string range = merged_range(in);
    std::vector<Frame> parts;
    for (const MergeInput& m : in) parts.push_back(frame_from_exr(m));
    Frame frame = in_film(parts[0], in[0]);
    for (size_t k = 1; k < in.size(); ++k) frame.merge(in_film(parts[k], in[k]));
    const uint32_t spp = even_spp(frame);
    const std::string name = fs::path(in[0].path).stem().string();
    // The merged film is whole: no window of its own.
    RenderInfo info = merged_info(in[0], name, range, spp);
    if (!in[0].queries.empty()) {
        info.extra_channels = merged_query_channels(in, parts, frame);
        info.extra_json.emplace_back("lpe", in[0].queries);
        info.queries = in[0].queries;
    }
    std::optional<Descriptor> desc;
    std::optional<DescriptorSummary> summary;
    if (info.capture) {
        desc = derive_descriptor(frame);
        if (!in[0].classes.empty()) use_taxonomy_classes(*desc, in[0].classes);
        summary = summarize(frame, *desc);
    }
    require_writable_dir(o.out, "OUT");
    OutputSet set(o.out, name);
    WrittenFiles files = write_render_outputs(set, info, frame, desc ? &*desc : nullptr, summary ? &*summary : nullptr);
    set.commit();
    for (const auto& w : files.warnings) std::cerr << "vkmech: warning: " << w << "\n";
    std::printf("merged %zu renders of %s: samples %s, %u per pixel\n", in.size(), name.c_str(), range.c_str(), spp);
    for (const auto& f : {files.exr, files.png, files.dominant_png, files.purity_png, files.json})
        if (!f.empty()) std::printf("wrote %s\n", f.c_str());
    return 0;
}

}  // namespace

void register_merge(CLI::App& app, CliCommands& commands) {
    auto o = std::make_shared<MergeOptions>();
    auto* merge = app.add_subcommand(
        "merge",
        "Combine renders of one scene and seed on disjoint sample ranges (render --sample-range A:B) into the render "
        "of their union: the outputs of `render`, written to OUT");
    merge->add_option("OUT", o->out, "Output directory")->required();
    merge->add_option("IN", o->inputs, "Renders to merge: their EXR files, or output directories holding one")
        ->required()
        ->expected(2, 1 << 16);
    commands.push_back({merge, [o](const std::vector<std::string>&) { return cmd_merge(*o); }});
}

}  // namespace vkmech
