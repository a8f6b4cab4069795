#include "harness/synctest_command.h"

#include <algorithm>
#include <cstdio>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "harness/match/bots.h"
#include "harness/match/cli_error.h"
#include "harness/cli_validators.h"
#include "harness/match/hex.h"
#include "harness/report/output_path.h"
#include "harness/replay_command.h"
#include "harness/match/scene_loader.h"
#include "rollback/replay.h"
#include "rollback/sync_test.h"
#include "rollback/world_simulation.h"

namespace lockroll::harness {

namespace {
struct Options {
    std::string scene;
    int frames = 720;
    int distance = 8;
    std::uint64_t seed = 1;
    std::string bot = "random";
    std::string record;
    bool quiet = false;
};

void run_synctest(const Options& o) {
    if (!o.record.empty()) check_output_file("--record", o.record);
    sim::SceneDesc scene;
    try {
        scene = load_scene(o.scene);
    } catch (const SceneError& e) {
        throw UsageError(e.what());
    }
    const auto kind = parse_bot_kind(o.bot);
    if (!kind) throw UsageError("--bot: '" + o.bot + "' is not a bot (random, chase)");
    const int players = std::max(sim::player_count(scene), 1);
    rollback::WorldSimulation sim(scene, players);
    rollback::SyncTest test(sim, {players, rollback::kWorldInputSize, o.distance});

    std::vector<Bot> bots;
    for (int p = 0; p < players; ++p) bots.emplace_back(BotConfig{*kind, o.seed, scene.tick_rate, 4.0}, p);

    std::unique_ptr<rollback::ReplayRecorder> recorder;
    if (!o.record.empty()) {
        rollback::Replay header;
        header.players = static_cast<std::uint32_t>(players);
        header.input_size = rollback::kWorldInputSize;
        header.tick_rate = static_cast<std::uint32_t>(scene.tick_rate);
        header.initial_checksum = test.checksum(0);
        header.scene_name = o.scene;
        header.scene_text = scene_text_for_replay(o.scene);
        recorder = std::make_unique<rollback::ReplayRecorder>(std::move(header));
    }

    std::vector<std::uint8_t> inputs(static_cast<std::size_t>(players) * rollback::kWorldInputSize);
    for (int f = 0; f < o.frames; ++f) {
        const auto frame = static_cast<std::uint32_t>(f);
        for (int p = 0; p < players; ++p) {
            const auto in = rollback::encode_input(bots[static_cast<std::size_t>(p)].input(frame, sim.world()));
            std::copy(in.begin(), in.end(), inputs.begin() + p * static_cast<int>(rollback::kWorldInputSize));
        }
        if (const auto failure = test.advance(inputs)) {
            throw std::runtime_error("synctest " + scene.name + ": nondeterminism at frame " +
                                     std::to_string(failure->frame) + " (resimulated from frame " +
                                     std::to_string(failure->loaded_frame) + "): first run " +
                                     hex16(failure->expected) + ", resimulated " + hex16(failure->actual) + ": " +
                                     failure->detail);
        }
        if (recorder) recorder->add(test.frame(), inputs, test.checksum(test.frame()));
    }
    if (recorder) write_replay_file(o.record, recorder->replay());
    if (!o.quiet)
        std::printf("synctest %s: %d frames, each rolled back %d frames and resimulated (%llu resimulated "
                    "frames): deterministic; final %s\n",
                    scene.name.c_str(), o.frames, o.distance,
                    static_cast<unsigned long long>(test.resimulated_frames()), hex16(test.checksum(test.frame())).c_str());
}
}  // namespace

void add_synctest_command(CLI::App& app) {
    auto opts = std::make_shared<Options>();
    CLI::App* cmd = app.add_subcommand(
        "synctest", "Roll back and resimulate every frame, checking the simulation is deterministic");
    cmd->add_option("--scene", opts->scene, "Scene file, or a shipped scene name (paper, bodies_1k, bodies_10k)")
        ->required();
    cmd->add_option("--frames", opts->frames, "Frames to simulate")->check(CLI::Range(0, 10000000));
    cmd->add_option("--distance", opts->distance, "Frames rolled back every frame (1..8; up to 64 allowed)")
        ->check(CLI::Range(1, 64));
    cmd->add_option("--seed", opts->seed, "Bot seed")->check(kNonNegativeInteger);
    cmd->add_option("--bot", opts->bot, "Input bot: random or chase");
    cmd->add_option("--record", opts->record, "Also write the run as a replay file");
    cmd->add_flag("--quiet", opts->quiet, "Print nothing on success");
    cmd->callback([opts] { run_synctest(*opts); });
}

}  // namespace lockroll::harness
