// `vkmech study sensitivity` (docs/results/sensitivity): the axes vary what they
// say and nothing else (the light's power stays fixed while its size changes,
// every axis passes once through the scene as committed), the plan renders
// each level's pilot, reference and seeds, and end to end the committed scene
// measures the same on every axis.
#include "experiments/study_config.hpp"
#include "gpu_fixture.hpp"
#include "scene/scene.hpp"
#include "study/study_runner.hpp"

#include <doctest/doctest.h>

#include <glm/glm.hpp>

#include <unistd.h>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

namespace fs = std::filesystem;
using namespace vkmech;

namespace {

std::string scene_path(const std::string& name) { return std::string(VKMECH_SOURCE_DIR) + "/scenes/" + name + ".xml"; }

StudyConfig two_scene_config() {
    StudyConfig cfg = preset_config("quick");
    cfg.scenes = {{"glass_caustic", scene_path("glass_caustic"), {}}, {"cubes_dof", scene_path("cubes_dof"), {}}};
    return cfg;
}

// The emitted power's spectral factor: radiance x area of the one emitter (one-sided, so the pi and the
// cosine integral are common to every level).
double emitter_power(const Scene& s) {
    REQUIRE(s.emitters.size() == 1);
    const Mesh& m = s.meshes[s.emitters[0].mesh];
    double area = 0;
    for (const auto& t : m.indices)
        area += 0.5 * glm::length(glm::cross(m.positions[t.y] - m.positions[t.x], m.positions[t.z] - m.positions[t.x]));
    return static_cast<double>(s.emitters[0].radiance.x) * area;
}

Scene load_level(const SensitivityLevel& lv) {
    LoadOptions lo;
    lo.params = lv.variant.params;
    return load_scene(lv.variant.path, lo);
}

const Material& material_of_shape(const Scene& s, const std::string& shape) {
    for (const auto& m : s.meshes)
        if (m.name == shape) return s.materials.at(m.material);
    FAIL("no shape " << shape);
    return s.materials.front();
}

}  // namespace

TEST_CASE("sensitivity: each axis passes once through the scene as committed and varies only its parameter") {
    const StudyConfig cfg = two_scene_config();
    const auto axes = sensitivity_axes(cfg);
    REQUIRE(axes.size() ==
            7);  // glass_caustic: light size, IOR, roughness, estimator; cubes_dof: aperture, film, light
    for (const auto& a : axes) {
        CAPTURE(a.name);
        const SceneVariant& committed = a.scene == "glass_caustic" ? cfg.scenes[0] : cfg.scenes[1];
        size_t as_committed = 0;
        for (const auto& lv : a.levels) as_committed += lv.variant == committed && lv.estimator == Estimator::Nee;
        CHECK(as_committed == 1);
        REQUIRE(a.base < a.levels.size());
        CHECK(a.levels[a.base].variant == committed);
        std::set<std::string> names;
        for (const auto& lv : a.levels) names.insert(lv.variant.name + to_string(lv.estimator));
        CHECK(names.size() == a.levels.size());  // distinct levels, distinct display names
    }
    // A scene of another stem, or a variant, has no axes.
    StudyConfig other = preset_config("quick");
    other.scenes = {{"snooker", scene_path("snooker"), {}},
                    {"glass_caustic", scene_path("glass_caustic"), {{"ior", "2"}}}};
    CHECK(sensitivity_axes(other).empty());
}

TEST_CASE(
    "sensitivity: the light-size levels keep the committed light's power, and the other levels load what they "
    "name") {
    const StudyConfig cfg = two_scene_config();
    const auto axes = sensitivity_axes(cfg);
    // The committed lights: glass_caustic 40 x (0.4 m)^2, cubes_dof 10 x (2 m)^2 (their XML files).
    const double power_glass = 40.0 * 0.4 * 0.4, power_cubes = 10.0 * 2.0 * 2.0;
    size_t light_levels = 0;
    for (const auto& a : axes) {
        if (a.name != "light size at fixed power") continue;
        for (const auto& lv : a.levels) {
            CAPTURE(lv.variant.name);
            const Scene s = load_level(lv);
            const double want = a.scene == "glass_caustic" ? power_glass : power_cubes;
            CHECK(emitter_power(s) == doctest::Approx(want).epsilon(1e-5));
            // The size on the axis is the light's half-width.
            const double half = std::sqrt(emitter_power(s) / s.emitters[0].radiance.x) / 2.0;
            CHECK(half == doctest::Approx(lv.x).epsilon(1e-5));
            ++light_levels;
        }
    }
    CHECK(light_levels == 8);
    for (const auto& a : axes) {
        for (const auto& lv : a.levels) {
            CAPTURE(lv.variant.name);
            if (a.name == "sphere IOR") {
                const Scene s = load_level(lv);  // kept alive: m refers into it
                const Material& m = material_of_shape(s, "glass_sphere");
                CHECK(m.type == BsdfType::Dielectric);
                CHECK(m.int_ior == doctest::Approx(lv.x));
            }
            if (a.name == "sphere roughness") {
                const Scene s = load_level(lv);
                const Material& m = material_of_shape(s, "glass_sphere");
                if (lv.x == 0.0) {
                    CHECK(m.type == BsdfType::Dielectric);
                } else {
                    CHECK(m.type == BsdfType::RoughDielectric);
                    CHECK(m.alpha_u == doctest::Approx(lv.x));
                    CHECK(m.int_ior == doctest::Approx(1.5));
                }
            }
            if (a.name == "thin-lens aperture") CHECK(load_level(lv).camera.aperture_radius == doctest::Approx(lv.x));
            if (a.name == "film width (pixel footprint)") {
                const LoadedScene ls = load_variant(lv.variant, cfg.res, Traversal::Bvh);
                CHECK(ls.scene.camera.width == static_cast<int>(lv.x));
            }
        }
    }
}

TEST_CASE("sensitivity: the plan renders each level's pilot, reference and seeds, and all leaves it out") {
    const StudyConfig cfg = two_scene_config();
    const auto plan = plan_renders(cfg, StudyKind::Sensitivity);
    size_t levels = 0;
    for (const auto& a : sensitivity_axes(cfg)) levels += a.levels.size();
    CHECK(plan.size() == levels * (2 + static_cast<size_t>(cfg.variance_seeds)));
    std::set<uint32_t> seeds_used;
    for (const auto& r : plan) seeds_used.insert(r.seed);
    CHECK(seeds_used.count(seeds::stability(0)) == 1);
    CHECK(seeds_used.count(seeds::stability(cfg.stability_spp.size() - 1)) == 1);
    for (int s = 0; s < cfg.variance_seeds; ++s) CHECK(seeds_used.count(seeds::sensitivity(s)) == 1);
    CHECK(seeds_used.size() == 2 + static_cast<size_t>(cfg.variance_seeds));
    const auto all = parse_study("all");
    CHECK(std::find(all.begin(), all.end(), StudyKind::Sensitivity) == all.end());
    CHECK(parse_study("sensitivity") == std::vector<StudyKind>{StudyKind::Sensitivity});
}

TEST_SUITE("gpu") {
    TEST_CASE(
        "sensitivity: vkmech study sensitivity writes its table and figure, and the committed scene measures "
        "the same on every axis") {
        VKMECH_REQUIRE_GPU(ctx);
        const fs::path out = fs::temp_directory_path() / ("vkmech_sensitivity_" + std::to_string(::getpid()));
        fs::remove_all(out);
        const std::string cmd = std::string(VKMECH_CLI) +
                                " study sensitivity --preset quick --res 16 --no-plots --scenes glass_caustic --out " +
                                out.string() + " > " + out.string() + ".log 2>&1";
        const int status = std::system(cmd.c_str());
        std::ifstream logf(out.string() + ".log");
        std::stringstream log;
        log << logf.rdbuf();
        INFO(log.str());
        REQUIRE(status == 0);
        std::ifstream csv(out / "tables" / "sensitivity_glass_caustic.csv");
        REQUIRE(csv.good());
        CHECK(fs::exists(out / "figures" / "sensitivity_glass_caustic.json"));
        std::string line;
        std::getline(csv, line);  // header
        std::vector<std::string> committed_rows;
        size_t rows = 0;
        while (std::getline(csv, line)) {
            ++rows;
            if (line.find("as committed") == std::string::npos) continue;
            // Everything after the level's name: the measures.
            const size_t second_comma = line.find(',', line.find(',') + 1);
            committed_rows.push_back(line.substr(second_comma));
        }
        CHECK(rows == 18);
        REQUIRE(committed_rows.size() == 4);
        for (const auto& r : committed_rows) CHECK(r == committed_rows.front());
        fs::remove_all(out);
        fs::remove(out.string() + ".log");
    }
}
