// SessionBuilder beyond slots and addresses (issue 23, "the builder covers the engine"): the
// validation of spectator(), join(), record_replay(), desync_report_dir() and the timeouts, then
// each over ENet on 127.0.0.1 with NetSessions on threads: a spectator follows a match to the
// players' checksums, a planted desync writes both evidence files naming body and field, a
// recorded replay plays back to the final checksum, and a player process restarted with its
// usual settings rejoins by snapshot (before and after the survivor dropped it). A World match
// recorded through the builder plays back in `lockroll replay`.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "builder_test_support.h"
#include "harness/match/match.h"
#include "harness/match/scene_loader.h"
#include "net/peer_runner.h"
#include "net/session_builder.h"
#include "rollback/replay.h"
#include "rollback/simulation.h"
#include "rollback/world_simulation.h"

namespace lockroll::net {
namespace {

namespace fs = std::filesystem;
using Kind = rollback::SessionEvent::Kind;

// Three bodies (one per slot) with two named fields: how many frames it saw and its inputs
// mixed in. The frame number is part of the state, so a planted fault at one frame stays the
// same through rollbacks: plant_at(F) makes this process's body 1 differ from frame F on.
class Tally final : public rollback::Simulation {
public:
    using Simulation::step;
    void plant_at(std::uint64_t frame) { plant_ = frame; }
    void step(std::span<const std::uint8_t> in) override {
        ++frame_;
        for (std::size_t b = 0; b < 3; ++b) {
            count_[b] += 1;
            mix_[b] = mix_[b] * 31 + (b < in.size() ? in[b] : 0) + 1;
        }
        if (frame_ == plant_) mix_[1] ^= 1;
    }
    std::size_t state_size() const override { return 56; }
    void save(std::span<std::uint8_t> out) const override {
        put(out, 0, frame_);
        for (std::size_t b = 0; b < 3; ++b) {
            put(out, 8 + b * 16, count_[b]);
            put(out, 16 + b * 16, mix_[b]);
        }
    }
    std::string load(std::span<const std::uint8_t> in) override {
        if (in.size() != 56) return "expected 56 bytes";
        frame_ = get(in, 0);
        for (std::size_t b = 0; b < 3; ++b) {
            count_[b] = get(in, 8 + b * 16);
            mix_[b] = get(in, 16 + b * 16);
        }
        return {};
    }
    std::uint32_t body_count() const override { return 3; }
    int field_count() const override { return 2; }
    const char* field_name(int f) const override { return f == 0 ? "count" : "mix"; }
    std::int64_t field_value(std::span<const std::uint8_t> s, std::uint32_t body, int f) const override {
        return static_cast<std::int64_t>(get(s, 8 + body * 16 + static_cast<std::size_t>(f) * 8));
    }

private:
    static void put(std::span<std::uint8_t> out, std::size_t at, std::uint64_t v) {
        for (std::size_t i = 0; i < 8; ++i) out[at + i] = static_cast<std::uint8_t>(v >> (8 * i));
    }
    static std::uint64_t get(std::span<const std::uint8_t> in, std::size_t at) {
        std::uint64_t v = 0;
        for (std::size_t i = 0; i < 8; ++i) v |= std::uint64_t{in[at + i]} << (8 * i);
        return v;
    }
    std::uint64_t frame_ = 0;
    std::array<std::uint64_t, 3> count_{}, mix_{};
    std::uint64_t plant_ = 0;
};

std::string start_error(const SessionBuilder& b) { return test_support::start_error<Tally>(b); }

void input_of(rollback::PlayerId slot, std::uint32_t f, std::span<std::uint8_t> out) {
    out[0] = static_cast<std::uint8_t>(f * 5 + slot * 77);
}

using test_support::drain;
using test_support::has;

fs::path scratch(const std::string& name) {
    const fs::path p = fs::path(::testing::TempDir()) / ("builder-engine-" + name);
    fs::remove_all(p);
    return p;
}

// Every run here is bounded: 30 s after synchronizing at most (the builder's default is none).
SessionBuilder bounded(SessionBuilder b) {
    return b.configure([](rollback::SessionConfig&, RunnerConfig& r) { r.run_timeout_us = 30'000'000; });
}

// Two players on ephemeral ports: B binds one, gives it up, and takes it again once A knows it.
struct Pair {
    std::uint16_t port_b = 0;
    std::unique_ptr<NetSession> a, b;
};
Pair start_pair(SessionBuilder base, rollback::Simulation& sim_a, rollback::Simulation& sim_b,
                const std::function<void(SessionBuilder&)>& only_a = {}) {
    Pair p;
    Tally probe;
    p.port_b = SessionBuilder(base).local_player(1).remote_player(0, "127.0.0.1", 1).start(probe)->port();
    SessionBuilder a = SessionBuilder(base).local_player(0).remote_player(1, "127.0.0.1", p.port_b);
    if (only_a) only_a(a);
    p.a = a.start(sim_a);
    p.b = SessionBuilder(base).local_player(1).listen("127.0.0.1", p.port_b).remote_player(0, "127.0.0.1", p.a->port()).start(sim_b);
    return p;
}

TEST(SessionBuilderEngine, SettingsAreCheckedNamingTheSetting) {
    const auto base = [] { return SessionBuilder().players(2).input_size(1); };
    EXPECT_NE(start_error(base().spectators(1).spectator("127.0.0.1", 9).local_player(0))
                  .find("spectator() and local_player() exclude each other"),
              std::string::npos);
    EXPECT_NE(start_error(base().spectators(1).spectator("127.0.0.1", 9).remote_player(1, "127.0.0.1", 8))
                  .find("spectator() and remote_player() exclude each other"),
              std::string::npos);
    EXPECT_NE(start_error(base().spectator("127.0.0.1", 9)).find("spectators(0) admits none"), std::string::npos);
    EXPECT_NE(start_error(base().spectators(2).spectator("127.0.0.1", 9, 2)).find("index must be 0..spectators()-1"),
              std::string::npos);
    EXPECT_NE(start_error(base().spectators(1).spectator("", 9)).find("spectator(): needs a host and a port"),
              std::string::npos);
    EXPECT_NE(start_error(base().spectators(1).spectator("127.0.0.1", 9).join()).find("spectator() and join()"),
              std::string::npos);
    EXPECT_NE(start_error(base().local_player(0).remote_player(1, "127.0.0.1", 9).join().record_replay("x.lrr"))
                  .find("record_replay() with join()"),
              std::string::npos);
    EXPECT_NE(start_error(base().local_player(0).remote_player(1, "127.0.0.1", 9).interrupt_timeout(0))
                  .find("interrupt_timeout(0)"),
              std::string::npos);
    EXPECT_NE(start_error(base().local_player(0).remote_player(1, "127.0.0.1", 9).disconnect_timeout(3'600'001))
                  .find("disconnect_timeout(3600001)"),
              std::string::npos);
    // Consistent with each other: the session config's own check names the field.
    EXPECT_NE(start_error(base().local_player(0).remote_player(1, "127.0.0.1", 9).interrupt_timeout(2000).disconnect_timeout(1000))
                  .find("interrupt_us must be below disconnect_us"),
              std::string::npos);
    // Paths are tried before anything is bound.
    const fs::path dir = scratch("settings");
    fs::create_directories(dir);
    const fs::path file = dir / "a-file";
    std::ofstream(file) << "x";
    EXPECT_NE(start_error(base().local_player(0).remote_player(1, "127.0.0.1", 9).desync_report_dir(file.string()))
                  .find("desync_report_dir(" + file.string() + ")"),
              std::string::npos);
    EXPECT_NE(start_error(base().local_player(0).remote_player(1, "127.0.0.1", 9).record_replay(dir.string()))
                  .find("record_replay(" + dir.string() + "): is a directory"),
              std::string::npos);
    const std::string missing = (dir / "no-such-dir" / "r.lrr").string();
    EXPECT_NE(start_error(base().local_player(0).remote_player(1, "127.0.0.1", 9).record_replay(missing))
                  .find("record_replay(" + missing + "): cannot be written"),
              std::string::npos);
    // Through a server a spectator names no player's address (spectator() alone: the server
    // places it; tests/net/session_builder_relay_test.cpp).
    EXPECT_NE(start_error(base().spectator("127.0.0.1", 9).server("127.0.0.1", 9))
                  .find("spectator(host, port) and server() exclude each other"),
              std::string::npos);
}

TEST(SessionBuilderEngine, SettingsReachTheConfigs) {
    const auto spect = SessionBuilder().players(3).input_size(2).spectators(2).spectator("127.0.0.1", 7100, 1);
    const rollback::SessionConfig s = spect.session_config();
    EXPECT_EQ(s.role, rollback::Role::Spectator);
    EXPECT_EQ(s.local_player, 4);  // players + index: no fake local slot
    EXPECT_EQ(s.max_spectators, 2);
    EXPECT_TRUE(s.handshake);
    const RunnerConfig rc = spect.runner_config();
    ASSERT_EQ(rc.peers.size(), 1u);
    EXPECT_EQ(rc.peers[0].slot, 0);
    EXPECT_EQ(rc.peers[0].port, 7100);

    const auto joiner = SessionBuilder().players(2).input_size(1).local_player(1).remote_player(0, "127.0.0.1", 7000).join()
                            .interrupt_timeout(300).disconnect_timeout(0);
    const rollback::SessionConfig j = joiner.session_config();
    EXPECT_EQ(j.role, rollback::Role::Joiner);
    EXPECT_EQ(j.local_player, 1);
    EXPECT_EQ(j.interrupt_us, 300'000u);
    EXPECT_EQ(j.disconnect_us, 0u);  // never
    // Untouched without the setters: the session's defaults.
    const rollback::SessionConfig d = SessionBuilder().players(2).input_size(1).local_player(0).remote_player(1, "h", 1).session_config();
    EXPECT_EQ(d.role, rollback::Role::Player);
    EXPECT_EQ(d.interrupt_us, rollback::SessionConfig{}.interrupt_us);
    EXPECT_EQ(d.disconnect_us, rollback::SessionConfig{}.disconnect_us);

    const auto relay = SessionBuilder().players(2).input_size(1).local_player(1).server("127.0.0.1", 9).join().disconnect_timeout(2500);
    const rollback::RelaySessionConfig r = relay.relay_config();
    EXPECT_EQ(r.role, rollback::RelayRole::Joiner);
    EXPECT_EQ(r.server_timeout_us, 2'500'000u);
}

// Two players and a spectator that names only slot 0's address and plays no slot.
TEST(SessionBuilderEngine, SpectatorFollowsToThePlayersChecksums) {
    constexpr std::uint32_t kFrames = 300;
    Tally sim_a, sim_b, sim_s;
    const auto base = bounded(SessionBuilder().players(2).input_size(1).spectators(1).frames(kFrames).input_delay(1));
    Pair p = start_pair(base, sim_a, sim_b);
    // Watch the match: no local slot; slot 0's process serves the snapshot and every stream.
    SessionBuilder watch = SessionBuilder().players(2).input_size(1).spectators(1).frames(kFrames);
    watch.spectator("127.0.0.1", p.a->port());
    std::unique_ptr<NetSession> spectator = bounded(watch).start(sim_s);
    EXPECT_TRUE(spectator->local_slots().empty());
    RunOutcome oa{}, ob{}, os{};
    std::thread ta([&] { oa = p.a->run([](std::uint32_t f, std::span<std::uint8_t> o) { input_of(0, f, o); }); });
    std::thread tb([&] { ob = p.b->run([](std::uint32_t f, std::span<std::uint8_t> o) { input_of(1, f, o); }); });
    // No local slot: whatever the input callback writes goes nowhere.
    std::thread ts([&] { os = spectator->run([](std::uint32_t, std::span<std::uint8_t>) {}); });
    ta.join();
    tb.join();
    // The players are done; the spectator has had the last inputs (or gets them now): stop it.
    std::this_thread::sleep_for(std::chrono::milliseconds(500));
    spectator->request_stop();
    ts.join();
    ASSERT_EQ(oa, RunOutcome::Completed) << p.a->session().failure();
    ASSERT_EQ(ob, RunOutcome::Completed) << p.b->session().failure();
    EXPECT_NE(os, RunOutcome::Failed) << spectator->session().failure();
    std::uint32_t snapshot = 0;
    bool loaded = false;
    for (const auto& e : drain(*spectator))
        if (e.kind == Kind::SnapshotLoaded) {
            loaded = true;
            snapshot = e.frame;
        }
    ASSERT_TRUE(loaded) << "the spectator never loaded its host's snapshot";
    bool served = false;
    for (const auto& e : drain(*p.a)) served = served || (e.kind == Kind::SpectatorJoined && e.peer == 2);
    EXPECT_TRUE(served);
    const std::uint32_t last = std::min(spectator->session().confirmed_frame(), kFrames);
    ASSERT_GE(last, snapshot + 60) << "the spectator followed too few frames";
    for (std::uint32_t f = snapshot + 1; f <= last; ++f) {
        const auto cs = spectator->confirmed_checksum(f), ca = p.a->confirmed_checksum(f);
        ASSERT_TRUE(cs && ca) << f;
        ASSERT_EQ(*cs, *ca) << "frame " << f;
    }
}

// The game's own observer sees the session's callbacks next to the builder's.
class Seen final : public rollback::SessionObserver {
public:
    void on_frame_confirmed(const rollback::FrameConfirmed&) override { ++confirmed; }
    void on_desync_report(const rollback::DesyncReport& r) override {
        ++reports;
        body = r.body_id;
        field = r.field_name;
    }
    std::atomic<int> confirmed{0}, reports{0};
    std::uint32_t body = 99;
    std::string field;
};

TEST(SessionBuilderEngine, PlantedDesyncWritesTheEvidenceNamingBodyAndField) {
    constexpr std::uint32_t kFrames = 240;
    const fs::path dir_a = scratch("evidence-a"), dir_b = scratch("evidence-b");
    Tally sim_a, sim_b;
    sim_b.plant_at(50);  // this process's body 1 differs from frame 50 on
    Seen seen_a, seen_b;
    const auto base = bounded(SessionBuilder().players(2).input_size(1).frames(kFrames).input_delay(1));
    Tally probe;
    const std::uint16_t port_b = SessionBuilder(base).local_player(1).remote_player(0, "127.0.0.1", 1).start(probe)->port();
    SessionBuilder builder_a = SessionBuilder(base).local_player(0).remote_player(1, "127.0.0.1", port_b);
    builder_a.desync_report_dir(dir_a.string());  // the evidence file goes here
    builder_a.observer(&seen_a);                  // the game's own SessionObserver
    std::unique_ptr<NetSession> a = builder_a.start(sim_a);
    auto b = SessionBuilder(base).local_player(1).listen("127.0.0.1", port_b).remote_player(0, "127.0.0.1", a->port())
                 .desync_report_dir(dir_b.string()).observer(&seen_b).start(sim_b);
    std::thread ta([&] { a->run([](std::uint32_t f, std::span<std::uint8_t> o) { input_of(0, f, o); }); });
    std::thread tb([&] { b->run([](std::uint32_t f, std::span<std::uint8_t> o) { input_of(1, f, o); }); });
    ta.join();
    tb.join();
    EXPECT_EQ(a->output_error(), "");
    EXPECT_EQ(b->output_error(), "");
    struct Side {
        NetSession& s;
        const fs::path& dir;
        rollback::PlayerId me, peer;
        Seen& seen;
    };
    for (const Side side : {Side{*a, dir_a, 0, 1, seen_a}, Side{*b, dir_b, 1, 0, seen_b}}) {
        SCOPED_TRACE("slot " + std::to_string(side.me));
        const fs::path file = side.dir / ("desync-client" + std::to_string(side.me) + "-peer" + std::to_string(side.peer) + "-frame50.txt");
        ASSERT_TRUE(fs::exists(file)) << "no evidence file " << file;
        std::ifstream in(file);
        std::string first_line;
        std::getline(in, first_line);
        EXPECT_NE(first_line.find("first differing frame 50"), std::string::npos) << first_line;
        EXPECT_NE(first_line.find("body 1 mix"), std::string::npos) << first_line;
        const std::string rest((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
        EXPECT_FALSE(rest.empty()) << "the state is missing from the evidence";
        bool reported = false;
        for (rollback::SessionEvent e; side.s.next_event(e);)
            if (e.kind == rollback::SessionEvent::Kind::DesyncReport) {  // e.detail: body, field, file
                reported = true;
                EXPECT_EQ(e.peer, side.peer);
                EXPECT_EQ(e.frame, 50u);
                EXPECT_NE(e.detail.find("body 1 mix"), std::string::npos) << e.detail;
                EXPECT_NE(e.detail.find("evidence " + file.string()), std::string::npos) << e.detail;
            }
        EXPECT_TRUE(reported) << "no desync_report event";
        EXPECT_EQ(side.seen.reports.load(), 1);
        EXPECT_EQ(side.seen.body, 1u);
        EXPECT_EQ(side.seen.field, "mix");
        EXPECT_GE(side.seen.confirmed.load(), 50);
    }
}

TEST(SessionBuilderEngine, RecordedReplayPlaysBackToTheFinalChecksum) {
    constexpr std::uint32_t kFrames = 180;
    const fs::path dir = scratch("replay");
    fs::create_directories(dir);
    const fs::path path = dir / "match.lrr";
    Tally sim_a, sim_b;
    const auto base = bounded(SessionBuilder().players(2).input_size(1).frames(kFrames).input_delay(1));
    Pair p = start_pair(base, sim_a, sim_b, [&](SessionBuilder& a) { a.record_replay(path.string(), "{\"game\": \"tally\"}"); });
    EXPECT_FALSE(fs::exists(path)) << "start() tries the path but leaves no file";
    RunOutcome oa{}, ob{};
    std::thread ta([&] { oa = p.a->run([](std::uint32_t f, std::span<std::uint8_t> o) { input_of(0, f, o); }); });
    std::thread tb([&] { ob = p.b->run([](std::uint32_t f, std::span<std::uint8_t> o) { input_of(1, f, o); }); });
    ta.join();
    tb.join();
    ASSERT_EQ(oa, RunOutcome::Completed) << p.a->session().failure();
    ASSERT_EQ(ob, RunOutcome::Completed) << p.b->session().failure();
    ASSERT_EQ(p.a->output_error(), "");
    std::ifstream in(path, std::ios::binary);
    const std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    rollback::Replay replay;
    const auto err = rollback::decode_replay(bytes, replay);
    ASSERT_FALSE(err) << err->what << " at " << err->offset;
    EXPECT_EQ(replay.players, 2u);
    EXPECT_EQ(replay.input_size, 1u);
    EXPECT_EQ(replay.scene_text, "{\"game\": \"tally\"}");
    ASSERT_GE(replay.frames(), kFrames);  // every confirmed frame, the lingering ones too
    const auto final_a = p.a->confirmed_checksum(kFrames), final_b = p.b->confirmed_checksum(kFrames);
    ASSERT_TRUE(final_a && final_b);
    EXPECT_EQ(*final_a, *final_b);
    EXPECT_EQ(replay.checksums[kFrames - 1], *final_a);
    // Played back on a fresh game: every frame's checksum again, the last one the match's.
    Tally fresh;
    const auto mismatch = rollback::verify_replay(replay, fresh);
    EXPECT_FALSE(mismatch) << "frame " << mismatch->frame;
    // The inputs are the players' own.
    for (std::uint32_t f = 0; f < kFrames; f += 37) {
        std::array<std::uint8_t, 1> x{}, y{};
        input_of(0, f, x);
        input_of(1, f, y);
        if (f >= 1) {  // frame 0's input (before the delay) is the neutral one
            EXPECT_EQ(replay.inputs_of(f)[0], x[0]) << f;
            EXPECT_EQ(replay.inputs_of(f)[1], y[0]) << f;
        }
    }
}

// The paper scene's World through the builder, recorded with its scene JSON: `lockroll replay`
// (the real program) rebuilds the World from the file alone and finds every checksum again,
// the last one the match's.
TEST(SessionBuilderEngine, LockrollReplayPlaysTheRecordedWorldBack) {
    constexpr std::uint32_t kFrames = 120;
    std::ifstream scene_file(std::string(LOCKROLL_SOURCE_DIR) + "/harness/scenes/paper.json", std::ios::binary);
    const std::string scene_text((std::istreambuf_iterator<char>(scene_file)), std::istreambuf_iterator<char>());
    ASSERT_FALSE(scene_text.empty());
    sim::SceneDesc scene = harness::with_players(harness::parse_scene(scene_text, "paper.json"), 2);
    scene.tick_rate = 60;
    rollback::WorldSimulation sim_a(scene, 2), sim_b(scene, 2);
    const fs::path dir = scratch("world-replay");
    fs::create_directories(dir);
    const fs::path path = dir / "paper.lrr";
    const auto base =
        bounded(SessionBuilder().players(2).input_size(rollback::kWorldInputSize).frames(kFrames).input_delay(1));
    const auto record = [&](SessionBuilder& a) {
        a.record_replay(path.string(), scene_text);  // written when the run ends
    };
    Pair p = start_pair(base, sim_a, sim_b, record);
    // Each player steers: forward and right from the frame number, so bodies move.
    const auto steer = [](rollback::PlayerId slot) {
        return [slot](std::uint32_t f, std::span<std::uint8_t> o) {
            const auto in = rollback::encode_input({static_cast<std::int8_t>(f % 3 == 0 ? 1 : -1),
                                                    static_cast<std::int8_t>(slot == 0 ? 1 : (f / 30) % 2), 0});
            std::copy(in.begin(), in.end(), o.begin());
        };
    };
    RunOutcome oa{}, ob{};
    std::thread ta([&] { oa = p.a->run(steer(0)); });
    std::thread tb([&] { ob = p.b->run(steer(1)); });
    ta.join();
    tb.join();
    ASSERT_EQ(oa, RunOutcome::Completed) << p.a->session().failure();
    ASSERT_EQ(ob, RunOutcome::Completed) << p.b->session().failure();
    ASSERT_EQ(p.a->output_error(), "");
    const std::string command = std::string(LOCKROLL_EXE) + " replay " + path.string() + " 2>&1";
    FILE* out = ::popen(command.c_str(), "r");
    ASSERT_NE(out, nullptr);
    std::string printed;
    std::array<char, 512> buf{};
    while (std::fgets(buf.data(), buf.size(), out)) printed += buf.data();
    const int status = ::pclose(out);
    ASSERT_EQ(status, 0) << printed;
    const auto at = printed.find(" frames: every checksum matches; final ");
    ASSERT_NE(at, std::string::npos) << printed;
    const auto frames_at = printed.rfind(' ', at - 1);
    const auto frames = static_cast<std::uint32_t>(std::stoul(printed.substr(frames_at + 1, at - frames_at - 1)));
    ASSERT_GE(frames, kFrames) << printed;
    const auto last = p.a->confirmed_checksum(frames);
    ASSERT_TRUE(last) << frames;
    char hex[17];
    std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(*last));
    EXPECT_NE(printed.find(std::string("final ") + hex), std::string::npos) << printed;
    EXPECT_EQ(p.b->confirmed_checksum(kFrames), p.a->confirmed_checksum(kFrames));
}

// Slot 1's process is "killed" (destroyed mid-match) and started again with exactly the same
// builder settings; it rejoins by snapshot and the two finish on one checksum.
void restart_rejoins(std::uint64_t disconnect_ms, int down_ms) {
    constexpr std::uint32_t kFrames = 420;
    Tally sim_a, sim_b, sim_b2;
    const auto base = bounded(SessionBuilder().players(2).input_size(1).frames(kFrames).input_delay(1).disconnect_timeout(disconnect_ms));
    Pair p = start_pair(base, sim_a, sim_b);
    const auto b_settings = SessionBuilder(base).local_player(1).listen("127.0.0.1", p.port_b).remote_player(0, "127.0.0.1", p.a->port());
    RunOutcome oa{}, ob{};
    std::thread ta([&] { oa = p.a->run([](std::uint32_t f, std::span<std::uint8_t> o) { input_of(0, f, o); }); });
    // The first process of slot 1 plays in the game's own loop until frame 90, then is gone.
    const auto input_b = [](std::uint32_t f, std::span<std::uint8_t> o) { input_of(1, f, o); };
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
    while (p.b->session().frame() < 90 && std::chrono::steady_clock::now() < deadline) {
        ASSERT_FALSE(p.b->update(input_b).outcome);
        p.b->wait();
    }
    ASSERT_GE(p.b->session().frame(), 90u);
    p.b.reset();
    std::this_thread::sleep_for(std::chrono::milliseconds(down_ms));
    std::unique_ptr<NetSession> b2 = SessionBuilder(b_settings).start(sim_b2);  // its usual settings: no join()
    ob = b2->run(input_b);
    ta.join();
    ASSERT_EQ(oa, RunOutcome::Completed) << p.a->session().failure();
    ASSERT_EQ(ob, RunOutcome::Completed) << b2->session().failure();
    const auto events = drain(*b2);
    EXPECT_FALSE(has(events, Kind::Kicked)) << "the refusal that started the rejoin reached the game";
    EXPECT_FALSE(has(events, Kind::Failed));
    std::uint32_t snapshot = 0;
    for (const auto& e : events)
        if (e.kind == Kind::SnapshotLoaded) snapshot = e.frame;
    ASSERT_GT(snapshot, 90u) << "the restarted process did not rejoin by snapshot";
    EXPECT_EQ(b2->session().config().role, rollback::Role::Joiner);
    const auto a_events = drain(*p.a);
    EXPECT_TRUE(has(a_events, Kind::Disconnected));
    EXPECT_TRUE(has(a_events, Kind::Joined));
    for (std::uint32_t f = snapshot + 1; f <= kFrames; ++f) {
        const auto ca = p.a->confirmed_checksum(f), cb = b2->confirmed_checksum(f);
        ASSERT_TRUE(ca && cb) << f;
        ASSERT_EQ(*ca, *cb) << "frame " << f;
    }
}

// Back before the survivor's disconnect timeout: the survivor tells the new process apart from
// the old one by its hello and drops the old one at once.
TEST(SessionBuilderEngine, RestartedPlayerRejoinsBySnapshotBeforeTheTimeout) { restart_rejoins(5000, 200); }

// Back after the survivor dropped the slot for silence: refused as dropped, it rejoins.
TEST(SessionBuilderEngine, RestartedPlayerRejoinsBySnapshotAfterTheDrop) { restart_rejoins(800, 1500); }

}  // namespace
}  // namespace lockroll::net
