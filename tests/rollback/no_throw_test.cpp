// No exceptions across per-tick calls. Compile time: receive, advance, poll, catch_up and
// next_event are noexcept (this file stops compiling if one loses it). Run time: a game whose
// step() throws, bytes that are garbage, and input of the wrong size never throw out of the
// session; what cannot go on becomes phase() == Failed with the reason and a `failed` event.
#include <gtest/gtest.h>

#include <cstdint>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "rollback/session.h"
#include "rollback/simulation.h"
#include "sim/rng.h"

namespace lockroll::rollback {
namespace {

static_assert(noexcept(std::declval<Session&>().receive(PlayerId{}, std::span<const std::uint8_t>{}, 0)));
static_assert(noexcept(std::declval<Session&>().advance(std::span<const std::uint8_t>{}, 0)));
static_assert(noexcept(std::declval<Session&>().poll(0, std::declval<std::vector<Datagram>&>())));
static_assert(noexcept(std::declval<Session&>().catch_up(0, 1)));
static_assert(noexcept(std::declval<Session&>().next_event(std::declval<SessionEvent&>())));

// One counter; step() throws at a chosen frame (a game bug lockroll must not let escape).
class Fragile : public Simulation {
public:
    using Simulation::step;
    void step(std::span<const std::uint8_t> in) override {
        if (++steps_ == throw_at) throw std::runtime_error("the game broke at step " + std::to_string(steps_));
        v_ += in[0] + 1;
    }
    std::size_t state_size() const override { return 8; }
    void save(std::span<std::uint8_t> out) const override {
        for (int i = 0; i < 8; ++i) out[static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(v_ >> (8 * i));
    }
    std::string load(std::span<const std::uint8_t> in) override {
        v_ = 0;
        for (int i = 0; i < 8; ++i) v_ |= std::uint64_t{in[static_cast<std::size_t>(i)]} << (8 * i);
        return {};
    }
    std::uint64_t throw_at = 0;

private:
    std::uint64_t steps_ = 0, v_ = 0;
};

SessionConfig one_byte(int players) {
    SessionConfig c;
    c.players = players;
    c.input_size = 1;
    return c;
}

TEST(NoThrow, AGameThatThrowsFailsTheSessionWithItsMessage) {
    Fragile sim;
    sim.throw_at = 5;
    Session s(one_byte(1), sim);
    const std::uint8_t in = 1;
    for (int k = 0; k < 10; ++k) s.advance(std::span(&in, 1), 1000 + static_cast<std::uint64_t>(k) * 16667);
    EXPECT_EQ(s.phase(), SessionPhase::Failed);
    EXPECT_NE(s.failure().find("advance: the game broke at step 5"), std::string::npos) << s.failure();
    bool failed_event = false;
    for (SessionEvent e; s.next_event(e);) failed_event = failed_event || e.kind == SessionEvent::Kind::Failed;
    EXPECT_TRUE(failed_event);
    std::vector<Datagram> out;
    s.poll(500000, out);  // still callable, quietly
}

TEST(NoThrow, GarbageAndWrongSizesAreValuesNotExceptions) {
    Fragile sim;
    Session s(one_byte(2), sim);
    sim::SplitMix64 rng(3);
    std::vector<std::uint8_t> junk;
    std::vector<Datagram> out;
    for (int k = 0; k < 2000; ++k) {
        junk.resize(rng.below(600));
        for (auto& b : junk) b = static_cast<std::uint8_t>(rng.below(256));
        if (!junk.empty() && k % 2 == 0) junk[0] = static_cast<std::uint8_t>(1 + rng.below(15));  // plausible kinds
        s.receive(static_cast<PlayerId>(rng.below(4)), junk, 1000 + static_cast<std::uint64_t>(k));
        const std::uint8_t two[2] = {1, 2};
        s.advance(std::span(two, k % 3 == 0 ? 2 : 1), 1000 + static_cast<std::uint64_t>(k));
        out.clear();
        s.poll(1000 + static_cast<std::uint64_t>(k), out);
    }
    EXPECT_NE(s.phase(), SessionPhase::Failed) << s.failure();  // garbage is counted, not fatal
    EXPECT_GT(s.stats().malformed_packets + s.stats().unknown_peer_packets, 0u);
    EXPECT_GT(s.stats().bad_local_inputs, 0u);
}

}  // namespace
}  // namespace lockroll::rollback
