// A game with its own state (not sim::World) that only names its fields still gets desyncs
// narrowed to the body and field: Simulation's default body_hash() hashes the named fields.
// The control case (a body_hash that ignores the fields, as the default once did) shows the same
// run cannot get past "all body hashes agree" -- which the report once worded as "the state
// header differs", a lie this default prevents.
#include <gtest/gtest.h>

#define XXH_INLINE_ALL
#include <xxhash.h>

#include <algorithm>
#include <array>
#include <cstdlib>
#include <memory>
#include <vector>

#include "rollback/session.h"
#include "rollback/simulation.h"

namespace lockroll::rollback {
namespace {

// Two-player pong in integers: bodies 0 and 1 are paddles, body 2 the ball; every body has the
// fields x, y, vx, vy. Input: one signed byte per player, the paddle's vertical speed.
class Pong : public Simulation {
public:
    static constexpr int kBodies = 3;
    static constexpr int kFields = 4;
    static constexpr std::int64_t kWidth = 4000, kHeight = 3000, kPaddleHalf = 300;

    Pong() {
        v_ = {{{0, kHeight / 2, 0, 0}, {kWidth, kHeight / 2, 0, 0}, {kWidth / 2, kHeight / 2, 37, 23}}};
    }

    using Simulation::step;  // the status overload forwards here
    void step(std::span<const std::uint8_t> inputs) override {
        for (int p = 0; p < 2; ++p) {
            auto& pad = v_[static_cast<std::size_t>(p)];
            pad[3] = static_cast<std::int8_t>(inputs[static_cast<std::size_t>(p)]);
            pad[1] = std::clamp<std::int64_t>(pad[1] + pad[3], kPaddleHalf, kHeight - kPaddleHalf);
        }
        auto& b = v_[2];
        b[0] += b[2];
        b[1] += b[3];
        if (b[1] < 0 || b[1] > kHeight) b[3] = -b[3];
        if (b[0] <= 0 || b[0] >= kWidth) {
            const auto& pad = v_[b[0] <= 0 ? 0 : 1];
            if (std::abs(b[1] - pad[1]) <= kPaddleHalf) b[2] = -b[2];
            else b = {kWidth / 2, kHeight / 2, -b[2], b[3]};
        }
    }

    std::size_t state_size() const override { return kBodies * kFields * 8; }
    void save(std::span<std::uint8_t> out) const override {
        std::size_t at = 0;
        for (const auto& body : v_)
            for (std::int64_t f : body)
                for (int i = 0; i < 8; ++i) out[at++] = static_cast<std::uint8_t>(static_cast<std::uint64_t>(f) >> (8 * i));
    }
    std::string load(std::span<const std::uint8_t> in) override {
        if (in.size() != state_size()) return "pong state must be " + std::to_string(state_size()) + " bytes";
        for (std::uint32_t b = 0; b < kBodies; ++b)
            for (int f = 0; f < kFields; ++f) v_[b][static_cast<std::size_t>(f)] = field_value(in, b, f);
        return {};
    }

    std::uint32_t body_count() const override { return kBodies; }
    int field_count() const override { return kFields; }
    const char* field_name(int field) const override {
        static constexpr const char* kNames[kFields] = {"x", "y", "vx", "vy"};
        return field >= 0 && field < kFields ? kNames[field] : "?";
    }
    std::int64_t field_value(std::span<const std::uint8_t> state, std::uint32_t index, int field) const override {
        const std::size_t at = (std::size_t{index} * kFields + static_cast<std::size_t>(field)) * 8;
        std::uint64_t v = 0;
        for (int i = 0; i < 8; ++i) v |= std::uint64_t{state[at + static_cast<std::size_t>(i)]} << (8 * i);
        return static_cast<std::int64_t>(v);
    }
    bool flip_bit(std::uint32_t body_id, int field, int bit) override {
        if (body_id >= kBodies || field < 0 || field >= kFields || bit < 0 || bit > 63) return false;
        auto& f = v_[body_id][static_cast<std::size_t>(field)];
        f = static_cast<std::int64_t>(static_cast<std::uint64_t>(f) ^ (std::uint64_t{1} << bit));
        return true;
    }

private:
    std::array<std::array<std::int64_t, kFields>, kBodies> v_{};
};

// The control: a body hash that does not look at the fields (the old default returned 0).
class PongBlindHash : public Pong {
public:
    std::uint64_t body_hash(std::span<const std::uint8_t>, std::uint32_t) const override { return 0; }
};

TEST(DefaultBodyHash, IsXxh3OfTheFieldsLittleEndianSeededWithTheBodyId) {
    Pong pong;
    std::vector<std::uint8_t> state(pong.state_size());
    pong.save(state);
    for (std::uint32_t b = 0; b < Pong::kBodies; ++b) {
        std::vector<std::uint8_t> le;
        for (int f = 0; f < Pong::kFields; ++f) {
            const auto v = static_cast<std::uint64_t>(pong.field_value(state, b, f));
            for (int i = 0; i < 8; ++i) le.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
        }
        EXPECT_EQ(pong.body_hash(state, b), XXH3_64bits_withSeed(le.data(), le.size(), b)) << "body " << b;
    }
    // Paddles 0 and 1 differ only in x; the ball in everything.
    EXPECT_NE(pong.body_hash(state, 0), pong.body_hash(state, 1));
}

TEST(DefaultBodyHash, ChangesWithEveryFieldAndOnlyForThatBody) {
    Pong pong;
    std::vector<std::uint8_t> before(pong.state_size()), after(pong.state_size());
    pong.save(before);
    for (int f = 0; f < Pong::kFields; ++f) {
        Pong flipped;
        ASSERT_TRUE(flipped.flip_bit(2, f, 0));
        flipped.save(after);
        EXPECT_NE(pong.body_hash(before, 2), pong.body_hash(after, 2)) << "field " << f;
        EXPECT_EQ(pong.body_hash(before, 0), pong.body_hash(after, 0));
        EXPECT_EQ(pong.body_hash(before, 1), pong.body_hash(after, 1));
    }
}

TEST(DefaultBodyHash, IsZeroWithoutNamedFields) {
    struct NoFields : Pong {
        int field_count() const override { return 0; }
    } game;
    std::vector<std::uint8_t> state(game.state_size());
    game.save(state);
    EXPECT_EQ(game.body_hash(state, 2), 0u);
}

struct Recorder : SessionObserver {
    void on_desync_report(const DesyncReport& r) override { reports.push_back(r); }
    std::vector<DesyncReport> reports;
};

// Two sessions over a perfect network with one tick of latency; client 1 flips a bit of the
// ball's field `field` when it produces frame 40. Returns each client's reports.
template <class Game>
std::array<std::vector<DesyncReport>, 2> run_pong_with_fault(int field, int bit) {
    std::array<Game, 2> games;
    std::array<Recorder, 2> observers;
    std::array<std::unique_ptr<Session>, 2> sessions;
    for (PlayerId p = 0; p < 2; ++p) {
        SessionConfig cfg;
        cfg.players = 2;
        cfg.local_player = p;
        cfg.input_size = 1;
        cfg.checksum_interval = 5;
        sessions[p] = std::make_unique<Session>(cfg, games[p], &observers[p]);
    }
    EXPECT_EQ(sessions[1]->inject_fault(40, 2, field, bit), "");
    std::vector<Datagram> in_flight, out;
    for (std::uint64_t tick = 0; tick < 300; ++tick) {
        const std::uint64_t now = tick * 16667;
        for (const Datagram& d : in_flight) sessions[d.peer]->receive(d.peer == 0 ? 1 : 0, d.bytes, now);
        in_flight.clear();
        for (PlayerId p = 0; p < 2; ++p) {
            const std::uint8_t input = static_cast<std::uint8_t>((tick / 20 + p) % 2 ? 25 : -25);
            sessions[p]->advance(std::span(&input, 1), now);
            out.clear();
            sessions[p]->poll(now, out);
            for (Datagram& d : out) in_flight.push_back(std::move(d));
        }
    }
    return {observers[0].reports, observers[1].reports};
}

TEST(CustomGameDesync, ReportNamesTheBodyAndTheFieldThatDiverged) {
    const char* names[] = {"x", "y", "vx", "vy"};
    for (int field = 0; field < Pong::kFields; ++field) {
        const auto reports = run_pong_with_fault<Pong>(field, 5);
        for (int c = 0; c < 2; ++c) {
            ASSERT_EQ(reports[c].size(), 1u) << "client " << c << " field " << names[field];
            const DesyncReport& r = reports[c][0];
            EXPECT_EQ(r.outcome, NarrowOutcome::BodyNamed) << r.summary;
            EXPECT_EQ(r.frame, 40u) << r.summary;
            EXPECT_EQ(r.body_id, 2u) << r.summary;
            EXPECT_EQ(r.field, field) << r.summary;
            EXPECT_EQ(r.field_name, names[field]) << r.summary;
            EXPECT_EQ(static_cast<std::uint64_t>(r.local_value ^ r.remote_value), std::uint64_t{1} << 5);
            EXPECT_NE(r.summary.find(std::string("body 2 ") + names[field] + " "), std::string::npos) << r.summary;
        }
    }
}

TEST(CustomGameDesync, ABodyHashBlindToTheFieldsBlamesTheHeader) {
    const auto reports = run_pong_with_fault<PongBlindHash>(3, 5);
    for (int c = 0; c < 2; ++c) {
        ASSERT_EQ(reports[c].size(), 1u) << "client " << c;
        EXPECT_EQ(reports[c][0].outcome, NarrowOutcome::HeaderOnly) << reports[c][0].summary;
        EXPECT_NE(reports[c][0].summary.find("all body hashes agree"), std::string::npos) << reports[c][0].summary;
    }
}

}  // namespace
}  // namespace lockroll::rollback
