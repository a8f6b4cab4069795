// The C ABI (capi/lockroll.h) over net::SessionBuilder and net::NetSession. Every entry point
// catches: no exception crosses into C. The game's callbacks become a rollback::Simulation
// (GameSimulation); the rest is a thin translation of values, and of errors into
// lockroll_status plus a per-thread message.
#include "capi/lockroll.h"

#include <lockroll/version.h>

#include <algorithm>
#include <cstddef>
#include <cstring>
#include <exception>
#include <memory>
#include <new>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "net/peer_runner.h"
#include "net/session_builder.h"
#include "rollback/events.h"
#include "rollback/relay_messages.h"
#include "rollback/session_types.h"
#include "rollback/simulation.h"

namespace {

using namespace lockroll;

thread_local std::string last_error;

lockroll_status fail(lockroll_status status, const char* where, const std::string& what) {
    last_error = std::string(where) + ": " + what;
    return status;
}

// Runs f (which returns a lockroll_status) and turns any exception into a status and a message.
template <class F>
lockroll_status guarded(const char* where, lockroll_status on_error, F&& f) noexcept {
    try {
        return f();
    } catch (const std::bad_alloc&) {
        return fail(LOCKROLL_INTERNAL, where, "out of memory");
    } catch (const std::exception& e) {
        return fail(on_error, where, e.what());
    } catch (...) {
        return fail(LOCKROLL_INTERNAL, where, "an unknown exception (from a callback?)");
    }
}

// The game's callbacks as the Simulation rollback/ steps. save() is asked twice per saved
// frame (saved_size(), then save()); the C callback is called once and its bytes kept until
// the state changes.
class GameSimulation final : public rollback::Simulation {
public:
    GameSimulation(const lockroll_game& game, void* user) : user_(user), scratch_(game.state_size) {
        // Only the fields the caller's struct has whole (struct_size; start() checked it covers
        // the required ones): later ones stay zero. A field cut by a garbled struct_size is
        // not taken (half a function pointer is an address nobody wrote; fuzz/capi_fuzz.cpp),
        // and the desync-report fields are one group, taken only with a whole struct.
        game_ = lockroll_game{};
        std::memcpy(&game_, &game, offsetof(lockroll_game, checksum));
        if (game.struct_size >= offsetof(lockroll_game, checksum) + sizeof game.checksum) game_.checksum = game.checksum;
        if (game.struct_size >= sizeof game_) game_ = game;
        if (game_.field_count > 0)
            for (int i = 0; i < game_.field_count; ++i)
                names_.emplace_back(game_.field_names[i] ? game_.field_names[i] : "");
    }

    void step(std::span<const std::uint8_t> inputs) override {
        status_.assign(players_, static_cast<std::uint8_t>(LOCKROLL_INPUT_CONFIRMED));
        advance(inputs);
    }
    void step(std::span<const std::uint8_t> inputs, std::span<const rollback::InputStatus> status) override {
        status_.resize(status.size());
        for (std::size_t i = 0; i < status.size(); ++i) status_[i] = static_cast<std::uint8_t>(status[i]);
        advance(inputs);
    }
    std::size_t state_size() const override { return game_.state_size; }
    std::size_t saved_size() const override {
        fill();
        return saved_;
    }
    void save(std::span<std::uint8_t> out) const override {
        fill();
        if (const std::size_t n = std::min({saved_, out.size(), scratch_.size()}); n > 0) std::memcpy(out.data(), scratch_.data(), n);
    }
    std::string load(std::span<const std::uint8_t> in) override {
        fresh_ = false;
        const int rc = game_.load(user_, in.data(), in.size());
        if (rc == 0) return {};
        return "the game's load callback refused a state of " + std::to_string(in.size()) + " bytes (returned " +
               std::to_string(rc) + ")";
    }
    std::uint64_t checksum(std::span<const std::uint8_t> state) const override {
        return game_.checksum ? game_.checksum(user_, state.data(), state.size()) : Simulation::checksum(state);
    }
    std::uint32_t body_count() const override { return game_.field_value ? game_.body_count : 0; }
    int field_count() const override { return game_.field_value ? std::max(game_.field_count, 0) : 0; }
    const char* field_name(int field) const override {
        return field >= 0 && static_cast<std::size_t>(field) < names_.size() ? names_[static_cast<std::size_t>(field)].c_str()
                                                                              : Simulation::field_name(field);
    }
    std::int64_t field_value(std::span<const std::uint8_t> state, std::uint32_t index, int field) const override {
        return game_.field_value ? game_.field_value(user_, state.data(), state.size(), index, field) : 0;
    }

    void set_players(std::uint32_t players) { players_ = players; }

private:
    void advance(std::span<const std::uint8_t> inputs) {
        fresh_ = false;
        game_.advance(user_, inputs.data(), inputs.size(), status_.data(), static_cast<std::uint32_t>(status_.size()));
    }
    void fill() const {
        if (fresh_) return;
        saved_ = game_.save(user_, scratch_.data(), scratch_.size());
        fresh_ = true;
    }

    lockroll_game game_{};
    void* user_;
    std::vector<std::string> names_;
    std::vector<std::uint8_t> status_;
    std::uint32_t players_ = 0;
    mutable std::vector<std::uint8_t> scratch_;
    mutable std::size_t saved_ = 0;
    mutable bool fresh_ = false;
};

lockroll_outcome to_c(net::RunOutcome o) {
    switch (o) {
        case net::RunOutcome::Completed: return LOCKROLL_COMPLETED;
        case net::RunOutcome::ConnectTimeout: return LOCKROLL_CONNECT_TIMEOUT;
        case net::RunOutcome::FinishTimeout: return LOCKROLL_FINISH_TIMEOUT;
        case net::RunOutcome::RunTimeout: return LOCKROLL_RUN_TIMEOUT;
        case net::RunOutcome::Failed: return LOCKROLL_FAILED;
        case net::RunOutcome::Stopped: return LOCKROLL_STOPPED;
        case net::RunOutcome::Partitioned: return LOCKROLL_PARTITIONED;
        case net::RunOutcome::ServerLost: return LOCKROLL_SERVER_LOST;
    }
    return LOCKROLL_FAILED;
}

lockroll_event_kind to_c(rollback::SessionEvent::Kind k) {
    using K = rollback::SessionEvent::Kind;
    switch (k) {
        case K::Synchronizing: return LOCKROLL_EVENT_SYNCHRONIZING;
        case K::Synchronized: return LOCKROLL_EVENT_SYNCHRONIZED;
        case K::Refused: return LOCKROLL_EVENT_REFUSED;
        case K::Interrupted: return LOCKROLL_EVENT_INTERRUPTED;
        case K::Resumed: return LOCKROLL_EVENT_RESUMED;
        case K::Disconnected: return LOCKROLL_EVENT_DISCONNECTED;
        case K::Partitioned: return LOCKROLL_EVENT_PARTITIONED;
        case K::NeutralFrom: return LOCKROLL_EVENT_NEUTRAL_FROM;
        case K::Joined: return LOCKROLL_EVENT_JOINED;
        case K::SpectatorJoined: return LOCKROLL_EVENT_SPECTATOR_JOINED;
        case K::SnapshotLoaded: return LOCKROLL_EVENT_SNAPSHOT_LOADED;
        case K::SnapshotRejected: return LOCKROLL_EVENT_SNAPSHOT_REJECTED;
        case K::DesyncDetected: return LOCKROLL_EVENT_DESYNC_DETECTED;
        case K::DesyncRecovered: return LOCKROLL_EVENT_DESYNC_RECOVERED;
        case K::Kicked: return LOCKROLL_EVENT_KICKED;
        case K::Failed: return LOCKROLL_EVENT_FAILED;
        case K::Draining: return LOCKROLL_EVENT_SERVER_DRAINING;
        case K::DesyncReport: return LOCKROLL_EVENT_DESYNC_REPORT;
        case K::ServerLost: return LOCKROLL_EVENT_SERVER_LOST;
        default: return LOCKROLL_EVENT_OTHER;  // a kind newer than the C header
    }
}

lockroll_status slot_ok(const char* where, std::int32_t slot) {
    if (slot < 0 || slot >= rollback::kMaxPlayers)
        return fail(LOCKROLL_INVALID_ARGUMENT, where,
                    "slot must be 0.." + std::to_string(rollback::kMaxPlayers - 1) + ", got " + std::to_string(slot));
    return LOCKROLL_OK;
}

// host must be a non-empty string; port 0 only where it means "any" (listen).
lockroll_status address_ok(const char* where, const char* host, std::uint16_t port, bool port_zero_ok) {
    if (host == nullptr || *host == '\0') return fail(LOCKROLL_INVALID_ARGUMENT, where, "host is NULL or empty");
    if (port == 0 && !port_zero_ok) return fail(LOCKROLL_INVALID_ARGUMENT, where, "port must be 1..65535, got 0");
    return LOCKROLL_OK;
}

}  // namespace

struct lockroll_builder {
    net::SessionBuilder builder;
    std::int32_t players = 2;  // the builder's default
    std::size_t input_size = 0;
    std::uint32_t frames = 0;
    std::uint64_t connect_us = 0, finish_us = 0, run_us = 0;
};

struct lockroll_session {
    std::unique_ptr<GameSimulation> game;     // before net: the session steps it until freed
    std::unique_ptr<net::NetSession> net;
    std::uint32_t frames = 0;
    std::size_t input_bytes = 0;              // input_size * local players
    std::vector<std::uint8_t> input;          // this update()'s local input
    net::InputSource source;
    std::string detail;                       // the last event's, handed out as a C string
    rollback::SessionEvent::Reason reason = rollback::SessionEvent::Reason::None;  // the last event's
    mutable std::string output_error;         // lockroll_output_error()'s, handed out likewise
};

namespace {

// A builder setter: the handle checked, then `set` (which only stores values) under guarded().
template <class F>
lockroll_status with_builder(lockroll_builder* b, const char* where, F&& set) noexcept {
    if (b == nullptr) return fail(LOCKROLL_INVALID_ARGUMENT, where, "builder is NULL");
    return guarded(where, LOCKROLL_INVALID_ARGUMENT, [&] {
        set();
        return LOCKROLL_OK;
    });
}

}  // namespace

#define LOCKROLL_NEED(ptr, where)                                                    \
    do {                                                                             \
        if ((ptr) == nullptr) return fail(LOCKROLL_INVALID_ARGUMENT, where, #ptr " is NULL"); \
    } while (0)

extern "C" {

const char* lockroll_version(void) { return LOCKROLL_VERSION_STRING; }

const char* lockroll_last_error(void) { return last_error.c_str(); }

const char* lockroll_outcome_name(lockroll_outcome outcome) {
    switch (outcome) {
        case LOCKROLL_RUNNING: return "running";
        case LOCKROLL_COMPLETED: return net::outcome_name(net::RunOutcome::Completed);
        case LOCKROLL_CONNECT_TIMEOUT: return net::outcome_name(net::RunOutcome::ConnectTimeout);
        case LOCKROLL_FINISH_TIMEOUT: return net::outcome_name(net::RunOutcome::FinishTimeout);
        case LOCKROLL_RUN_TIMEOUT: return net::outcome_name(net::RunOutcome::RunTimeout);
        case LOCKROLL_FAILED: return net::outcome_name(net::RunOutcome::Failed);
        case LOCKROLL_STOPPED: return net::outcome_name(net::RunOutcome::Stopped);
        case LOCKROLL_PARTITIONED: return net::outcome_name(net::RunOutcome::Partitioned);
        case LOCKROLL_SERVER_LOST: return net::outcome_name(net::RunOutcome::ServerLost);
    }
    return "unknown";
}

const char* lockroll_event_name(lockroll_event_kind kind) {
    // Through to_c(), so the C values need not follow SessionEvent::Kind's order.
    if (kind != LOCKROLL_EVENT_OTHER)
        for (int i = 0; i <= 0xff; ++i) {
            const auto k = static_cast<rollback::SessionEvent::Kind>(i);
            if (to_c(k) == kind) return rollback::event_name(k);
        }
    return "other";
}

lockroll_builder* lockroll_builder_new(void) {
    try {
        return new lockroll_builder();
    } catch (...) {
        fail(LOCKROLL_INTERNAL, "lockroll_builder_new", "out of memory");
        return nullptr;
    }
}

void lockroll_builder_free(lockroll_builder* builder) { delete builder; }

lockroll_status lockroll_builder_players(lockroll_builder* b, std::int32_t players) {
    return with_builder(b, "lockroll_builder_players", [&] {
        b->builder.players(players);
        b->players = players;
    });
}

lockroll_status lockroll_builder_input_size(lockroll_builder* b, std::uint32_t bytes) {
    return with_builder(b, "lockroll_builder_input_size", [&] {
        b->builder.input_size(bytes);
        b->input_size = bytes;
    });
}

lockroll_status lockroll_builder_local_player(lockroll_builder* b, std::int32_t slot) {
    constexpr const char* where = "lockroll_builder_local_player";
    if (slot_ok(where, slot) != LOCKROLL_OK) return LOCKROLL_INVALID_ARGUMENT;
    return with_builder(b, where, [&] { b->builder.local_player(static_cast<rollback::PlayerId>(slot)); });
}

lockroll_status lockroll_builder_remote_player(lockroll_builder* b, std::int32_t slot, const char* host, std::uint16_t port) {
    constexpr const char* where = "lockroll_builder_remote_player";
    if (slot_ok(where, slot) != LOCKROLL_OK || address_ok(where, host, port, false) != LOCKROLL_OK)
        return LOCKROLL_INVALID_ARGUMENT;
    return with_builder(b, where, [&] { b->builder.remote_player(static_cast<rollback::PlayerId>(slot), host, port); });
}

lockroll_status lockroll_builder_server(lockroll_builder* b, const char* host, std::uint16_t port) {
    constexpr const char* where = "lockroll_builder_server";
    if (address_ok(where, host, port, false) != LOCKROLL_OK) return LOCKROLL_INVALID_ARGUMENT;
    return with_builder(b, where, [&] { b->builder.server(host, port); });
}

lockroll_status lockroll_builder_listen(lockroll_builder* b, const char* host, std::uint16_t port) {
    constexpr const char* where = "lockroll_builder_listen";
    if (address_ok(where, host, port, true) != LOCKROLL_OK) return LOCKROLL_INVALID_ARGUMENT;
    return with_builder(b, where, [&] { b->builder.listen(host, port); });
}

lockroll_status lockroll_builder_tick_rate(lockroll_builder* b, std::int32_t hz) {
    return with_builder(b, "lockroll_builder_tick_rate", [&] { b->builder.tick_rate(hz); });
}

lockroll_status lockroll_builder_input_delay(lockroll_builder* b, std::int32_t frames) {
    return with_builder(b, "lockroll_builder_input_delay", [&] { b->builder.input_delay(frames); });
}

lockroll_status lockroll_builder_prediction_window(lockroll_builder* b, std::int32_t frames) {
    return with_builder(b, "lockroll_builder_prediction_window", [&] { b->builder.prediction_window(frames); });
}

lockroll_status lockroll_builder_match_id(lockroll_builder* b, std::uint64_t id) {
    return with_builder(b, "lockroll_builder_match_id", [&] { b->builder.match_id(id); });
}

lockroll_status lockroll_builder_frames(lockroll_builder* b, std::uint32_t frames) {
    return with_builder(b, "lockroll_builder_frames", [&] {
        b->builder.frames(frames);
        b->frames = frames;
    });
}

lockroll_status lockroll_builder_timeouts(lockroll_builder* b, std::uint64_t connect_us, std::uint64_t finish_us,
                                          std::uint64_t run_us) {
    return with_builder(b, "lockroll_builder_timeouts", [&] {
        b->connect_us = connect_us;
        b->finish_us = finish_us;
        b->run_us = run_us;
    });
}

lockroll_status lockroll_builder_disconnect_timeouts(lockroll_builder* b, std::uint64_t interrupt_us,
                                                     std::uint64_t disconnect_us) {
    // The builder's own settings (whole milliseconds, rounded up): one path for C and C++.
    const auto ms = [](std::uint64_t us) { return us / 1000 + (us % 1000 != 0 ? 1 : 0); };
    return with_builder(b, "lockroll_builder_disconnect_timeouts", [&] {
        if (interrupt_us) b->builder.interrupt_timeout(ms(interrupt_us));
        if (disconnect_us) b->builder.disconnect_timeout(ms(disconnect_us));
    });
}

lockroll_status lockroll_builder_spectator(lockroll_builder* b, const char* host, std::uint16_t port, std::int32_t index) {
    constexpr const char* where = "lockroll_builder_spectator";
    if (address_ok(where, host, port, false) != LOCKROLL_OK) return LOCKROLL_INVALID_ARGUMENT;
    if (index < 0) return fail(LOCKROLL_INVALID_ARGUMENT, where, "index " + std::to_string(index) + " must be >= 0");
    return with_builder(b, where, [&] { b->builder.spectator(host, port, index); });
}

lockroll_status lockroll_builder_spectators(lockroll_builder* b, std::int32_t count) {
    constexpr const char* where = "lockroll_builder_spectators";
    if (count < 0) return fail(LOCKROLL_INVALID_ARGUMENT, where, "count " + std::to_string(count) + " must be >= 0");
    return with_builder(b, where, [&] { b->builder.spectators(count); });
}

lockroll_status lockroll_builder_server_spectator(lockroll_builder* b) {
    return with_builder(b, "lockroll_builder_server_spectator", [&] { b->builder.spectator(); });
}

lockroll_status lockroll_builder_connect_token(lockroll_builder* b, const std::uint8_t* token, std::size_t size) {
    constexpr const char* where = "lockroll_builder_connect_token";
    if (token == nullptr) return fail(LOCKROLL_INVALID_ARGUMENT, where, "token is NULL");
    if (size == 0 || size > rollback::kRelayMaxTokenBytes)
        return fail(LOCKROLL_INVALID_ARGUMENT, where,
                    "size " + std::to_string(size) + " must be 1.." + std::to_string(rollback::kRelayMaxTokenBytes));
    return with_builder(b, where, [&] { b->builder.connect_token(std::vector<std::uint8_t>(token, token + size)); });
}

lockroll_status lockroll_builder_join(lockroll_builder* b) {
    return with_builder(b, "lockroll_builder_join", [&] { b->builder.join(); });
}

lockroll_status lockroll_builder_record_replay(lockroll_builder* b, const char* path, const char* scene_text) {
    constexpr const char* where = "lockroll_builder_record_replay";
    if (path == nullptr || *path == 0) return fail(LOCKROLL_INVALID_ARGUMENT, where, "path is NULL or empty");
    return with_builder(b, where, [&] { b->builder.record_replay(path, scene_text ? scene_text : ""); });
}

lockroll_status lockroll_builder_desync_report_dir(lockroll_builder* b, const char* path) {
    constexpr const char* where = "lockroll_builder_desync_report_dir";
    if (path == nullptr || *path == 0) return fail(LOCKROLL_INVALID_ARGUMENT, where, "path is NULL or empty");
    return with_builder(b, where, [&] { b->builder.desync_report_dir(path); });
}

lockroll_session* lockroll_builder_start(const lockroll_builder* b, const lockroll_game* game, void* user) {
    constexpr const char* where = "lockroll_builder_start";
    lockroll_session* out = nullptr;
    const lockroll_status status = [&]() -> lockroll_status {
        LOCKROLL_NEED(b, where);
        LOCKROLL_NEED(game, where);
        if (game->struct_size < offsetof(lockroll_game, checksum))
            return fail(LOCKROLL_INVALID_ARGUMENT, where,
                        "game->struct_size is " + std::to_string(game->struct_size) + ", set it to sizeof(lockroll_game)");
        if (!game->save || !game->load || !game->advance)
            return fail(LOCKROLL_INVALID_ARGUMENT, where, "game->save, game->load and game->advance are required");
        if (game->state_size == 0) return fail(LOCKROLL_INVALID_ARGUMENT, where, "game->state_size must be > 0");
        const bool has_fields = game->struct_size >= sizeof(lockroll_game) && game->field_count > 0;
        if (has_fields && (!game->field_names || !game->field_value))
            return fail(LOCKROLL_INVALID_ARGUMENT, where, "game->field_count > 0 needs field_names and field_value");
        return guarded(where, LOCKROLL_START_FAILED, [&] {
            auto s = std::make_unique<lockroll_session>();
            s->game = std::make_unique<GameSimulation>(*game, user);
            net::SessionBuilder builder = b->builder;
            const lockroll_builder c = *b;
            const auto runner_timeouts = [c](net::RunnerConfig& r) {
                if (c.connect_us) r.connect_timeout_us = c.connect_us;
                if (c.finish_us) r.finish_timeout_us = c.finish_us;
                if (c.run_us) r.run_timeout_us = c.run_us;
            };
            builder.configure([runner_timeouts](rollback::SessionConfig&, net::RunnerConfig& r) { runner_timeouts(r); });
            builder.configure_relay([runner_timeouts](rollback::RelaySessionConfig&, net::RunnerConfig& r) { runner_timeouts(r); });
            s->game->set_players(static_cast<std::uint32_t>(std::max(b->players, 0)));
            s->net = builder.start(*s->game);
            s->frames = b->frames;
            s->input_bytes = b->input_size * s->net->local_slots().size();
            s->input.assign(s->input_bytes, 0);
            s->source = [raw = s.get()](std::uint32_t, std::span<std::uint8_t> bytes) {
                // A spectator has no local input (an empty vector's data() may be NULL).
                if (const std::size_t n = std::min(bytes.size(), raw->input.size()); n > 0) std::memcpy(bytes.data(), raw->input.data(), n);
            };
            out = s.release();
            return LOCKROLL_OK;
        });
    }();
    return status == LOCKROLL_OK ? out : nullptr;
}

void lockroll_session_free(lockroll_session* session) {
    try {
        delete session;
    } catch (...) {  // a callback threw while the session shut down: nothing left to tell
    }
}

lockroll_status lockroll_update(lockroll_session* s, const std::uint8_t* input, std::size_t input_size,
                                lockroll_update_result* out) {
    constexpr const char* where = "lockroll_update";
    LOCKROLL_NEED(s, where);
    if (input_size != s->input_bytes)
        return fail(LOCKROLL_INVALID_ARGUMENT, where,
                    "input is " + std::to_string(input_size) + " bytes, want " + std::to_string(s->input_bytes) +
                        " (input_size per local player)");
    if (input_size > 0 && input == nullptr) return fail(LOCKROLL_INVALID_ARGUMENT, where, "input is NULL");
    return guarded(where, LOCKROLL_INTERNAL, [&] {
        if (input_size > 0) std::memcpy(s->input.data(), input, input_size);
        const net::UpdateResult r = s->net->update(s->source);
        if (out) {
            out->frames = r.frames;
            out->rollback_depth = r.rollback_depth;
            out->interpolation = r.interpolation;
            out->events = static_cast<std::uint32_t>(r.events.size());
            out->outcome = r.outcome ? to_c(*r.outcome) : LOCKROLL_RUNNING;
        }
        return LOCKROLL_OK;
    });
}

void lockroll_wait(const lockroll_session* s) {
    if (s == nullptr) return;
    try {
        s->net->wait();
    } catch (...) {
    }
}

void lockroll_request_stop(lockroll_session* s) {
    if (s) s->net->request_stop();
}

int lockroll_next_event(lockroll_session* s, lockroll_event* out) {
    if (s == nullptr || out == nullptr) {
        fail(LOCKROLL_INVALID_ARGUMENT, "lockroll_next_event", s ? "out is NULL" : "session is NULL");
        return 0;
    }
    int got = 0;
    guarded("lockroll_next_event", LOCKROLL_INTERNAL, [&] {
        rollback::SessionEvent e;
        if (!s->net->next_event(e)) return LOCKROLL_OK;
        out->kind = to_c(e.kind);
        out->player = static_cast<std::int32_t>(e.peer);
        out->frame = e.frame;
        out->at_us = e.at_us;
        s->detail = out->kind == LOCKROLL_EVENT_OTHER ? std::string(rollback::event_name(e.kind)) + ": " + e.detail
                                                      : std::move(e.detail);
        out->detail = s->detail.c_str();
        s->reason = e.reason;
        got = 1;
        return LOCKROLL_OK;
    });
    return got;
}

const char* lockroll_event_reason(const lockroll_session* s) {
    return rollback::reason_name(s ? s->reason : rollback::SessionEvent::Reason::None);
}

lockroll_status lockroll_network_stats(const lockroll_session* s, std::int32_t peer, lockroll_stats* out) {
    constexpr const char* where = "lockroll_network_stats";
    LOCKROLL_NEED(s, where);
    LOCKROLL_NEED(out, where);
    return guarded(where, LOCKROLL_INTERNAL, [&] {
        const bool relay = s->net->through_server();
        const int players = relay ? 0 : s->net->session().config().players;
        if (!relay && (peer < 0 || peer >= players))
            return fail(LOCKROLL_NOT_FOUND, where,
                        "peer " + std::to_string(peer) + " is not a slot (0.." + std::to_string(players - 1) + ")");
        const rollback::NetworkStats n = s->net->network_stats(static_cast<rollback::PlayerId>(relay ? 0 : peer));
        *out = lockroll_stats{};
        out->ping_us = n.ping_us;
        out->jitter_us = n.jitter_us;
        out->frames_behind = n.frames_behind;
        out->send_queue = n.send_queue;
        out->kbps_sent = n.kbps_sent;
        out->kbps_received = n.kbps_received;
        out->interrupted = n.interrupted ? 1 : 0;
        if (!relay) {
            const auto& peers = s->net->session().stats().peers;
            if (static_cast<std::size_t>(peer) < peers.size()) {
                out->bytes_sent = peers[static_cast<std::size_t>(peer)].bytes_sent;
                out->bytes_received = peers[static_cast<std::size_t>(peer)].bytes_received;
            }
        }
        return LOCKROLL_OK;
    });
}

lockroll_status lockroll_confirmed_checksum(const lockroll_session* s, std::uint32_t frame, std::uint64_t* out) {
    constexpr const char* where = "lockroll_confirmed_checksum";
    LOCKROLL_NEED(s, where);
    LOCKROLL_NEED(out, where);
    return guarded(where, LOCKROLL_INTERNAL, [&] {
        const auto c = s->net->confirmed_checksum(frame);
        if (!c) return fail(LOCKROLL_NOT_FOUND, where, "frame " + std::to_string(frame) + " is not confirmed (or too old)");
        *out = *c;
        return LOCKROLL_OK;
    });
}

lockroll_status lockroll_final_checksum(const lockroll_session* s, std::uint64_t* out) {
    constexpr const char* where = "lockroll_final_checksum";
    LOCKROLL_NEED(s, where);
    if (s->frames == 0) return fail(LOCKROLL_NOT_FOUND, where, "no last frame: lockroll_builder_frames was not set");
    return lockroll_confirmed_checksum(s, s->frames, out);
}

std::uint32_t lockroll_frame(const lockroll_session* s) {
    if (s == nullptr) return 0;
    return s->net->through_server() ? s->net->relay_session().frame() : s->net->session().frame();
}

std::uint32_t lockroll_confirmed_frame(const lockroll_session* s) {
    if (s == nullptr) return 0;
    return s->net->through_server() ? s->net->relay_session().confirmed_frame() : s->net->session().confirmed_frame();
}

std::uint16_t lockroll_port(const lockroll_session* s) { return s ? s->net->port() : 0; }

const char* lockroll_output_error(const lockroll_session* s) {
    if (s == nullptr) return "";
    try {
        s->output_error = s->net->output_error();
    } catch (...) {  // out of memory copying a message: say nothing rather than throw
        return "";
    }
    return s->output_error.c_str();
}

}  // extern "C"
