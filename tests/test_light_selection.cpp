// docs/descriptor.md §1 light selection for NEE: uniform over emitters (the default, as
// Mitsuba) or proportional to power, then uniform over the chosen emitter's
// area. Checked on the light table the GPU samples from, with hand-computed
// probabilities.
#include "render/gpu_scene.hpp"
#include "scene/primitives.hpp"
#include "scene_fixtures.hpp"

#include <doctest/doctest.h>

#include <glm/gtc/matrix_transform.hpp>

#include <bit>
#include <vector>

using namespace vkmech;

namespace {

// The quad scene plus three emitters: A = a 2x2 rectangle (area 4) of
// radiance 1, B = a 0.2x0.2 rectangle (area 0.04) of radiance 10, C = a
// 2x2 rectangle of radiance 0 (emits nothing, never selected).
Scene three_emitters() {
    Scene s = testing::quad_scene();
    auto add = [&](const glm::mat4& m, glm::vec3 radiance) {
        Mesh mesh = make_rectangle(m);
        mesh.material = 0;
        mesh.emitter = static_cast<int>(s.emitters.size());
        s.emitters.push_back({radiance, static_cast<int>(s.meshes.size())});
        s.meshes.push_back(mesh);
    };
    add(glm::translate(glm::mat4(1.0f), {0, 0, 2}), glm::vec3(1.0f));
    add(glm::scale(glm::translate(glm::mat4(1.0f), {0, 0, 3}), {0.1f, 0.1f, 1.0f}), glm::vec3(10.0f));
    add(glm::translate(glm::mat4(1.0f), {0, 0, 4}), glm::vec3(0.0f));
    return s;
}

struct PerEmitter {
    double probability = 0.0;  // summed selection probability of its triangles
    float pdf_area = 0.0f;     // GpuEmitter::info.w
};

std::vector<PerEmitter> per_emitter(const SceneArrays& a) {
    std::vector<PerEmitter> out(a.emitters.size());
    double prev = 0.0;
    for (const auto& lt : a.light_triangles) {
        out[lt.info.y].probability += lt.cdf.x - prev;
        prev = lt.cdf.x;
        // Every triangle of an emitter has the emitter's area pdf.
        CHECK(lt.cdf.z == doctest::Approx(std::bit_cast<float>(a.emitters[lt.info.y].info.w)).epsilon(1e-5));
    }
    for (size_t e = 0; e < a.emitters.size(); ++e) out[e].pdf_area = std::bit_cast<float>(a.emitters[e].info.w);
    return out;
}

}  // namespace

TEST_CASE("light selection: uniform gives each emitting emitter the same probability") {
    SceneArrays a = flatten_scene(three_emitters(), LightSelection::Uniform);
    auto e = per_emitter(a);
    REQUIRE(e.size() == 3);
    CHECK(e[0].probability == doctest::Approx(0.5).epsilon(1e-6));
    CHECK(e[1].probability == doctest::Approx(0.5).epsilon(1e-6));
    CHECK(e[2].probability == 0.0);
    CHECK(e[0].pdf_area == doctest::Approx(0.5 / 4.0).epsilon(1e-5));
    CHECK(e[1].pdf_area == doctest::Approx(0.5 / 0.04).epsilon(1e-5));
    CHECK(e[2].pdf_area == 0.0f);
}

TEST_CASE("light selection: power weighs emitters by luminance times area") {
    SceneArrays a = flatten_scene(three_emitters(), LightSelection::Power);
    auto e = per_emitter(a);
    // Powers 1 * 4 = 4 and 10 * 0.04 = 0.4.
    CHECK(e[0].probability == doctest::Approx(4.0 / 4.4).epsilon(1e-6));
    CHECK(e[1].probability == doctest::Approx(0.4 / 4.4).epsilon(1e-6));
    CHECK(e[0].pdf_area == doctest::Approx(4.0 / 4.4 / 4.0).epsilon(1e-5));
    CHECK(e[1].pdf_area == doctest::Approx(0.4 / 4.4 / 0.04).epsilon(1e-5));
}

TEST_CASE("light selection: the default of flatten_scene is uniform and names parse") {
    CHECK(flatten_scene(three_emitters()).light_selection == LightSelection::Uniform);
    CHECK(parse_light_selection("power") == LightSelection::Power);
    CHECK(parse_light_selection("uniform") == LightSelection::Uniform);
    CHECK_THROWS_AS(parse_light_selection("area"), std::invalid_argument);
}
