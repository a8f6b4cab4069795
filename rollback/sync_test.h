// Sync-test mode (as in GGPO and GGRS): one process, no network. Every frame is simulated
// forward, then the state from check_distance frames back is loaded and those frames are
// simulated again with the same inputs; every resimulated frame must give the same checksum as
// the first time. This catches what breaks rollback without needing two machines: state that
// save() misses or load() does not restore, hidden dependence on history or on the call order,
// and plain nondeterminism.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <lockroll/rollback/simulation.h>

namespace lockroll::rollback {

class SnapshotRing;  // rollback/snapshot_ring.h (in-tree): held by pointer, so this installed header need not include it

struct SyncTestConfig {
    int players = 2;
    std::size_t input_size = 3;
    int check_distance = 8;  // frames rolled back every frame, 1..64
};

struct SyncTestFailure {
    std::uint32_t frame = 0;          // the frame whose resimulation differed
    std::uint32_t loaded_frame = 0;   // the frame the rollback started from
    std::uint64_t expected = 0;       // checksum the first time
    std::uint64_t actual = 0;         // checksum when resimulated
    std::string detail;               // first differing body and field, when the simulation can tell
};

class SyncTest {
public:
    // The simulation must be in its initial state. Throws std::invalid_argument on a bad config.
    SyncTest(Simulation& sim, const SyncTestConfig& config);
    ~SyncTest();
    SyncTest(const SyncTest&) = delete;
    SyncTest& operator=(const SyncTest&) = delete;

    // Simulates frame() with `inputs` (players * input_size bytes), then rolls back and
    // resimulates. Returns the first discrepancy, if any (the test stops being meaningful then).
    std::optional<SyncTestFailure> advance(std::span<const std::uint8_t> inputs);

    std::uint32_t frame() const { return frame_; }
    std::uint64_t resimulated_frames() const { return resimulated_; }
    std::uint64_t checksum(std::uint32_t frame) const { return checksums_[frame % checksums_.size()]; }

private:
    std::string describe_difference(std::span<const std::uint8_t> expected, std::span<const std::uint8_t> actual) const;

    Simulation& sim_;
    SyncTestConfig config_;
    std::unique_ptr<SnapshotRing> ring_;
    std::vector<std::uint64_t> checksums_;   // by frame % (distance + 1)
    std::vector<std::uint8_t> inputs_;       // by frame % (distance + 1), players * input_size each
    std::vector<std::uint8_t> scratch_;
    std::uint32_t frame_ = 0;
    std::uint64_t resimulated_ = 0;
};

}  // namespace lockroll::rollback
