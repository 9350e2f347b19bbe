#include "render/taxonomy.hpp"

#include "io/invariant.hpp"
#include "io/json.hpp"
#include "shared/types.h"

#include <algorithm>
#include <bit>
#include <sstream>

namespace vkmech {

static_assert(lpe::kKindCamera == 0 && lpe::kKindRD == gpu::TAX_KIND_REFLECT + gpu::LOBE_D &&
                  lpe::kKindRG == gpu::TAX_KIND_REFLECT + gpu::LOBE_G &&
                  lpe::kKindRS == gpu::TAX_KIND_REFLECT + gpu::LOBE_S &&
                  lpe::kKindTD == gpu::TAX_KIND_TRANSMIT + gpu::LOBE_D &&
                  lpe::kKindTG == gpu::TAX_KIND_TRANSMIT + gpu::LOBE_G &&
                  lpe::kKindTS == gpu::TAX_KIND_TRANSMIT + gpu::LOBE_S && lpe::kKindLight == gpu::TAX_KIND_LIGHT &&
                  lpe::kKindBackground == gpu::TAX_KIND_BACKGROUND,
              "the shader's event kinds are the LPE compiler's");

std::vector<lpe::LabelSlot> taxonomy_label_slots(const Scene& scene) {
    std::vector<lpe::LabelSlot> slots;
    // The device has one default material when the scene has none (gpu_scene.cpp).
    if (scene.materials.empty()) slots.push_back({});
    std::vector<int> users(scene.materials.size(), 0), user(scene.materials.size(), -1);
    for (size_t k = 0; k < scene.meshes.size(); ++k) {
        const int m = scene.meshes[k].material;
        if (m < 0 || static_cast<size_t>(m) >= scene.materials.size()) continue;
        users[static_cast<size_t>(m)]++;
        user[static_cast<size_t>(m)] = static_cast<int>(k);
    }
    for (size_t m = 0; m < scene.materials.size(); ++m) {
        lpe::LabelSlot slot{{scene.materials[m].id}};
        if (users[m] == 1) slot.names.push_back(scene.meshes[static_cast<size_t>(user[m])].name);
        slots.push_back(std::move(slot));
    }
    for (const AreaEmitter& e : scene.emitters) {
        lpe::LabelSlot slot;
        if (e.mesh >= 0 && static_cast<size_t>(e.mesh) < scene.meshes.size()) {
            const Mesh& mesh = scene.meshes[static_cast<size_t>(e.mesh)];
            if (!mesh.name.empty()) slot.names.push_back(mesh.name);
            if (mesh.material >= 0 && static_cast<size_t>(mesh.material) < scene.materials.size())
                slot.names.push_back(scene.materials[static_cast<size_t>(mesh.material)].id);
        }
        slots.push_back(std::move(slot));
    }
    return slots;
}

int give_named_shapes_own_materials(Scene& scene, const lpe::TaxonomySource& source) {
    const std::vector<std::string> named = lpe::taxonomy_labels(source);
    std::vector<int> users(scene.materials.size(), 0);
    for (const Mesh& mesh : scene.meshes)
        if (mesh.material >= 0 && static_cast<size_t>(mesh.material) < scene.materials.size())
            users[static_cast<size_t>(mesh.material)]++;
    int copies = 0;
    for (Mesh& mesh : scene.meshes) {
        const int m = mesh.material;
        if (m < 0 || static_cast<size_t>(m) >= users.size() || users[static_cast<size_t>(m)] < 2) continue;
        if (std::find(named.begin(), named.end(), mesh.name) == named.end()) continue;
        users[static_cast<size_t>(m)]--;
        scene.materials.push_back(scene.materials[static_cast<size_t>(m)]);
        mesh.material = static_cast<int>(scene.materials.size()) - 1;
        users.push_back(1);
        ++copies;
    }
    return copies;
}

namespace {

// BINDING_TAXONOMY's words of a compiled taxonomy (shaders/shared/types.h TAX_*).
void pack_words(SceneTaxonomy& t, const Scene& scene) {
    const lpe::CompiledTaxonomy& c = t.compiled;
    const uint32_t materials = static_cast<uint32_t>(std::max<size_t>(scene.materials.size(), 1));
    std::vector<uint32_t>& w = t.words;
    w.assign(gpu::TAX_HEADER_WORDS, 0u);
    w[0] = c.alphabet_size;
    w[1] = c.label_class_count;
    w[2] = c.step(c.start_state, c.symbol(lpe::kKindCamera, 0));
    for (uint16_t next : c.next_state) w.push_back(next);
    w[3] = static_cast<uint32_t>(w.size());
    for (uint8_t cls : c.accept_class) w.push_back(cls);
    w[4] = static_cast<uint32_t>(w.size());
    for (uint32_t m = 0; m < materials; ++m) w.push_back(c.label_class_of_slot.at(m));
    w[5] = static_cast<uint32_t>(w.size());
    for (size_t e = 0; e < scene.emitters.size(); ++e) w.push_back(c.label_class_of_slot.at(materials + e));
    if (scene.emitters.empty()) w.push_back(0u);  // never read; keeps the buffer non-empty past the offsets
}

}  // namespace

SceneTaxonomy compile_scene_taxonomy(const lpe::TaxonomySource& source, const Scene& scene) {
    const uint32_t classes = static_cast<uint32_t>(source.lines.size()) + 1;
    if (classes > gpu::BUCKET_COUNT)
        throw lpe::LpeError(source.file, source.lines.size() > 6 ? source.lines[6].line : 0, 0,
                            "a taxonomy has at most " + std::to_string(gpu::BUCKET_COUNT - 1) +
                                " lines (with the implicit `other`, one tally slot per class); this one has " +
                                std::to_string(source.lines.size()));
    SceneTaxonomy t;
    t.source = source;
    t.compiled = lpe::compile_taxonomy(source, taxonomy_label_slots(scene));
    pack_words(t, scene);
    return t;
}

SceneTaxonomy compile_scene_queries(const lpe::TaxonomySource& queries, const Scene& scene) {
    SceneTaxonomy t;
    t.source = queries;
    lpe::CompileOptions options;
    options.all_matches = true;
    t.compiled = lpe::compile_taxonomy(queries, taxonomy_label_slots(scene), options);
    const std::vector<std::string>& names = t.compiled.class_names;
    if (names.size() > gpu::BUCKET_COUNT) {
        std::string combos;
        for (size_t k = 0; k + 1 < names.size(); ++k) combos += (k ? ", " : "") + names[k];
        throw lpe::LpeError(queries.file, 0, 0,
                            "paths over this scene's labels can match " + std::to_string(names.size() - 1) +
                                " combinations of the queries (" + combos + "); the tally has room for " +
                                std::to_string(gpu::BUCKET_COUNT - 1) +
                                ": use fewer queries, or queries that overlap less");
    }
    pack_words(t, scene);
    return t;
}

std::vector<ExrChannel> query_channels(const Frame& frame, const SceneTaxonomy& queries) {
    const std::vector<uint32_t>& combos = queries.compiled.class_lines;
    const uint32_t other = queries.compiled.other_class;
    const size_t pixels = frame.pixels.size();
    VKM_ASSERT(frame.bucket_rgb_sum.size() == pixels * Frame::kBucketRgb,
               "query channels need the classes' RGB sums (a render with the capture on)");
    const size_t queries_n = queries.source.lines.size();
    std::vector<std::string> names;
    for (const lpe::TaxonomyLine& l : queries.source.lines) names.push_back(l.name);
    std::vector<ExrChannel> out;
    for (std::string& name : query_channel_names(names))
        out.push_back({std::move(name), std::vector<float>(pixels), false});
    std::vector<double> per_query(queries_n);
    for (size_t i = 0; i < pixels; ++i) {
        const double n = frame.pixels[i].count;
        if (n <= 0.0) continue;
        const double* sums = &frame.bucket_rgb_sum[i * Frame::kBucketRgb];
        for (int c = 0; c < 3; ++c) {
            std::fill(per_query.begin(), per_query.end(), 0.0);
            double overlap = 0.0;
            for (size_t k = 0; k < combos.size(); ++k) {
                const double e = sums[3 * k + static_cast<size_t>(c)];
                for (size_t q = 0; q < queries_n; ++q)
                    if (combos[k] >> q & 1u) per_query[q] += e;
                overlap += (std::popcount(combos[k]) - 1) * e;
            }
            for (size_t q = 0; q < queries_n; ++q) out[3 * q + c].data[i] = static_cast<float>(per_query[q] / n);
            out[3 * queries_n + c].data[i] = static_cast<float>(sums[3 * other + static_cast<size_t>(c)] / n);
            out[3 * queries_n + 3 + c].data[i] = static_cast<float>(overlap / n);
        }
    }
    return out;
}

std::vector<std::string> query_channel_names(const std::vector<std::string>& query_names) {
    // Channel groups: each query, then _rest and _overlap; each R, G, B.
    std::vector<std::string> groups = query_names;
    groups.insert(groups.end(), {"_rest", "_overlap"});
    std::vector<std::string> out;
    for (const std::string& g : groups)
        for (const char* c : {".R", ".G", ".B"}) out.push_back("lpe." + g + c);
    return out;
}

uint32_t SceneTaxonomy::classes_with(bool lpe::TaxonomyLine::*property) const {
    uint32_t mask = 0;
    for (size_t k = 0; k < source.lines.size() && k < 32; ++k) mask |= source.lines[k].*property ? 1u << k : 0u;
    return mask;
}

uint32_t SceneTaxonomy::heavy_classes() const { return classes_with(&lpe::TaxonomyLine::heavy); }

uint32_t SceneTaxonomy::constant_classes() const { return classes_with(&lpe::TaxonomyLine::constant); }

uint32_t SceneTaxonomy::rare_classes() const { return classes_with(&lpe::TaxonomyLine::rare); }

std::string taxonomy_json(const SceneTaxonomy& t) {
    std::ostringstream o;
    o << "{\"file\": \"" << json_escape(t.source.file) << "\", \"lines\": [";
    for (size_t i = 0; i < t.source.lines.size(); ++i) {
        const lpe::TaxonomyLine& l = t.source.lines[i];
        o << (i ? ", " : "") << "{\"name\": \"" << json_escape(l.name) << "\", \"expression\": \""
          << json_escape(l.expression) << "\"" << (l.heavy ? ", \"heavy\": true" : "")
          << (l.constant ? ", \"constant\": true" : "") << (l.rare ? ", \"rare\": true" : "") << "}";
    }
    o << "], \"classes\": [";
    for (size_t i = 0; i < t.compiled.class_names.size(); ++i)
        o << (i ? ", " : "") << "\"" << json_escape(t.compiled.class_names[i]) << "\"";
    o << "], \"states\": " << t.compiled.state_count << "}";
    return o.str();
}

std::string queries_json(const SceneTaxonomy& queries, double seconds) {
    std::ostringstream o;
    o << "{\"queries\": [";
    for (size_t i = 0; i < queries.source.lines.size(); ++i) {
        const lpe::TaxonomyLine& l = queries.source.lines[i];
        o << (i ? ", " : "") << "{\"name\": \"" << json_escape(l.name) << "\", \"expression\": \""
          << json_escape(l.expression) << "\"}";
    }
    o << "], \"combinations\": [";
    for (size_t k = 0; k + 1 < queries.compiled.class_names.size(); ++k)
        o << (k ? ", " : "") << "\"" << json_escape(queries.compiled.class_names[k]) << "\"";
    o << "], \"states\": " << queries.compiled.state_count;
    if (seconds >= 0.0) o << ", \"seconds\": " << seconds;
    o << "}";
    return o.str();
}

}  // namespace vkmech
