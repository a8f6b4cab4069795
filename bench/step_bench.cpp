// Step, snapshot and checksum costs of the physics world (Google Benchmark).
// Results and the machine they came from: docs/performance.md and bench/results/*.csv.
#include <benchmark/benchmark.h>

#include <vector>

#include "harness/match/scene_loader.h"
#include "sim/snapshot.h"
#include "sim/world.h"

namespace {
using namespace lockroll;

// Warms a world past its spawn transient so the figures describe a scene in motion.
sim::World warmed(const sim::SceneDesc& scene, int frames) {
    sim::World w(scene);
    const std::vector<sim::PlayerInput> in(static_cast<std::size_t>(w.player_count()), sim::PlayerInput{60, -40, 0});
    for (int f = 0; f < frames; ++f) w.step(in);
    return w;
}

// Mean cost of a step over a scene's whole life: each repetition runs the 720 frames of the
// scene from its initial state (restored from a snapshot, ~50 ns), so the figure covers the
// spawn, the fall and the settled phase alike, not whichever phase a warm-up happens to reach.
constexpr int kSceneFrames = 720;

void step_scene(benchmark::State& state, const sim::SceneDesc& scene) {
    sim::World w(scene);
    const std::vector<sim::PlayerInput> in(static_cast<std::size_t>(w.player_count()), sim::PlayerInput{60, -40, 0});
    std::vector<std::uint8_t> initial(sim::snapshot_size(w));
    sim::save(w, initial);
    int frame = 0;
    for (auto _ : state) {
        if (frame == kSceneFrames) {
            benchmark::DoNotOptimize(sim::load(w, initial));
            frame = 0;
        }
        w.step(in);
        ++frame;
    }
    state.counters["bodies"] = static_cast<double>(w.dynamic_count());
}

void BM_StepPaper(benchmark::State& state) { step_scene(state, harness::load_scene("paper")); }
void BM_Step1k(benchmark::State& state) { step_scene(state, harness::load_scene("bodies_1k")); }
void BM_Step10k(benchmark::State& state) { step_scene(state, harness::load_scene("bodies_10k")); }

void BM_Step1kBroadphase(benchmark::State& state) {
    sim::SceneDesc s = harness::load_scene("bodies_1k");
    s.broadphase = state.range(0) ? sim::BroadphaseKind::Grid : sim::BroadphaseKind::SweepAndPrune;
    state.SetLabel(state.range(0) ? "grid" : "sap");
    step_scene(state, s);
}

// "Leave out what a scene does not need": the paper's 50 balls alone, then the same balls with
// features present but idle (a far-away player body with neutral input, a static capsule, a
// box): the idle features should cost next to nothing.
sim::SceneDesc balls_only() {
    sim::SceneDesc s = harness::load_scene("paper");
    std::vector<sim::BodyDesc> kept;
    for (const auto& b : s.bodies)
        if (b.player < 0) kept.push_back(b);
    s.bodies = kept;
    return s;
}
void BM_StepBallsOnly(benchmark::State& state) { step_scene(state, balls_only()); }
void BM_StepBallsPlusIdleFeatures(benchmark::State& state) {
    sim::SceneDesc s = balls_only();
    sim::BodyDesc player;
    player.shape = sim::Shape::Capsule;
    player.radius = *sim::Fixed::parse("0.4");
    player.half_height = *sim::Fixed::parse("0.5");
    player.position = {*sim::Fixed::parse("5.5"), *sim::Fixed::parse("0.9"), *sim::Fixed::parse("5.5")};
    player.mass = sim::Fixed::from_int(5);
    player.player = 0;
    player.gravity_scale = sim::Fixed::zero();
    s.bodies.push_back(player);
    sim::BodyDesc cap = player;
    cap.player = -1;
    cap.mass = sim::Fixed::zero();
    cap.position.z = -cap.position.z;
    s.bodies.push_back(cap);
    step_scene(state, s);
}

void save_scene(benchmark::State& state, const char* scene) {
    sim::World w = warmed(harness::load_scene(scene), 120);
    std::vector<std::uint8_t> buf(sim::snapshot_size(w));
    for (auto _ : state) {
        sim::save(w, buf);
        benchmark::DoNotOptimize(buf.data());
    }
    state.counters["snapshot_bytes"] = static_cast<double>(buf.size());
    state.counters["bytes_per_dynamic_body"] =
        static_cast<double>(buf.size()) / static_cast<double>(w.dynamic_count());
}
void BM_SavePaper(benchmark::State& state) { save_scene(state, "paper"); }
// paper_rigid: every body turns and rubs, capsule players (docs/physics.md).
void BM_SavePaperRigid(benchmark::State& state) { save_scene(state, "paper_rigid"); }
void BM_StepPaperRigid(benchmark::State& state) { step_scene(state, harness::load_scene("paper_rigid")); }
void BM_Step1kRigid(benchmark::State& state) { step_scene(state, harness::load_scene("bodies_1k_rigid")); }
void BM_Step10kRigid(benchmark::State& state) { step_scene(state, harness::load_scene("bodies_10k_rigid")); }

void BM_LoadPaper(benchmark::State& state) {
    sim::World w = warmed(harness::load_scene("paper"), 120);
    std::vector<std::uint8_t> buf(sim::snapshot_size(w));
    sim::save(w, buf);
    for (auto _ : state) benchmark::DoNotOptimize(sim::load(w, buf));
}

void BM_ChecksumPaper(benchmark::State& state) {
    sim::World w = warmed(harness::load_scene("paper"), 120);
    for (auto _ : state) benchmark::DoNotOptimize(sim::checksum(w));
}

// What a rollback of depth 8 costs the session: load the snapshot, then 8 steps each followed by
// the save and checksum the ring buffer and desync detector need.
void rollback8(benchmark::State& state, const char* scene) {
    sim::World w = warmed(harness::load_scene(scene), 120);
    const std::vector<sim::PlayerInput> in(2, sim::PlayerInput{60, -40, 0});
    std::vector<std::vector<std::uint8_t>> ring(9, std::vector<std::uint8_t>(sim::snapshot_size(w)));
    sim::save(w, ring[0]);
    for (auto _ : state) {
        benchmark::DoNotOptimize(sim::load(w, ring[0]));
        for (int f = 1; f <= 8; ++f) {
            w.step(in);
            sim::save(w, ring[static_cast<std::size_t>(f)]);
            benchmark::DoNotOptimize(sim::checksum(w));
        }
    }
}
void BM_Rollback8Paper(benchmark::State& state) { rollback8(state, "paper"); }
void BM_Rollback8PaperRigid(benchmark::State& state) { rollback8(state, "paper_rigid"); }

}  // namespace

BENCHMARK(BM_Rollback8Paper)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_StepPaper)->Iterations(20 * kSceneFrames);
BENCHMARK(BM_StepBallsOnly)->Iterations(20 * kSceneFrames);
BENCHMARK(BM_StepBallsPlusIdleFeatures)->Iterations(20 * kSceneFrames);
BENCHMARK(BM_Step1k)->Iterations(kSceneFrames)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_Step1kBroadphase)->Arg(0)->Arg(1)->Iterations(kSceneFrames)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_Step10k)->Iterations(kSceneFrames)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_SavePaper);
BENCHMARK(BM_LoadPaper);
BENCHMARK(BM_ChecksumPaper);
BENCHMARK(BM_StepPaperRigid)->Iterations(20 * kSceneFrames);
BENCHMARK(BM_SavePaperRigid);
BENCHMARK(BM_Rollback8PaperRigid)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_Step1kRigid)->Iterations(kSceneFrames)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_Step10kRigid)->Iterations(kSceneFrames)->Unit(benchmark::kMillisecond);
BENCHMARK_MAIN();
