#include "rollback/sync_test.h"

#include "rollback/snapshot_ring.h"

#include <algorithm>
#include <cinttypes>
#include <cstdio>
#include <stdexcept>

namespace lockroll::rollback {

namespace {
std::size_t slots_for(const SyncTestConfig& c) {
    if (c.check_distance < 1 || c.check_distance > 64) throw std::invalid_argument("check distance must be 1..64");
    return static_cast<std::size_t>(c.check_distance) + 1;
}
}  // namespace

SyncTest::SyncTest(Simulation& sim, const SyncTestConfig& config)
    : sim_(sim),
      config_(config),
      ring_(std::make_unique<SnapshotRing>(slots_for(config), sim.state_size())),
      checksums_(slots_for(config), 0),
      inputs_(slots_for(config) * static_cast<std::size_t>(std::max(config.players, 1)) * config.input_size),
      scratch_(sim.state_size()) {
    if (config.players < 1 || config.input_size < 1) throw std::invalid_argument("players and input size must be >= 1");
    const auto s = sim_.save_to(ring_->slot_for(0));
    ring_->set_used(0, s.size());
    checksums_[0] = sim_.checksum(s);
}

SyncTest::~SyncTest() = default;

std::string SyncTest::describe_difference(std::span<const std::uint8_t> expected,
                                          std::span<const std::uint8_t> actual) const {
    for (std::uint32_t i = 0; i < sim_.body_count(); ++i) {
        for (int f = 0; f < sim_.field_count(); ++f) {
            const std::int64_t a = sim_.field_value(expected, i, f);
            const std::int64_t b = sim_.field_value(actual, i, f);
            if (a != b) {
                char buf[256];
                std::snprintf(buf, sizeof buf, "body %u %s: %" PRId64 " first, %" PRId64 " resimulated", sim_.body_id(i),
                              sim_.field_name(f), a, b);
                return buf;
            }
        }
    }
    const auto it = std::mismatch(expected.begin(), expected.end(), actual.begin(), actual.end());
    if (it.first == expected.end()) return "states equal byte for byte (checksum differs?)";
    return "state bytes differ at offset " + std::to_string(it.first - expected.begin()) +
           (sim_.body_count() ? " (outside the bodies: header)" : "");
}

std::optional<SyncTestFailure> SyncTest::advance(std::span<const std::uint8_t> inputs) {
    const std::size_t frame_bytes = static_cast<std::size_t>(config_.players) * config_.input_size;
    if (inputs.size() != frame_bytes) throw std::invalid_argument("sync test: inputs must be players * input_size bytes");
    const std::size_t slots = checksums_.size();
    // Forward.
    std::copy(inputs.begin(), inputs.end(), inputs_.begin() + static_cast<std::ptrdiff_t>((frame_ % slots) * frame_bytes));
    sim_.step(inputs);
    ++frame_;
    const auto saved = sim_.save_to(ring_->slot_for(frame_));
    ring_->set_used(frame_, saved.size());
    checksums_[frame_ % slots] = sim_.checksum(saved);

    // Roll back and resimulate.
    const std::uint32_t back = std::min<std::uint32_t>(static_cast<std::uint32_t>(config_.check_distance), frame_);
    const std::uint32_t from = frame_ - back;
    const auto start = ring_->find(from);
    if (const std::string err = sim_.load(*start); !err.empty()) {
        SyncTestFailure f{from, from, checksums_[from % slots], 0, "load failed: " + err};
        return f;
    }
    const auto reloaded = sim_.save_to(scratch_);
    if (!std::equal(reloaded.begin(), reloaded.end(), start->begin(), start->end())) {
        return SyncTestFailure{from, from, checksums_[from % slots], sim_.checksum(reloaded),
                               "save after load differs from the saved state: " +
                                   describe_difference(*start, reloaded)};
    }
    for (std::uint32_t f = from; f < frame_; ++f) {
        sim_.step(std::span(inputs_).subspan((f % slots) * frame_bytes, frame_bytes));
        ++resimulated_;
        const auto now = sim_.save_to(scratch_);
        const std::uint64_t actual = sim_.checksum(now);
        const std::uint64_t expected = checksums_[(f + 1) % slots];
        if (actual != expected)
            return SyncTestFailure{f + 1, from, expected, actual, describe_difference(*ring_->find(f + 1), now)};
    }
    return std::nullopt;
}

}  // namespace lockroll::rollback
