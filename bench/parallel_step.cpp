// The parallel step's speed-up: paired runs of the same frames at 1 worker and at N workers
// (World::set_workers), wall time and process CPU time, medians of the pairs' ratios. Each pair
// also checks that both ends reach the same checksum (a parallel step that changed a bit would
// be no speed-up at all). Results and the machine: docs/performance.md, "Parallel step".
//
//   parallel_step [--scene NAME]... [--workers N] [--frames F] [--warm W] [--pairs P]
//
// Each run steps frames [W, W + F) of the scene from one warmed snapshot; the two runs of a
// pair alternate which goes first, so a drift in the machine's load falls on both.
#include <CLI/CLI.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <string>
#include <vector>

#include "bench/median.h"
#include "harness/match/hex.h"
#include "harness/match/scene_loader.h"
#include "sim/snapshot.h"
#include "sim/world.h"

namespace {
using namespace lockroll;
using lockroll::bench::median;

double process_cpu_seconds() {
    timespec ts{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return static_cast<double>(ts.tv_sec) + static_cast<double>(ts.tv_nsec) * 1e-9;
}

struct Run {
    double wall = 0, cpu = 0;  // seconds for the frames
    std::uint64_t checksum = 0;
};

Run run(const sim::World& warmed, int workers, int frames) {
    sim::World w(warmed);  // a copy steps sequentially until told otherwise
    w.set_workers(workers);
    const std::vector<sim::PlayerInput> in(static_cast<std::size_t>(w.player_count()), sim::PlayerInput{60, -40, 0});
    const auto t0 = std::chrono::steady_clock::now();
    const double c0 = process_cpu_seconds();
    for (int f = 0; f < frames; ++f) w.step(in);
    Run r;
    r.cpu = process_cpu_seconds() - c0;
    r.wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    r.checksum = sim::checksum(w);
    return r;
}

}  // namespace

int main(int argc, char** argv) {
    CLI::App app{"Paired runs of the parallel step at 1 and N workers: wall and CPU time, medians"};
    std::vector<std::string> scenes = {"bodies_10k", "bodies_10k_rigid"};
    int workers = 2, frames = 120, warm = 0, pairs = 5;
    app.add_option("--scene", scenes, "Scenes to run (default bodies_10k bodies_10k_rigid)");
    app.add_option("--workers", workers, "Workers of the parallel end of each pair")->check(CLI::Range(2, 64));
    app.add_option("--frames", frames, "Frames per run")->check(CLI::Range(1, 100000));
    app.add_option("--warm", warm, "Frames stepped once before the runs (sequentially)")->check(CLI::Range(0, 100000));
    app.add_option("--pairs", pairs, "Paired runs per scene")->check(CLI::Range(1, 1000));
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        const int code = app.exit(e);
        return code == 0 ? 0 : 2;
    }
    std::vector<sim::SceneDesc> loaded;
    try {
        for (const std::string& s : scenes) loaded.push_back(harness::load_scene(s));
    } catch (const std::exception& e) {
        std::fprintf(stderr, "parallel_step: %s\n", e.what());
        return 2;
    }

    std::printf("scene,workers,frames,warm,pairs,wall_ms_per_step_1,wall_ms_per_step_n,cpu_ms_per_step_1,"
                "cpu_ms_per_step_n,wall_speedup,cpu_ratio\n");
    for (std::size_t k = 0; k < loaded.size(); ++k) {
        sim::World base(loaded[k]);
        const std::vector<sim::PlayerInput> in(static_cast<std::size_t>(base.player_count()), sim::PlayerInput{60, -40, 0});
        for (int f = 0; f < warm; ++f) base.step(in);
        std::vector<double> wall1, walln, cpu1, cpun, speedup, cpu_ratio;
        for (int p = 0; p < pairs; ++p) {
            Run one, many;
            if (p % 2 == 0) {
                one = run(base, 1, frames);
                many = run(base, workers, frames);
            } else {
                many = run(base, workers, frames);
                one = run(base, 1, frames);
            }
            if (one.checksum != many.checksum) {
                std::fprintf(stderr, "parallel_step: %s: checksum %s at 1 worker but %s at %d after %d frames\n",
                             scenes[k].c_str(), harness::hex16(one.checksum).c_str(),
                             harness::hex16(many.checksum).c_str(), workers, warm + frames);
                return 1;
            }
            wall1.push_back(one.wall);
            walln.push_back(many.wall);
            cpu1.push_back(one.cpu);
            cpun.push_back(many.cpu);
            speedup.push_back(one.wall / many.wall);
            cpu_ratio.push_back(many.cpu / one.cpu);
        }
        const double per = 1e3 / frames;
        std::printf("%s,%d,%d,%d,%d,%.3f,%.3f,%.3f,%.3f,%.3f,%.3f\n", scenes[k].c_str(), workers, frames, warm, pairs,
                    median(wall1) * per, median(walln) * per, median(cpu1) * per, median(cpun) * per, median(speedup),
                    median(cpu_ratio));
        std::fflush(stdout);
    }
    return 0;
}
