// Runs the vkmech CLI with its output captured: the exit code and stdout +
// stderr together. $VKMECH_TEST_CLI, when set, names the binary to run instead
// of this build's (to run the CLI cases against another build).
#pragma once

#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace vkmech::testing {

struct CliRun {
    int code;
    std::string output;
};

// `env` is prefixed to the command line (e.g. "VKMECH_FAULT=x:TERM").
inline CliRun run_cli(const std::string& args, const std::string& env = "") {
    const char* bin = std::getenv("VKMECH_TEST_CLI");
    std::filesystem::path log =
        std::filesystem::temp_directory_path() / ("vkmech_cli_" + std::to_string(::getpid()) + ".log");
    std::string cmd = env + " " + (bin ? bin : VKMECH_CLI) + " " + args + " > " + log.string() + " 2>&1";
    int status = std::system(cmd.c_str());
    std::ifstream in(log);
    std::stringstream ss;
    ss << in.rdbuf();
    std::filesystem::remove(log);
    return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, ss.str()};
}

}  // namespace vkmech::testing
