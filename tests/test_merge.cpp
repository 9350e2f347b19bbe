// Sample ranges and merging (render --sample-range A:B, vkmech merge): disjoint
// ranges of one seed merge into the single render; inputs that are not parts
// of one render are refused, each with the reason.
#include "cli_run.hpp"
#include "gpu_fixture.hpp"
#include "temp_dir.hpp"

#include "io/exr.hpp"
#include "render/render_outputs.hpp"

#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iterator>
#include <string>
#include <utility>
#include <vector>

using namespace vkmech;

namespace {

// Renders ring_caustic (a caustic: delta-mediated and glossy labels side by side) at 24 pixels wide.
testing::CliRun render(const std::string& out, const std::string& samples, const std::string& extra = "") {
    return testing::run_cli("render --scene ring_caustic --res 24 --batch 8 " + samples + " --out " + out + " " +
                            extra);
}

// Every channel of `full` is in `merged` and agrees with it: the labels exactly, every other value
// within relative 1e-6 (the EXR's float means; measured: 2.3e-7 at most on ring_caustic).
void check_equal_to_single_render(const ExrImage& full, const ExrImage& merged) {
    REQUIRE(merged.channels.size() == full.channels.size());
    for (const auto& channel : full.channels) {
        const std::string& name = channel.first;  // not a structured binding: clang 14 cannot capture one
        const std::vector<float>& a = channel.second;
        CAPTURE(name);
        REQUIRE(merged.channels.count(name) == 1);
        const auto& b = merged.channels.at(name);
        REQUIRE(a.size() == b.size());
        double worst = 0.0;
        for (size_t i = 0; i < a.size(); ++i)
            if (a[i] != b[i]) worst = std::max(worst, std::abs(static_cast<double>(a[i]) - b[i]) / std::abs(a[i]));
        CAPTURE(worst);
        if (name == "dominant")
            CHECK(worst == 0.0);
        else
            CHECK(worst < 1e-6);
    }
}

// The --spp 16 render of ring_caustic with `options`, and the merge of its parts: samples 0:6 of the whole film,
// then 6:16 in two windows (left and right, each narrower than the film and the right one offset), merged in
// another order.
std::pair<ExrImage, ExrImage> full_and_merged_parts(const testing::TempDir& dir, const std::string& options) {
    REQUIRE(render(dir.file("full"), "--spp 16", options).code == 0);
    REQUIRE(render(dir.file("a"), "--sample-range 0:6", options).code == 0);
    REQUIRE(render(dir.file("left"), "--sample-range 6:16", options + " --pixel-bounds 0,10,0,24").code == 0);
    REQUIRE(render(dir.file("right"), "--sample-range 6:16", options + " --pixel-bounds 10,24,0,24").code == 0);
    const testing::CliRun m = testing::run_cli("merge " + dir.file("m") + " " + dir.file("right") + " " +
                                               dir.file("a") + " " + dir.file("left"));
    CAPTURE(m.output);
    REQUIRE(m.code == 0);
    return {read_exr_channels(dir.file("full/ring_caustic.exr")), read_exr_channels(dir.file("m/ring_caustic.exr"))};
}

// The part `a` of full_and_merged_parts merged with samples 6:16 rendered with `other` options, then with samples
// 6:16 rendered plainly: both refused (exit 2), with messages that hold `says_other` and `says_plain`.
void check_other_parts_refused(const testing::TempDir& dir, const std::string& other, const std::string& says_other,
                               const std::string& says_plain) {
    REQUIRE(render(dir.file("other"), "--sample-range 6:16", other).code == 0);
    REQUIRE(render(dir.file("plain"), "--sample-range 6:16").code == 0);
    testing::CliRun r = testing::run_cli("merge " + dir.file("m2") + " " + dir.file("a") + " " + dir.file("other"));
    CHECK(r.code == 2);
    CHECK(r.output.find(says_other) != std::string::npos);
    r = testing::run_cli("merge " + dir.file("m3") + " " + dir.file("a") + " " + dir.file("plain"));
    CHECK(r.code == 2);
    CHECK(r.output.find(says_plain) != std::string::npos);
}

}  // namespace

TEST_CASE(
    "merge: a sample range is A:B with A < B, whole numbers, at most 2^20 samples, and pixel bounds x0,x1,y0,y1") {
    const SampleRange r = parse_sample_range("32:64");
    CHECK(r.begin == 32u);
    CHECK(r.end == 64u);
    CHECK(parse_sample_range("0:1").end == 1u);
    CHECK_THROWS_WITH_AS(parse_sample_range("64:32"), doctest::Contains("A < B"), std::invalid_argument);
    CHECK_THROWS_WITH_AS(parse_sample_range("5:5"), doctest::Contains("A < B"), std::invalid_argument);
    CHECK_THROWS_WITH_AS(parse_sample_range("5"), doctest::Contains("expected A:B"), std::invalid_argument);
    CHECK_THROWS_WITH_AS(parse_sample_range("-1:4"), doctest::Contains("whole numbers"), std::invalid_argument);
    CHECK_THROWS_WITH_AS(parse_sample_range("0:9999999999"), doctest::Contains("2^32"), std::invalid_argument);
    CHECK_THROWS_WITH_AS(parse_sample_range("0:2000000"), doctest::Contains("2^20"), std::invalid_argument);
    const PixelBounds b = parse_pixel_bounds("1,5,2,7", 8, 8);
    CHECK(b.x0 == 1u);
    CHECK(b.x1 == 5u);
    CHECK(b.y0 == 2u);
    CHECK(b.y1 == 7u);
    CHECK_THROWS_WITH_AS(parse_pixel_bounds("1,5,2", 8, 8), doctest::Contains("four whole numbers"),
                         std::invalid_argument);
    CHECK_THROWS_WITH_AS(parse_pixel_bounds("5,5,2,7", 8, 8), doctest::Contains("x0 < x1"), std::invalid_argument);
    CHECK_THROWS_WITH_AS(parse_pixel_bounds("0,9,2,7", 8, 8), doctest::Contains("x1 <= 8"), std::invalid_argument);
    CHECK_THROWS_WITH_AS(parse_pixel_bounds("0,4,2,7,9", 8, 8), doctest::Contains("four whole numbers"),
                         std::invalid_argument);
}

TEST_SUITE("gpu") {
    TEST_CASE("merge: samples 0:16, 16:40 and 40:64, merged in any order, equal the --spp 64 render") {
        VKMECH_REQUIRE_GPU(ctx);
        testing::TempDir dir("merge");
        REQUIRE(render(dir.file("full"), "--spp 64").code == 0);
        REQUIRE(render(dir.file("a"), "--sample-range 0:16").code == 0);
        REQUIRE(render(dir.file("b"), "--sample-range 16:40").code == 0);
        REQUIRE(render(dir.file("c"), "--sample-range 40:64").code == 0);
        const testing::CliRun m = testing::run_cli("merge " + dir.file("m") + " " + dir.file("c") + " " +
                                                   dir.file("a") + " " + dir.file("b/ring_caustic.exr"));
        CAPTURE(m.output);
        REQUIRE(m.code == 0);
        CHECK(m.output.find("samples 0:64, 64 per pixel") != std::string::npos);
        const ExrImage full = read_exr_channels(dir.file("full/ring_caustic.exr"));
        const ExrImage merged = read_exr_channels(dir.file("m/ring_caustic.exr"));
        CHECK(merged.attributes.at("vkmech.sampleRange").at(0) == "0:64");
        CHECK(merged.attributes.at("vkmech.spp").at(0) == "64");
        check_equal_to_single_render(full, merged);
    }

    TEST_CASE("merge: the four quarters of a --pixel-bounds split make the whole film's render") {
        VKMECH_REQUIRE_GPU(ctx);
        testing::TempDir dir("merge_quarters");
        REQUIRE(render(dir.file("full"), "--spp 16").code == 0);  // 24 x 24
        const char* quarters[] = {"0,10,0,13", "10,24,0,13", "0,10,13,24", "10,24,13,24"};
        std::string parts;
        for (const char* q : quarters) {
            const std::string out = dir.file(std::string("q") + q);
            REQUIRE(render(out, "--spp 16", std::string("--pixel-bounds ") + q).code == 0);
            parts += " " + out;
        }
        const ExrImage full = read_exr_channels(dir.file("full/ring_caustic.exr"));
        // A window is its crop of the whole render, bit for bit (its pixels' rays and streams).
        const ExrImage q3 = read_exr_channels(dir.file("q10,24,13,24/ring_caustic.exr"));
        REQUIRE(q3.width == 14);
        REQUIRE(q3.height == 11);
        CHECK(q3.attributes.at("vkmech.pixelBounds").at(0) == "10,24,13,24");
        CHECK(q3.attributes.at("vkmech.filmSize").at(0) == "24x24");
        for (const auto& channel : q3.channels) {
            const std::string& name = channel.first;
            const std::vector<float>& plane = channel.second;
            CAPTURE(name);
            size_t differ = 0;
            for (int y = 0; y < 11; ++y)
                for (int x = 0; x < 14; ++x)
                    differ += plane[static_cast<size_t>(y * 14 + x)] !=
                              full.channels.at(name)[static_cast<size_t>((y + 13) * 24 + x + 10)];
            CHECK(differ == 0);
        }
        const testing::CliRun m = testing::run_cli("merge " + dir.file("m") + parts);
        CAPTURE(m.output);
        REQUIRE(m.code == 0);
        const ExrImage merged = read_exr_channels(dir.file("m/ring_caustic.exr"));
        REQUIRE(merged.width == 24);
        REQUIRE(merged.height == 24);
        CHECK(merged.attributes.count("vkmech.pixelBounds") == 0);
        check_equal_to_single_render(full, merged);
        // Three quarters do not cover the film; bounds past the film are refused before rendering.
        const testing::CliRun three = testing::run_cli("merge " + dir.file("m3") + " " + dir.file("q0,10,0,13") + " " +
                                                       dir.file("q10,24,0,13") + " " + dir.file("q0,10,13,24"));
        CHECK(three.code == 2);
        CHECK(three.output.find("do not cover the film evenly") != std::string::npos);
        const testing::CliRun past = render(dir.file("past"), "--spp 1", "--pixel-bounds 0,25,0,4");
        CHECK(past.code == 2);
        CHECK(past.output.find("x1 <= 24") != std::string::npos);
    }

    TEST_CASE("merge: a --taxonomy render's sample ranges and windows merge into its single render, class by class") {
        VKMECH_REQUIRE_GPU(ctx);
        testing::TempDir dir("merge_taxonomy");
        // Paths seen in the gold ring (the dominant class of about 10 % of the pixels), one-bounce paths, other.
        std::ofstream(dir.file("t.lpe")) << "mirrored = C S+ [DG] .* [LB]\none_bounce = C [DGS] [LB]\n";
        std::ofstream(dir.file("reversed.lpe")) << "one_bounce = C [DGS] [LB]\nmirrored = C S+ [DG] .* [LB]\n";
        const auto [full, merged] = full_and_merged_parts(dir, "--taxonomy " + dir.file("t.lpe"));
        REQUIRE(full.attributes.count("vkmech.taxonomy") == 1);
        CHECK(merged.attributes.at("vkmech.taxonomy") == full.attributes.at("vkmech.taxonomy"));
        CHECK(merged.attributes.at("vkmech.dominantLegend") == full.attributes.at("vkmech.dominantLegend"));
        for (const char* c : {"lum.mirrored", "bucket.one_bounce.G", "frac.other", "depth_energy"}) {
            CAPTURE(std::string(c));
            CHECK(full.channels.count(c) == 1);
        }
        // Every class has energy, and more than one class is some pixel's dominant one.
        for (const char* c : {"lum.mirrored", "lum.one_bounce", "lum.other"}) {
            double sum = 0.0;
            for (float v : full.channels.at(c)) sum += v;
            CAPTURE(std::string(c));
            CHECK(sum > 0.0);
        }
        const auto& dominant = full.channels.at("dominant");
        CHECK(std::count(dominant.begin(), dominant.end(), 0.0f) > 0);
        CHECK(std::count(dominant.begin(), dominant.end(), 1.0f) > 0);
        check_equal_to_single_render(full, merged);
        std::ifstream json(dir.file("m/ring_caustic.json"));
        const std::string js((std::istreambuf_iterator<char>(json)), std::istreambuf_iterator<char>());
        CHECK(js.find("\"taxonomy\": {\"file\": ") != std::string::npos);
        CHECK(js.find("\"mirrored\": {\"pixel_share\"") != std::string::npos);
        // The same classes in another order are another taxonomy; and a taxonomy is not the buckets.
        check_other_parts_refused(dir, "--taxonomy " + dir.file("reversed.lpe"), "different taxonomies",
                                  "has no channel");
    }

    TEST_CASE("merge: a render --lpe's query channels merge from sample ranges and windows into its single render's") {
        VKMECH_REQUIRE_GPU(ctx);
        testing::TempDir dir("merge_lpe");
        // Two overlapping queries (every path; paths through the mirror-like ring) and one disjoint from
        // the second: _rest and _overlap are both non-zero somewhere.
        const std::string queries =
            "--lpe \"all=C .* [LB]\" --lpe \"mirrored=C S+ [DG] .* [LB]\" --lpe \"one_bounce=C [DGS] [LB]\"";
        const auto [full, merged] = full_and_merged_parts(dir, queries);
        REQUIRE(full.attributes.count("vkmech.lpe") == 1);
        CHECK(merged.attributes.at("vkmech.lpe") == full.attributes.at("vkmech.lpe"));
        // The queries' channels are there and not all zero (so their equality below says something).
        for (const char* c : {"lpe.all.G", "lpe.mirrored.R", "lpe.one_bounce.B", "lpe._overlap.G"}) {
            CAPTURE(std::string(c));
            REQUIRE(full.channels.count(c) == 1);
            double sum = 0.0;
            for (float v : full.channels.at(c)) sum += v;
            CHECK(sum > 0.0);
        }
        check_equal_to_single_render(full, merged);
        std::ifstream json(dir.file("m/ring_caustic.json"));
        const std::string js((std::istreambuf_iterator<char>(json)), std::istreambuf_iterator<char>());
        CHECK(js.find("\"lpe\": {\"queries\": [{\"name\": \"all\"") != std::string::npos);
        // Other queries, or none, are other outputs of other paths.
        check_other_parts_refused(
            dir, "--lpe \"all=C .* [LB]\" --lpe \"mirrored=C S .* [LB]\" --lpe \"one_bounce=C [DGS] [LB]\"",
            "different --lpe queries", "a/ring_caustic.exr was rendered with --lpe queries and");
    }

    TEST_CASE("merge: overlapping ranges, another seed, scene, film or output, and adaptive renders are refused") {
        VKMECH_REQUIRE_GPU(ctx);
        testing::TempDir dir("merge_refuse");
        REQUIRE(render(dir.file("a"), "--sample-range 0:8").code == 0);
        REQUIRE(render(dir.file("overlap"), "--sample-range 4:12").code == 0);
        REQUIRE(render(dir.file("seed"), "--sample-range 8:16", "--seed 3").code == 0);
        REQUIRE(testing::run_cli("render --scene ring_caustic --res 16 --sample-range 8:16 --out " + dir.file("film"))
                    .code == 0);
        REQUIRE(render(dir.file("capture"), "--sample-range 8:16", "--capture off").code == 0);
        REQUIRE(
            testing::run_cli("render --scene cubes_dof --res 24 --sample-range 8:16 --out " + dir.file("scene")).code ==
            0);
        REQUIRE(testing::run_cli("render --scene ring_caustic --res 24 --adaptive uniform --pilot 4 --budget 4 --out " +
                                 dir.file("adaptive"))
                    .code == 0);
        auto merge = [&](const std::string& other) {
            return testing::run_cli("merge " + dir.file("m") + " " + dir.file("a") + " " + dir.file(other));
        };
        // Each refusal (exit 2) says which input and why.
        const std::pair<const char*, std::vector<std::string>> cases[] = {
            {"overlap", {"(0:8) and ", "(4:12) overlap on common pixels"}},
            {"seed", {"in the seed: '3' against '0'"}},
            {"film", {"is 16x"}},
            {"capture", {"has no channel"}},
            {"scene", {"in the scene (SHA-256)"}},
            {"adaptive", {"adaptive render"}}};
        for (const auto& c : cases) {
            const std::string other = c.first;
            const std::vector<std::string>& says = c.second;
            const testing::CliRun r = merge(other);
            CAPTURE(other);
            CAPTURE(r.output);
            CHECK(r.code == 2);
            for (const auto& text : says) CHECK(r.output.find(text) != std::string::npos);
        }
        CHECK_FALSE(std::filesystem::exists(dir.file("m/ring_caustic.exr")));
        const testing::CliRun with_spp =
            testing::run_cli("render --scene ring_caustic --spp 4 --sample-range 0:4 --out " + dir.file("x"));
        CHECK(with_spp.code == 2);
    }
}
