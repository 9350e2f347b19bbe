// The CLI end to end: renders write an EXR and a PNG; bad input exits 2 with
// a message naming the problem.
#include "cli_run.hpp"
#include "gpu_fixture.hpp"
#include "io/exr.hpp"
#include "io/sha256.hpp"
#include "render/gpu_scene.hpp"
#include "study/study_runner.hpp"
#include "temp_dir.hpp"

#include <doctest/doctest.h>

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputFile.h>

#include <sys/wait.h>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

namespace fs = std::filesystem;

namespace {

using vkmech::testing::run_cli;

}  // namespace

TEST_CASE("cli: bad usage and bad input exit with code 2 and say what is wrong") {
    auto r = run_cli("render --scene no_such_scene_name");
    CHECK(r.code == 2);
    CHECK(r.output.find("no scene named 'no_such_scene_name'") != std::string::npos);

    r = run_cli("render --scene /nonexistent/dir/scene.xml");
    CHECK(r.code == 2);
    CHECK(r.output.find("does not exist") != std::string::npos);

    r = run_cli("render --scene ring_caustic --spp 0");
    CHECK(r.code == 2);

    r = run_cli("render --scene ring_caustic --traversal warp");
    CHECK(r.code == 2);

    r = run_cli("bench render --counters --scenes cubes_dof");
    CHECK(r.code == 2);
    CHECK(r.output.find("--counters needs --profile") != std::string::npos);

    r = run_cli("render --scene ring_caustic --light-selection brightest");
    CHECK(r.code == 2);
    r = run_cli("render --scene ring_caustic --end-vertex first");
    CHECK(r.code == 2);
    r = run_cli("render --scene ring_caustic --exposure 99");
    CHECK(r.code == 2);

    r = run_cli("--help");
    CHECK(r.code == 0);
    CHECK(r.output.find("render") != std::string::npos);
    CHECK(r.output.find("devices") != std::string::npos);
}

TEST_CASE("cli: a malformed scene file is reported with file and line - exit 2") {
    fs::path dir = fs::temp_directory_path() / ("vkmech_cli_bad_" + std::to_string(::getpid()));
    fs::create_directories(dir);
    fs::path bad = dir / "broken.xml";
    std::ofstream(bad) << "<scene version=\"3.0.0\">\n  <shape type=\"sphere\">\n</scene>\n";
    auto r = run_cli("render --scene " + bad.string());
    CHECK(r.code == 2);
    CHECK(r.output.find("broken.xml:") != std::string::npos);
    fs::remove_all(dir);
}

TEST_SUITE("gpu") {
    TEST_CASE("cli: bench traversal --bvh-only measures the software BVH and not ray query") {
        VKMECH_REQUIRE_GPU(ctx);
        vkmech::testing::TempDir dir("cli_bench_trav");
        // The scene's row: name, triangles, ray query Mray/s (or a word), BVH Mray/s.
        auto row = [](const std::string& output) {
            std::istringstream lines(output);
            std::string line;
            while (std::getline(lines, line))
                if (line.rfind("cubes_dof ", 0) == 0) {
                    std::istringstream cells(line);
                    std::vector<std::string> c;
                    for (std::string x; cells >> x;) c.push_back(x);
                    return c;
                }
            return std::vector<std::string>{};
        };
        auto r =
            run_cli("bench traversal --scenes cubes_dof --rays 1000 --bvh-only --dump " + (dir.path / "a").string());
        INFO(r.output);
        REQUIRE(r.code == 0);
        std::vector<std::string> c = row(r.output);
        REQUIRE(c.size() == 5);
        CHECK(c[2] == "skipped");
        CHECK(std::stod(c[3]) > 0.0);
        CHECK(std::stod(c[4]) > 0.0);  // the software BVH with one ray per invocation
        const std::string json = vkmech::testing::read_text(dir.path / "a" / "cubes_dof.json");
        CHECK(json.find("\"rayquery_rays_per_second\": null") != std::string::npos);
        CHECK(json.find("\"bvh_rays_per_second\": null") == std::string::npos);

        // --slices measures the bvh column with slices on any device with subgroup ballot, and
        // says so; a device without ballot is refused with a message. Slices are the CPU
        // kernel's: with the GPU kernel they are refused.
        r = run_cli("bench traversal --scenes cubes_dof --rays 1000 --bvh-only --slices --kernel gpu");
        INFO(r.output);
        CHECK(r.code == 2);
        CHECK(r.output.find("--kernel cpu") != std::string::npos);
        r = run_cli("bench traversal --scenes cubes_dof --rays 1000 --bvh-only --slices --kernel cpu");
        INFO(r.output);
        if (ctx->info().compute_subgroup_ballot) {
            REQUIRE(r.code == 0);
            CHECK(r.output.find("bvh column: slices (--slices)") != std::string::npos);
            c = row(r.output);
            REQUIRE(c.size() == 5);
            CHECK(std::stod(c[3]) > 0.0);
        } else {
            CHECK(r.code != 0);
            CHECK(r.output.find("subgroup ballot") != std::string::npos);
        }

        // Without the flag a device with ray query measures both.
        if (ctx->ray_query_enabled()) {
            r = run_cli("bench traversal --scenes cubes_dof --rays 1000");
            REQUIRE(r.code == 0);
            c = row(r.output);
            REQUIRE(c.size() == 5);
            CHECK(std::stod(c[2]) > 0.0);
        }
    }

    TEST_CASE("cli: bench render --profile --counters prints the traversal's work and the phases' shares") {
        VKMECH_REQUIRE_GPU(ctx);
        auto r = run_cli("bench render --profile --counters --scenes cubes_dof --res 32 --spp 2 --batches 1");
        INFO(r.output);
        REQUIRE(r.code == 0);
        CHECK(r.output.find("cubes_dof, software BVH, 2 spp:") != std::string::npos);
        const size_t at = r.output.find("phases, % of the invocations' clock ticks: setup ");
        REQUIRE(at != std::string::npos);
        std::istringstream line(r.output.substr(at, r.output.find('\n', at) - at));
        // The eight exclusive phases, the traces' sum, then "(N intervals left out".
        std::vector<double> shares;
        for (std::string word; line >> word;) {
            if (!word.empty() && (word.back() == ',' || word.back() == ';')) word.pop_back();
            if (!word.empty() && word.front() == '(') word.erase(0, 1);
            char* end = nullptr;
            const double v = std::strtod(word.c_str(), &end);
            if (end != word.c_str() && *end == '\0') shares.push_back(v);
        }
        REQUIRE(shares.size() == 10);
        // A negative share would be a phase outside the one that should hold it (beyond
        // an interval left out, at 32 x 32 and one sample a batch a fraction of a point).
        for (size_t i = 0; i < 8; ++i) CHECK(shares[i] >= -0.5);
        CHECK(shares[1] > 0.0);  // camera rays are traced
        CHECK(shares[8] > 0.0);
        CHECK(shares[9] >= 0.0);
    }

    TEST_CASE("cli: vkmech --scene ring_caustic writes an EXR and a PNG") {
        VKMECH_REQUIRE_GPU(ctx);
        fs::path out = fs::temp_directory_path() / ("vkmech_cli_out_" + std::to_string(::getpid()));
        auto r = run_cli("--scene ring_caustic --spp 4 --res 48 --out " + out.string());
        INFO(r.output);
        REQUIRE(r.code == 0);
        CHECK(fs::file_size(out / "ring_caustic.png") > 0);
        auto exr = vkmech::read_exr_channels((out / "ring_caustic.exr").string());
        CHECK(exr.width == 48);
        for (const char* c : {"R", "G", "B", "lum_mean", "lum_var", "spp", "nonfinite"}) {
            CAPTURE(c);
            REQUIRE(exr.channels.count(c) == 1);
        }
        double sum = 0.0;
        for (float v : exr.channels.at("R")) {
            CHECK(std::isfinite(v));
            sum += v;
        }
        CHECK(sum > 0.0);
        for (float v : exr.channels.at("spp")) CHECK(v == 4.0f);
        // docs/descriptor.md §1/§2 defaults of plain `render`, recorded in the EXR header.
        using Attr = std::vector<std::string>;
        CHECK(exr.attributes["vkmech.estimator"] == Attr{"mis"});
        CHECK(exr.attributes["vkmech.lightSelection"] == Attr{"uniform"});
        CHECK(exr.attributes["vkmech.endVertex"] == Attr{"last-nondelta"});
        CHECK(exr.attributes["vkmech.spp"] == Attr{"4"});
        CHECK(exr.attributes.count("vkmech.warnings") == 1);
        // No temporary files are left behind by the atomic writes.
        for (const auto& e : fs::directory_iterator(out))
            CHECK(e.path().filename().string().find(".tmp") == std::string::npos);
        fs::remove_all(out);
    }

    TEST_CASE("cli: a black render warns on stderr and in the JSON - exit 0") {
        VKMECH_REQUIRE_GPU(ctx);
        fs::path dir = fs::temp_directory_path() / ("vkmech_cli_black_" + std::to_string(::getpid()));
        fs::create_directories(dir);
        // The one emitter is behind the only surface, which hides it from
        // the camera and faces away from it.
        std::ofstream(dir / "away.xml") << R"(<scene version="3.0.0">
    <sensor type="perspective"><transform name="to_world"><lookat origin="0, 0, 5" target="0, 0, 0" up="0, 1, 0"/></transform></sensor>
    <shape type="rectangle"><bsdf type="diffuse"/></shape>
    <shape type="rectangle">
        <transform name="to_world"><scale value="0.2"/><translate z="-2"/></transform>
        <emitter type="area"><rgb name="radiance" value="5, 5, 5"/></emitter>
    </shape>
</scene>
)";
        auto r = run_cli("render --scene " + (dir / "away.xml").string() + " --spp 2 --res 16 --out " +
                         (dir / "out").string());
        INFO(r.output);
        CHECK(r.code == 0);
        CHECK(r.output.find("vkmech: warning: the image is black") != std::string::npos);
        CHECK(r.output.find("vkmech: warning: no pixel has a label") != std::string::npos);
        std::ifstream json(dir / "out" / "away.json");
        std::stringstream ss;
        ss << json.rdbuf();
        CHECK(ss.str().find("the image is black") != std::string::npos);
        fs::remove_all(dir);
    }

    TEST_CASE("cli: --capture off writes the image channels alone and the JSON summary reports the run") {
        VKMECH_REQUIRE_GPU(ctx);
        fs::path out = fs::temp_directory_path() / ("vkmech_cli_nocap_" + std::to_string(::getpid()));
        auto r = run_cli(
            "--scene cubes_dof --spp 2 --res 16 --capture off --estimator nee --light-selection power "
            "--end-vertex literal --exposure -1.5 --out " +
            out.string());
        INFO(r.output);
        REQUIRE(r.code == 0);
        auto exr = vkmech::read_exr_channels((out / "cubes_dof.exr").string());
        CHECK(exr.channels.size() == 7);
        CHECK(exr.channels.count("dominant") == 0);
        CHECK_FALSE(fs::exists(out / "cubes_dof_dominant.png"));
        std::ifstream json(out / "cubes_dof.json");
        std::stringstream ss;
        ss << json.rdbuf();
        CHECK(ss.str().find("\"paths_per_second\"") != std::string::npos);
        CHECK(ss.str().find("\"nonfinite_samples\": 0") != std::string::npos);
        // Every non-default setting is recorded.
        CHECK(ss.str().find("\"estimator\": \"nee\"") != std::string::npos);
        CHECK(ss.str().find("\"light_selection\": \"power\"") != std::string::npos);
        CHECK(ss.str().find("\"end_vertex\": \"literal\"") != std::string::npos);
        CHECK(ss.str().find("\"preview_exposure_ev\": -1.5") != std::string::npos);
        CHECK(ss.str().find("\"preview_clipped_pixel_share\"") != std::string::npos);
        CHECK(exr.attributes["vkmech.endVertex"] == std::vector<std::string>{"literal"});
        fs::remove_all(out);
    }
}

TEST_SUITE("gpu") {
    TEST_CASE(
        "cli: render records its provenance and the dominant legend in the EXR header and the JSON, and verify outputs "
        "checks it") {
        VKMECH_REQUIRE_GPU(ctx);
        vkmech::testing::TempDir dir("cli_provenance");
        const std::string scene = std::string(VKMECH_SOURCE_DIR) + "/scenes/sweep_roughness.xml";
        const std::string out = (dir.path / "r").string();
        const std::time_t before = std::time(nullptr);
        auto r = run_cli("render --scene " + scene + " -D alpha=0.1 --res 16 --spp 3 --kernel cpu --out " + out);
        INFO(r.output);
        REQUIRE(r.code == 0);
        const auto a = vkmech::read_exr_attributes(out + "/sweep_roughness.exr");
        auto one = [&](const char* k) {
            CAPTURE(k);
            REQUIRE(a.count(k) == 1);
            REQUIRE(a.at(k).size() == 1);
            return a.at(k)[0];
        };
        // Computed here, independently of the renderer: the scene file's SHA-256, the
        // path tracer's digest (the study cache's), the -D values, the samples.
        CHECK(one("vkmech.sceneSha256") == vkmech::sha256_file(scene));
        CHECK(one("vkmech.codeDigest") ==
              vkmech::render_code_digest(vkmech::Traversal::Bvh, vkmech::vk::KernelClass::Cpu));
        CHECK(a.at("vkmech.defines") == std::vector<std::string>{"alpha=0.1"});
        CHECK(one("vkmech.sampleRange") == "0:3");
        CHECK(one("vkmech.kernel") == "cpu");
        CHECK(one("vkmech.version").rfind("0.", 0) == 0);
        // The includes (the box and the light) with their digests.
        const auto& files = a.at("vkmech.sceneFiles");
        REQUIRE(files.size() == 2);
        for (const std::string& f : files) {
            CAPTURE(f);
            const auto space = f.find(' ');
            REQUIRE(space == 64);
            CHECK(f.substr(0, 64) == vkmech::sha256_file(f.substr(65)));
        }
        // capDate: OpenEXR's "YYYY:MM:DD HH:MM:SS", UTC, the time of the render.
        const std::string date = one("capDate");
        std::tm tm{};
        REQUIRE(strptime(date.c_str(), "%Y:%m:%d %H:%M:%S", &tm) != nullptr);
        const std::time_t t = timegm(&tm);
        CHECK(t >= before - 1);
        CHECK(t <= std::time(nullptr) + 1);
        // The dominant channel's legend, by the descriptor's seven names in index order.
        CHECK(one("vkmech.dominantLegend") ==
              "{\"0\": \"emitter_direct\", \"1\": \"direct\", \"2\": \"diffuse_indirect\", \"3\": \"glossy\", "
              "\"4\": \"delta_mediated\", \"5\": \"specular_direct\", \"6\": \"other\", \"255\": \"unlabelled\"}");
        // The JSON says the same, and verify outputs checks that it does.
        std::ifstream in(out + "/sweep_roughness.json");
        std::stringstream json;
        json << in.rdbuf();
        CHECK(json.str().find("\"scene_sha256\": \"" + vkmech::sha256_file(scene) + "\"") != std::string::npos);
        CHECK(json.str().find("\"date_utc\": \"" + date + "\"") != std::string::npos);
        r = run_cli("verify outputs " + out);
        INFO(r.output);
        CHECK(r.code == 0);
        CHECK(r.output.find("provenance: vkmech 0.") != std::string::npos);
    }

    TEST_CASE("cli: each bucket is an R, G, B layer of the EXR, by OpenEXR's layer convention (tev's and Blender's)") {
        VKMECH_REQUIRE_GPU(ctx);
        vkmech::testing::TempDir dir("cli_layers");
        const std::string out = (dir.path / "r").string();
        auto r = run_cli("render --scene ring_caustic --res 16 --spp 2 --out " + out);
        INFO(r.output);
        REQUIRE(r.code == 0);
        Imf::InputFile file((out + "/ring_caustic.exr").c_str());
        const Imf::ChannelList& ch = file.header().channels();
        std::set<std::string> layers;
        ch.layers(layers);
        const char* names[] = {"emitter_direct",  "direct", "diffuse_indirect", "glossy", "delta_mediated",
                               "specular_direct", "other"};
        for (const char* b : names) {
            const std::string layer = std::string("bucket.") + b;
            CAPTURE(layer);
            CHECK(layers.count(layer) == 1);
            Imf::ChannelList::ConstIterator first, last;
            ch.channelsInLayer(layer, first, last);
            std::vector<std::string> in_layer;
            for (auto it = first; it != last; ++it) in_layer.push_back(it.name());
            CHECK(in_layer == std::vector<std::string>{layer + ".B", layer + ".G", layer + ".R"});  // OpenEXR sorts
            CHECK(ch.findChannel(std::string("lum.") + b) != nullptr);  // the luminance energy, its own layer
        }
        CHECK(layers.count("lum") == 1);
        CHECK(ch.findChannel("bucket.glossy") == nullptr);  // no luminance channel left under the RGB layer's name
    }
}
