#include "cli/commands.hpp"
#include "cli/resources.hpp"

#include "io/output_set.hpp"
#include "scene/scene.hpp"

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <filesystem>
#include <iostream>

namespace fs = std::filesystem;

namespace vkmech {

void add_common_options(CLI::App* app, CommonOptions& o) {
    app->add_option(
           "--scene", o.scene,
           "Scene name in scenes/ (e.g. ring_caustic) or a path to a Mitsuba XML (.xml) or glTF (.gltf, .glb) file")
        ->required();
    app->add_option("-D,--define", o.defines, "Override a scene parameter: -D name=value (as Mitsuba's -D)");
    app->add_option("--res", o.res, "Film width in pixels (height follows the scene's aspect)")
        ->check(CLI::Range(1u, 16384u));
    app->add_option("--device", o.device, "Vulkan device index (see `vkmech devices`)");
    app->add_option("--traversal", o.traversal, "Ray traversal: auto, rayquery or bvh")
        ->check(CLI::IsMember({"auto", "rayquery", "bvh"}));
    app->add_flag("--substitute", o.substitute,
                  "Replace what is outside the model by its nearest model, and record each replacement: point/spot "
                  "lights by small spherical emitters of the same power, phong/cut-out masks/other BSDFs by "
                  "the nearest material, media ignored (README: Your own scenes)");
    app->add_option("--environment", o.environment,
                    "Light the scene with a latitude-longitude environment map (OpenEXR or Radiance HDR, +y up as in "
                    "Mitsuba), replacing any environment the scene has; recorded in the outputs")
        ->check(CLI::ExistingFile);
    app->add_option("--environment-scale", o.environment_scale, "Multiply --environment's map by this factor")
        ->check(CLI::Range(0.0f, 1e30f));
    app->add_flag("--environment-panel", o.environment_panel,
                  "The paper's treatment of a scene's envmap/constant emitter: an overhead area panel of the "
                  "environment's mean radiance x scale, recorded as a substitution (for reproductions)");
    app->add_option("--max-triangles", o.max_triangles,
                    "Most triangles the scene may expand to (default: $VKMECH_MAX_TRIANGLES, else 50000000)")
        ->check(CLI::PositiveNumber);
    app->add_flag("--validation", o.validation, "Enable the Vulkan validation layers when installed");
    add_pipeline_cache_option(app, o.pipeline_cache);
    add_kernel_option(app, o.kernel);
}

void add_kernel_option(CLI::App* app, std::string& kernel) {
    app->add_option("--kernel", kernel,
                    "Device-class kernel: auto (cpu on CPU devices such as lavapipe, gpu on every other; "
                    "$VKMECH_KERNEL overrides auto), cpu or gpu. Both give the same images to float rounding")
        ->check(CLI::IsMember({"auto", "cpu", "gpu"}));
}

void add_pipeline_cache_option(CLI::App* app, std::optional<std::string>& dir) {
    app->add_option("--pipeline-cache", dir,
                    "Directory of the on-disk Vulkan pipeline cache, or 'off' (default: $VKMECH_CACHE_DIR, else "
                    "$XDG_CACHE_HOME/vkmech, else ~/.cache/vkmech)");
}

std::string resolve_scene_path(const std::string& arg) {
    std::string ext = fs::path(arg).extension().string();
    for (auto& ch : ext) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
    bool looks_like_path = arg.find('/') != std::string::npos || ext == ".xml" || ext == ".gltf" || ext == ".glb";
    if (looks_like_path) {
        if (!fs::exists(arg)) throw UsageError("scene file '" + arg + "' does not exist");
        return arg;
    }
    for (const auto& d : scene_dir_candidates(ResourceRoots::from_process())) {
        fs::path p = fs::path(d.path) / (arg + ".xml");
        if (fs::exists(p)) return p.string();
    }
    const Resource dir = find_scene_dir();
    if (!dir.found()) throw UsageError("no scene named '" + arg + "': " + dir.missing_message());
    std::string known;
    for (const auto& n : project_scene_names()) known += " " + n;
    throw UsageError("no scene named '" + arg + "' (known:" + known + "; searched: " + dir.searched_list() + ")");
}

std::vector<std::string> project_scene_names() {
    const Resource dir = find_scene_dir();
    if (!dir.found()) return {};
    std::vector<std::string> names;
    for (const auto& e : fs::directory_iterator(dir.path))
        if (e.is_regular_file() && e.path().extension() == ".xml") names.push_back(e.path().stem().string());
    std::sort(names.begin(), names.end());
    return names;
}

std::map<std::string, std::string> parse_defines(const std::vector<std::string>& defines) {
    std::map<std::string, std::string> params;
    for (const auto& d : defines) {
        auto eq = d.find('=');
        if (eq == std::string::npos || eq == 0) throw UsageError("-D expects name=value, got '" + d + "'");
        params[d.substr(0, eq)] = d.substr(eq + 1);
    }
    return params;
}

namespace {

LoadOptions load_options(const CommonOptions& o) {
    LoadOptions lo;
    lo.substitute_unsupported = o.substitute;
    lo.environment_file = o.environment;
    lo.environment_scale = o.environment_scale;
    lo.environment_panel = o.environment_panel;
    lo.max_triangles = o.max_triangles;
    lo.params = parse_defines(o.defines);
    return lo;
}

}  // namespace

vk::ContextOptions context_options(const CommonOptions& o) {
    vk::ContextOptions co;
    co.device_index = o.device;
    co.validation = o.validation;
    co.pipeline_cache_dir = o.pipeline_cache;
    co.kernel = vk::parse_kernel_class(o.kernel);
    return co;
}

Scene load_for_cli(const CommonOptions& o, bool report) {
    std::string path = resolve_scene_path(o.scene);
    Scene scene = load_scene(path, load_options(o));
    if (o.res) {
        scene.camera.set_film_width(static_cast<int>(*o.res));
    }
    if (report) {
        for (const auto& s : scene.substitutions) std::cerr << "vkmech: substitution: " << s << "\n";
        for (const auto& w : scene.warnings) std::cerr << "vkmech: warning: " << w << "\n";
    }
    return scene;
}

std::string scene_stem(const std::string& name_or_path) { return fs::path(name_or_path).stem().string(); }

void require_writable_dir(const std::string& dir, const std::string& option) {
    try {
        check_writable_dir(dir, option);
    } catch (const std::runtime_error& e) {
        throw UsageError(e.what());
    }
}

}  // namespace vkmech
