#include "cli/provenance.hpp"

#include "io/sha256.hpp"
#include "study/study_runner.hpp"
#include "vkmech_describe.h"

#include <ctime>
#include <filesystem>
#include <set>

namespace fs = std::filesystem;

namespace vkmech {

std::string build_version() { return VKMECH_DESCRIBE; }

std::string canonical_path(const std::string& p) {
    std::error_code ec;
    fs::path a = fs::weakly_canonical(fs::absolute(p), ec);
    return ec ? p : a.string();
}

std::vector<std::pair<std::string, std::string>> scene_input_files(const Scene& scene) {
    std::set<std::string> files;
    for (const Texture& t : scene.textures)
        if (fs::is_regular_file(t.path)) files.insert(canonical_path(t.path));
    for (const std::string& f : scene.files)
        if (fs::is_regular_file(f)) files.insert(canonical_path(f));
    std::vector<std::pair<std::string, std::string>> out;
    for (const auto& f : files) out.emplace_back(f, sha256_file(f));
    return out;
}

Provenance make_provenance(const std::string& scene_path, const Scene& scene, const std::vector<std::string>& defines,
                           const vk::Context& ctx, Traversal trav, uint32_t spp) {
    Provenance p;
    p.version = build_version();
    p.code_digest = render_code_digest(trav, ctx.kernel());
    p.scene_sha256 = sha256_file(scene_path);
    const std::string self = canonical_path(scene_path);
    for (const auto& [path, sha] : scene_input_files(scene))
        if (path != self) p.scene_files.push_back(sha + " " + path);
    for (const auto& [name, value] : parse_defines(defines)) p.defines.push_back(name + "=" + value);
    p.sample_range = "0:" + std::to_string(spp);
    p.driver = ctx.info().driver;
    const std::time_t t = std::time(nullptr);
    std::tm tm{};
    gmtime_r(&t, &tm);
    char b[32];
    std::strftime(b, sizeof b, "%Y:%m:%d %H:%M:%S", &tm);
    p.date_utc = b;
    return p;
}

}  // namespace vkmech
