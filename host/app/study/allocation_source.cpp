#include "study/allocation_source.hpp"

#include "adaptive/adaptive.hpp"
#include "allocation/mom.hpp"
#include "study/study_runner.hpp"

#include <cmath>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <utility>

namespace fs = std::filesystem;

namespace vkmech {

RenderedAllocationSource::RenderedAllocationSource(const StudyConfig& cfg, const vk::Context& ctx, Traversal traversal,
                                                   const RenderCache& cache, std::string code_digest,
                                                   std::function<bool()> interrupted)
    : cfg_(cfg),
      ctx_(ctx),
      traversal_(traversal),
      cache_(cache),
      code_digest_(std::move(code_digest)),
      interrupted_(std::move(interrupted)) {}

RenderedAllocationSource::Loaded& RenderedAllocationSource::load(const SceneVariant& v) {
    if (loaded_ && loaded_->variant == v) return *loaded_;
    loaded_.reset();  // one scene on the device at a time
    LoadedScene ls = load_variant(v, cfg_.alloc_res, traversal_, cfg_.taxonomy ? &*cfg_.taxonomy : nullptr);
    Loaded l;
    l.variant = v;
    l.digest = ls.digest;
    if (cfg_.taxonomy) {
        l.taxonomy = compile_variant_taxonomy(*cfg_.taxonomy, v, ls.scene, /*print_warnings=*/false);
        l.taxonomy_key = taxonomy_key(*l.taxonomy);
    }
    l.session = std::make_unique<RenderSession>(ctx_, std::move(ls.scene), std::move(ls.arrays), traversal_);
    Features f = l.session->features();
    if (l.taxonomy) f.taxonomy = l.taxonomy->words;
    l.renderer = l.session->make_renderer(f);
    std::fprintf(stderr, "allocation: %s (%dx%d)\n", v.name.c_str(), l.session->scene().camera.width,
                 l.session->scene().camera.height);
    loaded_ = std::move(l);
    return *loaded_;
}

namespace {
// The samples per dispatch of each cached input (part of its key): reference chunks 64, the pool and the
// per-sample pilots 1 (one frame per sample), a pilot its median-of-means block size where that is defined.
constexpr uint32_t kReferenceBatch = 64;
uint32_t pilot_batch(uint32_t n0) {
    return alloc::mom_defined(static_cast<int>(n0)) ? static_cast<uint32_t>(alloc::mom_block_size(static_cast<int>(n0)))
                                                    : 8;
}
}  // namespace

std::string RenderedAllocationSource::key(const std::string& digest, const std::string& taxonomy_key, const Camera& c,
                                          uint32_t spp, uint32_t seed, uint32_t batch) const {
    return cache_key({digest, c.width, c.height, spp, seed, 0, batch, to_string(traversal_), ctx_.info().name,
                      code_digest_, 0, taxonomy_key});
}

std::string RenderedAllocationSource::key(const Loaded& l, uint32_t spp, uint32_t seed, uint32_t batch) const {
    return key(l.digest, l.taxonomy_key, l.session->scene().camera, spp, seed, batch);
}

std::vector<std::string> RenderedAllocationSource::class_names(const SceneVariant& v) {
    const Loaded& l = load(v);
    return l.taxonomy ? l.taxonomy->class_names() : AllocationSource::class_names(v);
}

alloc::ClassTraits RenderedAllocationSource::class_traits(const SceneVariant& v) {
    const Loaded& l = load(v);
    return vkmech::class_traits(l.taxonomy ? &*l.taxonomy : nullptr);
}

void RenderedAllocationSource::check_interrupt() const {
    if (interrupted_ && interrupted_()) throw StudyInterrupted(pending_signal() ? pending_signal() : SIGINT);
}

Frame RenderedAllocationSource::reference(const SceneVariant& v) {
    Loaded& l = load(v);
    Frame ref;
    for (uint32_t c = 0; c < cfg_.alloc_ref_chunks; ++c) {
        check_interrupt();
        const uint32_t seed = downstream_seeds::reference_chunk(c);
        const std::string k = key(l, cfg_.alloc_ref_chunk_spp, seed, kReferenceBatch);
        std::optional<Frame> f = cache_.try_load(k);
        if (!f) {
            need(v.name + " allocation reference chunk " + std::to_string(c));
            RenderSpec spec;
            spec.spp = cfg_.alloc_ref_chunk_spp;
            spec.seed = seed;
            spec.batch_spp = kReferenceBatch;
            f = l.renderer->render(spec);
            cache_.store(k, *f, v.name + " allocation reference chunk " + std::to_string(c));
        }
        if (c == 0)
            ref = std::move(*f);
        else
            ref.merge(*f);
    }
    return ref;
}

SamplePool RenderedAllocationSource::pool(const SceneVariant& v, uint32_t index) {
    Loaded& l = load(v);
    check_interrupt();
    const uint32_t F = downstream_seeds::kPoolSize;
    const std::string k = key(l, F, downstream_seeds::pool(index), 1);
    const std::string what = v.name + " allocation " + downstream_seeds::pool_label(index);
    const size_t P = static_cast<size_t>(l.session->scene().camera.width) * l.session->scene().camera.height;
    if (std::optional<SamplePool> cached = cache_.try_load_pool(k)) {
        if (cached->pixels == P && cached->frames == F) return std::move(*cached);
        std::fprintf(stderr,
                     "vkmech: warning: render cache file '%s': %u frames of %zu pixels, not %u of %zu; rendering it "
                     "again\n",
                     cache_.path(k, "pool").c_str(), cached->frames, cached->pixels, F, P);
    }
    need(what);
    SamplePool pool;
    pool.frames = F;
    pool.pixels = P;
    pool.samples.assign(static_cast<size_t>(F) * P * 4, 0.0f);
    RenderSpec spec;
    spec.spp = F;
    spec.seed = downstream_seeds::pool(index);
    spec.batch_spp = 1;
    uint32_t f = 0;
    spec.on_batch = [&](const std::vector<gpu::GpuPixelAccum>& b) {  // one batch per sample index: one pool frame
        for (size_t p = 0; p < P; ++p) {
            float* x = &pool.samples[(static_cast<size_t>(f) * P + p) * 4];
            x[0] = b[p].rgb.x;
            x[1] = b[p].rgb.y;
            x[2] = b[p].rgb.z;
            x[3] = b[p].rgb.w;
        }
        ++f;
    };
    spec.progress = [&](uint32_t, uint32_t) { check_interrupt(); };
    const Frame whole = l.renderer->render(spec);
    pool.oracle_var.resize(P);
    for (size_t p = 0; p < P; ++p) pool.oracle_var[p] = whole.pixels[p].lum_var();  // the pool's converged variance
    cache_.store_pool(k, pool);
    return pool;
}

Pilot RenderedAllocationSource::pilot(const SceneVariant& v, uint32_t n0, uint32_t draw) {
    Loaded& l = load(v);
    check_interrupt();
    const bool robust = alloc::mom_defined(static_cast<int>(n0));
    const std::string k = key(l, n0, downstream_seeds::pilot(draw), pilot_batch(n0));
    if (std::optional<Pilot> cached = cache_.try_load_pilot(k)) return std::move(*cached);
    need(v.name + " allocation pilot N0 = " + std::to_string(n0) + ", draw " + std::to_string(draw));
    Pilot p = render_pilot(*l.renderer, n0, downstream_seeds::pilot(draw), robust);
    cache_.store_pilot(k, p);
    return p;
}

PilotSamples RenderedAllocationSource::pilot_samples(const SceneVariant& v, uint32_t n0, uint32_t draw) {
    Loaded& l = load(v);
    check_interrupt();
    const std::string k = key(l, n0, downstream_seeds::pilot(draw), 1);  // batch 1: one sample per batch
    if (std::optional<PilotSamples> cached = cache_.try_load_pilot_samples(k)) return std::move(*cached);
    need(v.name + " allocation per-sample pilot N0 = " + std::to_string(n0) + ", draw " + std::to_string(draw));
    const Camera& c = l.session->scene().camera;
    PilotSamples s;
    s.samples = n0;
    s.pixels = static_cast<size_t>(c.width) * c.height;
    s.lum.assign(static_cast<size_t>(n0) * s.pixels, 0.0f);
    RenderSpec spec;
    spec.spp = n0;
    spec.seed = downstream_seeds::pilot(draw);
    spec.batch_spp = 1;
    uint32_t i = 0;
    spec.on_batch = [&](const std::vector<gpu::GpuPixelAccum>& b) {  // a batch of one sample: its mean is the sample
        for (size_t p = 0; p < s.pixels; ++p)
            s.lum[static_cast<size_t>(i) * s.pixels + p] = b[p].rgb.w > 0.0f ? b[p].lum.x : std::nanf("");
        ++i;
    };
    l.renderer->render(spec);
    cache_.store_pilot_samples(k, s);
    return s;
}

double RenderedAllocationSource::final_render_seconds(const SceneVariant& v, const std::vector<uint32_t>& n) {
    Loaded& l = load(v);
    check_interrupt();
    RenderSpec spec;
    spec.seed = downstream_seeds::kPool;
    spec.batch_spp = 16;
    spec.sample_counts = n;
    return l.renderer->render(spec).seconds;
}

void RenderedAllocationSource::need(const std::string& what) const {
    if (offline_)
        throw std::runtime_error("the render cache lacks " + what +
                                 " (--analyse-only renders nothing: run the study "
                                 "without it, or its --shard / --jobs commands, first)");
}

namespace {
// Whether the per-sample pilots of N0 are read (the median-of-means sweep, allocation.cpp).
bool reads_pilot_samples(const StudyConfig& cfg, uint32_t n0) {
    return alloc::mom_defined(static_cast<int>(n0)) && !cfg.alloc_mom_k.empty();
}
}  // namespace

std::vector<std::string> RenderedAllocationSource::missing(const SceneVariant& v) {
    // Keys from the scene's content at the allocation film, without the device.
    const LoadedScene ls = load_variant(v, cfg_.alloc_res, traversal_, cfg_.taxonomy ? &*cfg_.taxonomy : nullptr);
    const std::string tk =
        cfg_.taxonomy ? taxonomy_key(compile_variant_taxonomy(*cfg_.taxonomy, v, ls.scene, false)) : std::string();
    auto key = [&](uint32_t spp, uint32_t seed, uint32_t batch) {
        return this->key(ls.digest, tk, ls.scene.camera, spp, seed, batch);
    };
    auto absent = [&](const std::string& k, const std::string& kind) { return !fs::exists(cache_.path(k, kind)); };
    std::vector<std::string> out;
    for (uint32_t ch = 0; ch < cfg_.alloc_ref_chunks; ++ch)
        if (absent(key(cfg_.alloc_ref_chunk_spp, downstream_seeds::reference_chunk(ch), kReferenceBatch), "frame"))
            out.push_back(v.name + " allocation reference chunk " + std::to_string(ch));
    for (uint32_t j = 0; j < static_cast<uint32_t>(cfg_.alloc_pools); ++j)
        if (absent(key(downstream_seeds::kPoolSize, downstream_seeds::pool(j), 1), "pool"))
            out.push_back(v.name + " allocation " + downstream_seeds::pool_label(j));
    for (uint32_t n0 : cfg_.alloc_pilots)
        for (uint32_t d = 0; d < static_cast<uint32_t>(cfg_.alloc_draws); ++d) {
            if (absent(key(n0, downstream_seeds::pilot(d), pilot_batch(n0)), "pilot"))
                out.push_back(v.name + " allocation pilot N0 = " + std::to_string(n0) + ", draw " + std::to_string(d));
            if (reads_pilot_samples(cfg_, n0) && absent(key(n0, downstream_seeds::pilot(d), 1), "pilot-samples"))
                out.push_back(v.name + " allocation per-sample pilot N0 = " + std::to_string(n0) + ", draw " +
                              std::to_string(d));
        }
    return out;
}

void RenderedAllocationSource::render_all(const SceneVariant& v) {
    reference(v);
    for (uint32_t j = 0; j < static_cast<uint32_t>(cfg_.alloc_pools); ++j) pool(v, j);
    for (uint32_t n0 : cfg_.alloc_pilots)
        for (uint32_t d = 0; d < static_cast<uint32_t>(cfg_.alloc_draws); ++d) {
            pilot(v, n0, d);
            if (reads_pilot_samples(cfg_, n0)) pilot_samples(v, n0, d);
        }
}

}  // namespace vkmech
