// No exceptions across per-tick calls, of Session and of RelaySession. Compile time: receive,
// advance, poll, catch_up and next_event are noexcept (this file stops compiling if one loses
// it). Run time: a game whose step(), save(), load() or checksum() throws, bytes that are
// garbage, and input of the wrong size never throw out of the session; what cannot go on
// becomes phase() == Failed with the reason and a `failed` event, for good.
#include <gtest/gtest.h>

#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "rollback/relay_session.h"
#include "rollback/session.h"
#include "rollback/simulation.h"
#include "server/relay_server.h"
#include "sim/rng.h"

namespace lockroll::rollback {
namespace {

static_assert(noexcept(std::declval<Session&>().receive(PlayerId{}, std::span<const std::uint8_t>{}, 0)));
static_assert(noexcept(std::declval<Session&>().advance(std::span<const std::uint8_t>{}, 0)));
static_assert(noexcept(std::declval<Session&>().poll(0, std::declval<std::vector<Datagram>&>())));
static_assert(noexcept(std::declval<Session&>().catch_up(0, 1)));
static_assert(noexcept(std::declval<Session&>().next_event(std::declval<SessionEvent&>())));
static_assert(noexcept(std::declval<RelaySession&>().receive(std::span<const std::uint8_t>{}, 0)));
static_assert(noexcept(std::declval<RelaySession&>().advance(std::span<const std::uint8_t>{}, 0)));
static_assert(noexcept(std::declval<RelaySession&>().poll(0, std::declval<std::vector<Datagram>&>())));
static_assert(noexcept(std::declval<RelaySession&>().catch_up(0, 1)));
static_assert(noexcept(std::declval<RelaySession&>().next_event(std::declval<SessionEvent&>())));

// One counter; the throw_at-th call of one of its functions throws (a game bug lockroll must not
// let escape): step() by default, or save(), load() or checksum().
class Fragile : public Simulation {
public:
    enum class Call { Step, Save, Load, Checksum };
    using Simulation::step;
    void step(std::span<const std::uint8_t> in) override {
        maybe_throw(Call::Step, "step");
        v_ += in[0] + 1u;
    }
    std::size_t state_size() const override { return 8; }
    void save(std::span<std::uint8_t> out) const override {
        maybe_throw(Call::Save, "save");
        for (int i = 0; i < 8; ++i) out[static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(v_ >> (8 * i));
    }
    std::string load(std::span<const std::uint8_t> in) override {
        maybe_throw(Call::Load, "load");
        v_ = 0;
        for (int i = 0; i < 8; ++i) v_ |= std::uint64_t{in[static_cast<std::size_t>(i)]} << (8 * i);
        return {};
    }
    std::uint64_t checksum(std::span<const std::uint8_t> state) const override {
        maybe_throw(Call::Checksum, "checksum");
        return Simulation::checksum(state);
    }
    Call throws_in = Call::Step;
    std::uint64_t throw_at = 0;  // 0: never

private:
    void maybe_throw(Call c, const char* name) const {
        if (c == throws_in && ++calls_ == throw_at)
            throw std::runtime_error(std::string("the game broke at ") + name + " " + std::to_string(calls_));
    }
    mutable std::uint64_t calls_ = 0;
    std::uint64_t v_ = 0;
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

// Issue 21 (the try/catch drift, settled by SessionCore::guarded): the relay session too. Two
// clients play through an in-process RelayServer (no loss, 1 ms away); client 0's game throws
// from `call` at its throw_at-th call. The throw must not escape receive/advance/poll/catch_up
// (they are noexcept: it would terminate the test), and must fail the session once, for good,
// with the message and a `failed` event, while later calls go on quietly.
void relay_game_throws(Fragile::Call call, std::uint64_t throw_at, const std::string& expected) {
    RelaySessionConfig cfg;
    cfg.players = 2;
    cfg.input_size = 1;
    cfg.auto_input_delay = false;
    cfg.input_delay = 0;  // the other's inputs come a tick late: predictions, rollbacks, loads
    cfg.room_id = 7;
    cfg.prediction_window = 8;
    Fragile sims[2];
    sims[0].throws_in = call;
    sims[0].throw_at = throw_at;
    std::vector<std::unique_ptr<RelaySession>> clients;
    for (PlayerId p = 0; p < 2; ++p) {
        cfg.local_slot = p;
        clients.push_back(std::make_unique<RelaySession>(cfg, sims[p]));
    }
    server::RelayServer relay(server::ServerConfig{});
    std::uint64_t now = 1'000'000;
    for (server::ConnectionId c = 1; c <= 2; ++c) relay.on_connect(c, now);
    std::vector<Datagram> out;
    std::vector<server::Outgoing> down;
    bool failed_event = false;
    std::string failure;
    for (int k = 0; k < 600; ++k, now += 16667) {  // 10 s
        for (std::size_t i = 0; i < 2; ++i) {
            RelaySession& s = *clients[i];
            const std::uint8_t in = static_cast<std::uint8_t>((k / 3 + static_cast<int>(i)) % 5);  // mispredicted often
            s.advance(std::span(&in, 1), now);
            if (s.running() && s.behind(now) > 0) s.catch_up(now, 8);
            for (SessionEvent e; s.next_event(e);)
                if (i == 0) failed_event = failed_event || e.kind == SessionEvent::Kind::Failed;
            out.clear();
            s.poll(now, out);
            for (const Datagram& d : out) relay.receive(static_cast<server::ConnectionId>(i + 1), d.bytes, now + 1000);
        }
        relay.tick(now + 1000);
        down.clear();
        relay.take_outgoing(down);
        for (const server::Outgoing& o : down) clients[o.to - 1]->receive(o.bytes, now + 2000);
        // Failed once is failed for good, with the first reason.
        if (clients[0]->phase() == SessionPhase::Failed && failure.empty()) failure = clients[0]->failure();
        if (!failure.empty()) {
            ASSERT_EQ(clients[0]->phase(), SessionPhase::Failed) << "frame step " << k;
            ASSERT_EQ(clients[0]->failure(), failure);
        }
    }
    ASSERT_EQ(clients[0]->phase(), SessionPhase::Failed) << "the game never threw: the test drove too little";
    EXPECT_NE(failure.find(expected), std::string::npos) << failure;
    EXPECT_TRUE(failed_event);
}

TEST(NoThrow, RelayGameThatThrowsInStepFailsTheSessionWithItsMessage) {
    relay_game_throws(Fragile::Call::Step, 30, "advance: the game broke at step 30");
}
TEST(NoThrow, RelayGameThatThrowsInSaveFailsTheSessionWithItsMessage) {
    relay_game_throws(Fragile::Call::Save, 30, "advance: the game broke at save 30");
}
TEST(NoThrow, RelayGameThatThrowsInLoadFailsTheSessionWithItsMessage) {
    relay_game_throws(Fragile::Call::Load, 2, "advance: the game broke at load 2");
}
TEST(NoThrow, RelayGameThatThrowsInChecksumFailsTheSessionWithItsMessage) {
    relay_game_throws(Fragile::Call::Checksum, 30, "advance: the game broke at checksum 30");
}

}  // namespace
}  // namespace lockroll::rollback
