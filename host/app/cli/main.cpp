// vkmech: the command-line entry. Exit codes (docs/architecture.md, "Errors say what,
// where and what to do"): 0 ok, 1 runtime failure, 2 bad usage or bad input.
#include "cli/commands.hpp"
#include "io/invariant.hpp"

#include "scene/scene.hpp"
#include "study/study_runner.hpp"
#include "vk/buffer.hpp"
#include "vk/context.hpp"

#include <CLI/CLI.hpp>

#include <iostream>

int main(int argc, char** argv) {
    using namespace vkmech;
    // `vkmech --scene X ...` is shorthand for `vkmech render --scene X ...`.
    std::vector<std::string> args(argv + 1, argv + argc);
    if (!args.empty() && args[0].rfind("-", 0) == 0 && args[0] != "-h" && args[0] != "--help" && args[0] != "--version")
        args.insert(args.begin(), "render");

    CLI::App app{
        "vkmech: a Vulkan path tracer that labels every pixel with how its light arrived\n"
        "(the seven-bucket transport-mechanism descriptor).",
        "vkmech"};
    app.set_version_flag("--version", std::string("vkmech ") + VKMECH_VERSION);
    app.require_subcommand(1);
    app.footer(
        "Examples:\n  vkmech --scene ring_caustic --spp 64\n  vkmech check --scene my_scene.xml\n  vkmech devices\n"
        "  vkmech paths\n"
        "  vkmech bench traversal\n"
        "  vkmech study all --preset quick --out out/study\n"
        "  vkmech verify outputs out/ring_caustic\n"
        "  vkmech sentinel register --scene cubes_dof --out cubes_dof.sentinel.json\n"
        "  vkmech sentinel evaluate cubes_dof.sentinel.json\n"
        "Exit codes: 0 ok, 1 runtime failure, 2 bad usage or bad input.");

    // Each command registers its subcommand, options and action (docs/architecture.md, "A CLI
    // command"); the order here is --help's.
    CliCommands commands;
    register_render(app, commands);
    register_devices(app, commands);
    register_paths(app, commands);
    register_check(app, commands);
    register_merge(app, commands);
    register_bench(app, commands);
    register_study(app, commands);
    register_verify(app, commands);
    register_sentinel(app, commands);

    // A delimited list of nothing (`--scenes ,,,`): CLI11 drops the empty items and would take the next
    // argument (`--out`) as the list; say what is wrong instead.
    for (size_t i = 0; i < args.size(); ++i)
        for (const std::string opt : {"--scenes", "--spp-levels"}) {
            std::string value;
            if (args[i] == opt && i + 1 < args.size())
                value = args[i + 1];
            else if (args[i].rfind(opt + "=", 0) == 0)
                value = args[i].substr(opt.size() + 1);
            else
                continue;
            if (value.find_first_not_of(", \t") == std::string::npos) {
                std::cerr << "vkmech: error: " << opt << ": empty " << (opt == "--scenes" ? "scene list" : "list")
                          << "\n";
                return 2;
            }
        }

    try {
        std::vector<std::string> rev(args.rbegin(), args.rend());
        app.parse(rev);
    } catch (const CLI::ParseError& e) {
        return app.exit(e) == 0 ? 0 : 2;
    }

    try {
        for (const CliCommand& c : commands)
            if (c.sub->parsed()) return c.run(args);
    } catch (const StudyInterrupted& e) {
        std::cerr << "\nvkmech study: " << e.what()
                  << "; every finished render is in the cache, run the same command "
                     "again to resume\n";
        return e.exit_code();
    } catch (const Interrupted& e) {
        std::cerr << "\nvkmech: " << e.what()
                  << "; nothing new was committed: the output directory holds the previous "
                     "complete set, if any (its temporaries are removed)\n";
        return e.exit_code();
    } catch (const vkmech::vk::OutOfMemoryError& e) {
        std::cerr << "vkmech: out of memory: " << e.what() << "\n";
        return 1;
    } catch (const InternalError& e) {
        std::cerr << "vkmech: internal error (a bug in vkmech; please report it with the command line): " << e.what()
                  << "\n";
        return 1;
    } catch (const SceneError& e) {
        std::cerr << "vkmech: error: " << e.what() << "\n";
        return 2;
    } catch (const UsageError& e) {
        std::cerr << "vkmech: error: " << e.what() << "\n";
        return 2;
    } catch (const vkmech::vk::VulkanError& e) {
        std::cerr << "vkmech: Vulkan error: " << e.what() << "\n";
        return 1;
    } catch (const ::vk::SystemError& e) {
        std::cerr << "vkmech: Vulkan error: " << e.what() << "\n";
        return 1;
    } catch (const std::exception& e) {
        std::cerr << "vkmech: error: " << e.what() << "\n";
        return 1;
    }
    return 0;
}
