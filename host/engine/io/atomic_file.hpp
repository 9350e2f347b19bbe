// Atomic file writes (issue "outputs"): every output file is written to
// `path + ".host-<host>.tmp-<pid>"` in the destination directory, fsync'ed, then renamed
// over `path`. A reader therefore sees either the old file or the complete new
// one, never a partial file. On failure the temporary is removed and a
// std::runtime_error naming the path and the reason is thrown.
#pragma once

#include <functional>
#include <string>

namespace vkmech {

// The temporary name used for `path`: path + ".host-<host>.tmp-<pid>", unique
// across the machines that share a directory (a render cache on a shared
// filesystem), so concurrent writers of one file never share a temporary.
std::string atomic_temp_path(const std::string& path);
// This machine's host name as it appears in temporaries (file-name-safe).
std::string temp_host_name();

// Writes `bytes` to `path` atomically (temp + fsync + rename, then a
// best-effort fsync of the directory). Parent directories are created.
void write_file_atomic(const std::string& path, const std::string& bytes);

// General form: creates the parent directories, opens the temporary file
// (O_WRONLY|O_CREAT|O_TRUNC, mode 0666 & ~umask) and calls fill(fd, tmp_path),
// which must write the whole content to fd (it must not close fd; it reports
// failure by throwing). Then fsync, close, rename over `path`. Any exception
// from `fill` or from the commit removes the temporary and is rethrown as
// std::runtime_error("cannot write '<path>': <reason>").
void write_file_atomic_with(const std::string& path,
                            const std::function<void(int fd, const std::string& tmp_path)>& fill);

// Writes n bytes to fd, retrying on EINTR and short writes; throws
// std::runtime_error (with strerror) on failure.
void write_all_fd(int fd, const void* data, size_t n);

}  // namespace vkmech
