// The lockroll program: one subcommand per job (sim, run, compare, sweep, replay, ...).
// Exit status: 0 success, 2 bad usage or bad input (flags, scene or replay files), 1 failure.
#include <cstdio>
#include <cstring>
#include <exception>
#include <string>

#include <CLI/CLI.hpp>
#include <lockroll/version.h>

#include "harness/match/cli_error.h"
#include "harness/commands.h"
#include "harness/match/scene_loader.h"

namespace {
// CLI11 answers an unknown first word with "A subcommand is required"; name it instead.
// Returns the unknown word, or empty when argv[1] is an option or a subcommand.
std::string unknown_subcommand(const CLI::App& app, int argc, char** argv) {
    for (int i = 1; i < argc; ++i) {
        const char* a = argv[i];
        if (a[0] == '-') {
            if (std::strcmp(a, "--max-bodies") == 0) ++i;  // the one global option with a value
            continue;
        }
        for (const CLI::App* sub : app.get_subcommands([](const CLI::App*) { return true; }))
            if (sub->check_name(a)) return {};
        return a;
    }
    return {};
}
}  // namespace

int main(int argc, char** argv) {
    CLI::App app{"lockroll: deterministic fixed-point physics with rollback and lockstep netcode"};
    app.set_version_flag("--version", "lockroll " LOCKROLL_VERSION_STRING, "Print the version and exit");
    app.require_subcommand(1);
    app.add_option_function<std::size_t>(
           "--max-bodies", [](std::size_t n) { lockroll::harness::set_max_scene_bodies(n); },
           "Refuse scenes (files, embedded in replays) with more bodies than this; give it before the subcommand")
        ->check(CLI::Range(std::size_t{1}, std::size_t{100000000}))
        ->default_str(std::to_string(lockroll::harness::kDefaultMaxSceneBodies));
    lockroll::harness::add_all_commands(app);
    if (const std::string unknown = unknown_subcommand(app, argc, argv); !unknown.empty()) {
        std::fprintf(stderr, "lockroll: unknown subcommand '%s' (lockroll --help lists them)\n", unknown.c_str());
        return 2;
    }
    try {
        app.parse(argc, argv);
    } catch (const CLI::CallForHelp& e) {
        return app.exit(e);
    } catch (const CLI::CallForAllHelp& e) {
        return app.exit(e);
    } catch (const CLI::CallForVersion& e) {
        return app.exit(e);
    } catch (const CLI::ParseError& e) {
        app.exit(e);
        return 2;
    } catch (const lockroll::harness::UsageError& e) {
        std::fprintf(stderr, "lockroll: %s\n", e.what());
        return 2;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "lockroll: error: %s\n", e.what());
        return 1;
    }
    return 0;
}
