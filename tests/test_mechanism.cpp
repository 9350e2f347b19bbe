// The seven-bucket cascade of docs/descriptor.md §2 on synthetic events, through the very
// function the shader runs (shaders/mechanism.glsl compiled as C++).
#include "mechanism.glsl"

#include <doctest/doctest.h>

#include <initializer_list>

using namespace vkmech::shader;

TEST_CASE("mechanism: every row of the docs/descriptor.md §2 cascade") {
    // 1. n = 0 -> emitter_direct, whatever the lobe or flag.
    CHECK(classify_event(0, LOBE_NONE, false) == BUCKET_EMITTER_DIRECT);
    CHECK(classify_event(0, LOBE_S, true) == BUCKET_EMITTER_DIRECT);
    // 2. end lobe S -> specular_direct, before the delta flag is looked at.
    CHECK(classify_event(1, LOBE_S, false) == BUCKET_SPECULAR_DIRECT);
    CHECK(classify_event(3, LOBE_S, true) == BUCKET_SPECULAR_DIRECT);
    // 3. a lobe outside {D, G} -> other.
    CHECK(classify_event(2, LOBE_NONE, false) == BUCKET_OTHER);
    CHECK(classify_event(2, 17u, true) == BUCKET_OTHER);
    // 4. delta before the end vertex -> delta_mediated, for D and G ends.
    CHECK(classify_event(2, LOBE_D, true) == BUCKET_DELTA_MEDIATED);
    CHECK(classify_event(5, LOBE_G, true) == BUCKET_DELTA_MEDIATED);
    // 5. n = 1 -> direct, for D and G ends.
    CHECK(classify_event(1, LOBE_D, false) == BUCKET_DIRECT);
    CHECK(classify_event(1, LOBE_G, false) == BUCKET_DIRECT);
    // 6. D end, n > 1 -> diffuse_indirect.
    CHECK(classify_event(2, LOBE_D, false) == BUCKET_DIFFUSE_INDIRECT);
    CHECK(classify_event(11, LOBE_D, false) == BUCKET_DIFFUSE_INDIRECT);
    // 7. G end, n > 1 -> glossy.
    CHECK(classify_event(2, LOBE_G, false) == BUCKET_GLOSSY);
}

TEST_CASE("mechanism: the paper's worked examples (docs/descriptor.md §2)") {
    // E-S-D-L: chrome ball reflecting lit felt. NEE at V2 (felt, D); V1 delta.
    CHECK(classify_event(2, LOBE_D, true) == BUCKET_DELTA_MEDIATED);
    // E-G-D-L: rough plate reflecting a lit diffuse wall: end vertex D, no delta.
    CHECK(classify_event(2, LOBE_D, false) == BUCKET_DIFFUSE_INDIRECT);
}

// A BSDF-sampled emitter hit shot from Vn, labelled under one reading:
// lobes[i] is the lobe sampled at V(i+1); the last one shot the ray.
static uint label_bsdf_hit(bool literal, std::initializer_list<uint> lobes) {
    uint n = static_cast<uint>(lobes.size());
    uint last_nondelta = LOBE_NONE;
    bool delta_before = false;
    uint i = 0, lobe_n = LOBE_NONE;
    for (uint l : lobes) {
        if (++i == n) {
            lobe_n = l;
            break;
        }
        if (l == LOBE_S)
            delta_before = true;
        else
            last_nondelta = l;
    }
    return classify_event(n, bsdf_hit_end_lobe(literal, lobe_n, last_nondelta),
                          bsdf_hit_delta(literal, lobe_n, last_nondelta, delta_before));
}

TEST_CASE("mechanism: docs/descriptor.md §2 worked examples under the last-non-delta reading (the default)") {
    // E-S-D-L by BSDF sampling from the felt (D) after the chrome ball (S).
    CHECK(label_bsdf_hit(false, {LOBE_S, LOBE_D}) == BUCKET_DELTA_MEDIATED);
    // E-G-D-L: rough plate, then a diffuse wall whose sampled ray hit the light.
    CHECK(label_bsdf_hit(false, {LOBE_G, LOBE_D}) == BUCKET_DIFFUSE_INDIRECT);
    // E-D-S-L: a caustic on a diffuse floor found by BSDF sampling: the end
    // vertex is the floor, the glass is the other (delta) vertex.
    CHECK(label_bsdf_hit(false, {LOBE_D, LOBE_S}) == BUCKET_DELTA_MEDIATED);
    // E-D-S-S-L: through both surfaces of a glass sphere.
    CHECK(label_bsdf_hit(false, {LOBE_D, LOBE_S, LOBE_S}) == BUCKET_DELTA_MEDIATED);
    // E-G-S-L: a rough plate seeing the light in a mirror.
    CHECK(label_bsdf_hit(false, {LOBE_G, LOBE_S}) == BUCKET_DELTA_MEDIATED);
    // E-S-S-L: the light seen through a glass sphere: no non-delta vertex.
    CHECK(label_bsdf_hit(false, {LOBE_S, LOBE_S}) == BUCKET_SPECULAR_DIRECT);
    // E-S-L: the light in a mirror.
    CHECK(label_bsdf_hit(false, {LOBE_S}) == BUCKET_SPECULAR_DIRECT);
    // Hits from a non-delta vertex read the same as before: E-D-G-L.
    CHECK(label_bsdf_hit(false, {LOBE_D, LOBE_G}) == BUCKET_GLOSSY);
    CHECK(label_bsdf_hit(false, {LOBE_S, LOBE_D, LOBE_G}) == BUCKET_DELTA_MEDIATED);
}

TEST_CASE("mechanism: the literal reading (--end-vertex literal) keeps the last surface vertex") {
    CHECK(label_bsdf_hit(true, {LOBE_D, LOBE_S}) == BUCKET_SPECULAR_DIRECT);
    CHECK(label_bsdf_hit(true, {LOBE_D, LOBE_S, LOBE_S}) == BUCKET_SPECULAR_DIRECT);
    CHECK(label_bsdf_hit(true, {LOBE_S, LOBE_S}) == BUCKET_SPECULAR_DIRECT);
    CHECK(label_bsdf_hit(true, {LOBE_S, LOBE_D}) == BUCKET_DELTA_MEDIATED);
    CHECK(label_bsdf_hit(true, {LOBE_G, LOBE_D}) == BUCKET_DIFFUSE_INDIRECT);
    // The two readings differ only where a delta lobe shot the ray after a
    // non-delta vertex.
    for (uint a : {LOBE_D, LOBE_G, LOBE_S})
        for (uint b : {LOBE_D, LOBE_G}) CHECK(label_bsdf_hit(true, {a, b}) == label_bsdf_hit(false, {a, b}));
}

TEST_CASE("mechanism: heavy-tailed family") {
    CHECK_FALSE(bucket_is_heavy(BUCKET_EMITTER_DIRECT));
    CHECK_FALSE(bucket_is_heavy(BUCKET_DIRECT));
    CHECK_FALSE(bucket_is_heavy(BUCKET_DIFFUSE_INDIRECT));
    CHECK(bucket_is_heavy(BUCKET_GLOSSY));
    CHECK(bucket_is_heavy(BUCKET_DELTA_MEDIATED));
    CHECK(bucket_is_heavy(BUCKET_SPECULAR_DIRECT));
    CHECK_FALSE(bucket_is_heavy(BUCKET_OTHER));
}
