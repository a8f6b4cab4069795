// Writes seed corpora for the fuzz targets from the real encoders, so every target starts from
// valid inputs and mutates its way outward: fuzz_seeds DIR writes DIR/{protocol,session,replay,
// snapshot,relay,token,membership,drop_agreement}/*. The scene corpus is the shipped scenes (scripts/fuzz.sh copies them).
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "fuzz/drop_agreement_fuzz.h"
#include "fuzz/membership_fuzz.h"
#include "fuzz/relay_fuzz.h"
#include "fuzz/token_fuzz.h"
#include "rollback/protocol.h"
#include "rollback/relay_messages.h"
#include "rollback/replay.h"
#include "rollback/world_simulation.h"
#include "tests/rollback/test_support.h"

using namespace lockroll::rollback;
namespace fs = std::filesystem;

namespace {
void put(const fs::path& dir, const std::string& name, const std::vector<std::uint8_t>& bytes) {
    fs::create_directories(dir);
    std::ofstream(dir / name, std::ios::binary).write(reinterpret_cast<const char*>(bytes.data()),
                                                      static_cast<std::streamsize>(bytes.size()));
}

std::vector<std::uint8_t> input_message(int frames, bool time_sync, int checksums) {
    InputMessage m;
    m.ack = 70;
    m.first_frame = 65530;
    m.frame_count = static_cast<std::uint8_t>(frames);
    for (int f = 0; f < frames; ++f) m.inputs.insert(m.inputs.end(), {static_cast<std::uint8_t>(f / 3), 0x81, 0});
    m.has_time_sync = time_sync;
    m.sender_frame = 77;
    m.advantage = -3;
    m.checksum_count = static_cast<std::uint8_t>(checksums);
    for (int i = 0; i < checksums; ++i) {
        m.checksum_frames[i] = static_cast<std::uint16_t>(60 + i);
        m.checksums[i] = 0x9E3779B9u * static_cast<std::uint32_t>(i + 1);
    }
    std::vector<std::uint8_t> out;
    encode(m, 3, out);
    return out;
}
}  // namespace

int main(int argc, char** argv) {
    if (argc != 2) {
        std::fprintf(stderr, "usage: fuzz_seeds DIR\n");
        return 2;
    }
    const fs::path root = argv[1];

    // protocol: [input_size - 1] then one datagram.
    auto with_size = [](std::vector<std::uint8_t> d) {
        d.insert(d.begin(), 2);
        return d;
    };
    put(root / "protocol", "input_ack", with_size(input_message(0, false, 0)));
    put(root / "protocol", "input_runs", with_size(input_message(12, true, 3)));
    put(root / "protocol", "input_one", with_size(input_message(1, false, 1)));
    for (QueryWhat what : {QueryWhat::FrameChecksums, QueryWhat::BodyHashes, QueryWhat::BodyFields}) {
        const std::uint16_t count = what == QueryWhat::BodyFields ? 1 : 4;
        const std::uint32_t start = what == QueryWhat::FrameChecksums ? 0 : 9;
        std::vector<std::uint8_t> q;
        encode(QueryMessage{what, 60, start, count}, q);
        put(root / "protocol", "query" + std::to_string(static_cast<int>(what)), with_size(q));
        ReplyMessage r{what, true, 60, start, count, {}, {}};
        if (what == QueryWhat::BodyFields) r.fields = {1, -2, 3, -4, 5, -6};
        else r.values = {1, 2, 3, 4};
        std::vector<std::uint8_t> rb;
        encode(r, rb);
        put(root / "protocol", "reply" + std::to_string(static_cast<int>(what)), with_size(rb));
        r.available = false;
        rb.clear();
        encode(r, rb);
        put(root / "protocol", "reply_unavailable" + std::to_string(static_cast<int>(what)), with_size(rb));
    }

    // session: scripts of ticks, corrupted ticks, losses and raw datagrams (session_fuzz.cpp),
    // each within its 12 ticks: intact play, the desync and its narrowing, a mix, and peer 1
    // silent to session 0 long enough (5 ticks) for session 0 to vote it gone.
    std::vector<std::uint8_t> ticks(1, 0), desync(1, 1), mixed(1, 0), drop(1, 0);
    for (int i = 0; i < 12; ++i) ticks.push_back(1);
    for (int i = 0; i < 12; ++i) desync.push_back(1);
    for (int i = 0; i < 12; ++i) {
        mixed.push_back(static_cast<std::uint8_t>(1 + i % 3));
        if (i % 3 == 1) mixed.insert(mixed.end(), {static_cast<std::uint8_t>(i), 0x40});
        if (i % 4 == 0) {
            const auto d = input_message(3, true, 1);
            mixed.insert(mixed.end(), {0, 1, static_cast<std::uint8_t>(d.size())});
            mixed.insert(mixed.end(), d.begin(), d.end());
        }
    }
    for (int i = 0; i < 12; ++i) drop.push_back(i >= 1 && i < 7 ? 3 : 1);
    put(root / "session", "ticks", ticks);
    put(root / "session", "desync", desync);
    put(root / "session", "mixed", mixed);
    put(root / "session", "drop", drop);

    // replay: a small synthetic one and a two-block one with a real scene's text.
    for (std::uint32_t frames : {3u, 300u}) {
        Replay r;
        r.players = 2;
        r.input_size = 3;
        r.tick_rate = 60;
        r.initial_checksum = 0x1234;
        r.scene_name = "seed";
        r.scene_text = frames == 3 ? "{}" : R"({"room": {"min": [-1, 0, -1], "max": [1, 2, 1]}})";
        for (std::uint32_t f = 0; f < frames; ++f) {
            r.inputs.insert(r.inputs.end(), {static_cast<std::uint8_t>(f), 1, 2, 3, 4, static_cast<std::uint8_t>(f >> 3)});
            r.checksums.push_back(0xABCDEF00u + f);
        }
        put(root / "replay", "frames" + std::to_string(frames), encode_replay(r));
    }

    // snapshot: the snapshot_fuzz world at frame 0 and after 40 steps.
    WorldSimulation sim(testing::make_scene(2, 6), 2);
    std::vector<std::uint8_t> state(sim.state_size());
    sim.save(state);
    put(root / "snapshot", "frame0", state);
    const std::uint8_t in[6] = {100, 20, 0, 156, 0, 127};
    for (int f = 0; f < 40; ++f) sim.step(in);
    sim.save(state);
    put(root / "snapshot", "frame40", state);
    // relay: two players start a room and play a few frames; a spectator; a bad hello.
    {
        using namespace lockroll::fuzz;
        // Room 7 of 2 players by default; a couch's hello names its further slots (also).
        auto hello = [](int slot, RelayRole role, std::uint64_t room = 7, int players = 2, std::uint16_t also = 0) {
            RelayHello h;
            h.room_id = room;
            h.players = static_cast<std::uint8_t>(players);
            h.input_size = 3;
            h.slot = static_cast<std::uint8_t>(slot);
            h.also_slots = also;
            h.role = role;
            h.incarnation = (room == 7 ? 100 : 200) + static_cast<std::uint64_t>(slot);
            std::vector<std::uint8_t> b;
            encode(h, b);
            return b;
        };
        auto inputs = [](std::uint32_t first, int count, std::uint32_t ack, std::uint16_t slots) {
            RelayInput m;
            m.confirmed_ack = ack;
            m.first_frame = first;
            m.frame_count = static_cast<std::uint8_t>(count);
            m.slots = slots;
            m.inputs.assign(static_cast<std::size_t>(count) * 3 * static_cast<std::size_t>(relay_slot_count(slots)), 0x42);
            std::vector<std::uint8_t> b;
            encode(m, 3, b);
            return b;
        };
        std::vector<std::uint8_t> play;
        relay_op(play, kOpen, 0);
        relay_op(play, kOpen, 1);
        relay_op(play, kDatagram, 0, hello(0, RelayRole::Player));
        relay_op(play, kDatagram, 1, hello(1, RelayRole::Player));
        for (std::uint32_t f = 0; f < 6; f += 2) {
            relay_op(play, kDatagram, 0, inputs(f, 2, f, 0x1));
            relay_op(play, kDatagram, 1, inputs(f, 2, f, 0x2));
            relay_op(play, kTime, 0, {17});
            relay_op(play, kTake, 0);
        }
        put(root / "relay", "two_players", play);
        std::vector<std::uint8_t> watch = play;
        relay_op(watch, kOpen, 2);
        relay_op(watch, kDatagram, 2, hello(0, RelayRole::Spectator));
        RelayForward fwd;
        fwd.slot = 0;
        fwd.payload = {6, 0, 0, 0, 0, 0, 0, 0, 0, 0};
        std::vector<std::uint8_t> fb;
        encode(fwd, fb);
        relay_op(watch, kDatagram, 2, fb);
        relay_op(watch, kTime, 0, {200});
        relay_op(watch, kTake, 0);
        put(root / "relay", "spectator_forward", watch);
        std::vector<std::uint8_t> late = play;
        relay_op(late, kTime, 0, {255});
        relay_op(late, kDatagram, 1, inputs(10000, 3, 0, 0x2));
        relay_op(late, kDatagram, 0, hello(1, RelayRole::Player));
        relay_op(late, kTake, 0);
        put(root / "relay", "late_and_spoof", late);
        // Several local players (wire v3): a couch on connection 0 plays slots 0 and 1 of a
        // 3-player room, connection 1 plays slot 2; both send records; slot 2's connection then
        // sends records naming slot 0 (bad, ignored), and a version-2 hello is refused.
        auto couch_hello = [&](int slot, std::uint16_t also) { return hello(slot, RelayRole::Player, 8, 3, also); };
        std::vector<std::uint8_t> couch;
        relay_op(couch, kOpen, 0);
        relay_op(couch, kOpen, 1);
        relay_op(couch, kDatagram, 0, couch_hello(0, 0x2));
        relay_op(couch, kDatagram, 1, couch_hello(2, 0));
        for (std::uint32_t f = 0; f < 6; f += 2) {
            relay_op(couch, kDatagram, 0, inputs(f, 2, f, 0x3));
            relay_op(couch, kDatagram, 1, inputs(f, 2, f, 0x4));
            relay_op(couch, kTime, 0, {17});
            relay_op(couch, kTake, 0);
        }
        relay_op(couch, kDatagram, 1, inputs(6, 2, 6, 0x1));
        std::vector<std::uint8_t> v2 = couch_hello(1, 0);
        v2[1] = 2;
        v2.erase(v2.begin() + 25, v2.begin() + 27);  // the v2 layout: no also_slots
        relay_op(couch, kOpen, 2);
        relay_op(couch, kDatagram, 2, v2);
        relay_op(couch, kTake, 0);
        put(root / "relay", "couch_and_online", couch);
    }
    // token: grants sealed with the fuzzer's key (a player, a spectator of a 3-player room with
    // an absent slot, one expired at the fuzzer's clock), and a token of another key.
    {
        using namespace lockroll::server;
        ConnectGrant g;
        g.room_id = 7;
        g.client_id = 11;
        g.expires_unix_s = lockroll::fuzz::kFuzzUnixS + 600;
        put(root / "token", "player", seal_token(g, lockroll::fuzz::kFuzzTokenKey));
        ConnectGrant s = g;
        s.role = RelayRole::Spectator;
        s.players = 3;
        s.absent_slots = 0x4;
        put(root / "token", "spectator", seal_token(s, lockroll::fuzz::kFuzzTokenKey));
        ConnectGrant old = g;
        old.expires_unix_s = lockroll::fuzz::kFuzzUnixS - 1;
        put(root / "token", "expired", seal_token(old, lockroll::fuzz::kFuzzTokenKey));
        put(root / "token", "other_key", seal_token(g, new_token_key()));
        ConnectGrant couch = g;  // one connection, slots 0 and 1 (several local players)
        couch.also_slots = 0x2;
        put(root / "token", "couch", seal_token(couch, lockroll::fuzz::kFuzzTokenKey));
    }
    // membership: the cases of docs/sessions.md's Drop section as scripts (fuzz/membership_fuzz.h).
    {
        using namespace lockroll::fuzz;
        // A vote of `a` about slot `b` at the slot's epoch + delta.
        auto vote = [](std::vector<std::uint8_t>& s, Vote v, int voter, int slot, int delta) {
            membership_op(s, kVote, v, static_cast<std::uint8_t>(voter), static_cast<std::uint8_t>(slot),
                          static_cast<std::uint8_t>(128 + delta));
        };
        auto chorus = [](std::vector<std::uint8_t>& s, Vote v, unsigned voters, int slot) {
            membership_op(s, kChorus, v, static_cast<std::uint8_t>(voters), static_cast<std::uint8_t>(slot),
                          static_cast<std::uint8_t>(voters >> 8));
        };
        auto settle = [](std::vector<std::uint8_t>& s) { membership_op(s, kSettle, Vote::None, 0, 0, 0); };
        const fs::path dir = root / "membership";
        // 3 players, one killed: the two survivors drop it, one vote at a time.
        auto three = membership_header(3, 0, false);
        vote(three, Vote::Gone, 0, 2, 1);
        settle(three);
        vote(three, Vote::Gone, 1, 2, 1);
        settle(three);
        put(dir, "three_one_killed", three);
        // 4 players split 2/2: nobody reaches 3; then the heal withdraws the votes.
        auto four = membership_header(4, 0, false);
        chorus(four, Vote::Gone, 0b0011, 2);
        chorus(four, Vote::Gone, 0b0011, 3);
        settle(four);
        membership_op(four, kLocalAll, Vote::None, 0, 0b1100, 0);
        chorus(four, Vote::Runs, 0b0010, 2);
        settle(four);
        put(dir, "four_split_two_two", four);
        // 8 players split 5/3: the five drop the three; the three's votes about the five drop nobody.
        auto eight = membership_header(8, 0, false);
        for (int far : {5, 6, 7}) chorus(eight, Vote::Gone, 0b00011111, far);
        for (int near : {0, 1}) chorus(eight, Vote::Gone, 0b11100000, near);
        settle(eight);
        put(dir, "eight_split_five_three", eight);
        // Two players under each rule: PlayOnAlone drops on one vote, NoDrop never (partitioned).
        for (bool no_drop : {false, true}) {
            auto two = membership_header(2, 0, no_drop);
            membership_op(two, kVoteLocal, Vote::None, 1, 1, 0);
            settle(two);
            membership_op(two, kVoteLocal, Vote::None, 0, 1, 0);
            vote(two, Vote::Gone, 1, 0, 1);
            settle(two);
            put(dir, no_drop ? "two_no_drop" : "two_play_on_alone", two);
        }
        // Slots 0 and 1 on one process (1 a guest of 0), slot 2 alone and local: two voters;
        // votes about the guest do not count, the guest leaves with its host.
        auto guests = membership_header(3, 2, false, 0b010);
        membership_op(guests, kVoteLocal, Vote::None, 1, 1, 0);
        vote(guests, Vote::Gone, 1, 2, 1);
        membership_op(guests, kVoteLocal, Vote::None, 1, 0, 0);
        settle(guests);
        put(dir, "guests", guests);
        // One forged voice, repeated and contradicted; stale epochs; a rejoin in a newer epoch;
        // ids out of range and far out of range.
        auto forged = membership_header(3, 0, false);
        membership_op(forged, kVoteRaw, Vote::Gone, 2, 1, 7);
        membership_op(forged, kVoteRaw, Vote::Gone, 2, 1, 7);
        vote(forged, Vote::Gone, 2, 0, 1);
        settle(forged);
        vote(forged, Vote::Runs, 2, 1, 0);
        vote(forged, Vote::Gone, 3, 1, 1);
        vote(forged, Vote::Gone, 0xF3, 1, 1);
        vote(forged, Vote::Gone, 1, 0xFF, 1);
        chorus(forged, Vote::Gone, 0b011, 2);
        settle(forged);
        vote(forged, Vote::Gone, 2, 1, 1);  // a voter that left
        membership_op(forged, kSet, Vote::None, 1, 2, 0);  // slot 2 handed over: running, one epoch on
        vote(forged, Vote::Gone, 1, 2, -1);  // about its predecessor
        vote(forged, Vote::Gone, 1, 2, 0);   // not newer than the view's
        vote(forged, Vote::Runs, 1, 2, -1);
        vote(forged, Vote::Gone, 1, 2, 1);
        settle(forged);
        put(dir, "forged_stale_rejoin", forged);
        // Issue 21, a kill during a handoff: slot 1 absent, handed over to a joiner (no voter
        // yet), slot 2 silent: the survivor's own vote drops it (the two-player rule); the
        // joiner's handoff lapses (the survivor's vote about it decides too), or it starts.
        auto handoff = membership_header(3, 0, false);
        membership_op(handoff, kSet, Vote::None, 0, 1, 0);     // slot 1 absent
        membership_op(handoff, kSet, Vote::None, 0x81, 1, 0);  // handed over: joining
        vote(handoff, Vote::Gone, 1, 2, 1);                    // the joiner cannot vote yet
        membership_op(handoff, kVoteLocal, Vote::None, 1, 2, 0);
        settle(handoff);
        membership_op(handoff, kSet, Vote::None, 0x40, 1, 0);  // it plays: a voter
        membership_op(handoff, kVoteLocal, Vote::None, 1, 1, 0);
        settle(handoff);
        put(dir, "handoff_kill", handoff);
    }
    // drop_agreement: processes agreeing on a drop, honest and with a hostile one
    // (fuzz/drop_agreement_fuzz.h). None of these may break the target's properties.
    {
        using namespace lockroll::fuzz;
        const fs::path dir = root / "drop_agreement";
        auto vote = [](std::vector<std::uint8_t>& s, AgreeVote v, int voter, int slot, unsigned to = 0xFF) {
            agreement_op(s, kAgreeVote, static_cast<std::uint8_t>(voter), static_cast<std::uint8_t>(slot),
                         static_cast<std::uint8_t>(to), v);
        };
        auto step = [](std::vector<std::uint8_t>& s, int p, bool broadcast = true) {
            agreement_op(s, kAgreeStep, static_cast<std::uint8_t>(p), broadcast ? 1 : 0, 0);
        };
        // Everything in flight is heard, in the order the swaps leave it.
        auto deliver_all = [](std::vector<std::uint8_t>& s, int count) {
            for (int i = 0; i < count; ++i) agreement_op(s, kAgreeDeliver, 0, 0, 0);
        };
        // Processes 0 .. stepping - 1 step and send their reports to every other, heard at once.
        auto round = [&](std::vector<std::uint8_t>& s, int stepping, int players) {
            for (int p = 0; p < stepping; ++p) {
                step(s, p);
                deliver_all(s, players - 1);
            }
        };
        // 3 honest processes, slot 2 killed: 0 and 1 vote it gone and agree.
        auto three = agreement_header(3, kNoHostile);
        vote(three, kAgreeGone, 0, 2, 0b011);
        vote(three, kAgreeGone, 1, 2, 0b011);
        for (int r = 0; r < 3; ++r) round(three, 2, 3);
        agreement_op(three, kAgreeTable, 0, 0, 0b100);  // 2 learns it from 0's table
        step(three, 2);
        put(dir, "three_one_killed", three);
        // 5 honest processes, two proposers for different slots, a report lost and one heard
        // twice, time passing so the outbid one retries.
        auto five = agreement_header(5, kNoHostile, 3);
        for (int v : {0, 1, 2}) vote(five, kAgreeGone, v, 4, 0b11111);
        for (int v : {1, 2, 3}) vote(five, kAgreeGone, v, 0, 0b11111);
        vote(five, kAgreeGone, 0, 3);
        step(five, 0);
        step(five, 1);
        agreement_op(five, kAgreeDeliver, 0, 2, 2);  // lost
        agreement_op(five, kAgreeDeliver, 0, 1, 1);  // stays in flight
        deliver_all(five, 9);
        agreement_op(five, kAgreeTime, 15, 0, 0);
        for (int r = 0; r < 3; ++r) round(five, 5, 5);
        vote(five, kAgreeRuns, 1, 4);  // a vote withdrawn
        agreement_op(five, kAgreeTime, 40, 0, 0);
        for (int r = 0; r < 2; ++r) round(five, 5, 5);
        put(dir, "five_two_proposers", five);
        // 4 processes, 3 hostile: a ballot in 0's name with a huge round naming slot 1, a report
        // of another instance, a drop it claims, its vote about slot 0; then 1 and 2 vote it gone.
        auto hostile = agreement_header(4, 3);
        agreement_op(hostile, kAgreeForge, kForgeProposal, 0x00, 0xFC);  // round 0x3F0 in 0's name
        agreement_op(hostile, kAgreeForge, kForgeProposalSlot, 1, 0);
        agreement_op(hostile, kAgreeForged, 0, 0, 0b0111);
        agreement_op(hostile, kAgreeForge, kForgeInstance, 1, 0);
        agreement_op(hostile, kAgreeForge, kForgeAllBallots, 0xC3, 0xFF);  // the highest ballot, its own name
        agreement_op(hostile, kAgreeForge, kForgeAcceptedSlot, 0, 0);
        agreement_op(hostile, kAgreeForged, 0, 0, 0b0111);
        agreement_op(hostile, kAgreeTable, 3, 0, 129);  // "I dropped slot 0"
        vote(hostile, kAgreeGone, 3, 0, 129);
        deliver_all(hostile, 6);
        for (int v : {1, 2}) vote(hostile, kAgreeGone, v, 3);
        vote(hostile, kAgreeGone, 0, 3);
        for (int r = 0; r < 3; ++r) round(hostile, 3, 4);
        put(dir, "four_hostile_forges", hostile);
    }
    return 0;
}
