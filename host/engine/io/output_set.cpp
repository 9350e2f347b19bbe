#include "io/output_set.hpp"

#include "io/atomic_file.hpp"
#include "io/digest.hpp"
#include "io/interrupt.hpp"
#include "io/json.hpp"

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <set>
#include <sstream>
#include <stdexcept>
#include <system_error>

#include <fcntl.h>
#include <signal.h>
#include <unistd.h>

namespace fs = std::filesystem;

namespace vkmech {

namespace {

constexpr const char* kStagingPrefix = ".vkmech-tmp-";
constexpr const char* kCommitPrefix = ".vkmech-commit-";
constexpr const char* kPreviousManifest = "previous.manifest";

void fsync_dir(const fs::path& dir) {
    int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (fd < 0) return;
    (void)::fsync(fd);
    (void)::close(fd);
}

bool process_alive(long pid) {
    if (pid <= 0) return false;
    if (pid == static_cast<long>(::getpid())) return true;
    return ::kill(static_cast<pid_t>(pid), 0) == 0 || errno == EPERM;
}

// The pid of "<prefix><digits>[-...]" or of "...<marker><digits>" at the end; -1 when it does not match.
long leading_pid(const std::string& s, size_t from) {
    size_t end = from;
    while (end < s.size() && std::isdigit(static_cast<unsigned char>(s[end]))) ++end;
    if (end == from || end - from > 9) return -1;
    return std::stol(s.substr(from, end - from));
}

long trailing_tmp_pid(const std::string& name) {
    auto k = name.rfind(".tmp-");
    if (k == std::string::npos) return -1;
    size_t from = k + 5;
    if (from >= name.size()) return -1;
    for (size_t i = from; i < name.size(); ++i)
        if (!std::isdigit(static_cast<unsigned char>(name[i]))) return -1;
    return leading_pid(name, from);
}

std::string read_text(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    if (!in) return {};
    std::ostringstream ss;
    ss << in.rdbuf();
    return ss.str();
}

// The string value after `"key": "` starting at pos; advances pos past it.
std::optional<std::string> string_field(const std::string& t, const std::string& key, size_t& pos) {
    const std::string pat = "\"" + key + "\": \"";
    auto k = t.find(pat, pos);
    if (k == std::string::npos) return std::nullopt;
    std::string v;
    size_t i = k + pat.size();
    for (; i < t.size() && t[i] != '"'; ++i) {
        if (t[i] == '\\' && i + 1 < t.size()) ++i;
        v += t[i];
    }
    if (i >= t.size()) return std::nullopt;
    pos = i + 1;
    return v;
}

std::string new_run_id() {
    std::random_device rd;
    Digest d;
    d.pod(static_cast<long>(::getpid()))
        .pod(std::chrono::system_clock::now().time_since_epoch().count())
        .pod(rd())
        .pod(rd());
    return d.hex().substr(0, 16);
}

// Checks one set's files against its manifest; empty when they all match.
std::string check_files(const fs::path& dir, const Manifest& m) {
    for (const auto& f : m.files) {
        fs::path p = dir / f.name;
        std::error_code ec;
        if (!fs::is_regular_file(p, ec)) return "'" + f.name + "' is missing";
        uint64_t size = 0;
        std::string digest;
        try {
            digest = file_digest(p.string(), &size);
        } catch (const std::exception& e) {
            return e.what();
        }
        if (size != f.size)
            return "'" + f.name + "' has " + std::to_string(size) + " bytes, the manifest says " +
                   std::to_string(f.size);
        if (digest != f.digest) return "'" + f.name + "' does not match its checksum";
    }
    return {};
}

// Steps 3-5 of the commit (header): idempotent, so a run killed half-way is
// finished by the next one. `commit_dir` holds the new manifest and the files
// not moved yet.
void finish_commit(const fs::path& dir, const fs::path& commit_dir) {
    std::string why;
    std::optional<Manifest> m;
    std::string manifest_name;
    for (const auto& e : fs::directory_iterator(commit_dir)) {
        std::string n = e.path().filename().string();
        if (n.size() > 14 && n.compare(n.size() - 14, 14, ".manifest.json") == 0) {
            m = parse_manifest(read_text(e.path()), &why);
            manifest_name = n;
        }
    }
    if (!m) {  // cannot happen by construction (the manifest is staged before the commit point)
        fs::remove_all(commit_dir);
        return;
    }
    const fs::path final_manifest = dir / manifest_name;
    const fs::path previous = commit_dir / kPreviousManifest;
    // 3. The old manifest leaves first: from here the directory claims no complete set until step 5.
    if (fs::exists(final_manifest) && !fs::exists(previous)) {
        if (::rename(final_manifest.c_str(), previous.c_str()) != 0)
            throw std::runtime_error("cannot move '" + final_manifest.string() + "' aside: " + std::strerror(errno));
        fsync_dir(dir);
    }
    fault_point("commit-moving");
    // 4. The new files, then the old set's files the new set lacks.
    std::set<std::string> names;
    for (const auto& f : m->files) {
        names.insert(f.name);
        fs::path src = commit_dir / f.name;
        if (!fs::exists(src)) continue;  // moved before an interruption
        if (::rename(src.c_str(), (dir / f.name).c_str()) != 0)
            throw std::runtime_error("cannot move '" + src.string() + "' into '" + dir.string() +
                                     "': " + std::strerror(errno));
        fault_point("commit-moved-one");
    }
    if (auto old = parse_manifest(read_text(previous)))
        for (const auto& f : old->files)
            if (!names.count(f.name) && f.name.find('/') == std::string::npos) fs::remove(dir / f.name);
    fsync_dir(dir);
    // 5. The manifest last: the commit is visible.
    if (::rename((commit_dir / manifest_name).c_str(), final_manifest.c_str()) != 0)
        throw std::runtime_error("cannot move the manifest into '" + dir.string() + "': " + std::strerror(errno));
    fsync_dir(dir);
    fs::remove_all(commit_dir);
}

}  // namespace

std::string manifest_file_name(const std::string& set_name) { return set_name + ".manifest.json"; }

std::string manifest_json(const Manifest& m) {
    std::ostringstream o;
    o << "{\n  \"vkmech_manifest\": 1,\n  \"set\": \"" << json_escape(m.set_name) << "\",\n  \"run_id\": \""
      << json_escape(m.run_id) << "\",\n  \"files\": [\n";
    for (size_t i = 0; i < m.files.size(); ++i)
        o << "    {\"name\": \"" << json_escape(m.files[i].name) << "\", \"size\": " << m.files[i].size
          << ", \"digest\": \"" << m.files[i].digest << "\"}" << (i + 1 < m.files.size() ? "," : "") << "\n";
    o << "  ],\n  \"count\": " << m.files.size() << "\n}\n";
    return o.str();
}

std::optional<Manifest> parse_manifest(const std::string& t, std::string* why) {
    auto fail = [&](const char* w) -> std::optional<Manifest> {
        if (why) *why = w;
        return std::nullopt;
    };
    if (t.find("\"vkmech_manifest\": 1") == std::string::npos) return fail("not a vkmech manifest");
    Manifest m;
    size_t pos = 0;
    auto set = string_field(t, "set", pos);
    auto run = string_field(t, "run_id", pos);
    if (!set || !run) return fail("no set name or run id");
    m.set_name = *set;
    m.run_id = *run;
    const size_t files_end = t.find("\n  ],", pos);
    if (files_end == std::string::npos) return fail("no file list");
    for (;;) {
        size_t p = pos;
        auto name = string_field(t, "name", p);
        if (!name || p > files_end) break;
        ManifestEntry e;
        e.name = *name;
        auto sk = t.find("\"size\": ", p);
        if (sk == std::string::npos || sk > files_end) return fail("entry without a size");
        e.size = std::strtoull(t.c_str() + sk + 8, nullptr, 10);
        auto digest = string_field(t, "digest", p);
        if (!digest || digest->size() != 32 || p > files_end) return fail("entry without a digest");
        e.digest = *digest;
        if (e.name.empty() || e.name.find('/') != std::string::npos) return fail("bad file name");
        m.files.push_back(std::move(e));
        pos = p;
    }
    auto ck = t.find("\"count\": ", files_end);
    if (ck == std::string::npos || std::strtoull(t.c_str() + ck + 9, nullptr, 10) != m.files.size() ||
        t.find("\n}", ck) == std::string::npos)
        return fail("truncated (file count missing or different)");
    return m;
}

void check_writable_dir(const std::string& dir, const std::string& option) {
    auto fail = [&](const std::string& why) {
        throw std::runtime_error(option + " '" + dir + "' is not writable: " + why);
    };
    if (dir.empty()) fail("empty path");
    std::error_code ec;
    fs::create_directories(dir, ec);
    if (ec) fail("cannot create the directory (" + ec.message() + ")");
    if (!fs::is_directory(dir, ec)) fail("not a directory");
    const std::string probe = (fs::path(dir) / (".vkmech-probe.tmp-" + std::to_string(::getpid()))).string();
    int fd = ::open(probe.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0666);
    if (fd < 0) fail(std::string("cannot create a file there (") + std::strerror(errno) + ")");
    const bool wrote = ::write(fd, "probe", 5) == 5;
    const int err = errno;
    ::close(fd);
    ::unlink(probe.c_str());
    if (!wrote) fail(std::string("cannot write a file there (") + std::strerror(err) + ")");
}

size_t clean_stale_temporaries(const std::string& dir) {
    size_t n = 0;
    std::error_code ec;
    if (!fs::is_directory(dir, ec)) return 0;
    for (const auto& e : fs::directory_iterator(dir, ec)) {
        const std::string name = e.path().filename().string();
        long pid = -1;
        if (name.rfind(kStagingPrefix, 0) == 0)
            pid = leading_pid(name, std::strlen(kStagingPrefix));
        else
            pid = trailing_tmp_pid(name);
        // Another machine's temporary (a shared filesystem): its pid means nothing here.
        const size_t host = name.rfind(".host-"), tmp = name.rfind(".tmp-");
        if (host != std::string::npos && tmp != std::string::npos && host < tmp &&
            name.substr(host + 6, tmp - host - 6) != temp_host_name())
            continue;
        if (pid <= 0 || process_alive(pid)) continue;
        std::error_code rec;
        if (fs::remove_all(e.path(), rec) > 0) ++n;
    }
    return n;
}

size_t recover_pending_commits(const std::string& dir) {
    size_t n = 0;
    std::error_code ec;
    if (!fs::is_directory(dir, ec)) return 0;
    std::vector<fs::path> pending;
    for (const auto& e : fs::directory_iterator(dir, ec)) {
        const std::string name = e.path().filename().string();
        if (name.rfind(kCommitPrefix, 0) != 0 || !e.is_directory()) continue;
        long pid = leading_pid(name, std::strlen(kCommitPrefix));
        if (pid > 0 && process_alive(pid)) continue;
        pending.push_back(e.path());
    }
    for (const auto& p : pending) {
        finish_commit(dir, p);
        ++n;
    }
    return n;
}

std::vector<SetStatus> verify_output_dir(const std::string& dir, std::vector<std::string>* stale) {
    std::vector<SetStatus> out;
    std::vector<fs::path> entries;
    for (const auto& e : fs::directory_iterator(dir)) entries.push_back(e.path());
    std::sort(entries.begin(), entries.end());
    for (const auto& p : entries) {
        const std::string name = p.filename().string();
        if (name.rfind(kCommitPrefix, 0) == 0 && fs::is_directory(p)) {
            SetStatus s;
            s.kind = SetStatus::Pending;
            s.name = name;
            s.detail = "a commit interrupted while moving files in; the next run in this directory finishes it";
            for (const auto& f : fs::directory_iterator(p)) {
                const std::string fn = f.path().filename().string();
                if (fn.size() > 14 && fn.compare(fn.size() - 14, 14, ".manifest.json") == 0) {
                    std::string why;
                    if (auto m = parse_manifest(read_text(f.path()), &why)) {
                        s.name = m->set_name;
                        s.run_id = m->run_id;
                    }
                }
            }
            if (s.run_id.empty()) {
                s.kind = SetStatus::Bad;
                s.detail = "pending commit without a valid manifest";
            }
            out.push_back(s);
            continue;
        }
        if ((name.rfind(kStagingPrefix, 0) == 0 || trailing_tmp_pid(name) > 0)) {
            if (stale) stale->push_back(p.string());
            continue;
        }
        if (name.size() <= 14 || name.compare(name.size() - 14, 14, ".manifest.json") != 0) continue;
        SetStatus s;
        s.name = name.substr(0, name.size() - 14);
        std::string why;
        auto m = parse_manifest(read_text(p), &why);
        if (!m) {
            s.detail = "manifest: " + why;
        } else {
            s.run_id = m->run_id;
            s.detail = check_files(dir, *m);
            if (s.detail.empty()) {
                s.kind = SetStatus::Complete;
                s.detail = std::to_string(m->files.size()) + " files";
            }
        }
        out.push_back(s);
    }
    return out;
}

OutputSet::OutputSet(std::string dir, std::string set_name) : dir_(std::move(dir)), name_(std::move(set_name)) {
    check_writable_dir(dir_, "--out");
    clean_stale_temporaries(dir_);
    recover_pending_commits(dir_);
    staging_ = (fs::path(dir_) / (kStagingPrefix + std::to_string(::getpid()))).string();
    std::error_code ec;
    fs::remove_all(staging_, ec);
    fs::create_directories(staging_, ec);
    if (ec) throw std::runtime_error("--out '" + dir_ + "': cannot create '" + staging_ + "': " + ec.message());
    run_id_ = new_run_id();
}

OutputSet::~OutputSet() {
    if (committed_) return;
    std::error_code ec;
    fs::remove_all(staging_, ec);
}

std::string OutputSet::staged(const std::string& file_name) const { return (fs::path(staging_) / file_name).string(); }

std::string OutputSet::final_path(const std::string& file_name) const { return (fs::path(dir_) / file_name).string(); }

void OutputSet::commit() {
    throw_if_interrupted();
    Manifest m{name_, run_id_, {}};
    std::vector<fs::path> files;
    for (const auto& e : fs::directory_iterator(staging_))
        if (e.is_regular_file() && trailing_tmp_pid(e.path().filename().string()) < 0) files.push_back(e.path());
    std::sort(files.begin(), files.end());
    for (const auto& f : files) {
        ManifestEntry entry;
        entry.name = f.filename().string();
        entry.digest = file_digest(f.string(), &entry.size);
        m.files.push_back(entry);
    }
    write_file_atomic(staged(manifest_file_name(name_)), manifest_json(m));
    fsync_dir(staging_);
    fault_point("commit-staged");
    throw_if_interrupted();
    // 2. The commit point.
    const fs::path commit_dir = fs::path(dir_) / (kCommitPrefix + std::to_string(::getpid()) + "-" + name_);
    std::error_code ec;
    fs::remove_all(commit_dir, ec);
    if (::rename(staging_.c_str(), commit_dir.c_str()) != 0)
        throw std::runtime_error("cannot commit the outputs in '" + dir_ + "': " + std::strerror(errno));
    committed_ = true;
    fsync_dir(dir_);
    finish_commit(dir_, commit_dir);
}

}  // namespace vkmech
