// A render's files appear as a set (docs/reliability.md): never a mixed or partial set.
//
// An OutputSet stages every file of one run in `<dir>/.vkmech-tmp-<pid>/`,
// then commits:
//   1. a manifest `<name>.manifest.json` (file names, sizes, 128-bit digests,
//      run id) is written into the staging directory;
//   2. the staging directory is renamed to `<dir>/.vkmech-commit-<pid>-<name>`
//      (the commit point: from here on the new set is complete on disk and is
//      finished even if this process dies);
//   3. the old manifest is moved away (into the commit directory), so the
//      directory no longer claims a complete set;
//   4. each new file is renamed into `<dir>`; files of the old set that the
//      new one lacks are removed;
//   5. the new manifest is renamed into `<dir>` LAST: a set is complete
//      exactly when its manifest is present and every file it lists has the
//      listed size and digest.
// A run killed before step 2 leaves the old complete set untouched; one killed
// after it leaves a pending commit that the next run in the same directory
// (or `vkmech verify outputs`) reports and the next run finishes. Stale
// temporaries of dead processes (`.vkmech-tmp-<pid>` directories,
// `*.tmp-<pid>` files) are removed when a run starts in the directory.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace vkmech {

struct ManifestEntry {
    std::string name;  // file name inside the output directory
    uint64_t size = 0;
    std::string digest;  // file_digest()
};

struct Manifest {
    std::string set_name, run_id;
    std::vector<ManifestEntry> files;
};

std::string manifest_file_name(const std::string& set_name);  // "<name>.manifest.json"
std::string manifest_json(const Manifest& m);
// Parses what manifest_json wrote; nullopt (with *why) when it is not a valid manifest.
std::optional<Manifest> parse_manifest(const std::string& text, std::string* why = nullptr);

// Creates `dir` (and parents) and creates and removes a probe file in it.
// Throws std::runtime_error("<option> '<dir>' is not writable: <reason>") when
// that fails; `option` names the setting for the message (e.g. "--out").
void check_writable_dir(const std::string& dir, const std::string& option);

// Removes `.vkmech-tmp-<pid>` directories and `*.tmp-<pid>` files in `dir`
// (not recursively) whose process is gone. Returns how many were removed.
size_t clean_stale_temporaries(const std::string& dir);

// Finishes every pending commit in `dir` left by a dead process. Returns how many.
size_t recover_pending_commits(const std::string& dir);

struct SetStatus {
    enum Kind { Complete, Pending, Bad } kind = Bad;
    std::string name, run_id, detail;  // detail: why Bad, or what is pending
};
// Every set in `dir`: each manifest checked against its files, each pending commit.
// `stale` (optional) receives the stale temporaries found.
std::vector<SetStatus> verify_output_dir(const std::string& dir, std::vector<std::string>* stale = nullptr);

class OutputSet {
public:
    // Checks that `dir` is writable (check_writable_dir, option "--out"),
    // cleans stale temporaries, finishes pending commits and creates the
    // staging directory.
    OutputSet(std::string dir, std::string set_name);
    ~OutputSet();  // removes the staging directory unless committed
    OutputSet(const OutputSet&) = delete;
    OutputSet& operator=(const OutputSet&) = delete;

    const std::string& dir() const { return dir_; }
    const std::string& run_id() const { return run_id_; }
    // Where to write `file_name` now (inside the staging directory).
    std::string staged(const std::string& file_name) const;
    // Where `file_name` will be once committed.
    std::string final_path(const std::string& file_name) const;
    // Commits every staged file (see the top of this header). Checks for a
    // pending SIGINT/SIGTERM first (throws Interrupted); past the commit point
    // it runs to the end.
    void commit();

private:
    std::string dir_, name_, staging_, run_id_;
    bool committed_ = false;
};

}  // namespace vkmech
