// A user taxonomy bound to a scene (docs/lpe.md; issue 37): the LPE file compiled against the
// scene's labels and packed into the words the path tracer reads (shaders/shared/types.h TAX_*).
// A surface event carries its material's slot, which answers to the material's id and, when one
// shape alone uses the material, to that shape's id; an area emitter's event answers to its
// shape's id and its material's. Each class is one slot of the tally, so a taxonomy has at most
// gpu::BUCKET_COUNT classes: six lines and the implicit `other`.
#pragma once

#include "io/exr.hpp"
#include "render/frame.hpp"
#include "render/lpe.hpp"
#include "scene/scene.hpp"

#include <cstdint>
#include <string>
#include <vector>

namespace vkmech {

// The labels each event can carry: one slot per material (its id, and the id of the one shape
// that uses it, if one alone does), then one per area emitter (its shape's id, and its shape's
// material id).
std::vector<lpe::LabelSlot> taxonomy_label_slots(const Scene& scene);

// Gives every shape whose id the taxonomy names, and whose material other shapes share, a copy of
// that material of its own, so that its surface events answer to its id. The copies are equal to
// their originals: the image does not change. Returns the number of copies made.
int give_named_shapes_own_materials(Scene& scene, const lpe::TaxonomySource& source);

struct SceneTaxonomy {
    lpe::TaxonomySource source;  // the file and its lines
    lpe::CompiledTaxonomy compiled;
    std::vector<uint32_t> words;  // BINDING_TAXONOMY's contents
    const std::vector<std::string>& class_names() const { return compiled.class_names; }
    // The classes its lines declare `[heavy]`, `[constant]` and `[rare]`, a bit per class (class k is
    // line k; `other` is none of them): the allocation strategies' alloc::ClassTraits.
    uint32_t heavy_classes() const;
    uint32_t constant_classes() const;
    uint32_t rare_classes() const;

private:
    uint32_t classes_with(bool lpe::TaxonomyLine::*property) const;
};

// Compiles `source` against the scene's labels and packs it. Throws lpe::LpeError for a malformed
// expression, a DFA over the state limit, or more classes than the tally has slots.
SceneTaxonomy compile_scene_taxonomy(const lpe::TaxonomySource& source, const Scene& scene);

// `render --lpe name=EXPR` (docs/lpe.md, "Query channels"): the queries compiled against the scene's labels
// with every matching line counted (lpe::CompileOptions::all_matches) and packed as a taxonomy whose classes are
// the combinations of queries that paths match. Throws lpe::LpeError for a malformed query, a DFA over the state
// limit, or more combinations than the tally has slots (naming them).
SceneTaxonomy compile_scene_queries(const lpe::TaxonomySource& queries, const Scene& scene);

// The query channels of a render whose classes are `queries`' combinations: per query `lpe.<name>.R/.G/.B`, the
// mean radiance of the paths it matches; `lpe._rest.*`, of the paths no query matches; `lpe._overlap.*`, the
// radiance counted more than once (each combination's times its number of queries less one), so that the
// queries plus `_rest` less `_overlap` make the image. A pixel without samples is 0.
std::vector<ExrChannel> query_channels(const Frame& frame, const SceneTaxonomy& queries);
// Their names, in that order, for queries named `query_names`.
std::vector<std::string> query_channel_names(const std::vector<std::string>& query_names);

// The outputs' record of it (the JSON's "taxonomy"): {"file", "lines": [{"name", "expression"[, "heavy":
// true][, "constant": true][, "rare": true]}], "classes", "states"}.
std::string taxonomy_json(const SceneTaxonomy& t);
// The record of `render --lpe` queries: {"queries": [{"name", "expression"}], "combinations": [the classes but
// other], "states"[, "seconds"]}. `seconds`, the query pass's render time, is in the JSON summary's record and
// left out (< 0) of the EXR header's (vkmech.lpe), which `vkmech merge` compares between parts of one render.
std::string queries_json(const SceneTaxonomy& queries, double seconds = -1.0);

}  // namespace vkmech
