// Never silent garbage (docs/reliability.md, "Numerics"): scene scale, radiance scale,
// and the warnings a render's outputs carry when they come out empty or
// beyond float's range.
#include "gpu_fixture.hpp"
#include "io/exr.hpp"
#include "io/invariant.hpp"
#include "io/output_set.hpp"
#include "render/render_outputs.hpp"
#include "render_fixture.hpp"
#include "temp_dir.hpp"

#include <doctest/doctest.h>

#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>

using namespace vkmech;
using testing::read_text;
using testing::RenderSetup;

namespace {

std::string test_scene(const std::string& name) { return std::string(VKMECH_TEST_DATA) + "/render/" + name + ".xml"; }

// Every shape and the camera position scaled by k about the origin, and with them the
// camera's clip planes (world distances); the radiance stays.
Scene scaled(Scene s, float k) {
    for (auto& m : s.meshes) {
        for (auto& p : m.positions) p *= k;
        m.center *= k;
        m.radius *= k;
    }
    s.camera.to_world[3] = glm::vec4(glm::vec3(s.camera.to_world[3]) * k, 1.0f);
    s.camera.near_clip *= k;
    s.camera.far_clip *= k;
    return s;
}

double mean_luminance(const Frame& f) {
    double sum = 0.0;
    for (const auto& p : f.pixels) sum += p.lum_mean;
    return sum / static_cast<double>(f.pixels.size());
}

double nonfinite_samples(const Frame& f) {
    double n = 0.0;
    for (const auto& p : f.pixels) n += p.nonfinite;
    return n;
}

bool contains(const std::string& s, const std::string& what) { return s.find(what) != std::string::npos; }

// A w x 1 frame of `count` samples per pixel, luminance `lum` everywhere, all
// of it in bucket `direct` (so every pixel is labelled when lum > 0).
Frame flat_frame(int w, double lum, double count) {
    Frame f;
    f.width = w;
    f.height = 1;
    f.pixels.assign(static_cast<size_t>(w), PixelStats{});
    for (auto& p : f.pixels) {
        p.count = count;
        p.rgb_sum = {lum * count, lum * count, lum * count};
        p.lum_mean = lum;
        p.bucket_sum[gpu::BUCKET_DIRECT] = lum * count;
    }
    // Grey, all of it direct: the direct bucket's RGB is the pixel's.
    f.bucket_rgb_sum.assign(f.pixels.size() * Frame::kBucketRgb, 0.0);
    for (size_t i = 0; i < f.pixels.size(); ++i)
        for (int c = 0; c < 3; ++c) f.bucket_rgb_sum[i * Frame::kBucketRgb + 3 * gpu::BUCKET_DIRECT + c] = lum * count;
    f.samples = static_cast<uint64_t>(w * count);
    return f;
}

struct Written {
    std::string json;
    ExrImage exr;
};

Written write_outputs(const testing::TempDir& dir, const Frame& f) {
    RenderInfo info;
    info.scene_name = "synthetic";
    Descriptor d = derive_descriptor(f);
    DescriptorSummary s = summarize(f, d);
    OutputSet set(dir.path.string(), info.scene_name);
    WrittenFiles files = write_render_outputs(set, info, f, &d, &s);
    set.commit();
    return {read_text(files.json), read_exr_channels(files.exr)};
}

}  // namespace

TEST_CASE(
    "frame: each bucket's RGB comes from its own three floats of a batch, its energy is their luminance, and frames "
    "keep the RGB only when both have it") {
    // The shader packs bucket b's R, G, B at floats 3b..3b+2 of GpuPixelAccum::bucket_rgb
    // (shared/types.h): give every float its own value and find each where the layout says.
    std::vector<gpu::GpuPixelAccum> batch(1, gpu::GpuPixelAccum{});
    for (int k = 0; k < 21; ++k) batch[0].bucket_rgb[k / 4][k % 4] = static_cast<float>(k + 1);
    batch[0].rgb = glm::vec4(1.0f, 1.0f, 1.0f, 1.0f);
    Frame f;
    f.width = f.height = 1;
    f.pixels.assign(1, PixelStats{});
    f.bucket_rgb_sum.assign(Frame::kBucketRgb, 0.0);
    f.merge(batch);
    f.merge(batch);
    for (uint32_t b = 0; b < gpu::BUCKET_COUNT; ++b) {
        CAPTURE(b);
        const double r = 2.0 * (3 * b + 1), g = 2.0 * (3 * b + 2), bl = 2.0 * (3 * b + 3);
        CHECK(f.bucket_rgb_sum[3 * b] == r);
        CHECK(f.bucket_rgb_sum[3 * b + 1] == g);
        CHECK(f.bucket_rgb_sum[3 * b + 2] == bl);
        CHECK(f.pixels[0].bucket_sum[b] == doctest::Approx(0.2126 * r + 0.7152 * g + 0.0722 * bl).epsilon(1e-12));
    }
    Frame g = f;
    g.merge(f);
    CHECK(g.bucket_rgb_sum[20] == 4.0 * 21);
    Frame without = f;
    without.bucket_rgb_sum.clear();
    g.merge(without);
    CHECK(g.bucket_rgb_sum.empty());
    CHECK(g.pixels[0].bucket_sum[6] == doctest::Approx(3.0 * f.pixels[0].bucket_sum[6]));
    // Such a frame (the render cache keeps no RGB) is not written as a render's EXR.
    const Descriptor d = derive_descriptor(g);
    CHECK_THROWS_AS(render_channels(g, &d), InternalError);  // a bug in the caller, not bad input
    CHECK(render_channels(f, &d).size() == exr_channel_names(true).size());
}

TEST_CASE("invariant: VKM_ASSERT passes a true condition and names file, line and condition of a false one") {
    int checked = 0;
    VKM_ASSERT(++checked == 1, "not reached");
    CHECK(checked == 1);  // the condition is evaluated once
    const int line = __LINE__ + 2;
    try {
        VKM_ASSERT(checked == 2, "the message");
        FAIL("a false condition must throw");
    } catch (const InternalError& e) {
        CHECK(std::string(e.what()) ==
              "tests/test_numerics.cpp:" + std::to_string(line) + ": checked == 2 failed: the message");
    }
}

TEST_CASE("render outputs: an EXR value beyond float range is counted in the JSON and warned of") {
    testing::TempDir dir("numerics_overflow");
    Frame f = flat_frame(3, 1e30, 16.0);
    f.pixels[1].lum_m2 = 1e62;  // lum_var ~7e60: finite in double, inf as the EXR's float
    Written w = write_outputs(dir, f);
    size_t nonfinite = 0;
    for (const auto& [name, data] : w.exr.channels)
        for (float v : data) nonfinite += !std::isfinite(v);
    CHECK(nonfinite == 1);
    INFO(w.json);
    CHECK(contains(w.json, "\"nonfinite_output_values\": 1,"));
    CHECK(contains(w.json, "lum_var (1)"));
    // The same frame with a representable variance: nothing to report.
    f.pixels[1].lum_m2 = 1e38;
    w = write_outputs(dir, f);
    CHECK(contains(w.json, "\"nonfinite_output_values\": 0,"));
    CHECK(contains(w.json, "\"warnings\": []"));
}

TEST_CASE("render outputs: a black image and a label map without labels are warned of in the JSON") {
    testing::TempDir dir("numerics_black");
    Written w = write_outputs(dir, flat_frame(4, 0.0, 8.0));
    INFO(w.json);
    CHECK(contains(w.json, "the image is black"));
    CHECK(contains(w.json, "no pixel has a label"));
    CHECK(contains(w.json, "no emitter visible or reachable"));
    CHECK(contains(w.json, "\"labelled_pixels\": 0,"));
    // One lit pixel: neither warning.
    Frame lit = flat_frame(4, 0.0, 8.0);
    lit.pixels[2] = flat_frame(1, 0.5, 8.0).pixels[0];
    w = write_outputs(dir, lit);
    CHECK(contains(w.json, "\"warnings\": []"));
    // Excluded non-finite samples are a warning too, not only a count.
    lit.pixels[0].nonfinite = 3.0;
    w = write_outputs(dir, lit);
    CHECK(contains(w.json, "3 non-finite samples"));
}

TEST_CASE("scene: an emitter with zero radiance loads with a warning that it emits nothing") {
    testing::TempDir dir("numerics_dark_emitter");
    std::ofstream(dir.file("dark.xml")) << R"(<scene version="3.0.0">
    <sensor type="perspective"><transform name="to_world"><lookat origin="0, 0, 5" target="0, 0, 0" up="0, 1, 0"/></transform></sensor>
    <shape type="rectangle"><bsdf type="diffuse"/></shape>
    <shape type="rectangle" id="dark">
        <transform name="to_world"><translate z="2"/></transform>
        <emitter type="area"><rgb name="radiance" value="0, 0, 0"/></emitter>
    </shape>
</scene>
)";
    Scene s = load_scene(dir.file("dark.xml"));
    bool warned = false;
    for (const auto& w : s.warnings) warned = warned || contains(w, "emitter on shape 'dark' has zero radiance");
    CHECK(warned);
}

TEST_SUITE("gpu") {
    // The ray offsets must follow the scene's scale (no absolute epsilon):
    // the same samples at 1e-6 and 1e12 give the native image.
    TEST_CASE("numerics: a box scaled by 1e-6 and by 1e12 renders its native image - both traversals") {
        VKMECH_REQUIRE_GPU(ctx);
        Scene native = load_scene(test_scene("scale_box"));
        std::vector<Traversal> travs = {Traversal::Bvh};
        if (ctx->ray_query_enabled()) travs.push_back(Traversal::RayQuery);
        for (Traversal t : travs) {
            CAPTURE(std::string(to_string(t)));
            RenderSetup setup;
            setup.res = 24;
            setup.spp = 16;
            setup.traversal = t;
            Frame ref = testing::render_scene(*ctx, native, setup);
            double ref_mean = mean_luminance(ref);
            REQUIRE(ref_mean > 0.1);
            for (float k : {1e-6f, 1e12f}) {
                CAPTURE(k);
                Frame f = testing::render_scene(*ctx, scaled(native, k), setup);
                CHECK(nonfinite_samples(f) == 0.0);
                CHECK(mean_luminance(f) == doctest::Approx(ref_mean).epsilon(0.02));
            }
        }
    }

    // Per-pixel Welford moments in float overflowed (M2 ~ 1e60: lum_var inf)
    // or underflowed (M2 ~ 1e-60: lum_var 0) at extreme radiance; the same
    // samples scaled by k must give mean * k and variance * k^2.
    TEST_CASE("numerics: luminance mean and variance scale exactly with radiance 1e30 and 1e-30") {
        VKMECH_REQUIRE_GPU(ctx);
        Scene base = load_scene(test_scene("scale_box"));
        RenderSetup setup;
        setup.res = 16;
        setup.spp = 32;
        Frame ref = testing::render_scene(*ctx, base, setup);
        for (float k : {1e30f, 1e-30f}) {
            CAPTURE(k);
            Scene s = base;
            for (auto& e : s.emitters) e.radiance *= k;
            double ratio = static_cast<double>(s.emitters[0].radiance.x) / base.emitters[0].radiance.x;
            Frame f = testing::render_scene(*ctx, s, setup);
            size_t bad_mean = 0, bad_var = 0, with_var = 0;
            for (size_t i = 0; i < f.pixels.size(); ++i) {
                const PixelStats& a = f.pixels[i];
                const PixelStats& b = ref.pixels[i];
                CHECK(a.nonfinite == 0.0);
                if (!(std::abs(a.lum_mean - b.lum_mean * ratio) <= 1e-4 * b.lum_mean * ratio)) ++bad_mean;
                if (b.lum_var() > 0.0) ++with_var;
                double var = b.lum_var() * ratio * ratio;
                if (!(std::isfinite(a.lum_var()) && std::abs(a.lum_var() - var) <= 1e-3 * var)) ++bad_var;
            }
            CHECK(with_var > f.pixels.size() / 2);
            CHECK(bad_mean == 0);
            CHECK(bad_var == 0);
        }
    }
}
