// User taxonomies on the device (docs/lpe.md; render/taxonomy.hpp): the paper's buckets written
// as a taxonomy (taxonomies/paper.lpe, paper-literal.lpe) render every project scene exactly as
// the built-in cascade; a user taxonomy's classes partition the energy by the labels it names.
#include "cli_run.hpp"
#include "gpu_fixture.hpp"
#include "scene_fixtures.hpp"
#include "temp_dir.hpp"

#include "io/exr.hpp"
#include "io/json_value.hpp"
#include "io/sha256.hpp"
#include "render/descriptor.hpp"
#include "render/renderer.hpp"
#include "render/session.hpp"
#include "render/taxonomy.hpp"
#include "scene/primitives.hpp"

#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <regex>
#include <set>
#include <string>
#include <vector>

using namespace vkmech;

namespace {

std::string source_path(const std::string& rel) { return std::string(VKMECH_SOURCE_DIR) + "/" + rel; }

Frame render(RenderSession& session, const Features& f, uint32_t spp) {
    Renderer r = session.renderer(f);
    RenderSpec spec;
    spec.spp = spp;
    spec.seed = 7;
    spec.batch_spp = spp;
    return r.render(spec);
}

// The number of pixels whose tally differs in any bit (moments, RGB, every slot).
size_t differing_pixels(const Frame& a, const Frame& b) {
    REQUIRE(a.pixels.size() == b.pixels.size());
    REQUIRE(a.bucket_rgb_sum.size() == b.bucket_rgb_sum.size());
    size_t n = 0;
    for (size_t i = 0; i < a.pixels.size(); ++i) {
        const PixelStats &p = a.pixels[i], &q = b.pixels[i];
        bool same = p.count == q.count && p.lum_mean == q.lum_mean && p.lum_m2 == q.lum_m2 && p.rgb_sum == q.rgb_sum &&
                    p.bucket_sum == q.bucket_sum && p.glossy_sum == q.glossy_sum;
        same = same && std::memcmp(&a.bucket_rgb_sum[i * Frame::kBucketRgb], &b.bucket_rgb_sum[i * Frame::kBucketRgb],
                                   Frame::kBucketRgb * sizeof(double)) == 0;
        n += same ? 0 : 1;
    }
    return n;
}

// Two unit quads facing a diffuse floor, each its own emitter (shape ids "lamp_a", "lamp_b"),
// and a floor of material "floor".
Scene two_lamp_scene(float radiance_a, float radiance_b) {
    Scene s = testing::quad_scene();
    s.materials[0].id = "floor";
    s.meshes[0].name = "ground";
    s.meshes[0].positions = {{-4, -4, 0}, {-4, 4, 0}, {4, 4, 0}, {4, -4, 0}};  // faces -z, towards the camera
    Material lamp;
    lamp.id = "lamp_material";
    s.materials.push_back(lamp);
    for (int k = 0; k < 2; ++k)  // facing +z, towards the floor
        testing::add_square_lamp(s, k == 0 ? "lamp_a" : "lamp_b", k == 0 ? -1.5f : 1.5f, -2.0f, false,
                                 k == 0 ? radiance_a : radiance_b, 1);
    s.camera.to_world[3] = glm::vec4(0, 0, -6, 1);
    return s;
}

lpe::TaxonomySource taxonomy_text(const std::string& text) { return lpe::parse_taxonomy(text, "<test>"); }

// The guard's counts in a render --adaptive's output: pixels seen without a usable variance and dark
// pixels beside seen ones; {-1, -1} when the guard said neither. They depend on the device's pilot
// (float rounding), so tests compare them between renders of one device, not with fixed numbers.
std::pair<int, int> guard_counts(const std::string& output) {
    static const std::regex re("([0-9]+) seen without a usable variance, ([0-9]+) dark beside seen pixels");
    std::smatch m;
    if (!std::regex_search(output, m, re)) return {-1, -1};
    return {std::stoi(m[1].str()), std::stoi(m[2].str())};
}

// taxonomies/paper.lpe's lines and properties in reverse order: every bucket in another slot (b -> 5 - b).
const std::string kReversedPaper =
    "specular_direct [heavy rare] = C S+ [LB]\ndelta_mediated [heavy rare] = C (S+ [DG] | [DG]+ S) .* [LB]\n"
    "glossy [heavy] = C [DG]+ G [LB]\ndiffuse_indirect = C [DG]+ D [LB]\ndirect = C [DG] [LB]\n"
    "emitter_direct [constant] = C [LB]\n";

}  // namespace

TEST_CASE("taxonomy: the GPU words hold the DFA, the classes and the labels of the scene's materials and emitters") {
    Scene s = two_lamp_scene(1.0f, 1.0f);
    const SceneTaxonomy t =
        compile_scene_taxonomy(taxonomy_text("a = C .* <L.'lamp_a'>\nfloor_b = C 'floor' <L.'lamp_b'>\n"), s);
    CHECK(t.class_names() == std::vector<std::string>{"a", "floor_b", "other"});
    const auto& w = t.words;
    REQUIRE(w.size() > gpu::TAX_HEADER_WORDS);
    const uint32_t alphabet = w[0], labels = w[1];
    CHECK(alphabet == lpe::kKindCount * labels);
    auto step = [&](uint32_t state, uint32_t kind, uint32_t label) {
        return w[gpu::TAX_HEADER_WORDS + state * alphabet + kind * labels + label];
    };
    auto cls = [&](uint32_t state) { return w[w[3] + state]; };
    const uint32_t floor_label = w[w[4] + 0], lamp_a = w[w[5] + 0], lamp_b = w[w[5] + 1];
    CHECK(lamp_a != lamp_b);
    // C RD:floor L:lamp_b is floor_b; C RD:floor L:lamp_a is a (the first line); C L:lamp_b is other.
    const uint32_t after_floor = step(w[2], gpu::TAX_KIND_REFLECT + gpu::LOBE_D, floor_label);
    CHECK(cls(step(after_floor, gpu::TAX_KIND_LIGHT, lamp_b)) == 1);
    CHECK(cls(step(after_floor, gpu::TAX_KIND_LIGHT, lamp_a)) == 0);
    CHECK(cls(step(w[2], gpu::TAX_KIND_LIGHT, lamp_b)) == 2);
    CHECK(cls(step(w[2], gpu::TAX_KIND_LIGHT, lamp_a)) == 0);

    // Seven lines leave no slot for `other`: refused, naming the line.
    std::string seven;
    for (int i = 0; i < 7; ++i) seven += "c" + std::to_string(i) + " = C .* L\n";
    CHECK_THROWS_WITH_AS(compile_scene_taxonomy(taxonomy_text(seven), s), doctest::Contains("at most 6 lines"),
                         lpe::LpeError);
}

TEST_CASE(
    "taxonomy: paper.lpe and paper-literal.lpe declare the paper's heavy family, emitter_direct constant and the "
    "rare tail") {
    for (const char* file : {"taxonomies/paper.lpe", "taxonomies/paper-literal.lpe"}) {
        CAPTURE(std::string(file));
        const SceneTaxonomy t = compile_scene_taxonomy(lpe::read_taxonomy(source_path(file)), testing::quad_scene());
        CHECK(t.heavy_classes() == gpu::HEAVY_BUCKETS);
        CHECK(t.constant_classes() == (1u << gpu::BUCKET_EMITTER_DIRECT));
        CHECK(t.rare_classes() == ((1u << gpu::BUCKET_DELTA_MEDIATED) | (1u << gpu::BUCKET_SPECULAR_DIRECT)));
    }
    // A line declares any of them, or none.
    const SceneTaxonomy u = compile_scene_taxonomy(
        taxonomy_text("a = C D L\nb [heavy constant] = C L\nc [rare] = C S L\n"), testing::quad_scene());
    CHECK(u.heavy_classes() == 2u);
    CHECK(u.constant_classes() == 2u);
    CHECK(u.rare_classes() == 4u);
}

TEST_CASE("taxonomy: a shape the taxonomy names gets its own material, so its events answer to its id") {
    Scene s = two_lamp_scene(1.0f, 1.0f);
    Mesh wall = s.meshes[0];  // a second shape of material "floor"
    wall.name = "wall";
    s.meshes.push_back(wall);
    const auto src = taxonomy_text("on_ground = C <.D'ground'> .* [LB]\n");
    const size_t materials = s.materials.size();
    CHECK(give_named_shapes_own_materials(s, src) == 1);
    REQUIRE(s.materials.size() == materials + 1);
    CHECK(s.meshes[0].material == static_cast<int>(materials));  // ground: the copy
    CHECK(s.materials.back().id == "floor");
    CHECK(s.materials.back().reflectance.value == s.materials[0].reflectance.value);
    const auto slots = taxonomy_label_slots(s);
    CHECK(slots[0].names == std::vector<std::string>{"floor", "wall"});  // now the wall's alone
    CHECK(slots[materials].names == std::vector<std::string>{"floor", "ground"});
    CHECK(slots[1].names == std::vector<std::string>{"lamp_material"});  // two lamps share it
    CHECK(slots[materials + 1].names == std::vector<std::string>{"lamp_a", "lamp_material"});
    CHECK(give_named_shapes_own_materials(s, src) == 0);  // nothing left to split
}

TEST_SUITE("gpu") {
    TEST_CASE(
        "taxonomy: taxonomies/paper.lpe renders every project scene bit for bit as the built-in cascade (both "
        "readings)") {
        VKMECH_REQUIRE_GPU(ctx);
        const lpe::TaxonomySource paper = lpe::read_taxonomy(source_path("taxonomies/paper.lpe"));
        const lpe::TaxonomySource literal = lpe::read_taxonomy(source_path("taxonomies/paper-literal.lpe"));
        for (const char* name : {"cubes_dof", "glass_caustic", "kitchen_counter", "ring_caustic", "snooker",
                                 "sweep_lights", "sweep_roughness", "tabletop_mixed", "tabletop_separated"}) {
            Scene scene = load_scene(source_path(std::string("scenes/") + name + ".xml"));
            scene.camera.set_film_width(24);
            RenderSession session(*ctx, std::move(scene), Traversal::Bvh);
            // The readings differ only after a delta vertex: the literal one on the scenes that have them.
            const std::string n(name);
            const bool delta = n != "cubes_dof" && n != "sweep_lights" && n != "sweep_roughness";
            for (EndVertex reading : {EndVertex::LastNonDelta, EndVertex::Literal}) {
                if (reading == EndVertex::Literal && !delta) continue;
                Features f = session.features(Estimator::Mis);
                f.end_vertex = reading;
                const Frame cascade = render(session, f, 4);
                f.taxonomy =
                    compile_scene_taxonomy(reading == EndVertex::Literal ? literal : paper, session.scene()).words;
                const Frame taxonomy = render(session, f, 4);
                CAPTURE(std::string(name));
                CAPTURE(std::string(to_string(reading)));
                CHECK(differing_pixels(cascade, taxonomy) == 0);
                double energy = 0.0;
                for (const auto& p : cascade.pixels) energy += p.lum_mean;
                CHECK(energy > 0.0);
            }
        }
    }

    TEST_CASE(
        "taxonomy: under the GPU kernel too, paper.lpe is its cascade bit for bit, and reordered lines move the "
        "slots") {
        VKMECH_REQUIRE_GPU(ctx);
        const lpe::TaxonomySource paper = lpe::read_taxonomy(source_path("taxonomies/paper.lpe"));
        for (const char* name : {"glass_caustic", "kitchen_counter"}) {
            Scene scene = load_scene(source_path(std::string("scenes/") + name + ".xml"));
            scene.camera.set_film_width(24);
            RenderSession session(*ctx, std::move(scene), Traversal::Bvh, LightSelection::Uniform,
                                  vkmech::vk::KernelClass::Gpu);
            Features f = session.features(Estimator::Mis);
            const Frame cascade = render(session, f, 4);
            f.taxonomy = compile_scene_taxonomy(paper, session.scene()).words;
            CAPTURE(std::string(name));
            CHECK(differing_pixels(cascade, render(session, f, 4)) == 0);
            // The same six lines in reverse order (they are disjoint): the classes swap slots, so the
            // tally is the cascade's, slot b moved to slot 5 - b, bit for bit. The taxonomy is live.
            lpe::TaxonomySource reversed = paper;
            std::reverse(reversed.lines.begin(), reversed.lines.end());
            f.taxonomy = compile_scene_taxonomy(reversed, session.scene()).words;
            const Frame swapped = render(session, f, 4);
            size_t moved = 0, same = 0;
            for (size_t i = 0; i < cascade.pixels.size(); ++i)
                for (uint32_t b = 0; b < 6; ++b) {
                    same += swapped.pixels[i].bucket_sum[5 - b] == cascade.pixels[i].bucket_sum[b];
                    moved += cascade.pixels[i].bucket_sum[b] != 0.0 && swapped.pixels[i].bucket_sum[b] == 0.0;
                }
            CHECK(same == 6 * cascade.pixels.size());
            CHECK(moved > 0);
        }
    }

    TEST_CASE("taxonomy: per-light classes partition the image, each the image of its light alone") {
        VKMECH_REQUIRE_GPU(ctx);
        const char* text = "lamp_a = C .* <L.'lamp_a'>\nlamp_b = C .* <L.'lamp_b'>\n";
        RenderSession both(*ctx, two_lamp_scene(1.0f, 3.0f), Traversal::Bvh);
        Features f = both.features(Estimator::Mis);
        f.taxonomy = compile_scene_taxonomy(taxonomy_text(text), both.scene()).words;
        const Frame split = render(both, f, 1024);
        double a = 0.0, b = 0.0, rest = 0.0, total = 0.0;
        for (const auto& p : split.pixels) {
            a += p.bucket_sum[0] / p.count;
            b += p.bucket_sum[1] / p.count;
            for (uint32_t k = 2; k < gpu::BUCKET_COUNT; ++k) rest += p.bucket_sum[k] / p.count;
            total += p.lum_mean;
        }
        CHECK(rest == 0.0);
        CHECK(a + b == doctest::Approx(total).epsilon(1e-6));
        // Each class against a render lit by that lamp alone (the other's radiance 0).
        for (int k = 0; k < 2; ++k) {
            RenderSession alone(*ctx, two_lamp_scene(k == 0 ? 1.0f : 0.0f, k == 0 ? 0.0f : 3.0f), Traversal::Bvh);
            const Frame lit = render(alone, alone.features(Estimator::Mis), 1024);
            double mean = 0.0, var = 0.0;
            for (const auto& p : lit.pixels) {
                mean += p.lum_mean;
                var += p.lum_var() / p.count;
            }
            const double cls = k == 0 ? a : b;
            CAPTURE(k);
            CAPTURE(cls);
            CAPTURE(mean);
            CHECK(std::abs(cls - mean) < 5.0 * std::sqrt(2.0 * var));  // both renders' noise
            CHECK(cls > 0.1 * total);
        }
    }
}

TEST_SUITE("gpu") {
    TEST_CASE("taxonomy: vkmech render --taxonomy names every output by class, and refuses what it cannot do") {
        testing::TempDir dir("taxcli");
        std::ofstream(dir.file("lights.lpe")) << "# per light\nfirst = C .* <L.'sweep_light_0'>\n"
                                                 "second = C .* <L.'sweep_light_1'>\n";
        auto r = testing::run_cli("render --scene sweep_lights -D lights=2 --res 24 --spp 8 --taxonomy " +
                                  dir.file("lights.lpe") + " --out " + dir.file("out"));
        REQUIRE(r.code == 0);
        CHECK(r.output.find("first ") != std::string::npos);
        const ExrImage exr = read_exr_channels(dir.file("out/sweep_lights.exr"));
        for (const char* c : {"bucket.first.R", "lum.second", "frac.other", "dominant"}) {
            CAPTURE(std::string(c));
            CHECK(exr.channels.count(c) == 1);
        }
        CHECK(exr.channels.count("lum.direct") == 0);
        CHECK(exr.channels.count("caustic_frac") == 0);
        // The two lights of equal power share the image; nothing is `other`.
        double first = 0, second = 0, other = 0;
        for (size_t i = 0; i < exr.channels.at("lum.first").size(); ++i) {
            first += exr.channels.at("lum.first")[i];
            second += exr.channels.at("lum.second")[i];
            other += exr.channels.at("lum.other")[i];
        }
        CHECK(other == 0.0);
        CHECK(first > 0.2 * (first + second));
        CHECK(second > 0.2 * (first + second));
        std::ifstream json(dir.file("out/sweep_lights.json"));
        const std::string js((std::istreambuf_iterator<char>(json)), std::istreambuf_iterator<char>());
        CHECK(js.find("\"taxonomy\": {\"file\": ") != std::string::npos);
        CHECK(js.find("\"1\": \"second\"") != std::string::npos);  // the dominant legend

        std::ofstream(dir.file("bad.lpe")) << "ok = C D L\nbad = C (D L\n";
        r = testing::run_cli("render --scene cubes_dof --res 16 --spp 1 --taxonomy " + dir.file("bad.lpe") + " --out " +
                             dir.file("o2"));
        CHECK(r.code == 2);
        CHECK(r.output.find("bad.lpe:2:") != std::string::npos);
        r = testing::run_cli("render --scene cubes_dof --res 16 --spp 1 --capture off --taxonomy " +
                             dir.file("lights.lpe") + " --out " + dir.file("o3"));
        CHECK(r.code == 2);
        CHECK(r.output.find("--capture on") != std::string::npos);
        // The installed reliability curve is of the buckets, not of a taxonomy's classes.
        r = testing::run_cli("render --scene cubes_dof --adaptive bucket-floor --pilot 4 --budget 8 --curve " +
                             source_path("docs/results/predictor_curve.json") + " --taxonomy " +
                             dir.file("lights.lpe") + " --out " + dir.file("o4"));
        CHECK(r.code == 2);
        CHECK(r.output.find("was fitted on the paper's buckets, not on a taxonomy's classes") != std::string::npos);
    }

    TEST_CASE("taxonomy: vkmech study stability --taxonomy measures the classes at the stability levels only") {
        testing::TempDir dir("taxstudy");
        std::ofstream(dir.file("lights.lpe"))
            << "first = C .* <L.'sweep_light_0'>\nsecond = C .* <L.'sweep_light_1'>\n";
        auto r = testing::run_cli(
            "study stability --preset quick --res 16 --spp-levels 2,8 --scenes sweep_lights -D "
            "lights=2 --no-plots --taxonomy " +
            dir.file("lights.lpe") + " --out " + dir.file("st"));
        REQUIRE(r.code == 0);
        CHECK(r.output.find("plan 2 renders") != std::string::npos);  // the levels only
        std::ifstream csv(dir.file("st/tables/taxonomy_shares.csv"));
        std::string header;
        std::getline(csv, header);
        CHECK(header == "scene,first,second,other");
        std::ifstream stab(dir.file("st/tables/taxonomy_stability.csv"));
        std::getline(stab, header);
        CHECK(header.find("var3") != std::string::npos);
        // --jobs carries -D and --taxonomy: the job commands render the units, then --analyse-only gives the
        // single process's tables.
        const std::string jb =
            "study stability --preset quick --res 16 --spp-levels 2,8 --scenes sweep_lights -D "
            "lights=2 --no-plots --taxonomy " +
            dir.file("lights.lpe") + " --out " + dir.file("jb");
        r = testing::run_cli(jb + " --jobs " + dir.file("jobs.txt"));
        CAPTURE(r.output);
        REQUIRE(r.code == 0);
        std::ifstream jobs(dir.file("jobs.txt"));
        size_t commands = 0;
        for (std::string line; std::getline(jobs, line); ++commands) {
            CAPTURE(line);
            CHECK(line.find("-D lights=2") != std::string::npos);
            CHECK(line.find("--taxonomy " + std::filesystem::absolute(dir.file("lights.lpe")).string()) !=
                  std::string::npos);
            CHECK(std::system((line + " > /dev/null 2>&1").c_str()) == 0);
        }
        CHECK(commands == 2);
        r = testing::run_cli(jb + " --analyse-only");
        REQUIRE(r.code == 0);
        for (const char* t : {"taxonomy_shares.csv", "taxonomy_stability.csv"}) {
            CAPTURE(t);
            CHECK(testing::read_text(dir.file(std::string("jb/tables/") + t)) ==
                  testing::read_text(dir.file(std::string("st/tables/") + t)));
        }
    }

    TEST_CASE("taxonomy: vkmech study allocation --taxonomy allocates by the classes and the properties they declare") {
        VKMECH_REQUIRE_GPU(ctx);
        testing::TempDir dir("taxalloc");
        // Every table of `study allocation --preset quick` on glass_caustic (where the floor acts), its CSV's
        // lines, but the timing tables (measurements); the notes beside them (the .md) say which labels.
        auto tables = [&](const std::string& name, const std::string& taxonomy) {
            const std::string out = dir.file(name);
            const auto r = testing::run_cli("study allocation --preset quick --scenes glass_caustic --no-plots --out " +
                                            out + (taxonomy.empty() ? "" : " --taxonomy " + taxonomy));
            CAPTURE(r.output);
            REQUIRE(r.code == 0);
            std::map<std::string, std::vector<std::string>> t;
            for (const auto& e : std::filesystem::directory_iterator(out + "/tables")) {
                const std::string file = e.path().filename().string();
                if (file.rfind("alloc_time", 0) == 0 || file.rfind("equal_time", 0) == 0) continue;
                if (e.path().extension() != ".csv") continue;
                std::ifstream in(e.path());
                for (std::string line; std::getline(in, line);) t[file].push_back(line);
            }
            return t;
        };
        const auto sorted = [](std::vector<std::string> v) {
            std::sort(v.begin(), v.end());
            return v;
        };
        const auto buckets = tables("b", "");
        REQUIRE(buckets.size() > 10);
        // paper.lpe: the buckets' tables, line for line.
        CHECK(tables("paper", source_path("taxonomies/paper.lpe")) == buckets);
        // The same lines and properties in reverse order: every class in another slot, the same partition and
        // properties, so the same tables; the per-class rows come in the classes' (reversed) order.
        std::ofstream(dir.file("reversed.lpe")) << kReversedPaper;
        const auto rev = tables("rev", dir.file("reversed.lpe"));
        REQUIRE(rev.size() == buckets.size());
        for (const auto& entry : buckets) {
            const std::string& file = entry.first;  // not a structured binding: clang 14 cannot capture one
            CAPTURE(file);
            REQUIRE(rev.count(file) == 1);
            CHECK(sorted(rev.at(file)) == sorted(entry.second));
        }
        CHECK(rev.at("perbucket_mse.csv") != buckets.at("perbucket_mse.csv"));  // the rows' order: the slots
        // Without the properties nothing is heavy: bucket-floor floors nothing and ties observed-var.
        std::string bare = kReversedPaper;
        for (const std::string p : {" [heavy rare]", " [heavy]", " [constant]"})
            for (size_t at = bare.find(p); at != std::string::npos; at = bare.find(p)) bare.erase(at, p.size());
        std::ofstream(dir.file("bare.lpe")) << bare;
        const auto plain = tables("bare", dir.file("bare.lpe"));
        REQUIRE(plain.at("downstream.csv").size() == 2);
        CHECK(plain.at("downstream.csv")[1].find(",tie,tie,") != std::string::npos);
        CHECK(buckets.at("downstream.csv")[1].find(",tie,tie,") == std::string::npos);
    }
}

namespace {

// A study's CSV tables (the file's name -> rows of cells), but those that hold measured times.
using CsvTables = std::map<std::string, std::vector<std::vector<std::string>>>;
CsvTables study_tables(const std::string& study, const std::string& out, const std::string& taxonomy,
                       const std::string& scene = "glass_caustic", const std::string& extra = "") {
    const auto r = testing::run_cli("study " + study + " --preset quick --scenes " + scene + " --no-plots --out " +
                                    out + (taxonomy.empty() ? "" : " --taxonomy " + taxonomy) + extra);
    CAPTURE(r.output);
    REQUIRE(r.code == 0);
    CsvTables t;
    for (const auto& e : std::filesystem::directory_iterator(out + "/tables")) {
        const std::string file = e.path().filename().string();
        if (e.path().extension() != ".csv" || file == "cost_by_bucket_ms.csv") continue;
        std::ifstream in(e.path());
        for (std::string line; std::getline(in, line);) {
            std::vector<std::string> cells(1);
            for (char c : line)
                if (c == ',')
                    cells.emplace_back();
                else
                    cells.back().push_back(c);
            if (file == "cost_by_bucket_detail.csv") cells.resize(6);  // less the two columns of milliseconds
            t[file].push_back(cells);
        }
    }
    return t;
}

// The rows of a table keyed by their first cell.
std::map<std::string, std::vector<std::string>> rows_by_name(const std::vector<std::vector<std::string>>& rows) {
    std::map<std::string, std::vector<std::string>> m;
    for (size_t i = 1; i < rows.size(); ++i) m[rows[i][0]] = {rows[i].begin() + 1, rows[i].end()};
    return m;
}

// A one-row table's cells keyed by their column headers.
std::map<std::string, std::string> cells_by_header(const std::vector<std::vector<std::string>>& rows) {
    REQUIRE(rows.size() == 2);
    std::map<std::string, std::string> m;
    for (size_t i = 0; i < rows[0].size(); ++i) m[rows[0][i]] = rows[1].at(i);
    return m;
}

// One study's tables with the built-in buckets, with paper.lpe and with paper.lpe's lines reversed.
struct ThreeLabellings {
    CsvTables b, paper, rev;
};
ThreeLabellings three_labellings(const std::string& study, testing::TempDir& dir) {
    std::ofstream(dir.file("reversed.lpe")) << kReversedPaper;
    return {study_tables(study, dir.file("b"), ""),
            study_tables(study, dir.file("p"), source_path("taxonomies/paper.lpe")),
            study_tables(study, dir.file("r"), dir.file("reversed.lpe"))};
}

}  // namespace

TEST_SUITE("gpu") {
    TEST_CASE("taxonomy: vkmech study variance --taxonomy splits its per-bucket tables by the classes") {
        VKMECH_REQUIRE_GPU(ctx);
        testing::TempDir dir("taxvariance");
        const ThreeLabellings runs = three_labellings("variance", dir);
        const CsvTables &b = runs.b, &paper = runs.paper, &rev = runs.rev;
        for (const std::string file : {"sigma_splithalf.csv", "alpha_reliability.csv"}) {  // class-free: unchanged
            CAPTURE(file);
            CHECK(paper.at(file) == b.at(file));
            CHECK(rev.at(file) == b.at(file));
        }
        const std::map<std::string, std::string> header = {{"dir.", "direct"},
                                                           {"diff.", "diffuse_indirect"},
                                                           {"d-m", "delta_mediated"},
                                                           {"spec.", "specular_direct"},
                                                           {"gloss.", "glossy"}};
        for (const std::string file : {"sigma_perbucket.csv", "sigma_perbucket_4.csv"}) {
            CAPTURE(file);
            const auto buckets = cells_by_header(b.at(file)), p = cells_by_header(paper.at(file)),
                       r = cells_by_header(rev.at(file));
            CHECK(buckets.size() == 1 + header.size());
            CHECK(p.size() == 1 + 7);  // the scene, six lines and `other`
            size_t measured = 0;
            for (const auto& h : header) {
                CAPTURE(h.first);
                CHECK(p.at(h.second) == buckets.at(h.first));
                CHECK(r.at(h.second) == buckets.at(h.first));
                measured += buckets.at(h.first) != "---";
            }
            CHECK(measured >= 3);  // direct, diffuse_indirect and delta_mediated have 50 pixels or more
            CHECK(p.at("other") == "---");
            CHECK(rev.at(file)[0][1] == "specular_direct");  // the columns in the slots' order
        }
    }

    TEST_CASE("taxonomy: vkmech study cost --taxonomy gives each class a row and each class's share a component") {
        VKMECH_REQUIRE_GPU(ctx);
        testing::TempDir dir("taxcost");
        const ThreeLabellings runs = three_labellings("cost", dir);
        const CsvTables &b = runs.b, &paper = runs.paper, &rev = runs.rev;
        for (const CsvTables* t : {&paper, &rev}) {
            const auto rows = rows_by_name(t->at("cost_by_bucket.csv"));
            for (const auto& row : rows_by_name(b.at("cost_by_bucket.csv"))) CHECK(rows.at(row.first) == row.second);
            CHECK(rows.at("other") == std::vector<std::string>{"---"});
            auto detail = t->at("cost_by_bucket_detail.csv"), bdetail = b.at("cost_by_bucket_detail.csv");
            detail[0][1] = "bucket";  // the header says class
            std::sort(detail.begin(), detail.end());
            std::sort(bdetail.begin(), bdetail.end());
            CHECK(detail == bdetail);
            const auto dims = rows_by_name(t->at("cost_perdim.csv")), bdims = rows_by_name(b.at("cost_perdim.csv"));
            for (const std::string d : {"depth", "inv_purity", "glossy_frac"}) CHECK(dims.at(d) == bdims.at(d));
            CHECK(dims.at("delta_mediated share") == bdims.at("caustic_frac"));
            CHECK(dims.count("other share") == 0);
            CHECK(dims.size() == 3 + 6);
        }
        CHECK(b.at("cost_by_bucket_detail.csv").size() >= 4);             // three buckets or more have pixels
        CHECK(paper.at("cost_by_bucket.csv")[1][0] == "emitter_direct");  // the rows in the slots' order
        CHECK(rev.at("cost_by_bucket.csv")[1][0] == "specular_direct");
    }

    TEST_CASE(
        "taxonomy: vkmech study structure --taxonomy correlates every pair of the classes' shares, glossy_frac, "
        "depth and inv_purity") {
        VKMECH_REQUIRE_GPU(ctx);
        testing::TempDir dir("taxstructure");
        const ThreeLabellings runs = three_labellings("structure", dir);
        // A pair by its two names in either order (the reversed lines list the classes the other way round).
        auto by_pair = [](const std::vector<std::vector<std::string>>& rows) {
            std::map<std::set<std::string>, std::string> m;
            for (const auto& row : rows_by_name(rows)) {
                const size_t at = row.first.find(" <-> ");
                REQUIRE(at != std::string::npos);
                m[{row.first.substr(0, at), row.first.substr(at + 5)}] = row.second.at(0);
            }
            return m;
        };
        const auto b = by_pair(runs.b.at("correlation_matrix.csv"));
        REQUIRE(b.size() == 6);
        // The paper's four components are three of the taxonomy's, C being delta_mediated's share.
        const std::map<std::string, std::string> same = {
            {"C", "delta_mediated share"}, {"G", "glossy_frac"}, {"D", "depth"}, {"P", "inv_purity"}};
        const auto paper = by_pair(runs.paper.at("correlation_matrix.csv"));
        const auto rev = by_pair(runs.rev.at("correlation_matrix.csv"));
        CHECK(paper.size() == 36);  // every pair of six shares (not other's), glossy_frac, depth and inv_purity
        CHECK(rev == paper);
        size_t measured = 0;
        for (const auto& pair : b) {
            std::set<std::string> names;
            for (const std::string& n : pair.first) names.insert(same.at(n));
            CAPTURE(*pair.first.begin());
            CHECK(paper.at(names) == pair.second);
            measured += pair.second != "deg.";
        }
        CHECK(measured >= 3);  // C-P, D-C and D-P are defined on glass_caustic
        CHECK(paper.at({"direct share", "depth"}) != "deg.");
        // Findings 1 and 2 read caustic_frac and the buckets' purity: not checked, and no depth_purity table.
        CHECK(runs.b.count("depth_purity.csv") == 1);
        CHECK(runs.paper.count("depth_purity.csv") == 0);
        // tab:sign-reversal's separation measures do not depend on the labels; its caustic side is the [rare]
        // classes' (delta_mediated and specular_direct under paper.lpe).
        const auto sep = runs.paper.at("sign_reversal.csv"), bsep = runs.b.at("sign_reversal.csv");
        REQUIRE(sep.size() == 2);
        REQUIRE(bsep.size() == 2);
        CHECK(std::vector<std::string>(sep[1].begin(), sep[1].begin() + 5) ==
              std::vector<std::string>(bsep[1].begin(), bsep[1].begin() + 5));

        // On a scene with glossy energy (kitchen_counter): with delta_mediated the only [rare] class, the caustic
        // side is caustic_frac and rho C-G and its interval are the built-in ones; without a [rare] class there is
        // no caustic side.
        const std::string lines =
            "emitter_direct = C [LB]\ndirect = C [DG] [LB]\ndiffuse_indirect = C [DG]+ D [LB]\n"
            "glossy = C [DG]+ G [LB]\ndelta_mediated%s = C (S+ [DG] | [DG]+ S) .* [LB]\n"
            "specular_direct = C S+ [LB]\n";
        const size_t at = lines.find("%s");
        std::ofstream(dir.file("dm_rare.lpe")) << std::string(lines).replace(at, 2, " [rare]");
        std::ofstream(dir.file("no_rare.lpe")) << std::string(lines).replace(at, 2, "");
        const auto kb = study_tables("structure", dir.file("kb"), "", "kitchen_counter");
        const auto kr = study_tables("structure", dir.file("kr"), dir.file("dm_rare.lpe"), "kitchen_counter");
        const auto kn = study_tables("structure", dir.file("kn"), dir.file("no_rare.lpe"), "kitchen_counter");
        const auto krow = kb.at("sign_reversal.csv").at(1);
        REQUIRE(krow.size() >= 7);
        CAPTURE(krow[5]);
        CHECK(krow[5] != "deg.");  // kitchen_counter has glossy and caustic energy: a defined rho
        CHECK(kr.at("sign_reversal.csv").at(1) == krow);
        const auto nrow = kn.at("sign_reversal.csv").at(1);
        REQUIRE(nrow.size() >= 7);
        CHECK(std::vector<std::string>(nrow.begin(), nrow.begin() + 5) ==
              std::vector<std::string>(krow.begin(), krow.begin() + 5));
        CHECK(nrow[5].empty());  // a number's column: the CSV leaves it empty, the Markdown says why
        CHECK(nrow[6] == "no [rare]");
    }

    TEST_CASE(
        "taxonomy: vkmech study sensitivity --taxonomy reads the classes declared heavy - paper.lpe in reverse "
        "order gives the buckets' table") {
        VKMECH_REQUIRE_GPU(ctx);
        testing::TempDir dir("taxsensitivity");
        std::ofstream(dir.file("reversed.lpe")) << kReversedPaper;
        auto table = [&](const std::string& out, const std::string& taxonomy) {
            const auto r = testing::run_cli(
                "study sensitivity --preset quick --res 16 --no-plots --scenes glass_caustic "
                "--out " +
                dir.file(out) + (taxonomy.empty() ? "" : " --taxonomy " + taxonomy));
            CAPTURE(r.output);
            REQUIRE(r.code == 0);
            std::vector<std::string> rows;
            std::ifstream in(dir.file(out + "/tables/sensitivity_glass_caustic.csv"));
            for (std::string line; std::getline(in, line);) rows.push_back(line);
            return rows;
        };
        const auto b = table("b", "");
        REQUIRE(b.size() == 19);  // the header and 18 levels
        size_t heavy_levels = 0;  // levels with heavy pixels (the 8th column), so the comparison compares them
        for (size_t i = 1; i < b.size(); ++i) {
            size_t at = 0;
            for (int c = 0; c < 7; ++c) at = b[i].find(',', at) + 1;
            heavy_levels += b[i].compare(at, 2, "0,") != 0;
        }
        CHECK(heavy_levels >= 9);
        // The reversed lines put the heavy classes (specular_direct, delta_mediated, glossy) in slots 0-2, where the
        // buckets have emitter_direct, direct and diffuse_indirect: only their declared [heavy] gives the buckets'
        // heavy share and pixels; label agreement does not depend on which slot a class is in.
        CHECK(table("r", dir.file("reversed.lpe")) == b);
        // The note names the classes declared [heavy], in their lines' order.
        const std::string report = testing::read_text(dir.file("r/report.md"));
        CHECK(report.find("declared [heavy] (specular_direct, delta_mediated, glossy)") != std::string::npos);
        CHECK(testing::read_text(dir.file("b/report.md")).find("declared [heavy]") == std::string::npos);
    }
}

TEST_SUITE("gpu") {
    TEST_CASE(
        "taxonomy: vkmech study sweep-roughness --taxonomy follows the classes declared heavy - glossy alone in "
        "another slot gives the built-in rows") {
        VKMECH_REQUIRE_GPU(ctx);
        testing::TempDir dir("taxsweep");
        // paper.lpe's lines in reverse order (glossy in slot 2, where the buckets have diffuse_indirect), with
        // [heavy] on glossy alone, on diffuse_indirect alone, or on no class.
        auto without = [](std::string text, const std::string& what) {
            for (size_t at = text.find(what); at != std::string::npos; at = text.find(what))
                text.erase(at, what.size());
            return text;
        };
        const std::string glossy = without(kReversedPaper, " [heavy rare]");
        const std::string none = without(glossy, " [heavy]");
        std::string diffuse = none;
        diffuse.replace(diffuse.find("diffuse_indirect ="), 18, "diffuse_indirect [heavy] =");
        std::ofstream(dir.file("glossy.lpe")) << glossy;
        std::ofstream(dir.file("diffuse.lpe")) << diffuse;
        std::ofstream(dir.file("none.lpe")) << none;
        // The taxonomies' lines are the same (only their properties differ): one cache serves them.
        auto rows = [&](const std::string& out, const std::string& taxonomy) {
            return study_tables("sweep-roughness", dir.file(out), taxonomy.empty() ? "" : dir.file(taxonomy),
                                "glass_caustic", taxonomy.empty() ? "" : " --cache " + dir.file("taxcache"))
                .at("sweep_roughness.csv");
        };
        const auto b = rows("b", ""), g = rows("g", "glossy.lpe");
        REQUIRE(b.size() > 2);
        REQUIRE(g.size() == b.size());
        CHECK(b[0].at(1) == "glossy-dominant px");
        CHECK(g[0].at(1) == "[heavy]-dominant px");
        size_t measured = 0;  // levels with firefly ratios, so the comparison compares them
        for (size_t i = 1; i < b.size(); ++i) {
            CAPTURE(i);
            CHECK(g[i] == b[i]);
            measured += b[i].at(3) != "---";
        }
        CHECK(measured >= 2);
        // Another class declared [heavy]: another population.
        const auto d = rows("d", "diffuse.lpe");
        REQUIRE(d.size() == b.size());
        size_t differ = 0;
        for (size_t i = 1; i < b.size(); ++i) differ += d[i].at(1) != b[i].at(1);
        CHECK(differ >= 1);
        // No [heavy] class: no population, no measure; the note says why.
        const auto n = rows("n", "none.lpe");
        for (size_t i = 1; i < n.size(); ++i) {
            CAPTURE(i);
            CHECK(n[i].at(1) == "0");
            CHECK(n[i].at(3) == "---");
        }
        CHECK(testing::read_text(dir.file("n/report.md")).find("none: the taxonomy declares no class [heavy]") !=
              std::string::npos);
    }

    TEST_CASE("taxonomy: study predictor --taxonomy fits a curve of the classes, which only the same taxonomy takes") {
        VKMECH_REQUIRE_GPU(ctx);
        testing::TempDir dir("taxcurve");
        const std::string paper = source_path("taxonomies/paper.lpe");
        auto study = [&](const std::string& out, const std::string& args) {
            return testing::run_cli("study predictor --preset quick --no-plots --out " + dir.file(out) + " " + args);
        };
        REQUIRE(study("b", "--scenes glass_caustic").code == 0);
        REQUIRE(study("t", "--scenes glass_caustic --taxonomy " + paper).code == 0);
        const std::string b = testing::read_text(dir.file("b/predictor_curve.json")),
                          t = testing::read_text(dir.file("t/predictor_curve.json"));
        // paper.lpe's classes are the buckets: the same curve, which records the taxonomy it was fitted on.
        CHECK(t.substr(0, t.find("\"scenes\"")) == b.substr(0, b.find("\"scenes\"")));
        CHECK(b.find("\"taxonomy\"") == std::string::npos);
        CHECK(t.find("\"sha256\": \"" + sha256_file(paper) + "\"") != std::string::npos);
        CHECK(testing::read_text(dir.file("t/tables/predictor.csv")) ==
              testing::read_text(dir.file("b/tables/predictor.csv")));
        const std::string bc = " --curve " + dir.file("b/predictor_curve.json"),
                          tc = " --curve " + dir.file("t/predictor_curve.json");
        // A curve predicts only the labels it was fitted on (exit 2 before anything renders).
        auto r = study("x", "--scenes cubes_dof" + tc);
        CHECK(r.code == 2);
        CHECK(r.output.find("was fitted on the classes of the taxonomy") != std::string::npos);
        r = study("x", "--scenes cubes_dof --taxonomy " + paper + bc);
        CHECK(r.code == 2);
        CHECK(r.output.find("was fitted on the paper's buckets") != std::string::npos);
        std::ofstream(dir.file("one.lpe")) << "direct = C [DG] [LB]\n";  // another taxonomy
        r = study("x", "--scenes cubes_dof --taxonomy " + dir.file("one.lpe") + tc);
        CHECK(r.code == 2);
        CHECK(r.output.find("not on this taxonomy") != std::string::npos);
        REQUIRE(study("nb", "--scenes cubes_dof" + bc).code == 0);
        REQUIRE(study("nt", "--scenes cubes_dof --taxonomy " + paper + tc).code == 0);
        CHECK(testing::read_text(dir.file("nt/tables/predictor_new.csv")) ==
              testing::read_text(dir.file("nb/tables/predictor_new.csv")));
        // Sentinels and adaptive renders take it likewise.
        const std::string reg = "sentinel register --scene glass_caustic --res 24 --pilot 8 --out ";
        REQUIRE(testing::run_cli(reg + dir.file("sb.json") + bc).code == 0);
        REQUIRE(testing::run_cli(reg + dir.file("st.json") + " --taxonomy " + paper + tc).code == 0);
        auto margin = [&](const std::string& rec) {
            const auto doc = parse_json(testing::read_text(rec));
            REQUIRE(doc);
            for (const JsonValue& p : doc->find("predictions")->array)
                if (p.find("name")->string == "reliability.margin") return p.find("predicted")->number;
            return -1.0;
        };
        CHECK(margin(dir.file("sb.json")) > 0.0);
        CHECK(margin(dir.file("st.json")) == margin(dir.file("sb.json")));
        r = testing::run_cli(reg + dir.file("sx.json") + tc);
        CHECK(r.code == 2);
        CHECK(r.output.find("was fitted on the classes of the taxonomy") != std::string::npos);
        r = testing::run_cli(
            "render --scene glass_caustic --res 16 --adaptive observed-var --pilot 4 --budget 4 "
            "--taxonomy " +
            paper + bc + " --out " + dir.file("a"));
        CHECK(r.code == 2);
        CHECK(r.output.find("was fitted on the paper's buckets") != std::string::npos);
    }
}

TEST_SUITE("gpu") {
    TEST_CASE("taxonomy: an environment is B and a directional light is L") {
        VKMECH_REQUIRE_GPU(ctx);
        Scene s = testing::quad_scene();
        s.meshes[0].positions = {{-10, -10, 0}, {-10, 10, 0}, {10, 10, 0}, {10, -10, 0}};  // fills the view
        s.materials[0].reflectance.value = glm::vec3(0.5f);
        s.environment.kind = EnvironmentKind::Constant;
        s.environment.radiance = glm::vec3(0.25f);
        s.directional_lights.push_back({glm::vec3(0.0f, 0.0f, 1.0f), glm::vec3(2.0f)});  // head-on
        RenderSession session(*ctx, std::move(s), Traversal::Bvh);
        Features f = session.features(Estimator::Mis);
        f.taxonomy = compile_scene_taxonomy(taxonomy_text("sky = C .* B\nsun = C .* L\n"), session.scene()).words;
        const Frame frame = render(session, f, 256);
        double sky = 0, sun = 0, other = 0;
        for (const auto& p : frame.pixels) {
            sky += p.bucket_sum[0] / p.count / frame.pixels.size();
            sun += p.bucket_sum[1] / p.count / frame.pixels.size();
            other += p.bucket_sum[2] / p.count / frame.pixels.size();
        }
        // A white-ish plane facing the sun: albedo x E / pi from the sun; from the sky (the plane seen
        // from the front only, its back hemisphere hidden) albedo x L.
        CHECK(sun == doctest::Approx(0.5 * 2.0 / 3.14159265358979).epsilon(0.05));
        CHECK(sky == doctest::Approx(0.5 * 0.25).epsilon(0.05));
        CHECK(other == 0.0);
    }
}

TEST_SUITE("gpu") {
    TEST_CASE("taxonomy: under paper.lpe, --adaptive and --noise-threshold allocate as with the built-in buckets") {
        testing::TempDir dir("taxadaptive");
        const std::string paper = " --taxonomy " + source_path("taxonomies/paper.lpe");
        // Every channel both EXRs have (the taxonomy's lack caustic_frac and add depth_energy), bit for bit.
        auto same = [&](const std::string& a, const std::string& b) {
            const ExrImage x = read_exr_channels(dir.file(a + "/glass_caustic.exr"));
            const ExrImage y = read_exr_channels(dir.file(b + "/glass_caustic.exr"));
            size_t compared = 0;
            for (const auto& channel : x.channels) {
                const std::string& name = channel.first;  // not a structured binding: clang 14 cannot capture one
                if (!y.channels.count(name)) continue;
                CAPTURE(name);
                CHECK(channel.second == y.channels.at(name));
                ++compared;
            }
            CHECK(compared >= 30);  // RGB, the seven buckets' channels, the moments, spp (and err)
            CHECK(y.attributes.count("vkmech.taxonomy") == 1);
        };
        int builtin_dark = -1;  // the built-in guard's dark pixels beside seen ones
        for (const std::string strategy : {"bucket-floor", "guarded"}) {
            CAPTURE(strategy);
            const std::string cmd = "render --scene glass_caustic --res 24 --adaptive " + strategy +
                                    " --pilot 4 --budget 8 --out " + dir.file("b_" + strategy);
            const auto builtin = testing::run_cli(cmd);
            CAPTURE(builtin.output);
            REQUIRE(builtin.code == 0);
            // The floor acts on glass_caustic's pilot (its caustic is heavy-tailed), and the guard flags dark
            // pixels (23 on lavapipe) while it trusts the lamp seen directly: equality is not an abstention.
            CHECK(builtin.output.find("identical to observed-var") == std::string::npos);
            CHECK(guard_counts(builtin.output).first == 0);
            CHECK(guard_counts(builtin.output).second > 0);
            if (strategy == "guarded") builtin_dark = guard_counts(builtin.output).second;
            const std::string tcmd = "render --scene glass_caustic --res 24 --adaptive " + strategy +
                                     " --pilot 4 --budget 8 --out " + dir.file("t_" + strategy) + paper;
            const auto tax = testing::run_cli(tcmd);
            CAPTURE(tax.output);
            REQUIRE(tax.code == 0);
            same("b_" + strategy, "t_" + strategy);
        }
        const std::string thr = "render --scene glass_caustic --res 24 --noise-threshold 0.2 --min-spp 4 --max-spp 32 ";
        REQUIRE(testing::run_cli(thr + "--out " + dir.file("b_thr")).code == 0);
        const auto t = testing::run_cli(thr + "--out " + dir.file("t_thr") + paper);
        CAPTURE(t.output);
        REQUIRE(t.code == 0);
        same("b_thr", "t_thr");

        // The same lines in reverse order put every bucket in another slot (b -> 5 - b), so only the
        // declared properties, not the slots, can make the floor and the guard act as the built-in ones:
        // the same allocation (spp) and image. Without the properties the allocation differs.
        std::ofstream(dir.file("reversed.lpe")) << kReversedPaper;
        std::string bare = kReversedPaper;
        for (const std::string p : {" [heavy rare]", " [heavy]", " [constant]"})
            for (size_t at = bare.find(p); at != std::string::npos; at = bare.find(p)) bare.erase(at, p.size());
        std::ofstream(dir.file("bare.lpe")) << bare;
        auto planes = [&](const std::string& out) {
            const ExrImage x = read_exr_channels(dir.file(out + "/glass_caustic.exr"));
            std::vector<std::vector<float>> v;
            for (const char* c : {"spp", "R", "G", "B", "lum_var"}) v.push_back(x.channels.at(c));
            return v;
        };
        const std::string guarded = "render --scene glass_caustic --res 24 --adaptive guarded --pilot 4 --budget 8 ";
        REQUIRE(
            testing::run_cli(guarded + "--taxonomy " + dir.file("reversed.lpe") + " --out " + dir.file("rev")).code ==
            0);
        CHECK(planes("rev") == planes("b_guarded"));
        REQUIRE(
            testing::run_cli(thr + "--taxonomy " + dir.file("reversed.lpe") + " --out " + dir.file("rev_thr")).code ==
            0);
        CHECK(planes("rev_thr") == planes("b_thr"));
        REQUIRE(testing::run_cli(guarded + "--taxonomy " + dir.file("bare.lpe") + " --out " + dir.file("bare")).code ==
                0);
        CHECK(planes("bare")[0] != planes("b_guarded")[0]);

        // Without [constant], a lamp pixel's zero pilot variance is no longer vouched for.
        std::ifstream in(source_path("taxonomies/paper.lpe"));
        std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
        const size_t at = text.find("emitter_direct [constant]");
        REQUIRE(at != std::string::npos);
        text.replace(at, std::strlen("emitter_direct [constant]"), "emitter_direct");
        std::ofstream(dir.file("no_constant.lpe")) << text;
        const auto nc = testing::run_cli(
            "render --scene glass_caustic --res 24 --adaptive guarded --pilot 4 --budget 8 --taxonomy " +
            dir.file("no_constant.lpe") + " --out " + dir.file("nc"));
        CHECK(nc.code == 0);
        // The lamp's pixel: seen, zero pilot variance, and no longer trusted; the dark pixels as before.
        CHECK(guard_counts(nc.output) == std::make_pair(1, builtin_dark));

        // A taxonomy that declares no class heavy: the floor has nothing to floor.
        std::ofstream(dir.file("plain.lpe")) << "caustic = C D [SG]+ [LB]\n";
        const auto plain = testing::run_cli(
            "render --scene glass_caustic --res 24 --adaptive bucket-floor --pilot 4 --budget 8 --taxonomy " +
            dir.file("plain.lpe") + " --out " + dir.file("plain"));
        CHECK(plain.code == 0);
        CHECK(plain.output.find("bucket-floor: no heavy-tailed pilot pixels, identical to observed-var") !=
              std::string::npos);
        std::ifstream json(dir.file("t_guarded/glass_caustic.json"));
        const std::string js((std::istreambuf_iterator<char>(json)), std::istreambuf_iterator<char>());
        CHECK(js.find("\"name\": \"glossy\", \"expression\": \"C [DG]+ G [LB]\", \"heavy\": true") !=
              std::string::npos);
        // robust-adaptive keeps the plain variance on the [rare] classes: the reversed lines declare the
        // paper's two (delta_mediated, specular_direct) in other slots and allocate as the buckets do;
        // without the property robust-adaptive is robust-var, and allocates otherwise here.
        const std::string robust =
            "render --scene glass_caustic --res 24 --adaptive robust-adaptive --pilot 16 --budget 8 --out ";
        const auto rb = testing::run_cli(robust + dir.file("r_b"));
        REQUIRE(rb.code == 0);
        CHECK(rb.output.find("k = 1 (the plain pilot variance) on ") != std::string::npos);
        const auto rt = testing::run_cli(robust + dir.file("r_rev") + " --taxonomy " + dir.file("reversed.lpe"));
        CAPTURE(rt.output);
        REQUIRE(rt.code == 0);
        CHECK(rt.output.find("pilot pixels of the taxonomy's [rare] classes, k = ") != std::string::npos);
        CHECK(planes("r_rev") == planes("r_b"));
        const auto rn = testing::run_cli(robust + dir.file("r_bare") + " --taxonomy " + dir.file("bare.lpe"));
        REQUIRE(rn.code == 0);
        CHECK(rn.output.find("robust-adaptive: no pilot pixels of the taxonomy's [rare] classes, identical to "
                             "robust-var") != std::string::npos);
        CHECK(planes("r_bare")[0] != planes("r_b")[0]);
        const std::string robust_var =
            "render --scene glass_caustic --res 24 --adaptive robust-var --pilot 16 --budget 8 ";
        REQUIRE(testing::run_cli(robust_var + "--out " + dir.file("r_var")).code == 0);
        CHECK(planes("r_bare") == planes("r_var"));
    }
}
TEST_SUITE("gpu") {
    TEST_CASE("taxonomy: render --lpe adds overlapping query channels over the same samples, _rest and _overlap") {
        testing::TempDir dir("lpecli");
        const std::string scene = "render --scene sweep_lights -D lights=2 --res 24 --spp 8 ";
        const std::string first = "first=C .* <L.'sweep_light_0'>", second = "second=C .* <L.'sweep_light_1'>";
        // `all` holds every other query; `first` and `second` split it; `bounced` crosses both.
        auto r = testing::run_cli(scene + "--lpe \"all=C .* [LB]\" --lpe \"" + first + "\" --lpe \"" + second +
                                  "\" --lpe \"bounced=C . .+ [LB]\" --out " + dir.file("q"));
        INFO(r.output);
        REQUIRE(r.code == 0);
        const ExrImage q = read_exr_channels(dir.file("q/sweep_lights.exr"));
        // The same lines as a taxonomy (a partition, first match wins), and the plain render.
        std::ofstream(dir.file("lights.lpe")) << first << "\n" << second << "\n";
        r = testing::run_cli(scene + "--taxonomy " + dir.file("lights.lpe") + " --out " + dir.file("t"));
        REQUIRE(r.code == 0);
        const ExrImage t = read_exr_channels(dir.file("t/sweep_lights.exr"));
        auto ch = [](const ExrImage& e, const std::string& name) -> const std::vector<float>& {
            CAPTURE(name);
            REQUIRE(e.channels.count(name) == 1);
            return e.channels.at(name);
        };
        auto near = [](double a, double b) {
            return std::abs(a - b) <= 1e-5 * std::max(std::abs(a), std::abs(b)) + 1e-7;
        };
        size_t pixels = ch(q, "R").size(), bounced_lit = 0, direct_lit = 0, bad = 0;
        for (const char* c : {"R", "G", "B"}) {
            const std::string s = std::string(".") + c;
            for (size_t i = 0; i < pixels; ++i) {
                const double img = ch(q, c)[i], all = ch(q, "lpe.all" + s)[i], a = ch(q, "lpe.first" + s)[i],
                             b = ch(q, "lpe.second" + s)[i], bounced = ch(q, "lpe.bounced" + s)[i],
                             rest = ch(q, "lpe._rest" + s)[i], overlap = ch(q, "lpe._overlap" + s)[i];
                bool ok = img == ch(t, c)[i];                                  // the plain image is the taxonomy's
                ok = ok && near(all, img) && near(a + b, img) && rest == 0.0;  // every path is in all
                ok = ok && near(a, ch(t, "bucket.first" + s)[i]) && near(b, ch(t, "bucket.second" + s)[i]);
                ok = ok && near(overlap, a + b + bounced);                     // all + first + second + bounced - all
                ok = ok && near(all + a + b + bounced + rest - overlap, img);  // the identity of the channels
                ok = ok && bounced <= all * (1 + 1e-5) + 1e-7;
                bounced_lit += bounced > 0.0;
                direct_lit += all > bounced * (1 + 1e-3);
                if (!ok) {
                    ++bad;
                    if (bad <= 3)
                        MESSAGE(c << " pixel " << i << ": image " << img << " all " << all << " first " << a
                                  << " second " << b << " bounced " << bounced << " rest " << rest << " overlap "
                                  << overlap);
                }
            }
        }
        CHECK(bad == 0);
        CHECK(bounced_lit > pixels);  // over three channels: some light came after a bounce
        CHECK(direct_lit > pixels);   // and some directly, or at the first surface
        std::ifstream json(dir.file("q/sweep_lights.json"));
        const std::string js((std::istreambuf_iterator<char>(json)), std::istreambuf_iterator<char>());
        CHECK(js.find("\"lpe\": {\"queries\": [{\"name\": \"all\"") != std::string::npos);
        CHECK(js.find("\"all&first&bounced\"") != std::string::npos);

        // Refusals, each naming the reason.
        auto refused = [&](const std::string& args, const std::string& says) {
            CAPTURE(args);
            auto x = testing::run_cli("render --scene cubes_dof --res 8 --spp 1 " + args + " --out " + dir.file("no"));
            CHECK(x.code == 2);
            CAPTURE(x.output);
            CHECK(x.output.find(says) != std::string::npos);
        };
        std::string seven;  // seven disjoint queries: paths of 0 to 6 bounces
        for (int k = 0; k < 7; ++k) {
            seven += " --lpe \"n" + std::to_string(k) + "=C";
            for (int j = 0; j < k; ++j) seven += " .";
            seven += " [LB]\"";
        }
        refused(seven,
                "can match 7 combinations of the queries (n0, n1, n2, n3, n4, n5, n6); the tally has room for 6");
        refused("--lpe \"x=C (D L\"", "--lpe:1:");
        refused("--lpe \"a=C L\" --lpe \"b [heavy] = C D L\"", "--lpe:2:3: a query takes no properties");
        refused("--lpe \"_rest=C L\"", "`_rest` is reserved");
        refused("--lpe \"a=C L\" --capture off", "--lpe needs --capture on");
        refused("--lpe \"a=C L\" --adaptive bucket-floor --pilot 4 --budget 8",
                "--lpe is for a render of a fixed budget");
        refused("--lpe \"a=C L\" --noise-threshold 0.1", "--lpe is for a render of a fixed budget");
        refused("--lpe \"a=C L\" --preview", "--lpe and --preview: the direct-light preview tallies no paths");
        refused("--taxonomy " + dir.file("lights.lpe") + " --preview", "--taxonomy and --preview");
    }
}
