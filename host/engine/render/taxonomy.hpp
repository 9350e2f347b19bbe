// A user taxonomy bound to a scene (docs/lpe.md; issue 37): the LPE file compiled against the
// scene's labels and packed into the words the path tracer reads (shaders/shared/types.h TAX_*).
// A surface event carries its material's slot, which answers to the material's id and, when one
// shape alone uses the material, to that shape's id; an area emitter's event answers to its
// shape's id and its material's. Each class is one slot of the tally, so a taxonomy has at most
// gpu::BUCKET_COUNT classes: six lines and the implicit `other`.
#pragma once

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
    // The classes its lines declare `[heavy]` and `[constant]`, a bit per class (class k is line k;
    // `other` is neither): the allocation strategies' alloc::ClassTraits.
    uint32_t heavy_classes() const;
    uint32_t constant_classes() const;

private:
    uint32_t classes_with(bool lpe::TaxonomyLine::*property) const;
};

// Compiles `source` against the scene's labels and packs it. Throws lpe::LpeError for a malformed
// expression, a DFA over the state limit, or more classes than the tally has slots.
SceneTaxonomy compile_scene_taxonomy(const lpe::TaxonomySource& source, const Scene& scene);

// The outputs' record of it (the JSON's "taxonomy"): {"file", "lines": [{"name", "expression"[, "heavy":
// true][, "constant": true]}], "classes", "states"}.
std::string taxonomy_json(const SceneTaxonomy& t);

}  // namespace vkmech
