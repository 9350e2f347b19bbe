// Mitsuba 3 (and 0.5/0.6) XML scenes, docs/descriptor.md §8: scene structure, shapes,
// emitters, the sensor and the integrator. BSDFs and textures are in
// mitsuba_bsdf.cpp.
#include "scene/mitsuba_loader.hpp"

#include "scene/environment.hpp"
#include "scene/image_texture.hpp"
#include "scene/mesh_io.hpp"
#include "scene/mesh_ops.hpp"
#include "scene/primitives.hpp"
#include "scene/serialized_io.hpp"
#include "scene/sunsky.hpp"
#include "scene/text_parse.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <iomanip>
#include <limits>
#include <sstream>

namespace fs = std::filesystem;

namespace vkmech {

namespace {

std::string fmt_num(float v) {
    std::ostringstream s;
    s << v;
    return s.str();
}

std::string fmt_vec(const glm::vec3& v) {
    std::ostringstream s;
    s << v.x << " " << v.y << " " << v.z;
    return s.str();
}

// Filesystem queries that answer "no" instead of throwing (a permission
// problem must surface as a SceneError at the referencing line).
bool is_file(const std::string& p) {
    std::error_code ec;
    return fs::is_regular_file(p, ec);
}

std::string canonical_or_self(const std::string& p) {
    std::error_code ec;
    fs::path c = fs::weakly_canonical(p, ec);
    return ec ? fs::path(p).lexically_normal().string() : c.string();
}

constexpr int kMaxIncludeDepth = 16;
// Each file may include the next many times: without a total, 16 levels
// of 8 includes each are 8^16 parses.
constexpr size_t kMaxIncludes = 1000;
// Mitsuba's max_depth = -1 ("no limit"); Russian roulette ends paths long
// before this in practice.
constexpr int kUnlimitedDepth = 1024;
// Instances of shape groups: a transform each (112 bytes on the device).
constexpr size_t kMaxInstances = 10'000'000;

}  // namespace

MitsubaLoader::MitsubaLoader(const std::string& path, const LoadOptions& options)
    : path_(path), options_(options), params_(options.params), budget_(max_triangles(options, path)) {}

Scene MitsubaLoader::load() {
    scene_.source = path_;
    docs_.push_back(std::make_unique<XmlDocument>(path_));
    include_stack_.push_back(canonical_or_self(path_));
    scene_element(*docs_.back(), 0, Pass::Declarations);
    scene_element(*docs_.front(), 0, Pass::Objects);
    if (!have_sensor_)
        throw SceneError(path_, docs_.front()->line_of(docs_.front()->root()),
                         "the scene has no <sensor> (docs/descriptor.md §8: perspective or thinlens)");
    add_substituted_panels();
    add_substituted_point_lights();
    for (const auto& name : params_.unused_overrides())
        scene_.warnings.push_back(path_ + ": -D " + name + "=... is not used by the scene (no $" + name +
                                  " in it); check the name");
    for (const auto& [id, e] : ids_)
        if (e.kind == IdKind::Emitter && declared_emitters_[e.index].uses == 0)
            scene_.warnings.push_back(e.file + ":" + std::to_string(e.line) + ": emitter '" + id +
                                      "' is declared but no shape uses it (<ref id=\"" + id + "\"/> inside a shape)");
    prune_uninstanced_groups();
    prune_unused();
    return std::move(scene_);
}

void MitsubaLoader::scene_element(const XmlDocument& doc, int depth, Pass pass) {
    XNode root(doc, doc.root(), params_);
    if (root.tag() != "scene") root.fail("the root element must be <scene>, not <" + root.tag() + ">");
    if (depth == 0 && pass == Pass::Declarations)
        if (auto v = root.attr("version"); v && !v->empty() && std::isdigit(static_cast<unsigned char>((*v)[0])))
            major_version_ = std::atoi(v->c_str());
    for (const XNode& c : root.children()) child_of_scene(c, depth, pass);
}

[[noreturn]] void MitsubaLoader::unsupported(const XNode& n, const std::string& kind, const std::string& extra) const {
    const std::string type = n.raw().attribute("type").value();
    // Plugin names are case-sensitive; a capitalized known name gets a hint.
    static const char* known[] = {"obj",
                                  "ply",
                                  "serialized",
                                  "rectangle",
                                  "cube",
                                  "sphere",
                                  "disk",
                                  "cylinder",
                                  "shapegroup",
                                  "instance",
                                  "perspective",
                                  "thinlens",
                                  "orthographic",
                                  "diffuse",
                                  "plastic",
                                  "roughplastic",
                                  "conductor",
                                  "roughconductor",
                                  "dielectric",
                                  "roughdielectric",
                                  "thindielectric",
                                  "principled",
                                  "twosided",
                                  "area",
                                  "bitmap",
                                  "checkerboard"};
    std::string hint;
    for (const char* k : known)
        if (type != k && text::lower(type) == k)
            hint = " (plugin names are lowercase: did you mean '" + std::string(k) + "'?)";
    n.fail("unsupported " + kind + " plugin '" + type + "'" + extra + hint);
}

void MitsubaLoader::warn(const XNode& n, const std::string& what) {
    scene_.warnings.push_back(n.file() + ":" + std::to_string(n.line()) + ": " + what);
}

void MitsubaLoader::warn_unused(const XProps& p) {
    std::vector<XNode> unused = p.unused();
    if (unused.empty()) return;
    std::string names;
    for (const XNode& u : unused)
        names += std::string(names.empty() ? "'" : ", '") + u.raw().attribute("name").as_string() + "'";
    warn(p.plugin(), p.plugin().describe() + ": " + (unused.size() == 1 ? "property " : "properties ") + names +
                         (unused.size() == 1 ? " is" : " are") + " not used by vkmech");
}

void MitsubaLoader::require_substitute(const XNode& n, const std::string& kind, const std::string& replacement) const {
    if (!options_.substitute_unsupported)
        n.fail("unsupported " + kind + " plugin '" + n.raw().attribute("type").value() +
               "' (outside vkmech's model, docs/descriptor.md §8; the --substitute option replaces it by " +
               replacement + ")");
}

void MitsubaLoader::record_substitution(const XNode& n, const std::string& kind, const std::string& replacement) {
    scene_.substitutions.push_back(n.file() + ":" + std::to_string(n.line()) + ": " + kind + " '" +
                                   n.raw().attribute("type").value() + "' replaced by " + replacement);
}

void MitsubaLoader::child_of_scene(const XNode& n, int depth, Pass pass) {
    const std::string t = n.tag();
    if (t == "include") return include(n, depth, pass);
    const bool declaration = t == "default" || t == "path" || t == "alias" || t == "bsdf" || t == "texture" ||
                             t == "emitter" || t == "sampler" || t == "rfilter" || t == "film";
    if (declaration != (pass == Pass::Declarations)) return;
    if (t == "default") {
        params_.add_default(n.required("name"), n.required("value"));
    } else if (t == "sampler" || t == "rfilter" || t == "film") {
        // Mitsuba 3 lets these be declared at top level and referenced from
        // the sensor: vkmech uses none of them (its sampler, box filter and
        // outputs are its own), so they are said and skipped.
        warn(n, "<" + t + " type=\"" + n.raw().attribute("type").value() + "\"> is not used" +
                    (t == "sampler"   ? " (set the samples with --spp)"
                     : t == "rfilter" ? " (vkmech uses a box filter)"
                                      : ""));
        register_id(n, IdKind::Ignored, -1);
    } else if (t == "bsdf") {
        bsdf(n);
    } else if (t == "texture") {
        texture(n);
    } else if (t == "shape") {
        shape(n);
    } else if (t == "emitter") {
        emitter_top(n);
    } else if (t == "sensor") {
        sensor(n);
    } else if (t == "integrator") {
        integrator(n);
    } else if (t == "path") {
        // Mitsuba's file resolver: later relative file names are also looked
        // up in this directory (relative to the file that names it).
        fs::path dir(n.required("value"));
        if (dir.is_relative()) dir = fs::path(n.file()).parent_path() / dir;
        search_paths_.push_back(dir.lexically_normal().string());
    } else if (t == "alias") {
        std::string id = n.required("id"), as = n.required("as");
        auto it = ids_.find(id);
        if (it == ids_.end()) n.fail("<alias> of unknown id '" + id + "'");
        auto [jt, inserted] = ids_.try_emplace(as, it->second);
        if (!inserted) n.fail("<alias as=\"" + as + "\">: the id '" + as + "' is already defined");
    } else if (t == "medium" || t == "phase" || t == "volume") {
        if (!options_.substitute_unsupported)
            n.fail("unsupported <" + t +
                   "> (participating media are outside vkmech's model; --substitute ignores "
                   "them)");
        scene_.substitutions.push_back(n.file() + ":" + std::to_string(n.line()) + ": <" + t + "> ignored (no media)");
    } else {
        n.fail("unknown element <" + t + "> in <scene>");
    }
}

std::string MitsubaLoader::resolve(const XNode& n, const std::string& filename) const {
    fs::path p(filename);
    if (p.is_absolute()) return p.lexically_normal().string();
    // Relative to the file that names it, then to the main scene file
    // (Mitsuba's file resolver has the scene's folder).
    fs::path here = fs::path(n.file()).parent_path() / p;
    if (is_file(here.string())) return here.lexically_normal().string();
    fs::path main = fs::path(path_).parent_path() / p;
    if (is_file(main.string())) return main.lexically_normal().string();
    for (auto it = search_paths_.rbegin(); it != search_paths_.rend(); ++it) {
        fs::path q = fs::path(*it) / p;
        if (is_file(q.string())) return q.lexically_normal().string();
    }
    return here.lexically_normal().string();
}

void MitsubaLoader::include(const XNode& n, int depth, Pass pass) {
    // Parsed in the first pass; the second walks the same document.
    const std::string key = n.file() + ":" + std::to_string(n.line());
    const XmlDocument* doc = nullptr;
    std::string canon;
    if (pass == Pass::Declarations) {
        std::string path = resolve(n, n.required("filename"));
        if (depth + 1 > kMaxIncludeDepth)
            n.fail("includes nested more than " + std::to_string(kMaxIncludeDepth) + " deep");
        canon = canonical_or_self(path);
        if (std::find(include_stack_.begin(), include_stack_.end(), canon) != include_stack_.end())
            n.fail("include cycle: '" + path + "' includes itself");
        if (docs_.size() > kMaxIncludes)
            n.fail("more than " + std::to_string(kMaxIncludes) +
                   " includes in one scene (files that include "
                   "others many times over?)");
        docs_.push_back(std::make_unique<XmlDocument>(path, n.file(), n.line()));
        scene_.files.push_back(path);
        doc = docs_.back().get();
        included_[key] = doc;
    } else {
        auto it = included_.find(key);
        if (it == included_.end()) return;
        doc = it->second;
        canon = canonical_or_self(doc->path());
    }
    include_stack_.push_back(canon);
    scene_element(*doc, depth + 1, pass);
    include_stack_.pop_back();
}

// ---- shapes ----

void MitsubaLoader::shape_group(const XNode& n) {
    if (current_group_ >= 0) n.fail("a shapegroup inside a shapegroup (Mitsuba does not nest them either)");
    const auto id = n.attr("id");
    if (!id) n.fail("a shapegroup needs an id: instances refer to it with <ref id=\"...\"/>");
    XProps p(n);
    const int g = static_cast<int>(scene_.groups.size());
    scene_.groups.push_back(ShapeGroup{*id});
    register_id(n, IdKind::ShapeGroup, g);
    current_group_ = g;
    for (const XNode& o : p.objects()) {
        if (o.tag() != "shape") o.fail("a shapegroup holds <shape> elements only, not <" + o.tag() + ">");
        shape(o);
    }
    current_group_ = -1;
    warn_unused(p);
}

void MitsubaLoader::instance(const XNode& n) {
    if (current_group_ >= 0) n.fail("an instance inside a shapegroup (Mitsuba does not nest instancing)");
    XProps p(n);
    Instance inst;
    inst.to_world = p.get_transform({"to_world", "toWorld"});
    const float det = glm::determinant(glm::mat3(inst.to_world));
    if (!(std::abs(det) > 0.0f)) n.fail(n.describe() + ": the to_world transform is singular");
    for (const XNode& o : p.objects()) {
        if (o.tag() != "ref") o.fail("an instance takes one <ref id=\"...\"/> to a shapegroup, not <" + o.tag() + ">");
        const IdEntry& e = lookup_ref(o);
        if (e.kind != IdKind::ShapeGroup)
            o.fail("'" + o.required("id") + "' is a " + to_string(e.kind) + "; an instance refers to a shapegroup");
        if (inst.group >= 0) o.fail("an instance refers to one shapegroup, not several");
        inst.group = e.index;
    }
    if (inst.group < 0) n.fail("an instance needs a <ref id=\"...\"/> to a shapegroup");
    inst.name = n.attr("id").value_or("instance#" + std::to_string(scene_.instances.size()));
    if (scene_.instances.size() >= kMaxInstances) n.fail("more than " + std::to_string(kMaxInstances) + " instances");
    warn_unused(p);
    scene_.instances.push_back(std::move(inst));
}

void MitsubaLoader::prune_uninstanced_groups() {
    std::vector<int> group_map(scene_.groups.size(), -1);
    std::vector<ShapeGroup> groups;
    for (const auto& i : scene_.instances)
        if (group_map[i.group] < 0) {
            group_map[i.group] = static_cast<int>(groups.size());
            groups.push_back(scene_.groups[i.group]);
        }
    if (groups.size() == scene_.groups.size() &&
        std::is_sorted(group_map.begin(), group_map.end()))  // every group used, in order: nothing to drop
        return;
    for (size_t g = 0; g < scene_.groups.size(); ++g)
        if (group_map[g] < 0)
            scene_.warnings.push_back(path_ + ": shapegroup '" + scene_.groups[g].name +
                                      "' is never instanced; its shapes are not rendered");
    std::vector<Mesh> meshes;
    std::vector<int> mesh_map(scene_.meshes.size(), -1);
    for (size_t m = 0; m < scene_.meshes.size(); ++m) {
        Mesh& mesh = scene_.meshes[m];
        if (mesh.group >= 0 && group_map[mesh.group] < 0) continue;
        if (mesh.group >= 0) mesh.group = group_map[mesh.group];
        mesh_map[m] = static_cast<int>(meshes.size());
        meshes.push_back(std::move(mesh));
    }
    for (auto& e : scene_.emitters) e.mesh = mesh_map[e.mesh];  // emitters are never in a group
    for (auto& i : scene_.instances) i.group = group_map[i.group];
    scene_.meshes = std::move(meshes);
    scene_.groups = std::move(groups);
}

void MitsubaLoader::shape(const XNode& n) {
    const std::string type = n.required("type");
    if (type == "shapegroup") return shape_group(n);
    if (type == "instance") return instance(n);
    XProps p(n);
    glm::mat4 to_world = p.get_transform({"to_world", "toWorld"});
    float det = glm::determinant(glm::mat3(to_world));
    if (!(std::abs(det) > 0.0f)) n.fail(n.describe() + ": the to_world transform is singular");
    bool flip = p.get_bool({"flip_normals", "flipNormals"}, false);

    Mesh mesh;
    if (type == "obj" || type == "ply" || type == "serialized") {
        auto filename = p.opt_string({"filename"});
        if (!filename) n.fail(n.describe() + " is missing the required property 'filename'");
        std::string path = resolve(n, *filename);
        if (!is_file(path)) n.fail("cannot open mesh file '" + *filename + "' (looked for " + path + ")");
        scene_.files.push_back(path);
        try {
            if (type == "serialized")
                mesh = load_serialized(path, p.opt_int({"shape_index", "shapeIndex"}).value_or(0), budget_.left());
            else
                mesh = type == "obj" ? load_obj(path, budget_.left()) : load_ply(path, budget_.left());
        } catch (const SceneError& e) {
            // Keep the mesh file's position; say which shape asked for it.
            throw SceneError(
                e.file(), e.line(),
                e.reason() + " (mesh of " + n.describe() + " at " + n.file() + ":" + std::to_string(n.line()) + ")");
        }
        bool face_normals = p.get_bool({"face_normals", "faceNormals"}, false);
        if (face_normals) mesh.normals.clear();
        bool file_normals = !mesh.normals.empty();
        // With normals from the file, keep their facing under a mirroring
        // to_world; without, Mitsuba derives them from the world-space
        // winding, so the winding stays as written.
        transform_mesh(mesh, to_world, /*keep_facing=*/file_normals);
        if (!face_normals && !file_normals) compute_vertex_normals(mesh);
        // Mitsuba's OBJ reader flips v by default (OBJ puts v = 0 at the
        // bottom, Mitsuba's bitmaps at the top row).
        if (p.get_bool({"flip_tex_coords", "flipTexCoords"}, type == "obj"))
            for (auto& uv : mesh.uvs) uv.y = 1.0f - uv.y;
        if (flip) flip_orientation(mesh);
        mesh.flip_normals = flip;
        mesh.kind = ShapeKind::Mesh;
        mesh.center = glm::vec3(to_world[3]);
    } else if (type == "rectangle") {
        mesh = make_rectangle(to_world, flip);
    } else if (type == "cube") {
        mesh = make_cube(to_world, flip);
    } else if (type == "disk") {
        mesh = make_disk(to_world, flip);
    } else if (type == "sphere") {
        glm::vec3 center = p.get_vector({"center"}, glm::vec3(0.0f));
        float radius = p.get_float({"radius"}, 1.0f);
        if (!(radius > 0.0f)) n.fail(n.describe() + ": the radius must be positive, got " + fmt_num(radius));
        // A non-uniform to_world gives an ellipsoid (the project's scenes use
        // them); Mitsuba would warn and keep a sphere. See make_sphere.
        mesh = make_sphere(center, radius, to_world, flip);
    } else if (type == "cylinder") {
        glm::vec3 p0 = p.get_vector({"p0"}, glm::vec3(0.0f));
        glm::vec3 p1 = p.get_vector({"p1"}, glm::vec3(0.0f, 0.0f, 1.0f));
        float radius = p.get_float({"radius"}, 1.0f);
        if (!(radius > 0.0f)) n.fail(n.describe() + ": the radius must be positive, got " + fmt_num(radius));
        if (!(glm::length(p1 - p0) > 0.0f)) n.fail(n.describe() + ": p0 and p1 coincide");
        mesh = make_cylinder(p0, p1, radius, to_world, flip);
    } else {
        unsupported(
            n, "shape",
            " (expected obj, ply, serialized, rectangle, cube, sphere, disk, cylinder, shapegroup or instance)");
    }
    mesh.name = n.attr("id").value_or(type + "#" + std::to_string(shape_count_));
    budget_.charge(mesh.indices.size(), n.file(), n.line(), n.describe() + " '" + mesh.name + "'");
    ++shape_count_;
    shape_bsdf_and_emitter(n, p, mesh);
    if (current_group_ >= 0) {
        if (mesh.emitter >= 0)
            n.fail(n.describe() + " in shapegroup '" + scene_.groups[current_group_].name +
                   "' is an emitter; shapegroups hold no emitters (as in Mitsuba)");
        mesh.group = current_group_;
    }
    warn_unused(p);
    scene_.meshes.push_back(std::move(mesh));
}

void MitsubaLoader::shape_bsdf_and_emitter(const XNode& n, const XProps& p, Mesh& mesh) {
    int material = -1;
    int emission_texture = -1;  // a nested area emitter's radiance texture
    auto set_material = [&](const XNode& where, int m) {
        if (material >= 0) where.fail(n.describe() + " has more than one bsdf");
        material = m;
    };
    auto set_emitter = [&](const XNode& where, int e) {
        if (mesh.emitter >= 0) where.fail(n.describe() + " has more than one emitter");
        mesh.emitter = e;
    };
    const int mesh_index = static_cast<int>(scene_.meshes.size());  // the index this mesh will get
    auto use_declared_emitter = [&](const XNode& where, int declared) {
        declared_emitters_[declared].uses++;
        if (declared_emitters_[declared].texture >= 0) emission_texture = declared_emitters_[declared].texture;
        AreaEmitter e;
        e.radiance = declared_emitters_[declared].radiance;
        e.mesh = mesh_index;
        set_emitter(where, static_cast<int>(scene_.emitters.size()));
        scene_.emitters.push_back(e);
    };
    for (const XNode& o : p.objects()) {
        const std::string t = o.tag();
        if (t == "ref") {
            // A reference names a bsdf or an area emitter declared at top level.
            const IdEntry& e = lookup_ref(o);
            if (e.kind == IdKind::Bsdf)
                set_material(o, e.index);
            else if (e.kind == IdKind::Emitter)
                use_declared_emitter(o, e.index);
            else
                o.fail("'" + o.required("id") + "' is a " + to_string(e.kind) + "; a shape takes a bsdf or an emitter");
        } else if (t == "bsdf") {
            set_material(o, bsdf(o));
        } else if (t == "emitter") {
            const std::string type = o.required("type");
            if (type != "area") unsupported(o, "emitter", " (only 'area' emitters can be attached to a shape)");
            set_emitter(o, area_emitter(o, mesh_index, emission_texture));
        } else if (t == "medium") {
            if (!options_.substitute_unsupported)
                o.fail(
                    "unsupported <medium> (participating media are outside vkmech's model; --substitute ignores "
                    "them)");
            scene_.substitutions.push_back(o.file() + ":" + std::to_string(o.line()) + ": <medium> of " + n.describe() +
                                           " ignored (no media)");
        } else {
            o.fail("unexpected <" + t + "> inside " + n.describe());
        }
    }
    if (const XNode* r = p.find({"bsdf"})) set_material(*r, r->tag() == "ref" ? bsdf_ref(*r) : bsdf(*r));
    if (const XNode* r = p.find({"emitter"})) {
        if (r->tag() != "ref") r->fail("a named emitter property must be a <ref id=...>");
        const IdEntry& e = lookup_ref(*r);
        if (e.kind != IdKind::Emitter) r->fail("'" + r->required("id") + "' is not an emitter");
        use_declared_emitter(*r, e.index);
    }
    for (const char* medium : {"interior", "exterior"})
        if (const XNode* r = p.find({medium})) {
            if (!options_.substitute_unsupported)
                r->fail(std::string("unsupported ") + medium +
                        " medium (participating media are outside vkmech's model; --substitute ignores them)");
            scene_.substitutions.push_back(r->file() + ":" + std::to_string(r->line()) + ": " + medium + " medium of " +
                                           n.describe() + " ignored (no media)");
        }
    // Mitsuba gives a shape without a bsdf a diffuse 0.5 one.
    mesh.material = material >= 0 ? material : default_material();
    if (emission_texture >= 0) {
        // The radiance texture is the material's emission texture (Material::emission_texture): this
        // shape gets its own copy of the material, which other shapes may share.
        Material m = scene_.materials[mesh.material];
        m.emission_texture = emission_texture;
        m.id += "+emission";
        mesh.material = static_cast<int>(scene_.materials.size());
        scene_.materials.push_back(std::move(m));
    }
}

// ---- emitters, sensor, integrator ----

glm::vec3 MitsubaLoader::area_radiance(const XNode& n, const XProps& ep, int& radiance_texture) {
    const XNode* t = ep.peek("radiance");
    if (t && (t->tag() == "texture" || (t->tag() == "ref" && lookup_ref(*t).kind == IdKind::Texture))) {
        // A textured radiance: 1 times the texture at each point (Material::emission_texture).
        ep.find({"radiance"});
        radiance_texture = texture(*t);
        return glm::vec3(1.0f);
    }
    glm::vec3 radiance = ep.get_color({"radiance"}, glm::vec3(1.0f));
    if (radiance.x < 0.0f || radiance.y < 0.0f || radiance.z < 0.0f) n.fail("negative radiance " + fmt_vec(radiance));
    return radiance;
}

int MitsubaLoader::area_emitter(const XNode& n, int mesh_index, int& radiance_texture) {
    XProps ep(n);
    glm::vec3 radiance = area_radiance(n, ep, radiance_texture);
    warn_unused(ep);
    AreaEmitter e;
    e.radiance = radiance;
    e.mesh = mesh_index;
    scene_.emitters.push_back(e);
    return static_cast<int>(scene_.emitters.size()) - 1;
}

void MitsubaLoader::emitter_top(const XNode& n) {
    const std::string type = n.required("type");
    XProps p(n);
    if (type == "area") {
        // Declared with an id, attached to shapes through <ref id=...>
        // (Mitsuba 3's own Cornell box does this).
        if (!n.attr("id"))
            n.fail("an 'area' emitter outside a <shape> needs an id, and shapes use it with <ref id=\"...\"/>");
        int texture = -1;
        glm::vec3 radiance = area_radiance(n, p, texture);
        warn_unused(p);
        declared_emitters_.push_back({radiance, 0, texture});
        register_id(n, IdKind::Emitter, static_cast<int>(declared_emitters_.size()) - 1);
        return;
    }
    if (type == "envmap" || type == "constant") {
        environment(n, p, type);
        return;
    }
    if (type == "sunsky" || type == "sun" || type == "sky") {
        sunsky(n, p, type);
        return;
    }
    if (type == "point" || type == "spot") {
        require_substitute(n, "emitter", "a small spherical area emitter of the same power");
        PendingPointLight l;
        glm::mat4 m = p.get_transform({"to_world", "toWorld"});
        l.position = p.find({"position"}) ? p.get_vector({"position"}, glm::vec3(0.0f)) : glm::vec3(m[3]);
        l.intensity = p.get_color({"intensity"}, glm::vec3(1.0f));
        if (l.intensity.x < 0.0f || l.intensity.y < 0.0f || l.intensity.z < 0.0f) n.fail("negative intensity");
        for (const char* cone : {"cutoff_angle", "cutoffAngle", "beam_width", "beamWidth"}) p.find({cone});
        warn_unused(p);
        l.what = n.file() + ":" + std::to_string(n.line()) + ": emitter '" + type + "'" +
                 (type == "spot" ? " (its cone is ignored: the sphere emits in every direction)" : "");
        point_lights_.push_back(l);
        return;
    }
    if (type == "directional" || type == "distant") {
        // docs/descriptor.md §1: a light at infinity, sampled by NEE.
        DirectionalLight l;
        glm::mat4 m = p.get_transform({"to_world", "toWorld"});
        glm::vec3 dir = p.find({"direction"}) ? p.get_vector({"direction"}, glm::vec3(0, 0, 1))
                                              : glm::vec3(m * glm::vec4(0, 0, 1, 0));
        if (!(glm::length(dir) > 0.0f) || !std::isfinite(glm::length(dir))) n.fail("the light's direction is zero");
        l.direction = glm::normalize(dir);
        l.irradiance = p.get_color({"irradiance"}, glm::vec3(1.0f));
        if (l.irradiance.x < 0.0f || l.irradiance.y < 0.0f || l.irradiance.z < 0.0f) n.fail("negative irradiance");
        warn_unused(p);
        scene_.directional_lights.push_back(l);
        return;
    }
    unsupported(n, "emitter",
                " (docs/descriptor.md §1: area, envmap, constant and directional emitters; point and spot, and sunsky, "
                "only with --substitute)");
}

void MitsubaLoader::environment(const XNode& n, const XProps& p, const std::string& type) {
    const std::string what = n.file() + ":" + std::to_string(n.line()) + ": emitter '" + type + "'";
    float scale = p.get_float({"scale"}, 1.0f);
    if (!(scale >= 0.0f)) n.fail("'scale' must not be negative");
    glm::mat3 to_world(p.get_transform({"to_world", "toWorld"}));
    Environment env;
    if (type == "constant") {
        env.kind = EnvironmentKind::Constant;
        env.radiance = p.get_color({"radiance"}, glm::vec3(1.0f)) * scale;
        if (env.radiance.x < 0.0f || env.radiance.y < 0.0f || env.radiance.z < 0.0f)
            n.fail("negative radiance " + fmt_vec(env.radiance));
    } else {
        auto filename = p.opt_string({"filename"});
        if (!filename) n.fail(n.describe() + " is missing the required property 'filename'");
        std::string path = resolve(n, *filename);
        if (!is_file(path)) n.fail("cannot open environment map '" + *filename + "' (looked for " + path + ")");
        scene_.files.push_back(path);
        try {
            env = load_environment_map(path, scale, to_world);
        } catch (const std::exception& e) {
            n.fail(e.what());
        }
    }
    warn_unused(p);
    env.what = what;
    set_environment(n, std::move(env));
}

void MitsubaLoader::set_environment(const XNode& n, Environment env) {
    if (scene_.environment.kind != EnvironmentKind::None || !panels_.empty())
        n.fail("a second environment emitter (Mitsuba renders one per scene; the first is " +
               (panels_.empty() ? scene_.environment.what : panels_.front().what) + ")");
    if (options_.environment_panel) {
        // docs/descriptor.md §8 (the paper's matpreview treatment): an overhead area panel
        // whose radiance keeps the environment's mean radiance times its scale.
        panels_.push_back({env.what, environment_mean_radiance(env)});
        return;
    }
    scene_.environment = std::move(env);
}

void MitsubaLoader::sunsky(const XNode& n, const XProps& p, const std::string& type) {
    require_substitute(n, "emitter",
                       "Preetham's analytic daylight (a baked sky map and a directional sun, in Mitsuba's units)");
    SunskySpec s;
    s.mitsuba3 = major_version_ >= 2;
    s.want_sun = type != "sky";
    s.want_sky = type != "sun";
    const float scale = p.get_float({"scale"}, 1.0f);  // Mitsuba 0.x: both parts
    s.turbidity = p.get_float({"turbidity"}, 3.0f);
    if (!(s.turbidity >= 1.0 && s.turbidity <= 10.0)) n.fail("'turbidity' must be within [1, 10]");
    s.sun_scale = p.get_float({"sun_scale", "sunScale"}, scale);
    s.sky_scale = p.get_float({"sky_scale", "skyScale"}, scale);
    if (!(s.sun_scale >= 0.0 && s.sky_scale >= 0.0 && scale >= 0.0)) n.fail("the scales must not be negative");
    try {
        s.rotation = environment_rotation(glm::mat3(p.get_transform({"to_world", "toWorld"})));
    } catch (const std::exception& e) {
        n.fail(e.what());
    }
    const char* when[] = {"latitude", "longitude", "timezone", "year", "month", "day", "hour", "minute", "second"};
    const XNode* given = nullptr;
    for (const char* k : when)
        if (const XNode* w = p.find({k}); w && !given) given = w;
    if (p.find({"sun_direction", "sunDirection"})) {
        if (given)
            n.fail("give either 'sun_direction' or the location and time ('" +
                   std::string(given->raw().attribute("name").as_string()) + "'), not both");
        glm::dvec3 d(p.get_vector({"sun_direction", "sunDirection"}, glm::vec3(0, 0, 1)));
        if (!(glm::length(d) > 0.0) || !std::isfinite(glm::length(d))) n.fail("'sun_direction' is zero");
        s.sun_world = glm::normalize(d);
    } else {
        SunTime t;
        t.latitude = p.get_float({"latitude"}, static_cast<float>(t.latitude));
        t.longitude = p.get_float({"longitude"}, static_cast<float>(t.longitude));
        t.timezone = p.get_float({"timezone"}, static_cast<float>(t.timezone));
        t.year = p.opt_int({"year"}).value_or(t.year);
        t.month = p.opt_int({"month"}).value_or(t.month);
        t.day = p.opt_int({"day"}).value_or(t.day);
        t.hour = p.get_float({"hour"}, static_cast<float>(t.hour));
        t.minute = p.get_float({"minute"}, static_cast<float>(t.minute));
        t.second = p.get_float({"second"}, static_cast<float>(t.second));
        if (t.month < 1 || t.month > 12 || t.day < 1 || t.day > 31) n.fail("the date's month or day is out of range");
        if (!(std::abs(t.latitude) <= 90.0)) n.fail("'latitude' must be within [-90, 90] degrees");
        s.sun_world = glm::dmat3(s.rotation) * sun_direction_local(solar_angles(t), s.mitsuba3);
    }
    std::string ignored;
    for (const char* k : {"albedo", "sun_aperture", "sunRadiusScale", "complex_sun", "stretch", "resolution", "extend"})
        if (p.find({k})) ignored += std::string(ignored.empty() ? "" : ", ") + k;
    warn_unused(p);

    const glm::dvec3 up = glm::dmat3(s.rotation) * (s.mitsuba3 ? glm::dvec3(0, 0, 1) : glm::dvec3(0, 1, 0));
    const double elevation =
        90.0 - std::acos(std::clamp(glm::dot(up, s.sun_world), -1.0, 1.0)) * 180.0 / 3.14159265358979;
    std::ostringstream rec;
    rec << "Preetham's daylight at turbidity " << std::clamp(s.turbidity, 2.0, 10.0) << ", the sun " << std::fixed
        << std::setprecision(1) << elevation << " deg above the horizon";
    if (s.turbidity < 2.0) rec << " (turbidity " << s.turbidity << " raised to 2, the model's limit)";
    if (!ignored.empty()) rec << "; not modelled: " << ignored;
    const std::string what = n.file() + ":" + std::to_string(n.line()) + ": emitter '" + type + "' (substituted)";
    if (elevation <= 0.0) {
        // Mitsuba 3's sunsky emits nothing with the sun below the horizon (sky and sun alike).
        rec << "; the sun is below the horizon, so it emits nothing (as Mitsuba 3's sunsky)";
        warn(n, "the sun is below the horizon: sunsky emits no light (set the time, or sun_direction, for daylight)");
    } else {
        if (s.want_sky && s.sky_scale > 0.0) {
            Environment env = bake_preetham_sky(s);
            env.what = what;
            set_environment(n, std::move(env));
        }
        if (s.want_sun && s.sun_scale > 0.0) {
            DirectionalLight sun = sun_light(s);
            rec << "; sun irradiance " << std::setprecision(4) << sun.irradiance.x << ", " << sun.irradiance.y << ", "
                << sun.irradiance.z;
            scene_.directional_lights.push_back(sun);
        }
    }
    record_substitution(n, "emitter", rec.str());
}

void MitsubaLoader::sensor(const XNode& n) {
    const std::string type = n.required("type");
    if (type != "perspective" && type != "thinlens" && type != "orthographic")
        unsupported(n, "sensor", " (expected perspective, thinlens or orthographic)");
    XProps p(n);
    if (have_sensor_) {
        warn(n, "a second <sensor> is ignored (Mitsuba renders the first)");
        return;
    }
    Camera cam;
    cam.type = type == "thinlens"       ? CameraType::ThinLens
               : type == "orthographic" ? CameraType::Orthographic
                                        : CameraType::Perspective;
    cam.to_world = p.get_transform({"to_world", "toWorld"});
    if (cam.type == CameraType::Orthographic) {
        // The scale of to_world sizes the orthographic view (Mitsuba).
        if (!(std::abs(glm::determinant(glm::mat3(cam.to_world))) > 0.0f))
            n.fail(n.describe() + ": the to_world transform is singular");
    } else {
        for (int c = 0; c < 3; ++c)
            if (std::abs(glm::length(glm::vec3(cam.to_world[c])) - 1.0f) > 1e-3f)
                n.fail(n.describe() + ": to_world must not scale the camera (Mitsuba forbids it)");
    }

    std::optional<float> fov;
    if (cam.type != CameraType::Orthographic) fov = p.opt_float({"fov"});
    auto focal = p.opt_string({"focal_length", "focalLength"});
    if (fov && focal) n.fail(n.describe() + ": give either 'fov' or 'focal_length', not both");
    if (fov) {
        if (!(*fov > 0.0f && *fov < 180.0f)) n.fail(n.describe() + ": fov must be in (0, 180) degrees");
        cam.fov_deg = *fov;
        cam.fov_axis = text::lower(p.opt_string({"fov_axis", "fovAxis"}).value_or("x"));
        const char* axes[] = {"x", "y", "diagonal", "smaller", "larger"};
        if (std::none_of(std::begin(axes), std::end(axes), [&](const char* a) { return cam.fov_axis == a; }))
            n.fail("unknown fov_axis '" + cam.fov_axis + "' (expected x, y, diagonal, smaller or larger)");
    } else if (cam.type != CameraType::Orthographic) {
        // Mitsuba: a 35 mm-equivalent focal length (default 50mm) gives the
        // diagonal field of view.
        std::string f = focal.value_or("50mm");
        std::string_view fv = text::trim(f);
        if (fv.size() > 2 && fv.substr(fv.size() - 2) == "mm") fv.remove_suffix(2);
        double mm = n.number(fv, "focal_length");
        if (!(mm > 0.0)) n.fail(n.describe() + ": focal_length must be positive");
        cam.fov_deg =
            static_cast<float>(2.0 * glm::degrees(std::atan(std::sqrt(36.0 * 36.0 + 24.0 * 24.0) / (2.0 * mm))));
        cam.fov_axis = "diagonal";
    }
    cam.near_clip = p.get_float({"near_clip", "nearClip"}, 0.01f);
    cam.far_clip = p.get_float({"far_clip", "farClip"}, 10000.0f);
    if (!(cam.near_clip > 0.0f) || !(cam.far_clip > cam.near_clip))
        n.fail(n.describe() + ": need 0 < near_clip < far_clip");
    if (cam.type == CameraType::ThinLens) {
        auto aperture = p.opt_float({"aperture_radius", "apertureRadius"});
        if (!aperture) n.fail(n.describe() + " is missing the required property 'aperture_radius'");
        if (*aperture < 0.0f) n.fail(n.describe() + ": aperture_radius must not be negative");
        cam.aperture_radius = *aperture;
        // Mitsuba's default focus distance is the far clip plane.
        cam.focus_distance = p.get_float({"focus_distance", "focusDistance"}, cam.far_clip);
        if (!(cam.focus_distance > 0.0f)) n.fail(n.describe() + ": focus_distance must be positive");
    }
    for (const XNode& o : p.objects()) {
        if (o.tag() == "film") {
            XProps fp(o);
            const std::string ftype = o.required("type");
            if (ftype != "hdrfilm" && ftype != "ldrfilm")
                warn(o, "film '" + ftype + "' is read for its size only (vkmech writes a multi-layer EXR and PNGs)");
            for (const XNode& f : fp.objects()) {
                if (f.tag() == "rfilter")
                    warn(f, "reconstruction filter '" + f.required("type") +
                                "' is not used: vkmech uses a box filter (docs/descriptor.md §1)");
                else
                    f.fail("unexpected <" + f.tag() + "> inside " + o.describe());
            }
            // docs/descriptor.md §1: the default film is 256 x 256 (not Mitsuba's 768 x 576).
            cam.width = fp.opt_int({"width"}).value_or(256);
            cam.height = fp.opt_int({"height"}).value_or(256);
            if (cam.width <= 0 || cam.height <= 0)
                o.fail("the film size must be positive, got " + std::to_string(cam.width) + " x " +
                       std::to_string(cam.height));
            // A typo like width="256000" must not become a multi-gigabyte framebuffer.
            constexpr int kMaxFilmSide = 1 << 15;
            if (cam.width > kMaxFilmSide || cam.height > kMaxFilmSide)
                o.fail("the film size " + std::to_string(cam.width) + " x " + std::to_string(cam.height) + " exceeds " +
                       std::to_string(kMaxFilmSide) + " per side");
            warn_unused(fp);
        } else if (o.tag() == "sampler") {
            // Sampling is the renderer's (docs/descriptor.md §4): say what was not used.
            // Its count often is `$spp` with no default (set with -D in
            // Mitsuba): unbound there, it must not stop a scene that does
            // not use it.
            XProps sp(o);
            std::optional<int> count;
            try {
                count = sp.opt_int({"sample_count", "sampleCount"});
            } catch (const SceneError&) {
                sp.find({"sample_count", "sampleCount"});
            }
            warn(o, "sampler '" + o.required("type") + "'" +
                        (count ? " (sample_count " + std::to_string(*count) + ")" : std::string()) +
                        " is not used: vkmech samples with its counter-based generator; set the samples with --spp");
        } else if (o.tag() == "ref") {
            // A sampler, film or rfilter declared at top level (already said).
            const IdEntry& e = lookup_ref(o);
            if (e.kind != IdKind::Ignored)
                o.fail("'" + o.required("id") + "' is a " + to_string(e.kind) + "; a sensor takes a film or a sampler");
        } else {
            o.fail("unexpected <" + o.tag() + "> inside " + n.describe());
        }
    }
    warn_unused(p);
    scene_.camera = cam;
    have_sensor_ = true;
}

void MitsubaLoader::integrator(const XNode& n) {
    n.required("type");  // any integrator is accepted; its depth settings are read
    if (have_integrator_) {
        warn(n, "a second <integrator> is ignored (the first one's depths are used)");
        return;
    }
    have_integrator_ = true;
    std::optional<int> max_depth, rr_depth;
    // Wrappers (aov, moment, ...) carry the depths on a nested integrator.
    auto read = [&](auto&& self, const XNode& node) -> void {
        XProps p(node);
        const std::string type = node.required("type");
        if (type != "path" && type != "volpath" && type != "volpathmis")
            warn(node, "integrator '" + type +
                           "' is not what vkmech renders: it renders its own unidirectional path "
                           "tracer (--estimator), reading only max_depth and rr_depth from the scene");
        if (!max_depth) {
            max_depth = p.opt_int({"max_depth", "maxDepth"});
            if (max_depth && *max_depth < -1) node.fail("max_depth must be -1 (unlimited) or >= 0");
        }
        if (!rr_depth) {
            rr_depth = p.opt_int({"rr_depth", "rrDepth"});
            if (rr_depth && *rr_depth < 0) node.fail("rr_depth must be >= 0");
        }
        for (const XNode& o : p.objects())
            if (o.tag() == "integrator")
                self(self, o);
            else
                warn(o, "<" + o.tag() + "> inside " + node.describe() + " is not used");
        warn_unused(p);
    };
    read(read, n);
    if (max_depth) scene_.integrator.max_depth = *max_depth == -1 ? kUnlimitedDepth : *max_depth;
    if (rr_depth) scene_.integrator.rr_depth = *rr_depth;
}

// ---- end of load ----

void MitsubaLoader::bounds(glm::vec3& lo, glm::vec3& hi) const {
    if (!scene_.bounds(lo, hi)) {  // no geometry: a unit box at the camera
        glm::vec3 c(scene_.camera.to_world[3]);
        lo = c - glm::vec3(1.0f);
        hi = c + glm::vec3(1.0f);
    }
}

void MitsubaLoader::add_substituted_panels() {
    if (panels_.empty()) return;
    glm::vec3 lo, hi;
    bounds(lo, hi);
    // "Overhead" = along the camera's up vector, snapped to a world axis.
    glm::vec3 cam_up(scene_.camera.to_world[1]);
    int a = 0;
    for (int i = 1; i < 3; ++i)
        if (std::abs(cam_up[i]) > std::abs(cam_up[a])) a = i;
    float sign = cam_up[a] < 0.0f ? -1.0f : 1.0f;
    glm::vec3 up(0.0f);
    up[a] = sign;
    int b = (a + 1) % 3, c = (a + 2) % 3;
    glm::vec3 ext = hi - lo, center = 0.5f * (lo + hi);
    float diag = std::max(glm::length(ext), 1e-3f);
    float hb = std::max(0.5f * ext[b], 0.05f * diag), hc = std::max(0.5f * ext[c], 0.05f * diag);
    glm::vec3 pos = center;
    pos[a] = (sign > 0.0f ? hi[a] : lo[a]) + sign * 0.05f * diag;
    // Rectangle normal +z maps to -up (facing down); (u, v, n) right-handed.
    glm::vec3 n = -up, u(0.0f);
    u[b] = 1.0f;
    glm::vec3 v = glm::cross(n, u);
    float hv = std::abs(v[c]) > 0.5f ? hc : hb;
    glm::mat4 m(1.0f);
    m[0] = glm::vec4(u * hb, 0.0f);
    m[1] = glm::vec4(v * hv, 0.0f);
    m[2] = glm::vec4(n, 0.0f);
    m[3] = glm::vec4(pos, 1.0f);
    for (size_t i = 0; i < panels_.size(); ++i) {
        Mesh mesh = make_rectangle(m);
        mesh.name = "substituted-panel#" + std::to_string(i);
        mesh.material = default_material();
        mesh.emitter = static_cast<int>(scene_.emitters.size());
        scene_.emitters.push_back({panels_[i].radiance, static_cast<int>(scene_.meshes.size())});
        scene_.meshes.push_back(std::move(mesh));
        std::ostringstream s;
        s << panels_[i].what << " replaced by an overhead area panel of the environment's mean radiance x scale ("
          << 2 * hb << " x " << 2 * hv << ", centre " << fmt_vec(pos) << ", facing " << fmt_vec(n) << ", radiance "
          << fmt_vec(panels_[i].radiance) << ")";
        scene_.substitutions.push_back(s.str());
    }
}

void MitsubaLoader::add_substituted_point_lights() {
    if (point_lights_.empty()) return;
    glm::vec3 lo, hi;
    bounds(lo, hi);
    for (const auto& l : point_lights_) {
        lo = glm::min(lo, l.position);
        hi = glm::max(hi, l.position);
    }
    float radius = std::max(1e-2f * glm::length(hi - lo), 1e-4f);
    for (size_t i = 0; i < point_lights_.size(); ++i) {
        const auto& l = point_lights_[i];
        // Same power: a point of intensity I emits 4 pi I; a sphere of radius
        // r and radiance L emits 4 pi r^2 * pi L, so L = I / (pi r^2).
        glm::vec3 radiance = l.intensity / (3.14159265f * radius * radius);
        Mesh mesh = make_sphere(l.position, radius, glm::mat4(1.0f), false);
        mesh.name = "substituted-point-light#" + std::to_string(i);
        budget_.charge(mesh.indices.size(), path_, 0, l.what);
        mesh.material = default_material();
        mesh.emitter = static_cast<int>(scene_.emitters.size());
        scene_.emitters.push_back({radiance, static_cast<int>(scene_.meshes.size())});
        scene_.meshes.push_back(std::move(mesh));
        scene_.substitutions.push_back(l.what + " replaced by a sphere emitter of the same power, radius " +
                                       fmt_num(radius) + ", at " + fmt_vec(l.position) + " with radiance " +
                                       fmt_vec(radiance));
    }
}

void MitsubaLoader::prune_unused() {
    // Only materials and textures that some shape uses survive: what the
    // scene "calls for" (render/features.hpp) must not see unused definitions.
    std::vector<int> mat_map(scene_.materials.size(), -1), tex_map(scene_.textures.size(), -1);
    std::vector<Material> mats;
    std::vector<Texture> texs;
    // A blend keeps its components, which come before it as they did.
    auto keep_material = [&](auto& self, int i) -> int {
        if (mat_map[i] >= 0) return mat_map[i];
        Material m = scene_.materials[i];
        if (m.type == BsdfType::Blend) {
            m.blend_first = self(self, m.blend_first);
            m.blend_second = self(self, m.blend_second);
        }
        mat_map[i] = static_cast<int>(mats.size());
        mats.push_back(std::move(m));
        return mat_map[i];
    };
    for (auto& mesh : scene_.meshes) mesh.material = keep_material(keep_material, mesh.material);
    auto keep = [&](int& t) {
        if (t < 0) return;
        if (tex_map[t] < 0) {
            tex_map[t] = static_cast<int>(texs.size());
            texs.push_back(scene_.textures[t]);
        }
        t = tex_map[t];
    };
    for (auto& m : mats) m.for_each_texture(keep);
    scene_.materials = std::move(mats);
    scene_.textures = std::move(texs);
}

Scene load_mitsuba_xml(const std::string& path, const LoadOptions& options) {
    return MitsubaLoader(path, options).load();
}

}  // namespace vkmech
