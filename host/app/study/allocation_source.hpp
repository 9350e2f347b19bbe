// The allocation experiment's data (analysis/experiments/allocation.hpp)
// rendered on the GPU and kept in the render cache: reference chunks as
// frames, the pool and each pilot as typed side files (`<key>.frame.pool`,
// `<key>.frame.pilot`), every one keyed like a study render, so a second
// run renders only what is missing or damaged.
#pragma once

#include "experiments/allocation.hpp"
#include "render/session.hpp"
#include "render/taxonomy.hpp"
#include "study/render_cache.hpp"
#include "vk/context.hpp"

#include <functional>
#include <memory>
#include <optional>
#include <string>

namespace vkmech {

class RenderedAllocationSource final : public AllocationSource {
public:
    // `interrupted` is asked before every render; true throws StudyInterrupted.
    RenderedAllocationSource(const StudyConfig& cfg, const vk::Context& ctx, Traversal traversal,
                             const RenderCache& cache, std::string code_digest, std::function<bool()> interrupted);

    Frame reference(const SceneVariant& v) override;
    SamplePool pool(const SceneVariant& v, uint32_t index) override;
    Pilot pilot(const SceneVariant& v, uint32_t n0, uint32_t draw) override;
    PilotSamples pilot_samples(const SceneVariant& v, uint32_t n0, uint32_t draw) override;
    double final_render_seconds(const SceneVariant& v, const std::vector<uint32_t>& n) override;
    // A study --taxonomy's classes and declared properties (compiled against v's labels), else the buckets'.
    std::vector<std::string> class_names(const SceneVariant& v) override;
    alloc::ClassTraits class_traits(const SceneVariant& v) override;

    // Scale-out (study --shard / --jobs / --analyse-only): the cache entries
    // v's allocation study reads (reference chunks, pool, pilots, per-sample
    // pilots) that the cache lacks, described one per line; rendering all of
    // them; and an offline mode in which a missing entry throws
    // std::runtime_error instead of being rendered (the timing renders, which
    // are measurements and never cached, still run).
    std::vector<std::string> missing(const SceneVariant& v);
    void render_all(const SceneVariant& v);
    void set_offline(bool offline) { offline_ = offline; }

private:
    struct Loaded {
        SceneVariant variant;
        std::string digest;
        std::optional<SceneTaxonomy> taxonomy;  // study --taxonomy against this variant's labels
        std::string taxonomy_key;               // its key part ("" for the buckets)
        std::unique_ptr<RenderSession> session;
        std::unique_ptr<Renderer> renderer;
    };
    // The variant on the device at the allocation resolution; one is kept at a time.
    Loaded& load(const SceneVariant& v);
    std::string key(const std::string& digest, const std::string& taxonomy_key, const Camera& c, uint32_t spp,
                    uint32_t seed, uint32_t batch) const;
    std::string key(const Loaded& l, uint32_t spp, uint32_t seed, uint32_t batch) const;
    void check_interrupt() const;

    const StudyConfig& cfg_;
    const vk::Context& ctx_;
    Traversal traversal_;
    const RenderCache& cache_;
    std::string code_digest_;
    std::function<bool()> interrupted_;
    std::optional<Loaded> loaded_;
    bool offline_ = false;
    // A cache entry is missing: render it, or in offline mode throw naming it.
    void need(const std::string& what) const;
};

}  // namespace vkmech
