// Variable-size state: a game that spawns and despawns saves only the bytes its entities take
// (Simulation::saved_size() below state_size(), the capacity). Two sessions over a lossy link
// roll back across spawns and despawns and confirm the same checksums; the sync test (roll back
// every frame) passes; saved frames really differ in size; and a game that saves more than it
// declared fails the session with a message instead of writing past the buffer or throwing.
#include <gtest/gtest.h>

#include <cstdint>
#include <set>
#include <string>
#include <vector>

#include "rollback/session.h"
#include "rollback/simulation.h"
#include "rollback/sync_test.h"
#include "test_support.h"

namespace lockroll::rollback {
namespace {

// Entities on a line, each (x, vx). Input byte per player: bit 0 spawns one at the player's
// side, bit 1 despawns the oldest. Saved as count (8 bytes) + 16 bytes per entity.
class Spawner : public Simulation {
public:
    static constexpr std::size_t kMaxEntities = 64;
    using Simulation::step;
    void step(std::span<const std::uint8_t> in) override {
        for (std::size_t p = 0; p < in.size(); ++p) {
            if ((in[p] & 1) && e_.size() < kMaxEntities) e_.push_back({static_cast<std::int64_t>(p) * 1000, 7 + static_cast<std::int64_t>(p)});
            if ((in[p] & 2) && !e_.empty()) e_.erase(e_.begin());
        }
        for (auto& [x, vx] : e_) {
            x += vx;
            if (x < 0 || x > 5000) vx = -vx;
        }
    }
    std::size_t state_size() const override { return 8 + 16 * kMaxEntities; }
    std::size_t saved_size() const override { return 8 + 16 * e_.size() + extra_; }
    void save(std::span<std::uint8_t> out) const override {
        put(out, 0, e_.size());
        for (std::size_t i = 0; i < e_.size(); ++i) {
            put(out, 8 + 16 * i, static_cast<std::uint64_t>(e_[i].first));
            put(out, 16 + 16 * i, static_cast<std::uint64_t>(e_[i].second));
        }
        for (std::size_t i = 0; i < extra_; ++i) out[8 + 16 * e_.size() + i] = 0;
    }
    std::string load(std::span<const std::uint8_t> in) override {
        if (in.size() < 8) return "short state";
        const std::uint64_t n = get(in, 0);
        if (n > kMaxEntities || in.size() != 8 + 16 * n) return "state size does not match its entity count";
        e_.resize(n);
        for (std::size_t i = 0; i < n; ++i)
            e_[i] = {static_cast<std::int64_t>(get(in, 8 + 16 * i)), static_cast<std::int64_t>(get(in, 16 + 16 * i))};
        return {};
    }
    std::size_t entities() const { return e_.size(); }
    std::size_t extra_ = 0;  // pretend-bug: bytes beyond the capacity

private:
    static void put(std::span<std::uint8_t> out, std::size_t at, std::uint64_t v) {
        for (int i = 0; i < 8; ++i) out[at + static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(v >> (8 * i));
    }
    static std::uint64_t get(std::span<const std::uint8_t> in, std::size_t at) {
        std::uint64_t v = 0;
        for (int i = 0; i < 8; ++i) v |= std::uint64_t{in[at + static_cast<std::size_t>(i)]} << (8 * i);
        return v;
    }
    std::vector<std::pair<std::int64_t, std::int64_t>> e_;
};

std::uint8_t input_of(PlayerId p, std::uint32_t f) {
    // Spawn in bursts, despawn in others, so the count rises and falls.
    const std::uint32_t phase = (f / 40 + p) % 4;
    return static_cast<std::uint8_t>(phase == 0 && f % 3 == 0 ? 1 : phase == 2 && f % 4 == 0 ? 2 : 0);
}

struct Peer : SessionObserver {
    explicit Peer(SessionConfig c) : session(c, sim, this) {}
    void on_frame_confirmed(const FrameConfirmed& f) override {
        confirmed[f.frame] = f.checksum;
        if (const auto s = session.saved_state(f.frame)) sizes.insert(s->size());
    }
    Spawner sim;
    Session session;
    std::map<std::uint32_t, std::uint64_t> confirmed;
    std::set<std::size_t> sizes;
};

TEST(VariableState, SpawnAndDespawnRollBackAndAgree) {
    testing::NetParams np;
    np.latency_us = 50000;
    np.jitter_us = 20000;
    np.loss_ppm = 100000;
    testing::TestNet net(np, 5);
    SessionConfig c;
    c.input_size = 1;
    c.input_delay = 0;
    std::vector<std::unique_ptr<Peer>> peers;
    for (PlayerId p = 0; p < 2; ++p) {
        c.local_player = p;
        peers.push_back(std::make_unique<Peer>(c));
    }
    std::vector<Datagram> out;
    std::uint64_t now = 1000;
    for (int k = 0; k < 600; ++k, now += 16667) {
        for (PlayerId p = 0; p < 2; ++p) {
            Session& s = peers[p]->session;
            net.deliver(now, [&](PlayerId from, PlayerId to, const std::vector<std::uint8_t>& b, std::uint64_t at) {
                peers[to]->session.receive(from, b, at);
            });
            const std::uint8_t in = input_of(p, s.frame());
            s.advance(std::span(&in, 1), now);
            out.clear();
            s.poll(now, out);
            for (auto& d : out) net.send(p, d.peer, d.bytes, now);
        }
    }
    const std::uint32_t upto = std::min(peers[0]->session.confirmed_frame(), peers[1]->session.confirmed_frame());
    ASSERT_GT(upto, 400u);
    for (std::uint32_t f = 1; f <= upto; ++f) ASSERT_EQ(peers[0]->confirmed.at(f), peers[1]->confirmed.at(f)) << f;
    EXPECT_GT(peers[0]->session.stats().rollbacks, 0u);
    EXPECT_GT(peers[0]->sizes.size(), 5u) << "saved states of many sizes";
    EXPECT_LT(*peers[0]->sizes.rbegin(), peers[0]->sim.state_size());
    EXPECT_EQ(peers[0]->session.stats().oversized_states, 0u);
}

TEST(VariableState, SyncTestRollsBackEveryFrame) {
    Spawner sim;
    SyncTest t(sim, SyncTestConfig{2, 1, 8});
    for (std::uint32_t f = 0; f < 400; ++f) {
        const std::uint8_t in[2] = {input_of(0, f), input_of(1, f)};
        const auto failure = t.advance(in);
        ASSERT_FALSE(failure) << failure->detail;
    }
    EXPECT_GT(sim.entities(), 0u);
}

TEST(VariableState, SavingBeyondTheCapacityFailsTheSessionWithoutThrowing) {
    SessionConfig c;
    c.input_size = 1;
    c.players = 1;
    Spawner sim;
    Session s(c, sim);
    const std::uint8_t spawn = 1;
    s.advance(std::span(&spawn, 1), 1000);
    EXPECT_TRUE(s.running());
    sim.extra_ = sim.state_size();  // the game now claims more than it declared
    AdvanceResult r;
    EXPECT_NO_THROW(r = s.advance(std::span(&spawn, 1), 2000));
    EXPECT_EQ(s.phase(), SessionPhase::Failed);
    EXPECT_NE(s.failure().find("more than its state_size()"), std::string::npos) << s.failure();
    EXPECT_NO_THROW(s.advance(std::span(&spawn, 1), 3000));  // and stays failed, quietly
    // A game that breaks the promise from the start is refused at construction.
    Spawner bad;
    bad.extra_ = bad.state_size();
    EXPECT_THROW(Session(c, bad), std::invalid_argument);
}

}  // namespace
}  // namespace lockroll::rollback
