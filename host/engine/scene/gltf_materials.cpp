// glTF metallic-roughness materials -> docs/descriptor.md §2's material models, base-colour
// textures and emission (docs/descriptor.md §8, glTF part).
#include "scene/gltf_loader.hpp"

#include "scene/image_texture.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <sstream>

namespace fs = std::filesystem;

namespace vkmech {

namespace {

// The object of extension `name`, or null.
const tinygltf::Value* extension(const tinygltf::ExtensionMap& m, const char* name) {
    auto it = m.find(name);
    return it != m.end() && it->second.IsObject() ? &it->second : nullptr;
}

// glTF roughness is perceptual: alpha = r^2 (glTF 2.0 Appendix B). alpha = 0
// would divide by zero in the microfacet terms; the Mitsuba loader's clamp.
float alpha_of(double roughness) { return std::max(static_cast<float>(roughness * roughness), 1e-4f); }

std::string fmt(double v) {
    std::ostringstream s;
    s << v;
    return s.str();
}

}  // namespace

std::string GltfLoader::material_label(int index) const {
    return index < 0 ? "the default material" : labelled("material", index, model_.materials[index].name);
}

int GltfLoader::material(int index) {
    if (index >= 0 && static_cast<size_t>(index) >= model_.materials.size())
        fail("a primitive refers to material " + std::to_string(index) + ", which does not exist (the file has " +
             std::to_string(model_.materials.size()) + ")");
    auto it = material_map_.find(index);
    if (it != material_map_.end()) return it->second;
    // A primitive without a material gets glTF's default material (glTF 2.0
    // §3.9.6: base colour 1, metallic 1, roughness 1), i.e. a rough white
    // conductor, not Mitsuba's grey diffuse.
    Material m = index < 0 ? convert_material(tinygltf::Material{}, material_label(index))
                           : convert_material(model_.materials[index], material_label(index));
    if (index < 0) m.id = "gltf-default";
    int out = static_cast<int>(scene_.materials.size());
    scene_.materials.push_back(m);
    material_map_[index] = out;
    return out;
}

Material GltfLoader::convert_material(const tinygltf::Material& g, const std::string& label) {
    // Numbers from extension objects, checked (tinygltf hands them over raw).
    auto number = [&](const tinygltf::Value* ext, const char* ext_name, const char* key, double fallback, double lo,
                      double hi) {
        if (!ext || !ext->Has(key)) return fallback;
        const tinygltf::Value& v = ext->Get(key);
        double x = v.IsNumber() ? v.GetNumberAsDouble() : std::nan("");
        if (!(x >= lo && x <= hi))
            fail(label + ": " + ext_name + "." + key + " must be a number in [" + fmt(lo) + ", " + fmt(hi) + "]");
        return x;
    };
    auto ignored_texture = [&](bool present, const std::string& what) {
        if (present)
            warn(label + ": its " + what +
                 " is ignored (base-colour, metallic-roughness, normal and emissive textures are supported)");
    };
    auto ext_texture = [](const tinygltf::Value* ext, const char* key) { return ext && ext->Has(key); };

    const auto& pbr = g.pbrMetallicRoughness;
    if (pbr.baseColorFactor.size() != 4) fail(label + ": baseColorFactor needs 4 numbers");
    for (double c : pbr.baseColorFactor)
        if (!(c >= 0.0) || !std::isfinite(c)) fail(label + ": baseColorFactor components must be in [0, 1]");
    glm::vec3 base(pbr.baseColorFactor[0], pbr.baseColorFactor[1], pbr.baseColorFactor[2]);
    if (glm::any(glm::greaterThan(base, glm::vec3(1.0f)))) {
        // Exporters write 1.0000001 now and then; more than 1 is not energy-conserving.
        warn(label + ": baseColorFactor above 1 is clamped to 1");
        base = glm::min(base, glm::vec3(1.0f));
    }
    if (pbr.baseColorFactor[3] < 1.0 || g.alphaMode == "BLEND" || g.alphaMode == "MASK")
        warn(label + ": alpha (baseColorFactor alpha " + fmt(pbr.baseColorFactor[3]) + ", alphaMode " + g.alphaMode +
             ") is ignored; the surface is opaque");
    double metallic = pbr.metallicFactor, roughness = pbr.roughnessFactor;
    if (!(metallic >= 0.0 && metallic <= 1.0)) fail(label + ": metallicFactor must be in [0, 1]");
    if (!(roughness >= 0.0 && roughness <= 1.0)) fail(label + ": roughnessFactor must be in [0, 1]");

    const tinygltf::Value* transmission = extension(g.extensions, "KHR_materials_transmission");
    const tinygltf::Value* ior_ext = extension(g.extensions, "KHR_materials_ior");
    const tinygltf::Value* clearcoat = extension(g.extensions, "KHR_materials_clearcoat");
    double trans = number(transmission, "KHR_materials_transmission", "transmissionFactor", 0.0, 0.0, 1.0);
    double ior = number(ior_ext, "KHR_materials_ior", "ior", 1.5, 1.0, 100.0);
    double cc = number(clearcoat, "KHR_materials_clearcoat", "clearcoatFactor", 0.0, 0.0, 1.0);
    double cc_rough = number(clearcoat, "KHR_materials_clearcoat", "clearcoatRoughnessFactor", 0.0, 0.0, 1.0);
    if (extension(g.extensions, "KHR_materials_unlit")) {
        // An unlit material shows its base colour whatever the light (glTF's extension for
        // baked or stylised looks): in a path tracer it neither reflects nor emits, so no
        // transport mechanism could label it. Refused; with --substitute it is the lit
        // material its pbrMetallicRoughness describes, said in the substitution list.
        if (!options_.substitute_unsupported)
            fail(label +
                 ": KHR_materials_unlit shows the base colour unlit, which has no physical meaning in a path "
                 "tracer (the surface would neither reflect nor emit light); re-export it as a lit material, or pass "
                 "--substitute to render it as the lit material its pbrMetallicRoughness describes");
        scene_.substitutions.push_back(path_ + ": " + label +
                                       ": KHR_materials_unlit ignored; rendered as the lit material of its "
                                       "pbrMetallicRoughness (base colour, metallic, roughness)");
    }
    for (const auto& [name, value] : g.extensions) {
        if (name == "KHR_materials_transmission" || name == "KHR_materials_ior" || name == "KHR_materials_clearcoat" ||
            name == "KHR_materials_emissive_strength" || name == "KHR_materials_unlit")
            continue;
        warn(label + ": extension " + name + " is not supported and is ignored");
    }

    // Textures other than these are ignored, each said once. The metallic-roughness texture makes the
    // material principled (metallic blends per point), except on a transmissive one.
    const bool mr_textured = pbr.metallicRoughnessTexture.index >= 0 && trans == 0.0;
    ignored_texture(pbr.metallicRoughnessTexture.index >= 0 && !mr_textured,
                    "metallicRoughnessTexture (on a transmissive material)");
    ignored_texture(g.occlusionTexture.index >= 0, "occlusionTexture");
    ignored_texture(ext_texture(transmission, "transmissionTexture"), "transmissionTexture");
    ignored_texture(ext_texture(clearcoat, "clearcoatTexture"), "clearcoatTexture");
    ignored_texture(ext_texture(clearcoat, "clearcoatRoughnessTexture"), "clearcoatRoughnessTexture");
    ignored_texture(ext_texture(clearcoat, "clearcoatNormalTexture"), "clearcoatNormalTexture");

    Material m;
    m.id = g.name.empty() ? label : g.name;
    m.twosided = g.doubleSided;
    m.distribution = MicrofacetDistribution::GGX;  // glTF's BRDF is GGX-based (glTF 2.0 Appendix B)
    float alpha = alpha_of(roughness);
    m.alpha_u = m.alpha_v = alpha;
    m.ext_ior = 1.0f;
    m.int_ior = static_cast<float>(ior);

    glm::vec3 mean = base;
    int tex = pbr.baseColorTexture.index >= 0 ? color_texture(pbr.baseColorTexture, base, label, mean) : -1;
    if (g.normalTexture.index >= 0) {
        // Linear data, the tangent-space normal (glTF 2.0 §3.9.3), x and y times `scale`.
        tinygltf::TextureInfo info;
        info.index = g.normalTexture.index;
        info.texCoord = g.normalTexture.texCoord;
        info.extensions = g.normalTexture.extensions;
        if (!std::isfinite(g.normalTexture.scale)) fail(label + ": normalTexture.scale must be a finite number");
        glm::vec3 unused;
        m.normal_texture = color_texture(info, glm::vec3(1.0f), label, unused, "normalTexture", /*raw=*/true);
        m.normal_scale = static_cast<float>(g.normalTexture.scale);
        m.normal_uv_handed = true;  // mirrored uv layouts flip the bitangent (MikkTSpace's sign)
    }
    // The emission's texture: the emitter's radiance (emissiveFactor x strength, emission()) times it.
    const bool emits = std::any_of(g.emissiveFactor.begin(), g.emissiveFactor.end(), [](double c) { return c > 0.0; });
    if (g.emissiveTexture.index >= 0 && !emits)
        warn(label + ": its emissiveTexture is ignored: emissiveFactor is 0 (the emission is their product)");
    if (g.emissiveTexture.index >= 0 && emits) {
        glm::vec3 unused;
        m.emission_texture = color_texture(g.emissiveTexture, glm::vec3(1.0f), label, unused, "emissiveTexture");
    }

    if (cc > 0.0 || mr_textured) {
        // KHR_materials_clearcoat or a metallicRoughnessTexture -> principled (with a clearcoat where
        // asked). Clearcoat is approximate:
        // Mitsuba's clearcoat roughness is lerp(0.1, 0.001, clearcoat_gloss),
        // glTF's is clearcoatRoughness^2; gloss = 1 - clearcoatRoughness keeps
        // the ends (smooth, rough) in order.
        m.type = BsdfType::Principled;
        m.reflectance = Spectrum3{mean, tex};
        m.metallic = static_cast<float>(metallic);
        m.roughness = static_cast<float>(roughness);  // principled roughness is perceptual too
        m.clearcoat = static_cast<float>(cc);
        m.clearcoat_gloss = static_cast<float>(1.0 - cc_rough);
        m.spec_trans = static_cast<float>(trans);
        m.eta_principled = static_cast<float>(ior);
        float r = static_cast<float>((ior - 1.0) / (ior + 1.0));
        m.specular = r * r / 0.08f;  // Mitsuba: specular and eta are one quantity
        if (mr_textured) {
            // Linear data: roughness in G, metallic in B, times their factors; the constants
            // become the texture's means (what the host reads of the material).
            glm::vec3 mr_mean;
            m.metallic_roughness_texture =
                color_texture(pbr.metallicRoughnessTexture, glm::vec3(1.0f, roughness, metallic), label, mr_mean,
                              "metallicRoughnessTexture", /*raw=*/true);
            if (m.metallic_roughness_texture >= 0) {
                m.roughness = mr_mean.y;
                m.metallic = mr_mean.z;
            }
        }
    } else if (trans > 0.0) {
        // KHR_materials_transmission -> dielectric family (docs/descriptor.md §8), tinted by
        // the base colour. Without KHR_materials_volume glTF means a thin
        // wall; vkmech refracts (closed meshes are the common case).
        m.type = roughness == 0.0 ? BsdfType::Dielectric : BsdfType::RoughDielectric;
        m.specular_transmittance = mean;
        m.specular_transmittance_texture = tex;
        if (trans < 1.0)
            warn(label + ": transmissionFactor " + fmt(trans) + " < 1 is treated as fully transmissive (dielectric)");
        if (metallic > 0.0)
            warn(label + ": metallicFactor " + fmt(metallic) + " is ignored on a transmissive material");
    } else if (metallic >= 0.5) {
        // metallic 1 -> conductor family (docs/descriptor.md §8): a perfect mirror
        // (eta 0, k 1, Material's "none") tinted by the base colour.
        m.type = roughness == 0.0 ? BsdfType::Conductor : BsdfType::RoughConductor;
        m.eta = glm::vec3(0.0f);
        m.k = glm::vec3(1.0f);
        m.specular_reflectance = mean;
        m.specular_reflectance_texture = tex;
        if (metallic < 1.0)
            warn(label + ": metallicFactor " + fmt(metallic) +
                 " is between 0 and 1; vkmech has no blend and uses a conductor (metallic >= 0.5)");
    } else {
        // Dielectric base -> (rough) plastic: a diffuse base under a smooth or
        // GGX coat of IOR 1.5 (glTF's fixed 4% F0) unless KHR_materials_ior.
        m.type = roughness == 0.0 ? BsdfType::Plastic : BsdfType::RoughPlastic;
        m.reflectance = Spectrum3{mean, tex};
        m.specular_reflectance = glm::vec3(1.0f);
        if (metallic > 0.0)
            warn(label + ": metallicFactor " + fmt(metallic) +
                 " is between 0 and 1; vkmech has no blend and uses a plastic (metallic < 0.5)");
    }
    return m;
}

// emissiveFactor * KHR_materials_emissive_strength, taken as radiance as is:
// glTF's emission has no physical unit or exposure, so the numbers carry over
// (docs/descriptor.md §8).
glm::vec3 GltfLoader::emission(int index) {
    if (index < 0) return glm::vec3(0.0f);
    const auto& g = model_.materials[index];
    std::string label = material_label(index);
    if (g.emissiveFactor.empty()) return glm::vec3(0.0f);
    if (g.emissiveFactor.size() != 3) fail(label + ": emissiveFactor needs 3 numbers");
    glm::vec3 e(0.0f);
    for (int c = 0; c < 3; ++c) {
        if (!(g.emissiveFactor[c] >= 0.0) || !std::isfinite(g.emissiveFactor[c]))
            fail(label + ": emissiveFactor must be non-negative");
        e[c] = static_cast<float>(g.emissiveFactor[c]);
    }
    double strength = 1.0;
    if (const tinygltf::Value* s = extension(g.extensions, "KHR_materials_emissive_strength");
        s && s->Has("emissiveStrength")) {
        const tinygltf::Value& v = s->Get("emissiveStrength");
        strength = v.IsNumber() ? v.GetNumberAsDouble() : -1.0;
        if (!(strength >= 0.0) || !std::isfinite(strength))
            fail(label + ": KHR_materials_emissive_strength.emissiveStrength must be a non-negative number");
    }
    e *= static_cast<float>(strength);
    if ((e.x > 0.0f || e.y > 0.0f || e.z > 0.0f) && g.doubleSided)
        warn_once("emit2:" + std::to_string(index), label +
                                                        " is emissive and doubleSided; vkmech's area emitters emit "
                                                        "from the front face only (docs/descriptor.md §1)");
    return e;
}

glm::mat3 GltfLoader::texture_transform(const tinygltf::TextureInfo& info, const std::string& label) {
    const tinygltf::Value* x = extension(info.extensions, "KHR_texture_transform");
    if (!x) return glm::mat3(1.0f);
    auto numbers = [&](const char* key, std::vector<double> fallback) {
        if (!x->Has(key)) return fallback;
        const tinygltf::Value& v = x->Get(key);
        std::vector<double> out;
        if (v.IsNumber()) out.push_back(v.GetNumberAsDouble());
        for (size_t i = 0; v.IsArray() && i < v.ArrayLen(); ++i)
            out.push_back(v.Get(static_cast<int>(i)).IsNumber() ? v.Get(static_cast<int>(i)).GetNumberAsDouble()
                                                                : std::nan(""));
        for (double d : out)
            if (!std::isfinite(d)) fail(label + ": KHR_texture_transform." + key + " must be finite numbers");
        if (out.size() != fallback.size())
            fail(label + ": KHR_texture_transform." + key + " needs " + std::to_string(fallback.size()) +
                 (fallback.size() == 1 ? " number" : " numbers"));
        return out;
    };
    if (x->Has("texCoord")) warn(label + ": KHR_texture_transform.texCoord is ignored (only TEXCOORD_0 is read)");
    std::vector<double> offset = numbers("offset", {0.0, 0.0}), scale = numbers("scale", {1.0, 1.0});
    double r = numbers("rotation", {0.0})[0];
    // The extension's matrix T R S, its GLSL spelled out: u' = c sx u - s sy v + ox,
    // v' = s sx u + c sy v + oy (glm, like GLSL, is column-major: m[column][row]).
    const double c = std::cos(r), s = std::sin(r);
    glm::mat3 m(1.0f);
    m[0][0] = static_cast<float>(c * scale[0]);
    m[0][1] = static_cast<float>(s * scale[0]);
    m[1][0] = static_cast<float>(-s * scale[1]);
    m[1][1] = static_cast<float>(c * scale[1]);
    m[2][0] = static_cast<float>(offset[0]);
    m[2][1] = static_cast<float>(offset[1]);
    return m;
}

int GltfLoader::color_texture(const tinygltf::TextureInfo& info, const glm::vec3& factor, const std::string& label,
                              glm::vec3& mean, const char* what, bool raw) {
    if (info.index < 0 || static_cast<size_t>(info.index) >= model_.textures.size())
        fail(label + ": " + what + " refers to texture " + std::to_string(info.index) +
             ", which does not exist (the file has " + std::to_string(model_.textures.size()) + ")");
    if (info.texCoord != 0) {
        warn(label + ": its " + what + " uses TEXCOORD_" + std::to_string(info.texCoord) +
             "; only TEXCOORD_0 is supported, so the texture is ignored");
        return -1;
    }
    const glm::mat3 to_uv = texture_transform(info, label + ": " + what);
    const auto& t = model_.textures[info.index];
    if (t.source < 0)
        fail(label + ": texture " + std::to_string(info.index) +
             " has no PNG/JPEG source (other image formats' extensions are not supported)");
    if (static_cast<size_t>(t.source) >= model_.images.size())
        fail(label + ": texture " + std::to_string(info.index) + " refers to image " + std::to_string(t.source) +
             ", which does not exist");
    const auto& img = model_.images[t.source];
    std::string img_label = labelled("image", t.source, img.name);

    auto key = std::make_tuple(
        t.source, factor.x, factor.y, factor.z, raw,
        std::array<float, 6>{to_uv[0][0], to_uv[1][0], to_uv[2][0], to_uv[0][1], to_uv[1][1], to_uv[2][1]});
    auto cached = texture_map_.find(key);
    int index;
    if (cached != texture_map_.end()) {
        index = cached->second;
    } else {
        const unsigned char* bytes = nullptr;
        size_t size = 0;
        std::string where;
        if (img.bufferView >= 0) {
            std::tie(bytes, size) = view_bytes(img.bufferView, label + " " + img_label);
            where = path_ + "#images[" + std::to_string(t.source) + "]";
        } else {
            bytes = img.image.data();
            size = img.image.size();
            if (!img.uri.empty()) {
                // tinygltf keeps the uri of external files only (data URIs are decoded).
                fs::path p = fs::path(path_).parent_path() / img.uri;
                std::error_code ec;
                fs::path abs = fs::absolute(p, ec);
                where = (ec ? p : abs).lexically_normal().string();
                if (size == 0)
                    fail(label + ": cannot read " + img_label + " '" + img.uri + "' (looked for " + where + ")");
            } else {
                where = path_ + "#images[" + std::to_string(t.source) + "]";
            }
        }
        Texture tex;
        try {
            tex = decode_image_texture(bytes, size, raw);  // colour textures are sRGB (glTF 2.0 §3.9.2)
        } catch (const std::exception& e) {
            fail(label + ": cannot decode " + img_label + ": " + e.what());
        }
        tex.path = where;
        // vkmech multiplies nothing: the factor (baseColorFactor) goes into the texels.
        for (size_t i = 0; i + 2 < tex.rgb.size(); i += 3)
            for (int c = 0; c < 3; ++c) tex.rgb[i + c] *= factor[c];
        if (t.sampler >= 0 && static_cast<size_t>(t.sampler) < model_.samplers.size()) {
            const auto& s = model_.samplers[t.sampler];
            tex.nearest = s.magFilter == TINYGLTF_TEXTURE_FILTER_NEAREST;
            if (s.wrapS != TINYGLTF_TEXTURE_WRAP_REPEAT || s.wrapT != TINYGLTF_TEXTURE_WRAP_REPEAT)
                warn(label + ": the texture's sampler asks for clamped or mirrored wrapping; vkmech repeats");
        }
        tex.to_uv = to_uv;
        index = static_cast<int>(scene_.textures.size());
        scene_.textures.push_back(std::move(tex));
        texture_map_[key] = index;
    }
    // The constant holds the texture's mean, as in the Mitsuba loader.
    const auto& rgb = scene_.textures[index].rgb;
    glm::dvec3 sum(0.0);
    for (size_t i = 0; i + 2 < rgb.size(); i += 3) sum += glm::dvec3(rgb[i], rgb[i + 1], rgb[i + 2]);
    size_t n = rgb.size() / 3;
    mean = n ? glm::vec3(sum / static_cast<double>(n)) : factor;
    return index;
}

}  // namespace vkmech
