// Which effects a scene calls for (docs/architecture.md, "Simulate only what the scene calls
// for"): each becomes a specialization constant of the render pipeline, so a
// diffuse-only scene runs code with none of the rest.
#pragma once

#include "scene/scene.hpp"
#include "shared/types.h"

#include <string>
#include <vector>

namespace vkmech {

// Values: EST_* (shared/types.h), the ESTIMATOR specialization constant.
enum class Estimator : uint32_t { Nee = gpu::EST_NEE, MisRestricted = gpu::EST_MIS_RESTRICTED, Mis = gpu::EST_MIS };
const char* to_string(Estimator e);
Estimator parse_estimator(const std::string& s);  // throws std::invalid_argument

// docs/descriptor.md §2's two readings of the end vertex: the last non-delta vertex
// (default) or, literally, the last surface vertex before the emitter.
enum class EndVertex : uint32_t { LastNonDelta = 0, Literal = 1 };
const char* to_string(EndVertex e);
EndVertex parse_end_vertex(const std::string& s);  // throws std::invalid_argument

struct Features {
    bool thin_lens = true;
    bool orthographic = false;  // a camera type, not an effect: never in the generic pipeline
    // The material features compiled in (gpu::FEATURE_BIT_*, shared/materials.h): from_scene sets
    // the features of the scene's materials (gpu::material_features of each).
    uint32_t materials = gpu::FEATURE_BITS_ALL;
    bool textures = true;
    // Normal maps on the file's tangents (glTF TANGENT; SceneArrays::tangents): a mesh that keeps
    // them. Only with textures.
    bool tangents = true;
    bool environment = true;    // emitters at infinity (Scene::environment, Scene::directional_lights)
    bool capture = true;        // the mechanism descriptor
    bool debug_events = false;  // record one pixel's contribution events (tests)
    // `render --extra-output direct_glossy` (docs/descriptor.md §3.4): the pipeline built from the
    // path tracer's second SPIR-V module, which also sums the `direct` bucket's energy whose end
    // vertex is glossy (Frame::direct_glossy_sum). Not a specialization constant: the default
    // module stays byte-identical. Needs capture.
    bool direct_glossy = false;
    // `render --pixel-bounds`: the renders are windows of the film (RenderSpec::window), the
    // specialization constant SPEC_WINDOW; off, the shader has no window code.
    bool window = false;
    // `bench render --profile --counters`: the instrumented module (VKMECH_COUNTERS) that counts
    // the software BVH's work (Renderer::counters()). Software BVH only; not with direct_glossy.
    bool counters = false;
    Estimator estimator = Estimator::Nee;
    EndVertex end_vertex = EndVertex::LastNonDelta;
    // `--taxonomy` (docs/lpe.md): a user taxonomy's words (SceneTaxonomy::words), whose classes
    // replace the built-in cascade's buckets in the tally (SPEC_TAXONOMY); empty: the cascade.
    // Needs capture.
    std::vector<uint32_t> taxonomy;

    // Everything on: the generic pipeline (for `bench render`).
    static Features generic(Estimator e = Estimator::Nee, bool capture = true);
    static Features from_scene(const Scene& scene, Estimator e = Estimator::Nee, bool capture = true);

    std::string describe() const;  // e.g. "thin-lens dielectric rough capture estimator=nee"
};

}  // namespace vkmech
