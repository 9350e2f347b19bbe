// `vkmech sentinel register` without the CLI (docs/descriptor.md §9): renders
// the pilot, and only the pilot, diagnoses it, measures the scene's
// separation, and fills the record's settings, render log, diagnosis and
// predictions. The caller adds the scene digest, code version, device,
// timestamp and curve, then seals and writes it.
#pragma once

#include "allocation/plan.hpp"
#include "experiments/sentinel.hpp"
#include "render/session.hpp"

#include <functional>

namespace vkmech {

// Renders a pilot of n0 samples of `seed` (robust: with the median-of-means
// blocks; adaptive/adaptive.hpp render_pilot). The only way register_sentinel
// renders anything: every call is logged in Record::renders.
using PilotRenderFn = std::function<Pilot(uint32_t n0, uint32_t seed, bool robust)>;

// The record of a pilot of `pilot_spp` samples, draw `pilot_draw` (seed
// downstream_seeds::pilot(pilot_draw)), rendered through `render`. `curve`
// (optional) gives the reliability predictions. The session supplies the
// film, the integrator settings and the separation segments (traced with the
// ray caster, not the path tracer). `taxonomy` (optional; `render` then labels
// by its classes): the pilot's classes and their traits, which the diagnosis
// and the predictions read; the record names it, and Finding 1's sign, defined
// by the buckets' caustic_frac and glossy_frac, is not predicted.
sentinel::Record register_sentinel(const RenderSession& session, const PilotRenderFn& render, uint32_t pilot_spp,
                                   uint32_t pilot_draw, const ReliabilityCurve* curve,
                                   const sentinel::TaxonomyRecord* taxonomy = nullptr);

}  // namespace vkmech
