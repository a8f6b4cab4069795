// Replays: every confirmed input of a run plus the checksum of every frame, so the run can be
// re-simulated later and checked frame by frame. The byte layout is docs/replay-format.md.
//
// Contract
//  - A replay is self-contained: it carries the text the simulation was built from (for the
//    World, the scene JSON), so it still verifies after the scene file changed or moved.
//  - Integrity: the header and every block of 256 frames carry their own XXH3-64, so damage is
//    reported with where it is (header, or which block, frames and byte range), and a
//    truncated file is told apart from a corrupted one.
//  - decode_replay never trusts a count or a length: each is range-checked against fixed
//    limits and the bytes present before use; errors name what and the byte offset.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <lockroll/rollback/events.h>
#include <lockroll/rollback/simulation.h>

namespace lockroll::rollback {

inline constexpr std::uint32_t kReplayMagic = 0x5052524Cu;  // bytes "LRRP"
inline constexpr std::uint16_t kReplayVersion = 1;
inline constexpr std::uint32_t kReplayBlockFrames = 256;
inline constexpr std::uint32_t kReplayMaxNameBytes = 4096;
inline constexpr std::uint32_t kReplayMaxSceneBytes = 64u << 20;

struct Replay {
    std::uint32_t players = 0;
    std::uint32_t input_size = 0;
    std::uint32_t tick_rate = 0;
    std::uint64_t initial_checksum = 0;      // frame 0
    std::string scene_name;                  // informational (what the user typed)
    std::string scene_text;                  // what the simulation is rebuilt from
    std::vector<std::uint8_t> inputs;        // frames() * players * input_size
    std::vector<std::uint64_t> checksums;    // checksums[i]: frame i + 1

    std::uint32_t frames() const { return static_cast<std::uint32_t>(checksums.size()); }
    // The inputs of frame i (consumed by the step to frame i + 1).
    std::span<const std::uint8_t> inputs_of(std::uint32_t i) const;
};

std::vector<std::uint8_t> encode_replay(const Replay& replay);

struct ReplayError {
    std::string what;          // names the field or block and the problem
    std::uint64_t offset = 0;  // byte offset in the file where it was found
};

// nullopt on success (out is filled), else what is wrong and where (out is unspecified).
std::optional<ReplayError> decode_replay(std::span<const std::uint8_t> bytes, Replay& out);

// Collects confirmed frames from a session (SessionObserver::on_frame_confirmed) in order.
class ReplayRecorder {
public:
    // header: players, input_size, tick_rate, initial_checksum and scene fields; no frames.
    explicit ReplayRecorder(Replay header);
    // Frames must come as 1, 2, 3, ... (throws std::logic_error otherwise).
    void add(const FrameConfirmed& frame);
    void add(std::uint32_t frame, std::span<const std::uint8_t> inputs, std::uint64_t checksum);
    const Replay& replay() const { return replay_; }

private:
    Replay replay_;
};

struct ReplayMismatch {
    std::uint32_t frame = 0;  // 0: the initial state already differs
    std::uint64_t recorded = 0;
    std::uint64_t replayed = 0;
};

// Re-runs the replay on `sim` (in its initial state, built from the replay's scene) and checks
// every checksum; the first frame that differs, or nullopt when all match. Throws
// std::invalid_argument if the replay's shape does not fit (input_size vs players).
std::optional<ReplayMismatch> verify_replay(const Replay& replay, Simulation& sim);

}  // namespace lockroll::rollback
