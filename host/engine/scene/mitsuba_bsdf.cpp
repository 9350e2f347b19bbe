// Mitsuba BSDFs and bitmap textures -> Material / Texture (docs/descriptor.md §2's
// material models, docs/descriptor.md §8). Parameter names: Mitsuba 3 first, then the
// 0.5/0.6 camelCase spelling.
#include "io/invariant.hpp"
#include "scene/image_texture.hpp"
#include "scene/mitsuba_loader.hpp"
#include "scene/named_ior.hpp"
#include "scene/text_parse.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
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
        if (!named)
            n->fail("unknown IOR name '" + name +
                    "' (expected a number or a Mitsuba name: vacuum, air, water, "
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
    if (s == "beckmann")
        m.distribution = MicrofacetDistribution::Beckmann;
    else if (s == "ggx")
        m.distribution = MicrofacetDistribution::GGX;
    else
        p.find({"distribution"})->fail("unknown microfacet distribution '" + *d + "' (expected beckmann or ggx)");
}

// The mean luminance of a texture's texels (a float parameter's constant stand-in).
float mean_luminance(const Texture& t) {
    double sum = 0.0;
    for (size_t i = 0; i + 2 < t.rgb.size(); i += 3)
        sum += gpu::LUM_R * t.rgb[i] + gpu::LUM_G * t.rgb[i + 1] + gpu::LUM_B * t.rgb[i + 2];
    const size_t count = t.rgb.size() / 3;
    return count ? static_cast<float>(sum / static_cast<double>(count)) : 0.0f;
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

// The one nested <bsdf> (or <ref>) of a wrapper; unnamed <texture> children
// (a bumpmap's height in the 0.6 style) are skipped.
const XNode& nested_ignoring_textures(const XProps& p, const XNode& n) {
    const XNode* inner = nullptr;
    for (const XNode& o : p.objects()) {
        if (o.tag() == "texture") continue;
        if (o.tag() != "bsdf" && o.tag() != "ref") o.fail("unexpected <" + o.tag() + "> inside " + n.describe());
        if (inner) o.fail(n.describe() + " with two different nested bsdfs is not supported");
        inner = &o;
    }
    if (!inner) n.fail(n.describe() + " needs a nested <bsdf>");
    return *inner;
}

void set_specular(Material& m, const Spectrum3& c, bool transmittance) {
    (transmittance ? m.specular_transmittance : m.specular_reflectance) = c.value;
    (transmittance ? m.specular_transmittance_texture : m.specular_reflectance_texture) = c.texture;
}

std::string fmt_weight(float v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.3g", v);
    return buf;
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

const char* MitsubaLoader::to_string(IdKind k) {
    switch (k) {
        case IdKind::Bsdf:
            return "bsdf";
        case IdKind::Texture:
            return "texture";
        case IdKind::Emitter:
            return "emitter";
        case IdKind::Ignored:
            return "sampler, film or rfilter";
        case IdKind::ShapeGroup:
            return "shapegroup";
    }
    return "?";
}

void MitsubaLoader::register_id(const XNode& n, IdKind kind, int index) {
    auto id = n.attr("id");
    if (!id) return;
    auto [it, inserted] = ids_.try_emplace(*id, IdEntry{kind, index, n.line(), n.file()});
    if (!inserted)
        n.fail("duplicate id '" + *id + "' (first defined at " + it->second.file + ":" +
               std::to_string(it->second.line) + ")");
}

const MitsubaLoader::IdEntry& MitsubaLoader::lookup_ref(const XNode& n) {
    std::string id = n.required("id");
    auto it = ids_.find(id);
    if (it == ids_.end())
        n.fail("unknown reference '" + id + "': no <bsdf>, <texture> or <emitter> with id=\"" + id +
               "\" is declared before this line (Mitsuba resolves references in document order)");
    return it->second;
}

int MitsubaLoader::bsdf_ref(const XNode& n) {
    const IdEntry& e = lookup_ref(n);
    if (e.kind != IdKind::Bsdf)
        n.fail("'" + n.required("id") + "' is " + (e.kind == IdKind::Emitter ? "an " : "a ") + to_string(e.kind) +
               " (declared at " + e.file + ":" + std::to_string(e.line) + "), not a bsdf");
    return e.index;
}

int MitsubaLoader::principled_texture(XProps& p) {
    // The textures among roughness and metallic: bitmaps, or checkerboards (whose two colours
    // are combined like two texels).
    const char* names[2] = {"roughness", "metallic"};
    const float defaults[2] = {0.5f, 0.0f};  // Mitsuba 3's
    int index[2] = {-1, -1};
    for (int k = 0; k < 2; ++k) {
        const XNode* t = p.peek(names[k]);
        if (!t || (t->tag() != "texture" && t->tag() != "ref")) continue;
        if (t->tag() == "ref" && lookup_ref(*t).kind != IdKind::Texture) continue;
        index[k] = texture(*t);  // may grow scene_.textures: pointers below, once both are read
    }
    const Texture* tex[2] = {index[0] >= 0 ? &scene_.textures[index[0]] : nullptr,
                             index[1] >= 0 ? &scene_.textures[index[1]] : nullptr};
    if (!tex[0] && !tex[1]) return -1;
    const Texture& base = tex[0] ? *tex[0] : *tex[1];
    if (tex[0] && tex[1] &&
        (tex[1]->kind != base.kind || tex[1]->width != base.width || tex[1]->height != base.height ||
         tex[1]->to_uv != base.to_uv || tex[1]->nearest != base.nearest))
        return -1;  // two layouts: both keep their means (--substitute, below)
    // G: roughness, B: metallic, each the texel's luminance or the constant.
    Texture both = base;
    both.path =
        "roughness " + (tex[0] ? tex[0]->path : "constant") + ", metallic " + (tex[1] ? tex[1]->path : "constant");
    const size_t texels = base.rgb.size() / 3;
    for (int k = 0; k < 2; ++k) {
        const float constant = tex[k] ? mean_luminance(*tex[k]) : p.get_float({names[k]}, defaults[k]);
        for (size_t i = 0; i < texels; ++i) {
            const float* c = tex[k] ? &tex[k]->rgb[3 * i] : nullptr;
            both.rgb[3 * i + 1 + k] =
                c ? static_cast<float>(gpu::LUM_R * c[0] + gpu::LUM_G * c[1] + gpu::LUM_B * c[2]) : constant;
        }
        if (tex[k]) p.set_float(names[k], constant);  // the model's constants hold the means
    }
    for (size_t i = 0; i < texels; ++i) both.rgb[3 * i] = 0.0f;
    scene_.textures.push_back(std::move(both));  // tex[] dangle from here
    return static_cast<int>(scene_.textures.size()) - 1;
}

int MitsubaLoader::bsdf(const XNode& n) {
    if (n.tag() == "ref") return bsdf_ref(n);
    const std::string type = n.required("type");
    XProps p(n);
    const std::string id = n.attr("id").value_or("");
    Material m;
    // roughconductor and roughdielectric read a textured alpha at each hit (Mitsuba 3's
    // textured alpha, alpha_u, alpha_v: the bitmap's luminance); the constant is its mean.
    int alpha_tex[2] = {-1, -1};  // alpha_u, alpha_v
    if (type == "roughconductor" || type == "roughdielectric") {
        for (const char* name : {"alpha", "alpha_u", "alphaU", "alpha_v", "alphaV"}) {
            const XNode* t = p.peek(name);
            if (!t || (t->tag() != "texture" && t->tag() != "ref")) continue;
            if (t->tag() == "ref" && lookup_ref(*t).kind != IdKind::Texture) continue;
            const int index = texture(*t);
            p.set_float(name, mean_luminance(scene_.textures[index]));
            const std::string_view n(name);  // "alpha" sets both, "alpha_u"/"alphaU" u, "alpha_v"/"alphaV" v
            const bool u = n.back() != 'v' && n.back() != 'V', v = n.back() != 'u' && n.back() != 'U';
            if (u) alpha_tex[0] = index;
            if (v) alpha_tex[1] = index;
        }
    }
    // principled reads a textured roughness and metallic at each hit: one linear texture
    // holding both (Material::metallic_roughness_texture, glTF's layout).
    const int principled_tex = type == "principled" ? principled_texture(p) : -1;
    // ... and Mitsuba 3's other textured float parameters, each its luminance texture
    // (Material::principled_param_textures); the constants become the means.
    std::array<int, 7> principled_params{-1, -1, -1, -1, -1, -1, -1};
    if (type == "principled")
        for (size_t k = 0; k < principled_params.size(); ++k) {
            const XNode* t = p.peek(Material::kPrincipledTextured[k]);
            if (!t || (t->tag() != "texture" && t->tag() != "ref")) continue;
            if (t->tag() == "ref" && lookup_ref(*t).kind != IdKind::Texture) continue;
            float mean = 0.0f;
            principled_params[k] = luminance_texture(texture(*t), mean);
            p.set_float(Material::kPrincipledTextured[k], mean);
        }
    // Other textured float parameters (specular, sheen, ...) are outside the
    // model: --substitute uses the texture's mean.
    static const char* float_params[] = {"alpha",     "alpha_u",    "alpha_v",   "alphaU",          "alphaV",
                                         "roughness", "metallic",   "specular",  "spec_tint",       "anisotropic",
                                         "sheen",     "sheen_tint", "clearcoat", "clearcoat_gloss", "spec_trans",
                                         "exponent",  "opacity",    "weight"};
    for (const char* name : float_params) {
        const XNode* t = p.peek(name);
        if (!t || (t->tag() != "texture" && t->tag() != "ref") || type == "mask" || type == "blendbsdf") continue;
        if ((type == "roughconductor" || type == "roughdielectric") && std::string(name).rfind("alpha", 0) == 0)
            continue;  // read at each hit (above)
        if (principled_tex >= 0 && (std::string(name) == "roughness" || std::string(name) == "metallic"))
            continue;          // read at each hit (above)
        bool per_hit = false;  // a principled parameter read at each hit (above)
        for (size_t k = 0; k < principled_params.size(); ++k)
            per_hit = per_hit || (principled_params[k] >= 0 && std::string(name) == Material::kPrincipledTextured[k]);
        if (per_hit) continue;
        if (t->tag() == "ref" && lookup_ref(*t).kind != IdKind::Texture) continue;
        require_substitute(*t, "texture", "its mean value on the float parameter '" + std::string(name) + "'");
        const Texture& tex = scene_.textures[texture(*t)];
        double sum = 0.0;
        for (float v : tex.rgb) sum += v;
        float mean = tex.rgb.empty() ? 0.0f : static_cast<float>(sum / tex.rgb.size());
        p.set_float(name, mean);
        record_substitution(*t, "texture", "its mean " + fmt_weight(mean) + " on the float parameter '" + name + "'");
    }

    auto nested = [&]() -> const XNode& { return nested_ignoring_textures(p, n); };

    if (type == "twosided") {
        // docs/descriptor.md §2: `twosided` is transparent to the lobe flags; the model
        // keeps the inner material and marks it two-sided.
        m = scene_.materials[bsdf(nested())];
        m.twosided = true;
    } else if (type == "normalmap") {
        // Mitsuba's normalmap: the nested bsdf in the frame of a tangent-space normal map
        // (Material::normal_texture; Mitsuba reads it as stored: give the bitmap raw="true").
        const XNode* map = p.find({"normalmap"});
        if (!map || (map->tag() != "texture" && map->tag() != "ref"))
            n.fail("bsdf 'normalmap' needs a texture property 'normalmap'");
        int tex = texture(*map);
        const int inner = bsdf(nested_ignoring_textures(p, n));
        m = scene_.materials[inner];
        if (shading_normal_mapped(inner))
            n.fail(
                "bsdf 'normalmap' around a bsdf that already has a normal or bump map (a blendbsdf: in a component): "
                "vkmech applies one "
                "shading-normal texture per material");
        m.normal_texture = tex;
    } else if (type == "bumpmap") {
        // Mitsuba 3's bumpmap: the nested bsdf under a height texture (its one texture, under
        // any name or none) whose luminance times 'scale' tilts the shading normal at each hit
        // (Material::bump_texture).
        const XNode* height = nullptr;
        for (const XNode& u : p.unused())
            if (!height && (u.tag() == "texture" || u.tag() == "ref"))
                height = p.find({u.raw().attribute("name").as_string()});
        for (const XNode& o : p.objects())
            if (!height && o.tag() == "texture") height = &o;
        if (!height) n.fail("bsdf 'bumpmap' needs a height <texture> (Mitsuba's 'arg')");
        const int tex = texture(*height);
        const float scale = p.get_float({"scale"}, 1.0f);
        if (!std::isfinite(scale)) p.find({"scale"})->fail("bsdf 'bumpmap': 'scale' must be a finite number");
        const int inner = bsdf(nested_ignoring_textures(p, n));
        m = scene_.materials[inner];
        if (shading_normal_mapped(inner))
            n.fail(
                "bsdf 'bumpmap' around a bsdf that already has a normal or bump map (a blendbsdf: in a component): "
                "vkmech applies one "
                "shading-normal texture per material");
        m.bump_texture = tex;
        m.bump_scale = scale;
    } else if (type == "mask") {
        float opacity = 0.5f;
        bool textured = false;
        if (const XNode* o = p.find({"opacity"})) {
            textured = o->tag() == "texture" || o->tag() == "ref";
            if (!textured) opacity = o->as_color().x;
        } else {
            opacity = 0.5f;  // Mitsuba's default
        }
        if (textured || opacity < 1.0f) require_substitute(n, "bsdf", "its nested bsdf, fully opaque");
        m = scene_.materials[bsdf(nested_ignoring_textures(p, n))];
        if (!textured && opacity >= 1.0f) {
            warn(n, "bsdf 'mask' with opacity 1 changes nothing: its nested bsdf is used");
        } else {
            record_substitution(n, "bsdf",
                                "its nested bsdf, fully opaque (the mask's " +
                                    std::string(textured ? "opacity texture" : "opacity") + " is ignored)");
        }
    } else if (type == "blendbsdf") {
        m = blend(p, n);
    } else if (type == "mixturebsdf") {
        m = mixture(p, n, id);
    } else if (type == "phong") {
        // The nearest model material: rough plastic whose Beckmann roughness
        // matches the Phong exponent (alpha = sqrt(2 / (n + 2)), Walter 2007).
        require_substitute(n, "bsdf", "roughplastic of matching roughness");
        m.type = BsdfType::RoughPlastic;
        m.reflectance = reflectance(p, {"diffuse_reflectance", "diffuseReflectance"}, glm::vec3(0.5f));
        p.find({"specular_reflectance", "specularReflectance"});
        float e = p.get_float({"exponent"}, 30.0f);
        if (!(e > 0.0f)) n.fail("'exponent' must be positive");
        m.alpha_u = m.alpha_v = std::sqrt(2.0f / (e + 2.0f));
        m.int_ior = kPolypropylene;
        m.ext_ior = kAir;
        record_substitution(n, "bsdf", "roughplastic with alpha " + fmt_weight(m.alpha_u) + " (Beckmann)");
    } else if (const std::optional<BsdfType> model = bsdf_type_of(type)) {
        m.type = *model;  // a model of the material table (shared/materials.h)
        model_parameters(p, n, m);
    } else if (type == "measured" || type == "hair" || type == "pplastic" || type == "polarizer" ||
               type == "retarder" || type == "circular" || type == "null" || type == "roughcoating" ||
               type == "coating" || type == "difftrans" || type == "principledthin" || type == "ward" ||
               type == "irawan" || type == "dipole" || type == "hk" || type == "sssbrdf") {
        require_substitute(n, "bsdf", "its nested bsdf, or diffuse 0.5");
        m.type = BsdfType::Diffuse;
        m.reflectance = Spectrum3{glm::vec3(0.5f), -1};
        for (const XNode& o : p.objects())
            if (o.tag() == "bsdf") {  // coatings: keep what they wrap
                m = scene_.materials[bsdf(o)];
                break;
            }
        record_substitution(n, "bsdf",
                            m.type == BsdfType::Diffuse && p.objects().empty() ? std::string("diffuse 0.5")
                                                                               : std::string("its nested bsdf"));
        for (const XNode& u : p.unused()) p.find({u.raw().attribute("name").as_string()});
    } else {
        unsupported(n, "bsdf",
                    " (docs/descriptor.md §2: " + bsdf_plugin_names() +
                        ", mixturebsdf, twosided, normalmap, bumpmap; with --substitute also mask, "
                        "phong)");
    }
    if (alpha_tex[0] >= 0) m.alpha_u_texture = alpha_tex[0];
    if (alpha_tex[1] >= 0) m.alpha_v_texture = alpha_tex[1];
    if (principled_tex >= 0) m.metallic_roughness_texture = principled_tex;
    // Only on the principled node itself: a wrapper's copy (twosided, normalmap, ...) keeps its own.
    if (type == "principled") m.principled_param_textures = principled_params;
    warn_unused(p);
    if (type != "twosided" || !id.empty()) m.id = id.empty() ? type + "#" + std::to_string(bsdf_count_) : id;
    ++bsdf_count_;
    int index = static_cast<int>(scene_.materials.size());
    scene_.materials.push_back(m);
    register_id(n, IdKind::Bsdf, index);
    return index;
}

Material MitsubaLoader::blend(const XProps& p, const XNode& n) {
    Material m;
    m.type = BsdfType::Blend;
    std::vector<int> parts;
    for (const XNode& o : p.objects()) {
        if (o.tag() != "bsdf" && o.tag() != "ref") o.fail("unexpected <" + o.tag() + "> inside " + n.describe());
        parts.push_back(bsdf(o));
    }
    if (parts.size() != 2)
        n.fail(n.describe() + " needs exactly two nested bsdfs (it has " + std::to_string(parts.size()) + ")");
    m.blend_first = parts[0];
    m.blend_second = parts[1];
    if (const XNode* w = p.find({"weight"})) {
        if (w->tag() == "texture" || w->tag() == "ref") {
            // A white texel is exactly 1: the second component, no draw (luminance_texture).
            m.blend_weight_texture = luminance_texture(texture(*w), m.blend_weight);
        } else {
            m.blend_weight = w->as_float();
            if (!(m.blend_weight >= 0.0f && m.blend_weight <= 1.0f))
                w->fail("bsdf 'blendbsdf': 'weight' must lie in [0, 1] (it is the second bsdf's share)");
        }
    }
    if (1 + std::max(blend_depth(parts[0]), blend_depth(parts[1])) > static_cast<int>(gpu::BLEND_MAX_DEPTH))
        n.fail(n.describe() + ": blends nested more than " + std::to_string(gpu::BLEND_MAX_DEPTH) +
               " deep (vkmech resolves at most that many at a hit)");
    return m;
}

Material MitsubaLoader::mixture(const XProps& p, const XNode& n, const std::string& id) {
    std::vector<double> w;
    if (auto ws = p.opt_string({"weights"})) w = n.numbers(*ws, "weights");
    std::vector<int> parts;
    for (const XNode& o : p.objects()) {
        if (o.tag() != "bsdf" && o.tag() != "ref") o.fail("unexpected <" + o.tag() + "> inside " + n.describe());
        parts.push_back(bsdf(o));
    }
    if (parts.empty()) n.fail(n.describe() + " needs nested bsdfs");
    if (w.size() != parts.size())
        n.fail(n.describe() + ": 'weights' must give one weight per nested bsdf (" + std::to_string(parts.size()) +
               ")");
    // The name bsdf() gives the mixture (its nested bsdfs counted), for the blends and the black part.
    const std::string name = id.empty() ? "mixturebsdf#" + std::to_string(bsdf_count_) : id;
    const bool conserve = p.get_bool({"ensureEnergyConservation", "ensure_energy_conservation"}, true);
    double total = 0.0;
    for (double x : w) {
        if (!(x >= 0.0)) n.fail(n.describe() + ": every weight must be >= 0");
        total += x;
    }
    if (!(total > 0.0)) n.fail(n.describe() + ": the weights must sum to more than 0");
    if (std::abs(total - 1.0) <= 1e-6) {
        // 1 up to the decimals' rounding (0.2 + 0.7 + 0.1 is 0.9999999999999999 in double): no
        // absorbed rest.
        for (double& x : w) x /= total;
    } else if (total > 1.0) {
        // Mitsuba 0.6 rescales them (ensureEnergyConservation, default true); a choice per hit
        // cannot give more than the whole, so vkmech refuses to keep them.
        if (!conserve)
            n.fail(n.describe() + ": the weights sum to " + fmt_weight(float(total)) +
                   " with ensureEnergyConservation false; vkmech renders a mixture as one component per hit, "
                   "so the weights must sum to at most 1");
        warn(n, "bsdf 'mixturebsdf': the weights sum to " + fmt_weight(float(total)) +
                    ", more than 1: rescaled to sum to 1, as Mitsuba does");
        for (double& x : w) x /= total;
    } else if (total < 1.0) {
        // The rest is absorbed: a black component of weight 1 - total.
        Material black;
        black.id = name + ".absorbed";
        black.reflectance = Spectrum3{glm::vec3(0.0f), -1};
        parts.push_back(static_cast<int>(scene_.materials.size()));
        scene_.materials.push_back(black);
        w.push_back(1.0 - total);
    }
    if (parts.size() == 1) return scene_.materials[parts[0]];
    // A chain of blends from the back: blend k picks component k with probability
    // w_k / (w_k + ... + w_last), else the blend after it.
    int tail = parts.back();
    double rest = w.back();
    for (size_t k = parts.size() - 1; k-- > 0;) {
        rest += w[k];
        Material b;
        b.type = BsdfType::Blend;
        b.id = name + (k == 0 ? "" : "." + std::to_string(k + 1));
        b.blend_first = parts[k];
        b.blend_second = tail;
        b.blend_weight = rest > 0.0 ? static_cast<float>(1.0 - w[k] / rest) : 0.0f;
        if (1 + std::max(blend_depth(parts[k]), blend_depth(tail)) > static_cast<int>(gpu::BLEND_MAX_DEPTH))
            n.fail(n.describe() + ": " + std::to_string(parts.size()) +
                   " components (with the absorbed rest) nest blends more than " +
                   std::to_string(gpu::BLEND_MAX_DEPTH) + " deep (vkmech resolves at most that many at a hit)");
        if (k == 0) return b;
        tail = static_cast<int>(scene_.materials.size());
        scene_.materials.push_back(b);
    }
    return scene_.materials[parts[0]];  // not reached: k == 0 returns above
}

int MitsubaLoader::luminance_texture(int source, float& mean) {
    Texture lum = scene_.textures[source];
    double sum = 0.0;
    for (size_t i = 0; i + 2 < lum.rgb.size(); i += 3) {
        const double l =
            double(gpu::LUM_R) * lum.rgb[i] + double(gpu::LUM_G) * lum.rgb[i + 1] + double(gpu::LUM_B) * lum.rgb[i + 2];
        lum.rgb[i] = lum.rgb[i + 1] = lum.rgb[i + 2] = static_cast<float>(l);
        sum += l;
    }
    lum.path = "luminance of " + lum.path;
    mean = static_cast<float>(sum / std::max<double>(1.0, static_cast<double>(lum.rgb.size() / 3)));
    scene_.textures.push_back(std::move(lum));
    return static_cast<int>(scene_.textures.size()) - 1;
}

int MitsubaLoader::blend_depth(int index) const {
    const Material& m = scene_.materials.at(static_cast<size_t>(index));
    if (m.type != BsdfType::Blend) return 0;
    return 1 + std::max(blend_depth(m.blend_first), blend_depth(m.blend_second));
}

bool MitsubaLoader::shading_normal_mapped(int index) const {
    const Material& m = scene_.materials.at(static_cast<size_t>(index));
    if (m.normal_texture >= 0 || m.bump_texture >= 0) return true;
    return m.type == BsdfType::Blend && (shading_normal_mapped(m.blend_first) || shading_normal_mapped(m.blend_second));
}

// The parameters of a model of the material table, by Mitsuba's names.
void MitsubaLoader::model_parameters(const XProps& p, const XNode& n, Material& m) {
    switch (m.type) {
        case BsdfType::Diffuse:
            m.reflectance = reflectance(p, {"reflectance"}, glm::vec3(0.5f));
            return;
        case BsdfType::Plastic:
        case BsdfType::RoughPlastic:
            m.reflectance = reflectance(p, {"diffuse_reflectance", "diffuseReflectance"}, glm::vec3(0.5f));
            set_specular(m, reflectance(p, {"specular_reflectance", "specularReflectance"}, glm::vec3(1.0f)), false);
            m.int_ior = ior(p, {"int_ior", "intIOR"}, kPolypropylene);
            m.ext_ior = ior(p, {"ext_ior", "extIOR"}, kAir);
            m.nonlinear = p.get_bool({"nonlinear"}, false);
            if (m.type == BsdfType::RoughPlastic) roughness(p, m, /*anisotropic_allowed=*/false);
            return;
        case BsdfType::Conductor:
        case BsdfType::RoughConductor:
            conductor_parameters(p, n, m);
            return;
        case BsdfType::Dielectric:
        case BsdfType::RoughDielectric:
        case BsdfType::ThinDielectric:
            m.int_ior = ior(p, {"int_ior", "intIOR"}, kBk7);
            m.ext_ior = ior(p, {"ext_ior", "extIOR"}, kAir);
            set_specular(m, reflectance(p, {"specular_reflectance", "specularReflectance"}, glm::vec3(1.0f)), false);
            set_specular(m, reflectance(p, {"specular_transmittance", "specularTransmittance"}, glm::vec3(1.0f)), true);
            if (m.type == BsdfType::RoughDielectric) roughness(p, m, /*anisotropic_allowed=*/true);
            return;
        case BsdfType::Principled:
            m.reflectance = reflectance(p, {"base_color", "baseColor"}, glm::vec3(0.5f));
            principled(p, m);
            return;
        case BsdfType::RoughDiffuse:
            // Oren-Nayar (Mitsuba 0.6): reflectance and the RMS roughness alpha (default 0.2).
            m.reflectance =
                reflectance(p, {"reflectance", "diffuseReflectance", "diffuse_reflectance"}, glm::vec3(0.5f));
            m.alpha_u = m.alpha_v = p.get_float({"alpha"}, 0.2f);
            if (!(m.alpha_u >= 0.0f) || !std::isfinite(m.alpha_u)) n.fail("'alpha' must be a finite number >= 0");
            if (p.get_bool({"use_fast_approx", "useFastApprox"}, false))
                warn(n, "use_fast_approx is ignored: the full Oren-Nayar model is rendered (Mitsuba's default)");
            return;
        case BsdfType::Blend:
            break;  // MitsubaLoader::blend; never parsed here
    }
    VKM_ASSERT(false, "BsdfType " + std::to_string(static_cast<uint32_t>(m.type)) + " has no parameter parsing");
}

// conductor, roughconductor: the complex IOR by 'material' or 'eta' and 'k'.
void MitsubaLoader::conductor_parameters(const XProps& p, const XNode& n, Material& m) {
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
            p.find({"material"})
                ->fail("unknown conductor material '" + name + "' (expected one of " + conductor_names() + ")");
        m.eta = c->eta;
        m.k = c->k;
    }
    set_specular(m, reflectance(p, {"specular_reflectance", "specularReflectance"}, glm::vec3(1.0f)), false);
    // Mitsuba 3's conductors have no exterior medium (eta is relative);
    // 0.6's `extEta` divides it.
    m.ext_ior = ior(p, {"ext_eta", "extEta"}, 1.0f);
    if (m.type == BsdfType::RoughConductor) roughness(p, m, /*anisotropic_allowed=*/true);
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

glm::mat3 MitsubaLoader::to_uv(const XProps& p) {
    // Mitsuba: a 3x3 uv transform, or the upper-left 3x3 of a 4x4 one (so a
    // <scale> works, and a 4x4 <translate> has no effect, as in Mitsuba).
    // Mitsuba 0.6 spelled it uscale / vscale / uoffset / voffset.
    glm::mat4 m = p.get_transform({"to_uv"});
    glm::mat3 out(1.0f);
    for (int r = 0; r < 2; ++r)
        for (int c = 0; c < 3; ++c) out[c][r] = m[c][r];
    float us = p.get_float({"uscale", "uScale"}, 1.0f), vs = p.get_float({"vscale", "vScale"}, 1.0f);
    float uo = p.get_float({"uoffset", "uOffset"}, 0.0f), vo = p.get_float({"voffset", "vOffset"}, 0.0f);
    if (us != 1.0f || vs != 1.0f || uo != 0.0f || vo != 0.0f) {
        glm::mat3 legacy(1.0f);
        legacy[0][0] = us;
        legacy[1][1] = vs;
        legacy[2][0] = uo;
        legacy[2][1] = vo;
        out = legacy * out;
    }
    for (int c = 0; c < 3; ++c)
        for (int r = 0; r < 2; ++r)
            if (!std::isfinite(out[c][r])) p.plugin().fail(p.plugin().describe() + ": the uv transform is not finite");
    return out;
}

int MitsubaLoader::texture(const XNode& n) {
    if (n.tag() == "ref") {
        const IdEntry& e = lookup_ref(n);
        if (e.kind != IdKind::Texture)
            n.fail("'" + n.required("id") + "' is " + (e.kind == IdKind::Emitter ? "an " : "a ") + to_string(e.kind) +
                   ", not a texture");
        return e.index;
    }
    const std::string type = n.required("type");
    XProps p(n);
    Texture t;
    if (type == "bitmap") {
        auto filename = p.opt_string({"filename"});
        if (!filename) n.fail(n.describe() + " is missing the required property 'filename'");
        bool raw = p.get_bool({"raw"}, false);
        std::string path = resolve(n, *filename);
        std::error_code ec;
        if (!fs::is_regular_file(path, ec))
            n.fail("cannot open texture file '" + *filename + "' (looked for " + path + ")");
        try {
            t = load_image_texture(path, raw);
        } catch (const std::exception& e) {
            n.fail("cannot decode texture '" + *filename + "': " + e.what());
        }
        fs::path abs = fs::absolute(path, ec);
        t.path = (ec ? fs::path(path) : abs).lexically_normal().string();
        scene_.files.push_back(t.path);
        if (auto filter = p.opt_string({"filter_type", "filterType"})) {
            std::string f = text::lower(*filter);
            if (f == "nearest")
                t.nearest = true;
            else if (f != "bilinear" && f != "ewa" && f != "trilinear")
                p.find({"filter_type", "filterType"})
                    ->fail("unknown filter_type '" + *filter + "' (expected bilinear or nearest)");
        }
        if (auto wrap = p.opt_string({"wrap_mode", "wrapMode"}); wrap && text::lower(*wrap) != "repeat")
            warn(n, n.describe() + ": wrap_mode '" + *wrap + "' is not supported; the texture repeats");
    } else if (type == "checkerboard") {
        // Mitsuba 3: colour 0 where exactly one of frac(u), frac(v) exceeds 1/2.
        t.kind = TextureKind::Checkerboard;
        glm::vec3 c0 = color(p, {"color0"}, glm::vec3(0.4f)), c1 = color(p, {"color1"}, glm::vec3(0.2f));
        t.width = 2;
        t.height = 1;
        t.rgb = {c0.x, c0.y, c0.z, c1.x, c1.y, c1.z};
        t.path = "checkerboard(" + fmt_weight(c0.x) + " " + fmt_weight(c0.y) + " " + fmt_weight(c0.z) + " / " +
                 fmt_weight(c1.x) + " " + fmt_weight(c1.y) + " " + fmt_weight(c1.z) + ")";
    } else {
        unsupported(n, "texture", " (expected bitmap or checkerboard)");
    }
    t.to_uv = to_uv(p);
    warn_unused(p);
    int index = static_cast<int>(scene_.textures.size());
    scene_.textures.push_back(std::move(t));
    register_id(n, IdKind::Texture, index);
    return index;
}

}  // namespace vkmech
