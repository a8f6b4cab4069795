// The C ABI (capi/lockroll.h) through liblockroll.so, as a C caller sees it: errors come back as
// statuses with a message naming the setting (never an exception), the event names follow the
// C enumerators, and a 1-player session (no network to wait for) runs the game's callbacks:
// advance() once per frame with the frame's input and status, save() every frame, the final
// checksum of the last frame, events, and the stats' range check.
#include <lockroll/lockroll.h>

#include <gtest/gtest.h>

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <thread>
#include <vector>

namespace {

struct Game {
    std::int64_t value = 0;
    int advances = 0, saves = 0, loads = 0;
    std::uint8_t last_status = 255;
    bool refuse_load = false;
};

std::size_t save(void* user, std::uint8_t* out, std::size_t capacity) {
    auto* g = static_cast<Game*>(user);
    ++g->saves;
    if (capacity < 8) return 0;
    std::memcpy(out, &g->value, 8);
    return 8;
}
int load(void* user, const std::uint8_t* state, std::size_t size) {
    auto* g = static_cast<Game*>(user);
    ++g->loads;
    if (g->refuse_load || size != 8) return 7;
    std::memcpy(&g->value, state, 8);
    return 0;
}
void advance(void* user, const std::uint8_t* inputs, std::size_t size, const std::uint8_t* status, std::uint32_t players) {
    auto* g = static_cast<Game*>(user);
    ++g->advances;
    g->value += 1;
    for (std::size_t i = 0; i < size; ++i) g->value += inputs[i];
    if (players > 0) g->last_status = status[0];
}

lockroll_game callbacks() {
    lockroll_game c{};
    c.struct_size = sizeof c;
    c.state_size = 8;
    c.save = save;
    c.load = load;
    c.advance = advance;
    return c;
}

std::string error() { return lockroll_last_error(); }

// One player (nobody to wait for) at 120 Hz, input size 1, `frames` frames.
lockroll_builder* one_player(std::uint32_t frames) {
    lockroll_builder* b = lockroll_builder_new();
    const bool ok = b && lockroll_builder_players(b, 1) == LOCKROLL_OK && lockroll_builder_input_size(b, 1) == LOCKROLL_OK &&
                    lockroll_builder_local_player(b, 0) == LOCKROLL_OK && lockroll_builder_tick_rate(b, 120) == LOCKROLL_OK &&
                    lockroll_builder_frames(b, frames) == LOCKROLL_OK;
    EXPECT_TRUE(ok) << error();
    return b;
}

TEST(CApi, NullHandlesAndBadValuesAreStatusesNamingWhat) {
    EXPECT_EQ(lockroll_builder_players(nullptr, 2), LOCKROLL_INVALID_ARGUMENT);
    EXPECT_NE(error().find("lockroll_builder_players"), std::string::npos) << error();
    lockroll_builder* b = lockroll_builder_new();
    ASSERT_NE(b, nullptr);
    EXPECT_EQ(lockroll_builder_local_player(b, -1), LOCKROLL_INVALID_ARGUMENT);
    EXPECT_NE(error().find("slot must be"), std::string::npos) << error();
    EXPECT_EQ(lockroll_builder_remote_player(b, 1, nullptr, 7000), LOCKROLL_INVALID_ARGUMENT);
    EXPECT_NE(error().find("host"), std::string::npos) << error();
    EXPECT_EQ(lockroll_builder_remote_player(b, 1, "127.0.0.1", 0), LOCKROLL_INVALID_ARGUMENT);
    EXPECT_NE(error().find("port"), std::string::npos) << error();
    EXPECT_EQ(lockroll_builder_players(b, 2), LOCKROLL_OK);
    lockroll_builder_free(b);
    lockroll_builder_free(nullptr);   // does nothing
    lockroll_session_free(nullptr);
}

TEST(CApi, StartRefusesBadGamesAndBadSlotsWithAMessage) {
    lockroll_builder* b = lockroll_builder_new();
    ASSERT_EQ(lockroll_builder_players(b, 2), LOCKROLL_OK);
    ASSERT_EQ(lockroll_builder_input_size(b, 1), LOCKROLL_OK);
    Game g;
    lockroll_game c = callbacks();
    c.advance = nullptr;
    EXPECT_EQ(lockroll_builder_start(b, &c, &g), nullptr);
    EXPECT_NE(error().find("game->advance"), std::string::npos) << error();
    c = callbacks();
    c.struct_size = 4;
    EXPECT_EQ(lockroll_builder_start(b, &c, &g), nullptr);
    EXPECT_NE(error().find("struct_size"), std::string::npos) << error();
    c = callbacks();
    c.field_count = 2;  // without names or values
    EXPECT_EQ(lockroll_builder_start(b, &c, &g), nullptr);
    EXPECT_NE(error().find("field_count"), std::string::npos) << error();
    // No local slot: the C++ builder's std::invalid_argument comes back as a status, not thrown.
    c = callbacks();
    EXPECT_EQ(lockroll_builder_start(b, &c, &g), nullptr);
    EXPECT_NE(error().find("lockroll_builder_start: SessionBuilder"), std::string::npos) << error();
    EXPECT_EQ(g.advances, 0);
    lockroll_builder_free(b);
}

TEST(CApi, EventNamesFollowTheEnumerators) {
    EXPECT_STREQ(lockroll_event_name(LOCKROLL_EVENT_SYNCHRONIZING), "synchronizing");
    EXPECT_STREQ(lockroll_event_name(LOCKROLL_EVENT_DISCONNECTED), "disconnected");
    EXPECT_STREQ(lockroll_event_name(LOCKROLL_EVENT_DESYNC_DETECTED), "desync");
    EXPECT_STREQ(lockroll_event_name(LOCKROLL_EVENT_FAILED), "failed");
    EXPECT_STREQ(lockroll_event_name(LOCKROLL_EVENT_SERVER_DRAINING), "server_draining");
    EXPECT_STREQ(lockroll_event_name(LOCKROLL_EVENT_DESYNC_REPORT), "desync_report");
    EXPECT_STREQ(lockroll_event_name(LOCKROLL_EVENT_OTHER), "other");
    EXPECT_STREQ(lockroll_outcome_name(LOCKROLL_COMPLETED), "completed");
    EXPECT_STREQ(lockroll_outcome_name(LOCKROLL_RUNNING), "running");
    EXPECT_STREQ(lockroll_outcome_name(LOCKROLL_SERVER_LOST), "server_lost");
    EXPECT_STREQ(lockroll_event_name(LOCKROLL_EVENT_SERVER_LOST), "server_lost");
    EXPECT_STREQ(lockroll_version(), "0.2.0");
}

// One player, 20 frames at 120 Hz: nobody to wait for, so it completes in a fraction of a second.
TEST(CApi, OnePlayerSessionRunsTheCallbacksToTheFinalChecksum) {
    lockroll_builder* b = one_player(20);
    ASSERT_EQ(lockroll_builder_input_delay(b, 2), LOCKROLL_OK);
    ASSERT_EQ(lockroll_builder_timeouts(b, 5000000, 5000000, 10000000), LOCKROLL_OK);
    Game g;
    const lockroll_game c = callbacks();
    lockroll_session* s = lockroll_builder_start(b, &c, &g);
    lockroll_builder_free(b);  // the session does not keep it
    ASSERT_NE(s, nullptr) << error();
    EXPECT_NE(lockroll_port(s), 0);

    std::uint64_t early = 0;
    EXPECT_EQ(lockroll_final_checksum(s, &early), LOCKROLL_NOT_FOUND);
    const std::uint8_t two[2] = {1, 1};
    EXPECT_EQ(lockroll_update(s, two, 2, nullptr), LOCKROLL_INVALID_ARGUMENT);  // one local player: 1 byte
    EXPECT_NE(error().find("want 1"), std::string::npos) << error();

    EXPECT_STREQ(lockroll_event_reason(s), "none") << "no event taken yet";
    EXPECT_STREQ(lockroll_event_reason(nullptr), "none");
    lockroll_update_result r{};
    int ticks = 0, synchronized = 0;
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
    const std::uint8_t press = 2;
    while (std::chrono::steady_clock::now() < deadline) {
        ASSERT_EQ(lockroll_update(s, &press, 1, &r), LOCKROLL_OK) << error();
        ticks += r.frames;
        EXPECT_GE(r.interpolation, 0.0);
        EXPECT_LT(r.interpolation, 1.0);
        lockroll_event e;
        while (lockroll_next_event(s, &e)) {
            ASSERT_NE(e.detail, nullptr);
            if (e.kind != LOCKROLL_EVENT_SYNCHRONIZED) continue;
            ++synchronized;
            EXPECT_STREQ(lockroll_event_reason(s), "handshake") << "started after the handshake, not from a snapshot";
        }
        if (r.outcome != LOCKROLL_RUNNING) break;
        lockroll_wait(s);
    }
    ASSERT_EQ(r.outcome, LOCKROLL_COMPLETED) << lockroll_outcome_name(r.outcome);
    EXPECT_EQ(synchronized, 1);
    EXPECT_GE(ticks, 20);
    EXPECT_EQ(g.advances, 20);            // frames 1..20, no rollback with one player
    // Each frame adds 1 and the press, which (input delay 2) reaches frames 3..20 only.
    EXPECT_EQ(g.value, 20 + 2 * (20 - 2));
    EXPECT_EQ(g.last_status, LOCKROLL_INPUT_CONFIRMED);
    EXPECT_GE(g.saves, 20);
    std::uint64_t last = 0, again = 0;
    ASSERT_EQ(lockroll_final_checksum(s, &last), LOCKROLL_OK) << error();
    ASSERT_EQ(lockroll_confirmed_checksum(s, 20, &again), LOCKROLL_OK);
    EXPECT_EQ(last, again);
    EXPECT_NE(last, 0u);
    EXPECT_EQ(lockroll_confirmed_checksum(s, 5000, &again), LOCKROLL_NOT_FOUND);
    EXPECT_EQ(lockroll_frame(s), 20u);
    lockroll_stats st;
    EXPECT_EQ(lockroll_network_stats(s, 3, &st), LOCKROLL_NOT_FOUND);
    EXPECT_EQ(lockroll_network_stats(s, 0, &st), LOCKROLL_OK);
    lockroll_session_free(s);
}

// Found by fuzz/capi_fuzz.cpp. A C caller may pass any int where an enumeration is expected
// (an enumerator of a newer header): it is a value the library reads and names "unknown".
TEST(CApi, AnyIntForAnEnumerationIsNamedUnknown) {
    const int garbage[] = {-1, 100, 255, 100000, 2147483647};
    for (int v : garbage) {
        EXPECT_STREQ(lockroll_outcome_name(static_cast<lockroll_outcome>(v)), "unknown") << v;
        ASSERT_NE(lockroll_event_name(static_cast<lockroll_event_kind>(v)), nullptr) << v;
    }
}

// Found by fuzz/capi_fuzz.cpp: a struct_size that ends inside a field (a garbled or mistaken
// size) must not hand the library half a function pointer, nor the desync fields without a
// whole struct: the cut field and the later ones read as absent, and the game still runs.
TEST(CApi, AStructSizeThatCutsAFieldTakesNoneOfIt) {
    for (std::size_t cut : {offsetof(lockroll_game, checksum) + 3, offsetof(lockroll_game, field_names) + 1,
                            sizeof(lockroll_game) - 1}) {
        lockroll_builder* b = one_player(3);
        Game g;
        lockroll_game c = callbacks();
        c.struct_size = cut;
        c.checksum = [](void*, const std::uint8_t*, std::size_t) -> std::uint64_t { return 0xbad; };
        c.field_count = 2;  // with no names: taken only from a whole struct, where start() refuses it
        lockroll_session* s = lockroll_builder_start(b, &c, &g);
        lockroll_builder_free(b);
        ASSERT_NE(s, nullptr) << cut << ": " << error();
        lockroll_update_result r{};
        const std::uint8_t press = 0;
        for (int i = 0; i < 20000 && r.outcome == LOCKROLL_RUNNING; ++i) {
            ASSERT_EQ(lockroll_update(s, &press, 1, &r), LOCKROLL_OK);
            lockroll_wait(s);
        }
        EXPECT_EQ(r.outcome, LOCKROLL_COMPLETED) << cut;
        std::uint64_t last = 0;
        ASSERT_EQ(lockroll_final_checksum(s, &last), LOCKROLL_OK);
        // The checksum callback is taken exactly when the struct holds all of it.
        const bool whole = cut >= offsetof(lockroll_game, checksum) + sizeof c.checksum;
        EXPECT_EQ(last == 0xbadu, whole) << cut;
        lockroll_session_free(s);
    }
}

// A custom checksum callback is the one the session confirms.
TEST(CApi, TheGamesChecksumCallbackIsUsed) {
    lockroll_builder* b = one_player(5);
    Game g;
    lockroll_game c = callbacks();
    c.checksum = [](void*, const std::uint8_t* state, std::size_t size) -> std::uint64_t {
        std::int64_t v = 0;
        if (size == 8) std::memcpy(&v, state, 8);
        return 0xabc000 + static_cast<std::uint64_t>(v);
    };
    lockroll_session* s = lockroll_builder_start(b, &c, &g);
    lockroll_builder_free(b);
    ASSERT_NE(s, nullptr) << error();
    lockroll_update_result r{};
    const std::uint8_t press = 0;
    for (int i = 0; i < 20000 && r.outcome == LOCKROLL_RUNNING; ++i) {
        ASSERT_EQ(lockroll_update(s, &press, 1, &r), LOCKROLL_OK);
        lockroll_wait(s);
    }
    ASSERT_EQ(r.outcome, LOCKROLL_COMPLETED);
    std::uint64_t last = 0;
    ASSERT_EQ(lockroll_final_checksum(s, &last), LOCKROLL_OK);
    EXPECT_EQ(last, 0xabc000u + 5u);  // frame 5: value 5
    lockroll_session_free(s);
}

}  // namespace

namespace {

// Runs a session to its end (bounded), with the one local player pressing 1.
lockroll_outcome run_to_end(lockroll_session* s) {
    lockroll_update_result r{};
    const std::uint8_t press = 1;
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
    while (r.outcome == LOCKROLL_RUNNING && std::chrono::steady_clock::now() < deadline) {
        if (lockroll_update(s, &press, 1, &r) != LOCKROLL_OK) return LOCKROLL_FAILED;
        lockroll_wait(s);
    }
    return r.outcome;
}

}  // namespace

// The builder's engine settings (spectator, join, replay, desync reports, timeouts): bad values
// are statuses naming the setting; settings that do not fit together fail the start naming them.
TEST(CApi, EngineSettingsAreCheckedNamingTheSetting) {
    lockroll_builder* b = lockroll_builder_new();
    ASSERT_NE(b, nullptr);
    EXPECT_EQ(lockroll_builder_spectator(b, nullptr, 7000, 0), LOCKROLL_INVALID_ARGUMENT);
    EXPECT_NE(error().find("lockroll_builder_spectator"), std::string::npos) << error();
    EXPECT_EQ(lockroll_builder_spectator(b, "127.0.0.1", 7000, -1), LOCKROLL_INVALID_ARGUMENT);
    EXPECT_NE(error().find("index -1"), std::string::npos) << error();
    EXPECT_EQ(lockroll_builder_spectators(b, -2), LOCKROLL_INVALID_ARGUMENT);
    EXPECT_NE(error().find("count -2"), std::string::npos) << error();
    EXPECT_EQ(lockroll_builder_record_replay(b, nullptr, nullptr), LOCKROLL_INVALID_ARGUMENT);
    EXPECT_NE(error().find("lockroll_builder_record_replay: path"), std::string::npos) << error();
    EXPECT_EQ(lockroll_builder_desync_report_dir(b, ""), LOCKROLL_INVALID_ARGUMENT);
    EXPECT_NE(error().find("lockroll_builder_desync_report_dir: path"), std::string::npos) << error();
    EXPECT_EQ(lockroll_builder_join(nullptr), LOCKROLL_INVALID_ARGUMENT);
    lockroll_builder_free(b);

    Game g;
    const lockroll_game c = callbacks();
    // A spectator of a match that admits none.
    b = lockroll_builder_new();
    ASSERT_EQ(lockroll_builder_input_size(b, 1), LOCKROLL_OK);
    ASSERT_EQ(lockroll_builder_spectator(b, "127.0.0.1", 7000, 0), LOCKROLL_OK);
    EXPECT_EQ(lockroll_builder_start(b, &c, &g), nullptr);
    EXPECT_NE(error().find("spectators(0) admits none"), std::string::npos) << error();
    lockroll_builder_free(b);
    // A joiner has no frames from 1 on to record.
    b = one_player(20);
    ASSERT_EQ(lockroll_builder_join(b), LOCKROLL_OK);
    ASSERT_EQ(lockroll_builder_record_replay(b, "x.lrr", nullptr), LOCKROLL_OK);
    EXPECT_EQ(lockroll_builder_start(b, &c, &g), nullptr);
    EXPECT_NE(error().find("record_replay() with join()"), std::string::npos) << error();
    lockroll_builder_free(b);
    // The timeouts reach the builder's own settings and their check.
    b = one_player(20);
    ASSERT_EQ(lockroll_builder_disconnect_timeouts(b, 2000000, 1000000), LOCKROLL_OK);
    EXPECT_EQ(lockroll_builder_start(b, &c, &g), nullptr);
    EXPECT_NE(error().find("interrupt_us must be below disconnect_us"), std::string::npos) << error();
    lockroll_builder_free(b);
    EXPECT_EQ(g.advances, 0);
}

// Watching through a relay server and connect tokens (issue 23): bad values are statuses naming
// the setting; settings that do not fit together fail the start naming them; a spectator
// through a server starts (nothing listens at the address: it would only say hello) and takes
// an input of 0 bytes.
TEST(CApi, ServerSpectatorAndConnectTokenAreCheckedNamingTheSetting) {
    const std::uint8_t token[3] = {1, 2, 3};
    EXPECT_EQ(lockroll_builder_server_spectator(nullptr), LOCKROLL_INVALID_ARGUMENT);
    EXPECT_NE(error().find("lockroll_builder_server_spectator: builder is NULL"), std::string::npos) << error();
    lockroll_builder* b = lockroll_builder_new();
    ASSERT_NE(b, nullptr);
    EXPECT_EQ(lockroll_builder_connect_token(b, nullptr, 3), LOCKROLL_INVALID_ARGUMENT);
    EXPECT_NE(error().find("lockroll_builder_connect_token: token is NULL"), std::string::npos) << error();
    EXPECT_EQ(lockroll_builder_connect_token(b, token, 0), LOCKROLL_INVALID_ARGUMENT);
    EXPECT_NE(error().find("size 0 must be 1..256"), std::string::npos) << error();
    EXPECT_EQ(lockroll_builder_connect_token(b, token, 257), LOCKROLL_INVALID_ARGUMENT);
    EXPECT_NE(error().find("size 257 must be 1..256"), std::string::npos) << error();
    EXPECT_EQ(lockroll_builder_connect_token(nullptr, token, 3), LOCKROLL_INVALID_ARGUMENT);
    lockroll_builder_free(b);

    Game g;
    const lockroll_game c = callbacks();
    const auto fails_naming = [&](lockroll_builder* builder, const char* what) {
        EXPECT_EQ(lockroll_builder_start(builder, &c, &g), nullptr);
        EXPECT_NE(error().find(what), std::string::npos) << error();
        lockroll_builder_free(builder);
    };
    const auto relay = [] {
        lockroll_builder* r = lockroll_builder_new();
        EXPECT_EQ(lockroll_builder_input_size(r, 1), LOCKROLL_OK);
        EXPECT_EQ(lockroll_builder_server(r, "127.0.0.1", 9), LOCKROLL_OK);
        return r;
    };
    b = relay();
    ASSERT_EQ(lockroll_builder_server_spectator(b), LOCKROLL_OK);
    ASSERT_EQ(lockroll_builder_local_player(b, 0), LOCKROLL_OK);
    fails_naming(b, "spectator() and local_player() exclude each other");
    b = relay();
    ASSERT_EQ(lockroll_builder_server_spectator(b), LOCKROLL_OK);
    ASSERT_EQ(lockroll_builder_spectators(b, 1), LOCKROLL_OK);
    fails_naming(b, "spectators(1) and server() exclude each other");
    b = relay();
    ASSERT_EQ(lockroll_builder_server_spectator(b), LOCKROLL_OK);
    ASSERT_EQ(lockroll_builder_join(b), LOCKROLL_OK);
    fails_naming(b, "spectator() and join() exclude each other");
    // Without a server: nothing to watch through; a token for nobody.
    b = lockroll_builder_new();
    ASSERT_EQ(lockroll_builder_input_size(b, 1), LOCKROLL_OK);
    ASSERT_EQ(lockroll_builder_server_spectator(b), LOCKROLL_OK);
    fails_naming(b, "spectator() without server()");
    b = one_player(20);
    ASSERT_EQ(lockroll_builder_connect_token(b, token, 3), LOCKROLL_OK);
    fails_naming(b, "connect_token() without server()");
    // Accepted: a spectator with a token; no local player, so its input is 0 bytes.
    b = relay();
    ASSERT_EQ(lockroll_builder_server_spectator(b), LOCKROLL_OK);
    ASSERT_EQ(lockroll_builder_connect_token(b, token, 3), LOCKROLL_OK);
    lockroll_session* s = lockroll_builder_start(b, &c, &g);
    lockroll_builder_free(b);
    ASSERT_NE(s, nullptr) << error();
    lockroll_update_result r{};
    EXPECT_EQ(lockroll_update(s, nullptr, 0, &r), LOCKROLL_OK) << error();
    EXPECT_EQ(r.outcome, LOCKROLL_RUNNING);
    const std::uint8_t one = 1;
    EXPECT_EQ(lockroll_update(s, &one, 1, &r), LOCKROLL_INVALID_ARGUMENT);
    EXPECT_NE(error().find("want 0"), std::string::npos) << error();
    lockroll_session_free(s);
    EXPECT_EQ(g.advances, 0);
}

// record_replay through the C ABI: the file is written when the run ends, a replay file
// (docs/replay-format.md: "LRRP" first) with every frame; desync_report_dir is created at start.
TEST(CApi, RecordReplayWritesTheReplayWhenTheRunEnds) {
    const std::filesystem::path dir = std::filesystem::path(::testing::TempDir()) / "capi-engine";
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir);
    const std::string path = (dir / "one.lrr").string();
    const std::string reports = (dir / "reports").string();
    lockroll_builder* b = one_player(20);
    ASSERT_EQ(lockroll_builder_record_replay(b, path.c_str(), "{\"game\": \"counter\"}"), LOCKROLL_OK);
    ASSERT_EQ(lockroll_builder_desync_report_dir(b, reports.c_str()), LOCKROLL_OK);
    Game g;
    const lockroll_game c = callbacks();
    lockroll_session* s = lockroll_builder_start(b, &c, &g);
    lockroll_builder_free(b);
    ASSERT_NE(s, nullptr) << error();
    EXPECT_TRUE(std::filesystem::is_directory(reports));
    EXPECT_FALSE(std::filesystem::exists(path)) << "written before the run ended";
    ASSERT_EQ(run_to_end(s), LOCKROLL_COMPLETED);
    EXPECT_STREQ(lockroll_output_error(s), "");
    std::ifstream in(path, std::ios::binary);
    const std::vector<char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    ASSERT_GT(bytes.size(), 20u * 9u) << "20 frames of 1 input byte and an 8-byte checksum each, at least";
    EXPECT_EQ(std::string(bytes.data(), 4), "LRRP");
    EXPECT_EQ(std::string(bytes.begin(), bytes.end()).find("{\"game\": \"counter\"}") != std::string::npos, true);
    lockroll_session_free(s);
    EXPECT_STREQ(lockroll_output_error(nullptr), "");
}
