// Mitsuba BSDFs and bitmap textures -> Material / Texture (SPEC §2's
// material models, SPEC §8). Parameter names: Mitsuba 3 first, then the
// 0.5/0.6 camelCase spelling.
#include "scene/image_texture.hpp"
#include "scene/mitsuba_loader.hpp"
#include "scene/named_ior.hpp"
#include "scene/text_parse.hpp"

#include <cmath>
#include <filesystem>

namespace fs = std::filesystem;

namespace vkmech {

namespace {

constexpr float kAir = 1.000277f;
constexpr float kBk7 = 1.5046f;
constexpr float kPolypropylene = 1.49f;

void check_nonnegative(const XProps& p, std::initializer_list<const char*> names, const glm::vec3& c) {
    if (c.x < 0.0f || c.y < 0.0f || c.z < 0.0f)
        p.find(names)->fail(std::string("'") + *names.begin() + "' must not be negative");
}

glm::vec3 color(const XProps& p, std::initializer_list<const char*> names, glm::vec3 fallback) {
    glm::vec3 c = p.get_color(names, fallback);
    check_nonnegative(p, names, c);
    return c;
}

// An IOR given as a number or by name ("bk7", "water", ...).
float ior(const XProps& p, std::initializer_list<const char*> names, float fallback) {
    const XNode* n = p.find(names);
    if (!n) return fallback;
    float v;
    if (n->tag() == "string") {
        std::string name = n->as_string();
        auto named = dielectric_ior(name);
        if (!named) n->fail("unknown IOR name '" + name + "' (expected a number or a Mitsuba name: vacuum, air, water, "
                            "bk7, acrylic glass, polypropylene, diamond, ...)");
        v = *named;
    } else {
        v = *p.opt_float(names);
    }
    if (!(v > 0.0f)) n->fail(std::string("'") + *names.begin() + "' must be positive");
    return v;
}

void distribution(const XProps& p, Material& m) {
    auto d = p.opt_string({"distribution"});
    if (!d) return;  // Mitsuba's default: beckmann
    std::string s = text::lower(*d);
    if (s == "beckmann") m.distribution = MicrofacetDistribution::Beckmann;
    else if (s == "ggx") m.distribution = MicrofacetDistribution::GGX;
    else p.find({"distribution"})->fail("unknown microfacet distribution '" + *d + "' (expected beckmann or ggx)");
}

// Microfacet roughness: `alpha`, or `alpha_u` and `alpha_v` together.
void roughness(const XProps& p, Material& m, bool anisotropic_allowed) {
    auto a = p.opt_float({"alpha"});
    auto au = p.opt_float({"alpha_u", "alphaU"});
    auto av = p.opt_float({"alpha_v", "alphaV"});
    const XNode& where = p.plugin();
    if ((au || av) && !anisotropic_allowed)
        where.fail(where.describe() + " is isotropic: give 'alpha', not 'alpha_u'/'alpha_v'");
    if (a && (au || av)) where.fail(where.describe() + ": give either 'alpha' or 'alpha_u' and 'alpha_v', not both");
    if (au.has_value() != av.has_value()) where.fail(where.describe() + ": 'alpha_u' and 'alpha_v' go together");
    float u = a ? *a : au.value_or(0.1f), v = a ? *a : av.value_or(0.1f);
    if (u < 0.0f || v < 0.0f) where.fail(where.describe() + ": roughness alpha must not be negative");
    // alpha = 0 is a delta lobe in disguise and divides by zero in the
    // microfacet terms; keep it tiny but finite.
    m.alpha_u = std::max(u, 1e-4f);
    m.alpha_v = std::max(v, 1e-4f);
    distribution(p, m);
}

float unit_float(const XProps& p, const char* name, float fallback) {
    float v = p.get_float({name}, fallback);
    if (v < 0.0f || v > 1.0f) p.find({name})->fail(std::string("'") + name + "' must be in [0, 1]");
    return v;
}

void principled(const XProps& p, Material& m) {
    m.metallic = unit_float(p, "metallic", 0.0f);
    m.roughness = unit_float(p, "roughness", 0.5f);
    m.spec_tint = unit_float(p, "spec_tint", 0.0f);
    m.anisotropic = unit_float(p, "anisotropic", 0.0f);
    m.sheen = unit_float(p, "sheen", 0.0f);
    m.sheen_tint = unit_float(p, "sheen_tint", 0.0f);
    m.clearcoat = unit_float(p, "clearcoat", 0.0f);
    m.clearcoat_gloss = unit_float(p, "clearcoat_gloss", 0.0f);
    m.spec_trans = unit_float(p, "spec_trans", 0.0f);
    // Mitsuba: `specular` and `eta` are two views of one quantity
    // (specular = ((eta - 1) / (eta + 1))^2 / 0.08); give one of them.
    auto eta = p.opt_float({"eta"});
    auto spec = p.opt_float({"specular"});
    if (eta && spec) p.plugin().fail(p.plugin().describe() + ": give either 'specular' or 'eta', not both");
    if (eta) {
        if (!(*eta > 0.0f)) p.find({"eta"})->fail("'eta' must be positive");
        m.eta_principled = *eta;
        float r = (*eta - 1.0f) / (*eta + 1.0f);
        m.specular = r * r / 0.08f;
    } else {
        m.specular = unit_float(p, "specular", 0.5f);
        m.eta_principled = 2.0f / (1.0f - std::sqrt(0.08f * m.specular)) - 1.0f;
    }
    m.distribution = MicrofacetDistribution::GGX;  // Mitsuba's principled is GGX-based
}

}  // namespace

int MitsubaLoader::default_material() {
    if (default_material_ < 0) {
        Material m;
        m.id = "default-diffuse";
        m.type = BsdfType::Diffuse;
        m.reflectance = Spectrum3{glm::vec3(0.5f), -1};
        default_material_ = static_cast<int>(scene_.materials.size());
        scene_.materials.push_back(m);
    }
    return default_material_;
}

void MitsubaLoader::register_id(const XNode& n, bool is_bsdf, int index) {
    auto id = n.attr("id");
    if (!id) return;
    auto [it, inserted] = ids_.try_emplace(*id, IdEntry{is_bsdf, index, n.line(), n.file()});
    if (!inserted)
        n.fail("duplicate id '" + *id + "' (first defined at " + it->second.file + ":" +
               std::to_string(it->second.line) + ")");
}

int MitsubaLoader::bsdf_ref(const XNode& n) {
    std::string id = n.required("id");
    auto it = ids_.find(id);
    if (it == ids_.end()) n.fail("unknown bsdf reference '" + id + "' (no <bsdf id=\"" + id + "\"> before it)");
    if (!it->second.is_bsdf) n.fail("'" + id + "' is a texture, not a bsdf");
    return it->second.index;
}

int MitsubaLoader::bsdf(const XNode& n) {
    if (n.tag() == "ref") return bsdf_ref(n);
    const std::string type = n.required("type");
    XProps p(n);
    const std::string id = n.attr("id").value_or("");
    Material m;

    auto nested = [&]() -> const XNode& {
        const XNode* inner = nullptr;
        for (const XNode& o : p.objects()) {
            if (o.tag() != "bsdf" && o.tag() != "ref") o.fail("unexpected <" + o.tag() + "> inside " + n.describe());
            if (inner) o.fail(n.describe() + " with two different nested bsdfs is not supported");
            inner = &o;
        }
        if (!inner) n.fail(n.describe() + " needs a nested <bsdf>");
        return *inner;
    };

    if (type == "twosided") {
        // SPEC §2: `twosided` is transparent to the lobe flags; the model
        // keeps the inner material and marks it two-sided.
        m = scene_.materials[bsdf(nested())];
        m.twosided = true;
    } else if (type == "mask" || type == "bumpmap" || type == "normalmap") {
        if (!options_.substitute_unsupported)
            unsupported(n, "bsdf", " (the --substitute option uses its nested bsdf instead)");
        m = scene_.materials[bsdf(nested())];
        scene_.substitutions.push_back(n.file() + ":" + std::to_string(n.line()) + ": bsdf '" + type +
                                       "' replaced by its nested bsdf (the map is ignored)");
    } else if (type == "diffuse") {
        m.type = BsdfType::Diffuse;
        m.reflectance = reflectance(p, {"reflectance"}, glm::vec3(0.5f));
    } else if (type == "plastic" || type == "roughplastic") {
        m.type = type == "plastic" ? BsdfType::Plastic : BsdfType::RoughPlastic;
        m.reflectance = reflectance(p, {"diffuse_reflectance", "diffuseReflectance"}, glm::vec3(0.5f));
        m.specular_reflectance = color(p, {"specular_reflectance", "specularReflectance"}, glm::vec3(1.0f));
        m.int_ior = ior(p, {"int_ior", "intIOR"}, kPolypropylene);
        m.ext_ior = ior(p, {"ext_ior", "extIOR"}, kAir);
        m.nonlinear = p.get_bool({"nonlinear"}, false);
        if (m.type == BsdfType::RoughPlastic) roughness(p, m, /*anisotropic_allowed=*/false);
    } else if (type == "conductor" || type == "roughconductor") {
        m.type = type == "conductor" ? BsdfType::Conductor : BsdfType::RoughConductor;
        auto material = p.opt_string({"material"});
        auto eta = p.opt_color({"eta"});
        auto k = p.opt_color({"k"});
        if (material && (eta || k)) n.fail(n.describe() + ": give either 'material' or 'eta' and 'k', not both");
        if (eta.has_value() != k.has_value()) n.fail(n.describe() + ": 'eta' and 'k' go together");
        if (eta) {
            if (eta->x < 0 || eta->y < 0 || eta->z < 0 || k->x < 0 || k->y < 0 || k->z < 0)
                n.fail(n.describe() + ": 'eta' and 'k' must not be negative");
            m.eta = *eta;
            m.k = *k;
        } else {
            std::string name = material.value_or("none");
            auto c = conductor_ior(name);
            if (!c)
                p.find({"material"})->fail("unknown conductor material '" + name +
                                           "' (expected none, Au, Ag, Al, Cu, Cr, Fe, Ni, Pt, Ti or W)");
            m.eta = c->eta;
            m.k = c->k;
        }
        m.specular_reflectance = color(p, {"specular_reflectance", "specularReflectance"}, glm::vec3(1.0f));
        // Mitsuba 3's conductors have no exterior medium (eta is relative);
        // 0.6's `extEta` divides it.
        m.ext_ior = ior(p, {"ext_eta", "extEta"}, 1.0f);
        if (m.type == BsdfType::RoughConductor) roughness(p, m, /*anisotropic_allowed=*/true);
    } else if (type == "dielectric" || type == "roughdielectric" || type == "thindielectric") {
        m.type = type == "dielectric"        ? BsdfType::Dielectric
                 : type == "roughdielectric" ? BsdfType::RoughDielectric
                                             : BsdfType::ThinDielectric;
        m.int_ior = ior(p, {"int_ior", "intIOR"}, kBk7);
        m.ext_ior = ior(p, {"ext_ior", "extIOR"}, kAir);
        m.specular_reflectance = color(p, {"specular_reflectance", "specularReflectance"}, glm::vec3(1.0f));
        m.specular_transmittance = color(p, {"specular_transmittance", "specularTransmittance"}, glm::vec3(1.0f));
        if (m.type == BsdfType::RoughDielectric) roughness(p, m, /*anisotropic_allowed=*/true);
    } else if (type == "principled") {
        m.type = BsdfType::Principled;
        m.reflectance = reflectance(p, {"base_color", "baseColor"}, glm::vec3(0.5f));
        principled(p, m);
    } else {
        unsupported(n, "bsdf",
                    " (SPEC §2: diffuse, plastic, roughplastic, conductor, roughconductor, dielectric, "
                    "roughdielectric, thindielectric, principled, twosided)");
    }
    if (type != "twosided" || !id.empty()) m.id = id.empty() ? type + "#" + std::to_string(bsdf_count_) : id;
    ++bsdf_count_;
    int index = static_cast<int>(scene_.materials.size());
    scene_.materials.push_back(m);
    register_id(n, /*is_bsdf=*/true, index);
    return index;
}

Spectrum3 MitsubaLoader::reflectance(const XProps& p, std::initializer_list<const char*> names, glm::vec3 fallback) {
    const XNode* n = p.find(names);
    if (n && (n->tag() == "texture" || n->tag() == "ref")) {
        int t = texture(*n);
        // The constant holds the texture's mean: a fair stand-in wherever a
        // single colour is needed (e.g. estimating albedo).
        glm::dvec3 sum(0.0);
        const auto& rgb = scene_.textures[t].rgb;
        for (size_t i = 0; i + 2 < rgb.size(); i += 3) sum += glm::dvec3(rgb[i], rgb[i + 1], rgb[i + 2]);
        size_t count = rgb.size() / 3;
        return Spectrum3{count ? glm::vec3(sum / static_cast<double>(count)) : fallback, t};
    }
    return Spectrum3{color(p, names, fallback), -1};
}

int MitsubaLoader::texture(const XNode& n) {
    if (n.tag() == "ref") {
        std::string id = n.required("id");
        auto it = ids_.find(id);
        if (it == ids_.end()) n.fail("unknown texture reference '" + id + "'");
        if (it->second.is_bsdf) n.fail("'" + id + "' is a bsdf, not a texture");
        return it->second.index;
    }
    const std::string type = n.required("type");
    if (type != "bitmap") unsupported(n, "texture", " (only 'bitmap' is supported)");
    XProps p(n);
    auto filename = p.opt_string({"filename"});
    if (!filename) n.fail(n.describe() + " is missing the required property 'filename'");
    bool raw = p.get_bool({"raw"}, false);
    std::string path = resolve(n, *filename);
    std::error_code ec;
    if (!fs::is_regular_file(path, ec)) n.fail("cannot open texture file '" + *filename + "' (looked for " + path + ")");
    Texture t;
    try {
        t = load_image_texture(path, raw);
    } catch (const std::exception& e) {
        n.fail("cannot decode texture '" + *filename + "': " + e.what());
    }
    fs::path abs = fs::absolute(path, ec);
    t.path = (ec ? fs::path(path) : abs).lexically_normal().string();
    int index = static_cast<int>(scene_.textures.size());
    scene_.textures.push_back(std::move(t));
    register_id(n, /*is_bsdf=*/false, index);
    return index;
}

}  // namespace vkmech
