// Several local players per process (SessionConfig::slot_hosts): one session plays slots 0 and 1
// (a couch), another slot 2, over a lossy in-test network. Every input each process gives for
// its slots must be the confirmed input of that slot and frame on both sides, and the confirmed
// checksums must agree; the guest's stream is authored by its host, never predicted there, and
// goes with its host when the host is dropped.
#include <gtest/gtest.h>

#include <array>
#include <cstdint>
#include <map>
#include <memory>
#include <vector>

#include "rollback/session.h"
#include "rollback/simulation.h"
#include "test_support.h"

namespace lockroll::rollback {
namespace {

// Three integer counters, each mixed with its slot's input byte: any wrong input shows.
class Counters : public Simulation {
public:
    using Simulation::step;
    void step(std::span<const std::uint8_t> inputs) override {
        for (std::size_t s = 0; s < v_.size(); ++s) v_[s] = v_[s] * 31 + inputs[s] + 1;
    }
    std::size_t state_size() const override { return v_.size() * 8; }
    void save(std::span<std::uint8_t> out) const override {
        for (std::size_t s = 0; s < v_.size(); ++s)
            for (int i = 0; i < 8; ++i) out[s * 8 + static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(v_[s] >> (8 * i));
    }
    std::string load(std::span<const std::uint8_t> in) override {
        if (in.size() != state_size()) return "wrong size";
        for (std::size_t s = 0; s < v_.size(); ++s) {
            v_[s] = 0;
            for (int i = 0; i < 8; ++i) v_[s] |= std::uint64_t{in[s * 8 + static_cast<std::size_t>(i)]} << (8 * i);
        }
        return {};
    }

private:
    std::array<std::uint64_t, 3> v_{};
};

// The input a slot plays for a frame: changes often, so a wrong frame or slot shows.
std::uint8_t input_of(PlayerId slot, std::uint32_t frame) {
    return static_cast<std::uint8_t>((frame * 7 + slot * 91 + (frame / 5) * 13) & 0xff);
}

struct Peer : SessionObserver {
    Peer(SessionConfig c) : session(c, sim, this) {}
    void on_frame_confirmed(const FrameConfirmed& f) override {
        confirmed[f.frame] = f.checksum;
        inputs[f.frame - 1].assign(f.inputs.begin(), f.inputs.end());
    }
    void on_frame_simulated(const FrameSimulated& f) override {
        if (f.predicted_mask & guest_mask) ++guest_predicted;
    }
    Counters sim;
    Session session;
    std::map<std::uint32_t, std::uint64_t> confirmed;
    std::map<std::uint32_t, std::vector<std::uint8_t>> inputs;  // frame -> inputs stepping it
    std::uint64_t guest_mask = 0;
    std::uint64_t guest_predicted = 0;
    std::vector<SessionEvent> events;
};

struct Match {
    explicit Match(SessionConfig base, testing::NetParams np = {}) : net(np, 99) {
        base.players = 3;
        base.input_size = 1;
        base.slot_hosts = {0, 0, 2};  // process A: slots 0 and 1; process B: slot 2
        SessionConfig a = base, b = base;
        a.local_player = 0;
        b.local_player = 2;
        peers[0] = std::make_unique<Peer>(a);
        peers[1] = std::make_unique<Peer>(b);
        peers[0]->guest_mask = 1u << 1;
    }
    // Ticks the live processes at 60 Hz for `ticks` ticks (B's clock 3 ms behind A's). A dead
    // process neither ticks nor receives.
    void run(int ticks, bool a_alive = true) {
        for (int k = 0; k < ticks; ++k) {
            for (int i = 0; i < 2; ++i) {
                if (i == 0 && !a_alive) continue;
                const std::uint64_t t = now + (i == 1 ? 3000 : 0);
                Session& s = peers[i]->session;
                net.deliver(t, [&](PlayerId from, PlayerId to, const std::vector<std::uint8_t>& bytes, std::uint64_t at) {
                    const int dest = to == 0 ? 0 : 1;
                    if (dest == 0 && !a_alive) return;
                    peers[dest]->session.receive(from, bytes, at);
                });
                const std::uint32_t f = s.frame() + static_cast<std::uint32_t>(s.input_delay());
                std::vector<std::uint8_t> in;
                for (PlayerId slot : s.local_slots()) in.push_back(input_of(slot, f));
                s.advance(in, t);
                for (SessionEvent e; s.next_event(e);) peers[i]->events.push_back(e);
                out.clear();
                s.poll(t, out);
                for (auto& d : out) net.send(i == 0 ? 0 : 2, d.peer, d.bytes, t);
            }
            now += 16667;
        }
    }
    testing::TestNet net;
    std::array<std::unique_ptr<Peer>, 2> peers;
    std::vector<Datagram> out;
    std::uint64_t now = 1000;
};

void expect_real_inputs_and_equal_checksums(const Match& m, std::uint32_t frames, int delay) {
    for (int i = 0; i < 2; ++i) {
        const Peer& p = *m.peers[i];
        ASSERT_GE(p.session.confirmed_frame(), frames) << "peer " << i;
        for (std::uint32_t f = static_cast<std::uint32_t>(delay); f < frames; ++f) {
            const auto& in = p.inputs.at(f);
            ASSERT_EQ(in.size(), 3u);
            for (PlayerId s = 0; s < 3; ++s) ASSERT_EQ(in[s], input_of(s, f)) << "peer " << i << " slot " << int(s) << " frame " << f;
        }
    }
    for (std::uint32_t f = 1; f <= frames; ++f)
        ASSERT_EQ(m.peers[0]->confirmed.at(f), m.peers[1]->confirmed.at(f)) << "frame " << f;
}

TEST(LocalPlayers, TwoOnACouchAndOneOnlineAgreeInRollback) {
    SessionConfig c;
    c.input_delay = 1;
    c.prediction_window = 8;
    testing::NetParams np;
    np.latency_us = 40000;
    np.jitter_us = 10000;
    np.loss_ppm = 50000;
    Match m(c, np);
    EXPECT_EQ(std::vector<PlayerId>(m.peers[0]->session.local_slots().begin(), m.peers[0]->session.local_slots().end()),
              (std::vector<PlayerId>{0, 1}));
    EXPECT_EQ(m.peers[1]->session.local_slots().size(), 1u);
    m.run(400);
    expect_real_inputs_and_equal_checksums(m, 300, c.input_delay);
    // The host never guesses its guest's input; B had to, and rolled back.
    EXPECT_EQ(m.peers[0]->guest_predicted, 0u);
    EXPECT_GT(m.peers[1]->session.stats().rollbacks, 0u);
    EXPECT_EQ(m.peers[0]->session.stats().malformed_packets + m.peers[1]->session.stats().malformed_packets, 0u);
}

TEST(LocalPlayers, LockstepWithHandshake) {
    SessionConfig c;
    c.input_delay = 4;
    c.prediction_window = 0;
    c.handshake = true;
    Match m(c);
    m.run(300);
    EXPECT_TRUE(m.peers[0]->session.running());
    EXPECT_TRUE(m.peers[1]->session.running());
    expect_real_inputs_and_equal_checksums(m, 200, c.input_delay);
    EXPECT_EQ(m.peers[1]->session.stats().rollbacks, 0u);
}

TEST(LocalPlayers, GuestGoesWithItsHost) {
    SessionConfig c;
    c.interrupt_us = 200000;
    c.disconnect_us = 500000;
    Match m(c);
    m.run(120);
    const std::uint32_t before = m.peers[1]->session.frame();
    ASSERT_GT(before, 100u);
    // A goes silent: B drops slot 0 and its guest 1, then plays on alone with neutral input.
    m.run(120, /*a_alive=*/false);
    const Session& b = m.peers[1]->session;
    EXPECT_EQ(b.slot_state(0), SlotState::Disconnected);
    EXPECT_EQ(b.slot_state(1), SlotState::Disconnected);
    EXPECT_GT(b.frame(), before + 60) << "B plays on without its peer";
    int dropped = 0;
    for (const auto& e : m.peers[1]->events)
        if (e.kind == SessionEvent::Kind::Disconnected) ++dropped;
    EXPECT_EQ(dropped, 2);
}

TEST(LocalPlayers, WrongInputSizeIsCountedNotThrown) {
    Match m(SessionConfig{});
    Session& a = m.peers[0]->session;
    const std::uint8_t one = 0;
    AdvanceResult r;
    EXPECT_NO_THROW(r = a.advance(std::span(&one, 1), 1000));  // A plays two slots: 2 bytes
    EXPECT_FALSE(r.advanced);
    EXPECT_EQ(a.stats().bad_local_inputs, 1u);
    EXPECT_EQ(a.frame(), 0u);
}

TEST(LocalPlayers, BadHostTablesAreRefusedAtConstruction) {
    Counters sim;
    SessionConfig c;
    c.players = 3;
    c.input_size = 1;
    c.slot_hosts = {0, 2, 2};  // a guest's host must be a lower slot
    EXPECT_THROW(Session(c, sim), std::invalid_argument);
    c.slot_hosts = {0, 0};  // one entry per slot
    EXPECT_THROW(Session(c, sim), std::invalid_argument);
    c.slot_hosts = {0, 0, 2};
    c.local_player = 1;  // a guest cannot be the session's own slot
    EXPECT_THROW(Session(c, sim), std::invalid_argument);
}

}  // namespace
}  // namespace lockroll::rollback
