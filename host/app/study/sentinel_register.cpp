#include "study/sentinel_register.hpp"

#include "allocation/guard.hpp"
#include "allocation/mom.hpp"
#include "study/separation_gpu.hpp"

namespace vkmech {

sentinel::Record register_sentinel(const RenderSession& session, const PilotRenderFn& render, uint32_t pilot_spp,
                                   uint32_t pilot_draw, const ReliabilityCurve* curve,
                                   const sentinel::TaxonomyRecord* taxonomy) {
    const Scene& scene = session.scene();
    sentinel::Record r;
    r.width = scene.camera.width;
    r.height = scene.camera.height;
    r.pilot_spp = pilot_spp;
    r.pilot_draw = pilot_draw;
    r.pilot_seed = downstream_seeds::pilot(pilot_draw);
    r.max_depth = scene.integrator.max_depth;
    r.rr_depth = scene.integrator.rr_depth;

    // The pilot: the one render before registration. Robust (median-of-means blocks) where N0 allows,
    // so that robust-var and robust-floor are predicted too.
    const bool robust = alloc::mom_defined(static_cast<int>(pilot_spp));
    r.renders.push_back({r.pilot_seed, pilot_spp});
    const Pilot pilot = render(pilot_spp, r.pilot_seed, robust);
    if (taxonomy) r.taxonomy = *taxonomy;
    r.diagnosis = alloc::diagnose_pilot(pilot, r.class_traits());

    if (!taxonomy) {
        const SeparationMeasures sep = measure_separation(session);
        if (sep.defined()) r.separation = sep;
    }
    r.predictions = sentinel::predict(pilot.frame, r.diagnosis, curve, r.separation ? &*r.separation : nullptr,
                                      taxonomy ? taxonomy->classes : std::vector<std::string>{});
    return r;
}

}  // namespace vkmech
