// The lockroll program: one subcommand per job (sim, run, compare, sweep, replay, ...).
// Exit status: 0 success, 2 bad usage or bad input (flags, scene or replay files), 1 failure.
#include <cstdio>
#include <exception>

#include <CLI/CLI.hpp>

#include "harness/cli_error.h"
#include "harness/commands.h"

int main(int argc, char** argv) {
    CLI::App app{"lockroll: deterministic fixed-point physics with rollback and lockstep netcode"};
    app.require_subcommand(1);
    lockroll::harness::add_all_commands(app);
    try {
        app.parse(argc, argv);
    } catch (const CLI::CallForHelp& e) {
        return app.exit(e);
    } catch (const CLI::CallForAllHelp& e) {
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
