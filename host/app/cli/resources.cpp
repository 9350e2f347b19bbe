#include "cli/resources.hpp"

#include "cli/commands.hpp"

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <system_error>

namespace fs = std::filesystem;

#ifndef VKMECH_DATA_FROM_BIN
#define VKMECH_DATA_FROM_BIN "../share/vkmech"
#endif

namespace vkmech {

namespace {

std::string env_or_empty(const char* name) {
    const char* v = std::getenv(name);
    return v ? v : "";
}

bool has_scene_file(const std::string& dir) {
    std::error_code ec;
    if (!fs::is_directory(dir, ec)) return false;
    for (const auto& e : fs::directory_iterator(dir, ec))
        if (e.path().extension() == ".xml" && e.is_regular_file(ec)) return true;
    return false;
}

bool is_file(const std::string& path) {
    std::error_code ec;
    return fs::is_regular_file(path, ec);
}

Resource first_of(std::string what, std::vector<ResourceCandidate> candidates, std::string how_to_override,
                  const std::function<bool(const std::string&)>& exists) {
    Resource r{std::move(what), "", "", std::move(candidates), std::move(how_to_override)};
    for (const auto& c : r.searched)
        if (exists(c.path)) {
            r.path = c.path;
            r.origin = c.origin;
            break;
        }
    return r;
}

// The candidates common to the single-file resources: the data root from the
// environment, next to the binary, then the file's place in the source tree.
std::vector<ResourceCandidate> data_candidates(const ResourceRoots& roots, const std::string& name,
                                               const std::string& source_rel) {
    std::vector<ResourceCandidate> c;
    if (!roots.data_dir_env.empty()) c.push_back({(fs::path(roots.data_dir_env) / name).string(), "$VKMECH_DATA_DIR"});
    if (!roots.exe.empty())
        c.push_back({(fs::path(data_dir_next_to(roots.exe)) / name).string(), "next to the binary"});
    if (!roots.source_dir.empty()) c.push_back({(fs::path(roots.source_dir) / source_rel).string(), "source tree"});
    return c;
}

}  // namespace

ResourceRoots ResourceRoots::from_process() {
    ResourceRoots r;
    r.scene_dir_env = env_or_empty("VKMECH_SCENE_DIR");
    r.plot_script_env = env_or_empty("VKMECH_PLOT_SCRIPT");
    r.data_dir_env = env_or_empty("VKMECH_DATA_DIR");
    std::error_code ec;
    fs::path exe = fs::read_symlink("/proc/self/exe", ec);
    if (!ec) r.exe = exe.string();
#ifdef VKMECH_SOURCE_DIR
    r.source_dir = VKMECH_SOURCE_DIR;
#endif
    return r;
}

std::string Resource::searched_list() const {
    std::string s;
    for (const auto& c : searched) s += (s.empty() ? "" : ", ") + c.path + " (" + c.origin + ")";
    return s.empty() ? "nowhere" : s;
}

std::string Resource::missing_message() const {
    return "no " + what + " found (searched: " + searched_list() + "); " + how_to_override;
}

std::string data_dir_next_to(const std::string& exe) {
    return (fs::path(exe).parent_path() / VKMECH_DATA_FROM_BIN).lexically_normal().string();
}

std::vector<ResourceCandidate> scene_dir_candidates(const ResourceRoots& roots) {
    std::vector<ResourceCandidate> c;
    if (!roots.scene_dir_env.empty()) c.push_back({roots.scene_dir_env, "$VKMECH_SCENE_DIR"});
    if (!roots.data_dir_env.empty())
        c.push_back({(fs::path(roots.data_dir_env) / "scenes").string(), "$VKMECH_DATA_DIR"});
    c.push_back({"scenes", "working directory"});
    if (!roots.exe.empty())
        c.push_back({(fs::path(data_dir_next_to(roots.exe)) / "scenes").string(), "next to the binary"});
    if (!roots.source_dir.empty()) c.push_back({(fs::path(roots.source_dir) / "scenes").string(), "source tree"});
    return c;
}

Resource find_scene_dir(const ResourceRoots& roots) {
    return first_of("scene directory", scene_dir_candidates(roots),
                    "set VKMECH_SCENE_DIR=DIR or VKMECH_DATA_DIR=DIR, or pass a scene file's path", has_scene_file);
}

Resource find_plot_script(const ResourceRoots& roots) {
    std::vector<ResourceCandidate> c;
    if (!roots.plot_script_env.empty()) c.push_back({roots.plot_script_env, "$VKMECH_PLOT_SCRIPT"});
    for (auto& d : data_candidates(roots, "plot_figures.py", "analysis/plot_figures.py")) c.push_back(std::move(d));
    return first_of("plot script", std::move(c), "set VKMECH_PLOT_SCRIPT=FILE or VKMECH_DATA_DIR=DIR", is_file);
}

Resource find_predictor_curve(const ResourceRoots& roots) {
    return first_of("predictor curve",
                    data_candidates(roots, "predictor_curve.json", "docs/results/predictor_curve.json"),
                    "pass --curve FILE or set VKMECH_DATA_DIR=DIR", is_file);
}

int cmd_paths() {
    const ResourceRoots roots = ResourceRoots::from_process();
    std::printf("binary: %s\n", roots.exe.empty() ? "(unknown)" : roots.exe.c_str());
    int rc = 0;
    for (const Resource& r : {find_scene_dir(roots), find_plot_script(roots), find_predictor_curve(roots)}) {
        if (r.found()) {
            std::printf("%s: %s (%s)\n", r.what.c_str(), fs::absolute(r.path).lexically_normal().c_str(),
                        r.origin.c_str());
        } else {
            std::printf("%s: not found\n", r.what.c_str());
            std::fprintf(stderr, "vkmech: error: %s\n", r.missing_message().c_str());
            rc = 1;
        }
    }
    return rc;
}

// `vkmech paths`.
void register_paths(CLI::App& app, CliCommands& commands) {
    auto* paths = app.add_subcommand(
        "paths",
        "Where the scenes, the figure script and the predictor curve are found: $VKMECH_SCENE_DIR, "
        "$VKMECH_PLOT_SCRIPT, $VKMECH_DATA_DIR (a data root), ./scenes, <prefix>/share/vkmech next to "
        "<prefix>/bin/vkmech, then the source tree; exit 1 when one is missing");

    commands.push_back({paths, [](const std::vector<std::string>&) { return cmd_paths(); }});
}

}  // namespace vkmech
