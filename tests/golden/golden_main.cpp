// Golden checksum runner: runs every shipped scene with a scripted input pattern and prints
// `scene frame checksum` lines. The same program, compiled by every compiler, optimisation
// level and CPU in scripts/cross-check.sh, must print exactly tests/golden/checksums.txt;
// the CTest test `golden_checksums` holds the normal build to the same file.
//
// It compiles from sim/*.cpp, harness/match/scene_loader.cpp and this file alone, with header-only
// nlohmann-json, xxHash and CLI11, so cross compilers need no libraries.
#include <CLI/CLI.hpp>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <functional>
#include <iostream>
#include <random>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "harness/match/hex.h"
#include "harness/match/scene_loader.h"
#include "sim/snapshot.h"
#include "sim/world.h"

namespace {

using lockroll::sim::PlayerInput;

// The scripted input of player `slot` for the step from `frame` to frame + 1: a pure integer
// function, so it is the same everywhere. Slots are phase-shifted by 40 frames so that players
// differ; the stick sweeps -1/0/+1 every second (forward) and every 0.75 s (right), and "up"
// is held for 10 frames every 3 s.
PlayerInput scripted_input(std::uint32_t frame, int slot) {
    const std::int64_t t = static_cast<std::int64_t>(frame) + 40 * static_cast<std::int64_t>(slot);
    PlayerInput in;
    in.forward = static_cast<std::int8_t>(127 * ((t / 60) % 3 - 1));
    in.right = static_cast<std::int8_t>(100 * ((t / 45) % 3 - 1));
    in.up = static_cast<std::int8_t>(t % 180 < 10 ? 127 : 0);
    return in;
}

struct GoldenScene {
    const char* name;
    std::vector<std::uint32_t> frames;  // ascending; checksum printed after reaching each
};

// bodies_10k stops at frame 60 to keep the slowest target (-O0 under qemu) quick.
const std::vector<GoldenScene> kScenes = {
    {"paper", {0, 1, 60, 240, 720}},
    {"bodies_1k", {0, 1, 60, 240, 720}},
    {"bodies_10k", {0, 1, 60}},
    // Opt-in solver paths (scene "solver" settings), so every CPU checks them too.
    {"stability/bounce_e1", {60, 240}},       // ballistic integrator + swept contacts
    {"stability/stack_24", {60, 240}},        // position-based + shock propagation + slop
    {"stability/resting_pile", {60, 240}},    // substeps
    {"stability/overlap_spawn", {60, 240}},   // push-out speed cap
    {"stability/tunneling", {60, 240}},       // swept tests against static bodies
    // Rigid bodies (scene "rigid"): orientation, friction, contact points, box-box SAT.
    {"paper_rigid", {0, 1, 60, 240}},
    {"bodies_1k_rigid", {0, 1, 60, 240}},    // rotating bodies at scale: balls and boxes in a pile
    {"stability/rigid_spin", {60, 240}},      // free precession, Dzhanibekov flip
    {"stability/rigid_tip", {60, 240}},       // edge contacts, friction, tipping
    {"stability/rigid_pyramid_10", {60}},     // box-box manifolds, shock propagation
    {"stability/rigid_stack_20", {60}},       // warm starting: carried impulses (layout 2)
};

// How the world runs its parallel phases: --workers N alone uses the world's own pool; with
// --task-runner the phases are cut into N tasks run by a runner of this file, which proves the
// bits do not depend on the order tasks run in or on which thread runs them.
struct Parallel {
    int workers = 1;
    std::string runner;  // "", "reversed", "shuffled" or "spawn"
};

// Runs the tasks on the calling thread, last first.
void run_reversed(std::size_t count, const std::function<void(std::size_t)>& task) {
    for (std::size_t i = count; i-- > 0;) task(i);
}

// Runs the tasks on the calling thread in a new pseudo-random order each call.
void run_shuffled(std::size_t count, const std::function<void(std::size_t)>& task) {
    static std::mt19937 rng(20261203);
    std::vector<std::size_t> order(count);
    for (std::size_t i = 0; i < count; ++i) order[i] = i;
    std::shuffle(order.begin(), order.end(), rng);
    for (std::size_t i : order) task(i);
}

// One new thread per task, started last first (overflow counts from other threads).
void run_spawn(std::size_t count, const std::function<void(std::size_t)>& task) {
    std::vector<std::thread> threads;
    for (std::size_t i = count; i-- > 0;) threads.emplace_back([&task, i] { task(i); });
    for (std::thread& t : threads) t.join();
}

void run(const GoldenScene& g, const std::string& scene_dir, const Parallel& parallel, std::ostream& out) {
    const std::string where = scene_dir.empty() ? std::string(g.name) : scene_dir + "/" + g.name + ".json";
    lockroll::sim::World world(lockroll::harness::load_scene(where));
    if (parallel.runner == "reversed")
        world.set_task_runner(parallel.workers, run_reversed);
    else if (parallel.runner == "shuffled")
        world.set_task_runner(parallel.workers, run_shuffled);
    else if (parallel.runner == "spawn")
        world.set_task_runner(parallel.workers, run_spawn);
    else
        world.set_workers(parallel.workers);
    std::vector<PlayerInput> inputs(static_cast<std::size_t>(world.player_count()));
    for (std::uint32_t target : g.frames) {
        while (world.frame() < target) {
            for (int p = 0; p < world.player_count(); ++p)
                inputs[static_cast<std::size_t>(p)] = scripted_input(world.frame(), p);
            world.step(inputs);
        }
        out << g.name << ' ' << world.frame() << ' ' << lockroll::harness::hex16(lockroll::sim::checksum(world)) << '\n';
    }
}

bool selected(const std::vector<std::string>& only, const std::string& scene) {
    return only.empty() || std::find(only.begin(), only.end(), scene) != only.end();
}

// Non-comment lines, restricted to the selected scenes (the first word of a line).
std::vector<std::string> data_lines(std::istream& in, const std::vector<std::string>& only) {
    std::vector<std::string> lines;
    for (std::string line; std::getline(in, line);)
        if (!line.empty() && line[0] != '#' && selected(only, line.substr(0, line.find(' ')))) lines.push_back(line);
    return lines;
}

}  // namespace

int main(int argc, char** argv) {
    CLI::App app{"Prints `scene frame checksum` for the shipped scenes under a scripted input pattern"};
    std::string scene_dir, check_path;
    std::vector<std::string> only;
    app.add_option("--scene-dir", scene_dir, "Directory holding <scene>.json (default: the usual scene search)");
    app.add_option("--check", check_path, "Compare with this golden file instead of printing; exit 1 on a difference")
        ->check(CLI::ExistingFile);
    Parallel parallel;
    app.add_option("--workers", parallel.workers,
                   "Step with this many workers (the world's own threads; with --task-runner, tasks per phase)")
        ->check(CLI::Range(1, 64));
    app.add_option("--task-runner", parallel.runner,
                   "Run the parallel phases with a runner of this program instead of the world's threads")
        ->check(CLI::IsMember({"reversed", "shuffled", "spawn"}));
    app.add_option("--only", only, "Run only these scenes")
        ->check(CLI::IsMember([] {
            std::vector<std::string> names;
            for (const auto& g : kScenes) names.emplace_back(g.name);
            return names;
        }()));
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        const int code = app.exit(e);  // prints help or the error
        return code == 0 ? 0 : 2;
    }

    std::ostringstream out;
    try {
        for (const auto& g : kScenes)
            if (selected(only, g.name)) run(g, scene_dir, parallel, out);
    } catch (const std::exception& e) {
        std::fprintf(stderr, "golden_main: %s\n", e.what());
        return 2;
    }
    if (check_path.empty()) {
        std::fputs(out.str().c_str(), stdout);
        return 0;
    }
    std::ifstream golden_file(check_path);
    std::istringstream got_stream(out.str());
    const auto want = data_lines(golden_file, only), got = data_lines(got_stream, only);
    for (std::size_t i = 0; i < std::max(want.size(), got.size()); ++i) {
        const std::string w = i < want.size() ? want[i] : "(end of file)", g = i < got.size() ? got[i] : "(no output)";
        if (w != g) {
            std::fprintf(stderr, "golden checksum mismatch at data line %zu of %s:\n  expected: %s\n  got:      %s\n",
                         i + 1, check_path.c_str(), w.c_str(), g.c_str());
            return 1;
        }
    }
    std::printf("%zu golden checksums match %s\n", got.size(), check_path.c_str());
    return 0;
}
