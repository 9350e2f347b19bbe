// Where the binary finds its data: the project scenes, the figure script and
// the frozen predictor curve. Each lookup tries, in order:
//   1. an environment override ($VKMECH_SCENE_DIR, $VKMECH_PLOT_SCRIPT, then
//      $VKMECH_DATA_DIR, a data root laid out as the installed one);
//   2. scenes only: ./scenes in the working directory;
//   3. the data root next to the binary: <prefix>/bin/vkmech ->
//      <prefix>/share/vkmech/{scenes, plot_figures.py, predictor_curve.json};
//   4. the source tree the binary was built from (a build-tree binary).
// The first candidate that exists wins.
#pragma once

#include <string>
#include <vector>

namespace vkmech {

// The inputs of every lookup; from_process() reads them from this process.
struct ResourceRoots {
    std::string scene_dir_env;    // $VKMECH_SCENE_DIR
    std::string plot_script_env;  // $VKMECH_PLOT_SCRIPT
    std::string data_dir_env;     // $VKMECH_DATA_DIR
    std::string exe;              // this binary (/proc/self/exe); empty when unknown
    std::string source_dir;       // the source tree configured in at build time
    static ResourceRoots from_process();
};

struct ResourceCandidate {
    std::string path;
    std::string origin;  // e.g. "$VKMECH_DATA_DIR", "next to the binary", "source tree"
};

struct Resource {
    std::string what;                         // "scene directory", "plot script", "predictor curve"
    std::string path;                         // the first candidate that exists; empty when none does
    std::string origin;                       // that candidate's origin
    std::vector<ResourceCandidate> searched;  // every candidate, in order
    std::string how_to_override;              // e.g. "set VKMECH_PLOT_SCRIPT=FILE or VKMECH_DATA_DIR=DIR"
    bool found() const { return !path.empty(); }
    // "every candidate path (origin), ..." for error messages.
    std::string searched_list() const;
    // "no plot script found (searched: ...); set ...".
    std::string missing_message() const;
};

// The data root next to a binary: <dir of exe>/<bin-to-data> (../share/vkmech).
std::string data_dir_next_to(const std::string& exe);

// The directories searched for scenes by name, in order (existing or not).
std::vector<ResourceCandidate> scene_dir_candidates(const ResourceRoots& roots);
// The first candidate directory holding a scene file (*.xml).
Resource find_scene_dir(const ResourceRoots& roots = ResourceRoots::from_process());
Resource find_plot_script(const ResourceRoots& roots = ResourceRoots::from_process());
Resource find_predictor_curve(const ResourceRoots& roots = ResourceRoots::from_process());

// `vkmech paths`: where each resource is found; exit 0 when all are, else 1.
int cmd_paths();

}  // namespace vkmech
