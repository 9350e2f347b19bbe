// The seven-bucket cascade of SPEC §2 on synthetic events, through the very
// function the shader runs (shaders/mechanism.glsl compiled as C++).
#include "mechanism.glsl"

#include <doctest/doctest.h>

using namespace vkmech::shader;

TEST_CASE("mechanism: every row of the SPEC §2 cascade") {
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

TEST_CASE("mechanism: the paper's worked examples (SPEC §2)") {
    // E-S-D-L: chrome ball reflecting lit felt. NEE at V2 (felt, D); V1 delta.
    CHECK(classify_event(2, LOBE_D, true) == BUCKET_DELTA_MEDIATED);
    // E-G-D-L: rough plate reflecting a lit diffuse wall: end vertex D, no delta.
    CHECK(classify_event(2, LOBE_D, false) == BUCKET_DIFFUSE_INDIRECT);
    // E-D-S-L: caustic on a diffuse floor by pure BSDF sampling: end vertex is
    // the glass (S), whose sampled direction hit the light.
    CHECK(classify_event(2, LOBE_S, false) == BUCKET_SPECULAR_DIRECT);
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
