// The data lookup (host/app/cli/resources.*): environment overrides first,
// then the data root next to the binary, then the source tree; a missing
// resource names every path searched and how to override. On fake layouts, so
// nothing depends on where the tests run (tests/install_selftest.sh checks a
// real install).
#include "cli/resources.hpp"
#include "temp_dir.hpp"

#include <doctest/doctest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

namespace fs = std::filesystem;

namespace {

void touch(const fs::path& p) {
    fs::create_directories(p.parent_path());
    std::ofstream(p) << "x";
}

std::vector<std::string> origins(const std::vector<vkmech::ResourceCandidate>& c) {
    std::vector<std::string> o;
    for (const auto& x : c) o.push_back(x.origin);
    return o;
}

}  // namespace

TEST_CASE("resources: the environment then next to the binary then the source tree") {
    vkmech::testing::TempDir tmp("resources_order");
    vkmech::ResourceRoots roots;
    roots.exe = (tmp.path / "prefix" / "bin" / "vkmech").string();
    roots.source_dir = (tmp.path / "src").string();
    const fs::path installed = vkmech::data_dir_next_to(roots.exe);
    CHECK(installed.string().rfind((tmp.path / "prefix").string() + "/", 0) == 0);
    CHECK(installed.filename() == "vkmech");

    // Only the source tree has the files: a build-tree binary.
    touch(tmp.path / "src" / "analysis" / "plot_figures.py");
    touch(tmp.path / "src" / "docs" / "results" / "predictor_curve.json");
    CHECK(vkmech::find_plot_script(roots).origin == "source tree");
    CHECK(vkmech::find_predictor_curve(roots).path == (tmp.path / "src/docs/results/predictor_curve.json").string());

    // Installed next to the binary: that wins over the source tree.
    touch(installed / "plot_figures.py");
    touch(installed / "predictor_curve.json");
    CHECK(vkmech::find_plot_script(roots).path == (installed / "plot_figures.py").string());
    CHECK(vkmech::find_predictor_curve(roots).origin == "next to the binary");

    // VKMECH_DATA_DIR, then VKMECH_PLOT_SCRIPT, win over both.
    roots.data_dir_env = (tmp.path / "data").string();
    touch(tmp.path / "data" / "predictor_curve.json");
    CHECK(vkmech::find_predictor_curve(roots).path == (tmp.path / "data" / "predictor_curve.json").string());
    CHECK(vkmech::find_plot_script(roots).origin == "next to the binary");  // not in the data dir: next one
    roots.plot_script_env = (tmp.path / "mine.py").string();
    touch(tmp.path / "mine.py");
    CHECK(vkmech::find_plot_script(roots).origin == "$VKMECH_PLOT_SCRIPT");

    // Scenes: the overrides, ./scenes (as before), next to the binary, the source tree.
    roots.scene_dir_env = (tmp.path / "myscenes").string();
    CHECK(origins(vkmech::scene_dir_candidates(roots)) ==
          std::vector<std::string>{"$VKMECH_SCENE_DIR", "$VKMECH_DATA_DIR", "working directory", "next to the binary",
                                   "source tree"});
    CHECK(vkmech::scene_dir_candidates(roots)[3].path == (installed / "scenes").string());
    touch(tmp.path / "myscenes" / "a.xml");
    CHECK(vkmech::find_scene_dir(roots).path == roots.scene_dir_env);
}

TEST_CASE("resources: a missing resource names every path searched and how to override") {
    vkmech::testing::TempDir tmp("resources_missing");
    vkmech::ResourceRoots roots;
    roots.exe = (tmp.path / "bin" / "vkmech").string();
    roots.source_dir = (tmp.path / "src").string();
    roots.data_dir_env = (tmp.path / "data").string();
    fs::create_directories(tmp.path / "data" / "scenes");  // a directory without scenes does not count

    const vkmech::Resource curve = vkmech::find_predictor_curve(roots);
    CHECK_FALSE(curve.found());
    const std::string msg = curve.missing_message();
    CHECK(msg.rfind("no predictor curve found (searched: ", 0) == 0);
    for (const auto& c : curve.searched) CHECK(msg.find(c.path + " (" + c.origin + ")") != std::string::npos);
    CHECK(curve.searched.size() == 3);
    CHECK(msg.find("--curve FILE") != std::string::npos);
    CHECK(msg.find("VKMECH_DATA_DIR") != std::string::npos);

    const vkmech::Resource script = vkmech::find_plot_script(roots);
    CHECK_FALSE(script.found());
    CHECK(script.missing_message().find("VKMECH_PLOT_SCRIPT=FILE") != std::string::npos);
    CHECK(script.missing_message().find((tmp.path / "src/analysis/plot_figures.py").string()) != std::string::npos);

    CHECK(vkmech::find_scene_dir(roots).origin != "$VKMECH_DATA_DIR");
}
