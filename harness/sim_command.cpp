#include "harness/sim_command.h"

#include <cstdio>
#include <memory>
#include <vector>

#include <nlohmann/json.hpp>

#include "harness/match/atomic_file.h"
#include "harness/match/cli_error.h"
#include "harness/match/hex.h"
#include "harness/report/output_path.h"
#include "harness/match/scene_loader.h"
#include "sim/snapshot.h"
#include "sim/world.h"

namespace lockroll::harness {

namespace {
struct SimOptions {
    std::string scene;
    int frames = 720;
    int every = 60;
    std::string json_path;
};

void run_sim(const SimOptions& o) {
    if (!o.json_path.empty()) check_output_file("--json", o.json_path);
    sim::SceneDesc scene;
    try {
        scene = load_scene(o.scene);
    } catch (const SceneError& e) {
        throw UsageError(e.what());
    }
    sim::World world(scene);
    const std::vector<sim::PlayerInput> neutral(static_cast<std::size_t>(world.player_count()));
    nlohmann::json checksums = nlohmann::json::array();
    auto record = [&] {
        const std::uint64_t c = sim::checksum(world);
        std::printf("%6u %s\n", world.frame(), hex16(c).c_str());
        checksums.push_back({{"frame", world.frame()}, {"checksum", hex16(c)}});
    };
    record();
    for (int f = 0; f < o.frames; ++f) {
        world.step(neutral);
        if (world.frame() % static_cast<unsigned>(o.every) == 0 && f + 1 < o.frames) record();
    }
    const std::uint64_t final_checksum = sim::checksum(world);
    if (o.frames > 0) checksums.push_back({{"frame", world.frame()}, {"checksum", hex16(final_checksum)}});
    if (world.overflow_count() != 0)
        std::fprintf(stderr, "warning: %llu fixed-point operations saturated\n",
                     static_cast<unsigned long long>(world.overflow_count()));
    std::printf("%s\n", hex16(final_checksum).c_str());
    if (!o.json_path.empty()) {
        const nlohmann::json out = {{"scene", scene.name},
                                    {"frames", o.frames},
                                    {"final_checksum", hex16(final_checksum)},
                                    {"checksums", checksums},
                                    {"overflow_count", world.overflow_count()}};
        write_file_atomic(o.json_path, out.dump(2) + "\n");
    }
}
}  // namespace

void add_sim_command(CLI::App& app) {
    auto opts = std::make_shared<SimOptions>();
    CLI::App* cmd = app.add_subcommand("sim", "Run a scene offline and print frame -> checksum");
    cmd->add_option("--scene", opts->scene, "Scene file, or a shipped scene name (paper, bodies_1k, bodies_10k)")
        ->required();
    cmd->add_option("--frames", opts->frames, "Frames to simulate")->check(CLI::Range(0, 100000000));
    cmd->add_option("--every", opts->every, "Print the checksum every K frames")->check(CLI::Range(1, 100000000));
    cmd->add_option("--json", opts->json_path, "Also write the checksums as JSON to this file");
    cmd->callback([opts] { run_sim(*opts); });
}

}  // namespace lockroll::harness
