#include "harness/replay_command.h"

#include <cstdio>
#include <fstream>
#include <iterator>
#include <memory>
#include <stdexcept>
#include <vector>

#include "harness/match/atomic_file.h"
#include "harness/match/cli_error.h"
#include "harness/match/hex.h"
#include "harness/match/match.h"
#include "harness/match/scene_loader.h"
#include "rollback/world_simulation.h"

namespace lockroll::harness {

namespace {
// The whole file, refusing before reading anything that is not a regular file (a directory,
// /dev/zero, a pipe) or is larger than max_bytes; the read itself also stops at max_bytes, in
// case the file grows or lies about its size (/proc).
std::vector<std::uint8_t> read_all(const std::filesystem::path& path, std::uint64_t max_bytes) {
    namespace fs = std::filesystem;
    std::error_code ec;
    const fs::file_status st = fs::status(path, ec);
    if (!fs::exists(st)) throw UsageError("replay " + path.string() + ": no such file");
    if (fs::is_directory(st)) throw UsageError("replay " + path.string() + ": is a directory, expected a replay file");
    if (!fs::is_regular_file(st)) throw UsageError("replay " + path.string() + ": not a regular file");
    const std::string too_big = "replay " + path.string() + ": larger than " + std::to_string(max_bytes) +
                                " bytes (raise --max-mib to read it)";
    if (const auto size = fs::file_size(path, ec); !ec && size > max_bytes) throw UsageError(too_big);
    std::ifstream in(path, std::ios::binary);
    if (!in) throw UsageError("replay " + path.string() + ": cannot open the file");
    std::vector<std::uint8_t> bytes;
    std::vector<char> chunk(1 << 16);
    while (in) {
        in.read(chunk.data(), static_cast<std::streamsize>(chunk.size()));
        const auto got = static_cast<std::size_t>(in.gcount());
        if (bytes.size() + got > max_bytes) throw UsageError(too_big);
        bytes.insert(bytes.end(), chunk.begin(), chunk.begin() + static_cast<std::ptrdiff_t>(got));
    }
    if (in.bad()) throw UsageError("replay " + path.string() + ": read error");
    return bytes;
}
}  // namespace

std::string scene_text_for_replay(const std::string& name_or_path) {
    std::filesystem::path path;
    try {
        path = resolve_scene(name_or_path);
    } catch (const SceneError& e) {
        throw UsageError(e.what());
    }
    std::ifstream in(path, std::ios::binary);
    if (!in) throw UsageError("scene " + path.string() + ": cannot open the file");
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void write_replay_file(const std::filesystem::path& path, const rollback::Replay& replay) {
    const auto bytes = rollback::encode_replay(replay);
    write_file_atomic(path, std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()));
}

void run_replay(const std::filesystem::path& path, bool quiet, std::uint64_t max_bytes) {
    const std::vector<std::uint8_t> bytes = read_all(path, max_bytes);
    rollback::Replay replay;
    if (const auto err = rollback::decode_replay(bytes, replay))
        throw UsageError("replay " + path.string() + ": byte " + std::to_string(err->offset) + ": " + err->what);
    if (replay.input_size != rollback::kWorldInputSize)
        throw UsageError("replay " + path.string() + ": input_size is " + std::to_string(replay.input_size) +
                         ", the physics world takes " + std::to_string(rollback::kWorldInputSize));
    sim::SceneDesc scene;
    try {
        scene = parse_scene(replay.scene_text, path.string() + " (embedded scene '" + replay.scene_name + "')");
    } catch (const SceneError& e) {
        throw UsageError(e.what());
    }
    // A match adds player bodies when the scene has fewer than its players, and runs the scene
    // at the match's tick rate; rebuild the same world.
    if (replay.players >= 2 && replay.players <= 16) scene = with_players(scene, static_cast<int>(replay.players));
    if (replay.tick_rate >= 1 && replay.tick_rate <= 1000) scene.tick_rate = static_cast<int>(replay.tick_rate);
    rollback::WorldSimulation sim(scene, static_cast<int>(replay.players));
    const auto mismatch = rollback::verify_replay(replay, sim);
    if (mismatch) {
        if (mismatch->frame == 0)
            throw std::runtime_error("replay " + path.string() + ": the initial state differs (recorded " +
                                     hex16(mismatch->recorded) + ", rebuilt " + hex16(mismatch->replayed) +
                                     "): the embedded scene does not produce the recorded world");
        throw std::runtime_error("replay " + path.string() + ": first bad frame " + std::to_string(mismatch->frame) +
                                 " of " + std::to_string(replay.frames()) + ": recorded " +
                                 hex16(mismatch->recorded) + ", replayed " + hex16(mismatch->replayed));
    }
    if (!quiet) {
        const std::uint64_t last = replay.frames() ? replay.checksums.back() : replay.initial_checksum;
        std::printf("replay %s: scene '%s', %u players, %u frames: every checksum matches; final %s\n",
                    path.string().c_str(), replay.scene_name.c_str(), replay.players, replay.frames(),
                    hex16(last).c_str());
    }
}

void add_replay_command(CLI::App& app) {
    struct Options {
        std::string file;
        bool quiet = false;
        std::uint64_t max_mib = kDefaultReplayMaxMiB;
    };
    auto opts = std::make_shared<Options>();
    CLI::App* cmd = app.add_subcommand("replay", "Re-run a replay file and verify the checksum of every frame");
    cmd->add_option("file", opts->file, "Replay file (docs/replay-format.md)")->required();
    cmd->add_flag("--quiet", opts->quiet, "Print nothing on success");
    cmd->add_option("--max-mib", opts->max_mib, "Refuse replay files larger than this many MiB")
        ->check(CLI::Range(std::uint64_t{1}, std::uint64_t{1} << 20))
        ->capture_default_str();
    cmd->callback([opts] { run_replay(opts->file, opts->quiet, opts->max_mib << 20); });
}

}  // namespace lockroll::harness
