// `render --extra-output direct_glossy` (docs/descriptor.md §3.4): the direct bucket's energy
// whose end vertex is glossy, from the path tracer's second SPIR-V module; the seven-bucket
// label and every other output are those of the default module, bit for bit.
#include "cli_run.hpp"
#include "gpu_fixture.hpp"
#include "temp_dir.hpp"

#include "io/exr.hpp"
#include "render/descriptor.hpp"
#include "render/render_outputs.hpp"
#include "render/session.hpp"
#include "render/shader_modules.hpp"

#include <doctest/doctest.h>

#include <algorithm>
#include <cstring>
#include <fstream>

using namespace vkmech;
using vkmech::testing::read_text;

namespace {

// A frame of two pixels by hand: pixel 0 with glossy-ended direct energy, pixel 1 without.
Frame two_pixel_frame(bool with_split) {
    Frame f;
    f.width = 2;
    f.height = 1;
    f.pixels.resize(2);
    for (auto& p : f.pixels) {
        p.count = 4.0;
        p.lum_mean = 1.0;
    }
    f.pixels[0].bucket_sum[gpu::BUCKET_DIRECT] = 2.0;
    f.pixels[0].bucket_sum[gpu::BUCKET_GLOSSY] = 2.0;
    f.pixels[1].bucket_sum[gpu::BUCKET_DIRECT] = 4.0;
    if (with_split) f.direct_glossy_sum = {1.5, 0.0};
    return f;
}

// A light panel behind the camera over two coplanar quads seen from above: rough
// aluminium on the upper half of the image (world y > 0), white diffuse on the lower.
// Nothing else is reachable, so every event but none is `direct`: NEE at V1 and, under
// mis, the BSDF-sampled hit from V1.
const char* kTwoPlanes = R"(<scene version="3.0.0">
    <sensor type="perspective">
        <float name="fov" value="30"/>
        <transform name="to_world"><lookat origin="0, 0, 3" target="0, 0, 0" up="0, 1, 0"/></transform>
        <film type="hdrfilm"><integer name="width" value="32"/><integer name="height" value="32"/></film>
    </sensor>
    <shape type="rectangle">
        <transform name="to_world"><translate y="1"/></transform>
        <bsdf type="roughconductor">
            <string name="material" value="Al"/>
            <float name="alpha" value="0.3"/>
        </bsdf>
    </shape>
    <shape type="rectangle">
        <transform name="to_world"><translate y="-1"/></transform>
        <bsdf type="diffuse"><rgb name="reflectance" value="0.8, 0.8, 0.8"/></bsdf>
    </shape>
    <shape type="rectangle">
        <transform name="to_world"><scale value="6"/><rotate y="1" angle="180"/><translate z="4"/></transform>
        <bsdf type="diffuse"><rgb name="reflectance" value="0, 0, 0"/></bsdf>
        <emitter type="area"><rgb name="radiance" value="1, 1, 1"/></emitter>
    </shape>
</scene>
)";

struct SplitRenders {
    Frame plain, split;
};

SplitRenders render_with_and_without(vkmech::vk::Context& ctx, Scene scene, Traversal trav, Estimator est,
                                     uint32_t spp) {
    RenderSession session(ctx, std::move(scene), trav);
    Features f = session.features(est);
    Renderer plain = session.renderer(f);
    f.direct_glossy = true;
    Renderer split = session.renderer(f);
    RenderSpec spec;
    spec.spp = spp;
    spec.seed = 3;
    spec.batch_spp = 8;
    return {plain.render(spec), split.render(spec)};
}

std::vector<Traversal> traversals(const vkmech::vk::Context& ctx) {
    std::vector<Traversal> t = {Traversal::Bvh};
    if (ctx.ray_query_enabled()) t.push_back(Traversal::RayQuery);
    return t;
}

}  // namespace

TEST_CASE("direct_glossy: the descriptor and the summary carry the split only when the frame has it") {
    Frame f = two_pixel_frame(true);
    Descriptor d = derive_descriptor(f);
    REQUIRE(d.direct_glossy.size() == 2);
    CHECK(d.direct_glossy[0] == doctest::Approx(0.375));  // 1.5 over 4 samples
    CHECK(d.direct_glossy[1] == 0.0f);
    DescriptorSummary s = summarize(f, d);
    CHECK(s.has_direct_glossy);
    // Image: direct 0.5 + 1.0, glossy 0.5, glossy-ended direct 0.375.
    CHECK(s.direct_glossy_share_of_direct == doctest::Approx(0.375 / 1.5));
    CHECK(s.direct_glossy_energy_share == doctest::Approx(0.375 / 2.0));
    RenderInfo info;
    info.scene_name = "two";
    CHECK(summary_json(info, f, &s).find("\"direct_glossy\": {\"energy_share\": 0.1875, \"share_of_direct\": 0.25}") !=
          std::string::npos);
    auto names = exr_channel_names(true, true);
    auto at = std::find(names.begin(), names.end(), "lum.direct_glossy");
    REQUIRE(at != names.end());
    CHECK(*(at - 1) == "lum.other");
    CHECK(names.size() == exr_channel_names(true).size() + 1);

    // Without the split: no field, and the JSON is that of the frame with the split but for it.
    Frame g = two_pixel_frame(false);
    Descriptor dg = derive_descriptor(g);
    CHECK(dg.direct_glossy.empty());
    DescriptorSummary sg = summarize(g, dg);
    CHECK_FALSE(sg.has_direct_glossy);
    std::string plain = summary_json(info, g, &sg), split = summary_json(info, f, &s);
    CHECK(plain.find("direct_glossy") == std::string::npos);
    CHECK(split.substr(0, split.find(",\n  \"direct_glossy\"")) + "\n}\n" == plain);
}

TEST_CASE("direct_glossy: merging frames adds the split when both have it and drops it otherwise") {
    Frame a = two_pixel_frame(true);
    a.merge(two_pixel_frame(true));
    CHECK(a.direct_glossy_sum == std::vector<double>{3.0, 0.0});
    a.merge(two_pixel_frame(false));
    CHECK(a.direct_glossy_sum.empty());
    Frame b = two_pixel_frame(false);
    b.merge(two_pixel_frame(true));
    CHECK(b.direct_glossy_sum.empty());
    // A batch's direct-glossy RGB (floats 21..23 of bucket_rgb) is added, as its luminance, only
    // to a frame that carries the split.
    std::vector<gpu::GpuPixelAccum> batch(2, gpu::GpuPixelAccum{});
    batch[0].bucket_rgb[5] = glm::vec4(0.0f, 0.25f, 0.25f, 0.25f);
    Frame c = two_pixel_frame(true);
    c.merge(batch);
    REQUIRE(c.direct_glossy_sum.size() == 2);
    CHECK(c.direct_glossy_sum[0] == doctest::Approx(1.75).epsilon(1e-12));  // grey: luminance 0.25
    CHECK(c.direct_glossy_sum[1] == 0.0);
}

TEST_CASE("direct_glossy: the default path-tracing module is not the variant") {
    for (vkmech::vk::KernelClass k : {vkmech::vk::KernelClass::Cpu, vkmech::vk::KernelClass::Gpu}) {
        for (Traversal t : {Traversal::Bvh, Traversal::RayQuery}) {
            auto plain = pathtrace_spirv(t, k), same = pathtrace_spirv(t, k, false),
                 variant = pathtrace_spirv(t, k, true);
            CHECK(plain.data() == same.data());
            CHECK(plain.size() == same.size());
            CHECK(variant.data() != plain.data());
        }
    }
}

TEST_SUITE("gpu") {
    TEST_CASE("direct_glossy: all of the glossy plane's direct energy and none of the diffuse plane's") {
        VKMECH_REQUIRE_GPU(ctx);
        testing::TempDir dir("direct_glossy_planes");
        std::ofstream(dir.file("planes.xml")) << kTwoPlanes;
        for (Traversal trav : traversals(*ctx))
            for (Estimator est : {Estimator::Nee, Estimator::Mis}) {
                CAPTURE(to_string(trav));
                CAPTURE(to_string(est));
                SplitRenders r = render_with_and_without(*ctx, load_scene(dir.file("planes.xml")), trav, est, 16);
                const Frame& f = r.split;
                REQUIRE(f.width == 32);
                REQUIRE(f.direct_glossy_sum.size() == f.pixels.size());
                CHECK(r.plain.direct_glossy_sum.empty());
                Descriptor d = derive_descriptor(f);
                size_t glossy_px = 0, diffuse_px = 0;
                bool glossy_all = true, diffuse_none = true;
                for (int y = 0; y < f.height; ++y) {
                    if (y == 15 || y == 16) continue;  // rows along the seam at world y = 0
                    for (int x = 0; x < f.width; ++x) {
                        const size_t i = static_cast<size_t>(y) * f.width + x;
                        const PixelStats& p = f.pixels[i];
                        const double direct = p.bucket_sum[gpu::BUCKET_DIRECT];
                        REQUIRE(direct > 0.0);
                        if (y < 15) {  // the upper half: rough aluminium
                            ++glossy_px;
                            glossy_all = glossy_all && f.direct_glossy_sum[i] == direct &&
                                         d.direct_glossy[i] == d.bucket_energy[i][gpu::BUCKET_DIRECT];
                        } else {  // the lower half: diffuse
                            ++diffuse_px;
                            diffuse_none = diffuse_none && f.direct_glossy_sum[i] == 0.0 && d.direct_glossy[i] == 0.0f;
                        }
                    }
                }
                CHECK(glossy_px == 15 * 32);
                CHECK(diffuse_px == 15 * 32);
                CHECK(glossy_all);
                CHECK(diffuse_none);
                // Everywhere (seam included): at most the direct energy.
                for (size_t i = 0; i < f.pixels.size(); ++i)
                    if (!(f.direct_glossy_sum[i] <= f.pixels[i].bucket_sum[gpu::BUCKET_DIRECT] * (1.0 + 1e-6))) {
                        CAPTURE(i);
                        CHECK(f.direct_glossy_sum[i] <= f.pixels[i].bucket_sum[gpu::BUCKET_DIRECT]);
                        break;
                    }
                // Every other output is the default module's, bit for bit.
                REQUIRE(r.plain.pixels.size() == f.pixels.size());
                CHECK(std::memcmp(r.plain.pixels.data(), f.pixels.data(), sizeof(PixelStats) * f.pixels.size()) == 0);
            }
    }

    TEST_CASE("direct_glossy: on project scenes the split is within the direct bucket and changes nothing else") {
        VKMECH_REQUIRE_GPU(ctx);
        for (const char* name : {"kitchen_counter", "snooker"}) {
            CAPTURE(name);
            Scene scene = load_scene(std::string(VKMECH_SOURCE_DIR) + "/scenes/" + name + ".xml");
            scene.camera.set_film_width(24);
            SplitRenders r = render_with_and_without(*ctx, std::move(scene), Traversal::Bvh, Estimator::Mis, 8);
            const Frame& f = r.split;
            REQUIRE(f.direct_glossy_sum.size() == f.pixels.size());
            double glossy = 0.0, direct = 0.0;
            size_t above = 0;
            for (size_t i = 0; i < f.pixels.size(); ++i) {
                glossy += f.direct_glossy_sum[i];
                direct += f.pixels[i].bucket_sum[gpu::BUCKET_DIRECT];
                above += f.direct_glossy_sum[i] > f.pixels[i].bucket_sum[gpu::BUCKET_DIRECT] ? 1 : 0;
            }
            CHECK(above == 0);
            CHECK(glossy > 0.0);     // both scenes have rough or glossy surfaces lit directly
            CHECK(glossy < direct);  // and diffuse ones
            CHECK(std::memcmp(r.plain.pixels.data(), f.pixels.data(), sizeof(PixelStats) * f.pixels.size()) == 0);
        }
    }

    TEST_CASE("direct_glossy: render --extra-output direct_glossy adds lum.direct_glossy and the JSON share") {
        VKMECH_REQUIRE_GPU(ctx);
        testing::TempDir dir("direct_glossy_cli");
        std::ofstream(dir.file("planes.xml")) << kTwoPlanes;
        const std::string common =
            "render --scene " + dir.file("planes.xml") + " --spp 4 --res 16 --traversal bvh --out ";
        auto plain = testing::run_cli(common + dir.file("plain"));
        INFO(plain.output);
        REQUIRE(plain.code == 0);
        auto split = testing::run_cli(common + dir.file("split") + " --extra-output direct_glossy");
        INFO(split.output);
        REQUIRE(split.code == 0);
        CHECK(split.output.find("direct energy ending at a glossy vertex:") != std::string::npos);
        ExrImage a = read_exr_channels(dir.file("plain/planes.exr")),
                 b = read_exr_channels(dir.file("split/planes.exr"));
        CHECK(a.channels.count("lum.direct_glossy") == 0);
        REQUIRE(b.channels.count("lum.direct_glossy") == 1);
        CHECK(b.channels.size() == a.channels.size() + 1);
        for (const auto& channel : a.channels) {
            const std::string& name = channel.first;
            CAPTURE(name);
            REQUIRE(b.channels.count(name) == 1);
            CHECK(b.channels.at(name) == channel.second);  // every other channel identical
        }
        const auto& dg = b.channels.at("lum.direct_glossy");
        const auto& direct = b.channels.at("lum.direct");
        for (size_t i = 0; i < dg.size(); ++i) CHECK(dg[i] <= direct[i]);
        CHECK(b.attributes["vkmech.features"].at(0).find("direct-glossy") != std::string::npos);
        CHECK(a.attributes["vkmech.features"].at(0).find("direct-glossy") == std::string::npos);
        const std::string json = read_text(dir.file("split/planes.json"));
        CHECK(json.find("\"direct_glossy\": {\"energy_share\": ") != std::string::npos);
        CHECK(read_text(dir.file("plain/planes.json")).find("\"direct_glossy\":") == std::string::npos);
        // It splits the descriptor's direct bucket: refused without the capture.
        auto nocap = testing::run_cli(common + dir.file("nocap") + " --capture off --extra-output direct_glossy");
        CHECK(nocap.code == 2);
        CHECK(nocap.output.find("needs --capture on") != std::string::npos);
        auto bad = testing::run_cli(common + dir.file("bad") + " --extra-output direct_diffuse");
        CHECK(bad.code == 2);
    }
}
