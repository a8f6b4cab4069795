// The page's handle on one lockroll match: the functions index.html calls (through emscripten's
// cwrap) to start a match of the paper scene between two clients over the in-page simulated
// network, step it one client tick at a time, and read what each client shows.
//
// Everything here is lockroll::match's Match, the match `lockroll run` plays: same bots, same
// seeded network and clocks, same auto input delay from the same ping phase, so the page's final
// confirmed checksum equals `lockroll run --frames N --seed S ...`'s with the same flags. Doubles
// appear only in what is handed to the page for drawing and in the network conditions (which
// `lockroll run` takes as doubles too). One match at a time; bad arguments return an error text
// (lr_error) instead of throwing into JavaScript.
#include <emscripten/emscripten.h>

#include <cstdint>
#include <cstdio>
#include <exception>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>

#include "harness/match/match.h"
#include "harness/match/scene_loader.h"

namespace {

using lockroll::harness::Match;

std::unique_ptr<Match> g_match;
std::string g_error;
std::string g_text;  // the last string returned to JavaScript (kept alive until the next call)

double metres(lockroll::sim::Fixed f) { return static_cast<double>(f.raw) / 4294967296.0; }

const char* text(std::string s) {
    g_text = std::move(s);
    return g_text.c_str();
}

bool valid_client(int c) { return g_match && c >= 0 && c < g_match->clients(); }

bool valid_body(int c, int i) {
    return valid_client(c) && i >= 0 && static_cast<std::size_t>(i) < g_match->world(c).dynamic_count();
}

const lockroll::sim::Vec3& body_position(int client, int index) {
    const lockroll::sim::World& w = g_match->world(client);
    return w.position(w.dynamic_ids()[static_cast<std::size_t>(index)]);
}

const lockroll::harness::FrameRow& row(int r) {
    static const lockroll::harness::FrameRow none;
    if (!g_match || r < 0 || static_cast<std::size_t>(r) >= g_match->rows().size()) return none;
    return g_match->rows()[static_cast<std::size_t>(r)];
}

}  // namespace

extern "C" {

// Starts a new match (replacing any running one): the paper scene (embedded at /scenes), two
// clients with random bots, auto input delay. Returns 1, or 0 with lr_error() saying why.
EMSCRIPTEN_KEEPALIVE int lr_start(int lockstep, double latency_ms, double jitter_ms, double loss, double seed,
                                  int frames) {
    g_match.reset();
    try {
        lockroll::harness::RunConfig c;
        c.scene = lockroll::harness::load_scene_file("/scenes/paper.json");
        c.mode = lockstep ? lockroll::harness::Mode::Lockstep : lockroll::harness::Mode::Rollback;
        c.frames = frames;
        c.net.latency_ms = latency_ms;
        c.net.jitter_ms = jitter_ms;
        c.net.loss = loss;
        // A JavaScript number holds integers exactly up to 2^53.
        if (!(seed >= 0 && seed <= 9007199254740991.0) || static_cast<double>(static_cast<std::uint64_t>(seed)) != seed)
            throw std::invalid_argument("seed must be an integer 0..2^53-1");
        c.seed = static_cast<std::uint64_t>(seed);
        g_match = std::make_unique<Match>(c);
        return 1;
    } catch (const std::exception& e) {
        g_error = e.what();
        return 0;
    }
}

EMSCRIPTEN_KEEPALIVE const char* lr_error() { return g_error.c_str(); }

// New latency, jitter and loss for datagrams sent from now on. Returns 1, or 0 (lr_error).
EMSCRIPTEN_KEEPALIVE int lr_set_conditions(double latency_ms, double jitter_ms, double loss) {
    if (!g_match) return 0;
    try {
        g_match->set_conditions({latency_ms, jitter_ms, loss, 0, 0, 0});
        return 1;
    } catch (const std::exception& e) {
        g_error = e.what();
        return 0;
    }
}

// Virtual time is in milliseconds since the match started (after its ping phase).
EMSCRIPTEN_KEEPALIVE double lr_next_tick_ms() {
    return g_match ? static_cast<double>(g_match->next_tick_us() - g_match->start_us()) / 1000.0 : 0;
}
EMSCRIPTEN_KEEPALIVE double lr_now_ms() {
    return g_match ? static_cast<double>(g_match->now_us() - g_match->start_us()) / 1000.0 : 0;
}
EMSCRIPTEN_KEEPALIVE int lr_finished() { return !g_match || g_match->finished() ? 1 : 0; }

// Runs the next client tick (whichever client's clock ticks first); 0 once the match is over.
EMSCRIPTEN_KEEPALIVE int lr_step() {
    if (!g_match || g_match->finished()) return 0;
    g_match->step();
    return 1;
}

EMSCRIPTEN_KEEPALIVE int lr_clients() { return g_match ? g_match->clients() : 0; }
EMSCRIPTEN_KEEPALIVE int lr_input_delay() { return g_match ? g_match->input_delay() : 0; }
EMSCRIPTEN_KEEPALIVE int lr_prediction() { return g_match ? g_match->prediction() : 0; }
EMSCRIPTEN_KEEPALIVE int lr_frame(int c) { return valid_client(c) ? static_cast<int>(g_match->frame(c)) : -1; }
EMSCRIPTEN_KEEPALIVE double lr_rollbacks(int c) {
    return valid_client(c) ? static_cast<double>(g_match->stats(c).rollbacks) : 0;
}
EMSCRIPTEN_KEEPALIVE double lr_stall_ticks(int c) {
    return valid_client(c) ? static_cast<double>(g_match->stats(c).stall_ticks) : 0;
}
EMSCRIPTEN_KEEPALIVE int lr_max_rollback_depth(int c) {
    return valid_client(c) ? static_cast<int>(g_match->stats(c).max_rollback_depth) : 0;
}

// The client's confirmed checksum of the last frame as 16 hex digits, "" until it has one.
EMSCRIPTEN_KEEPALIVE const char* lr_final_checksum(int c) {
    if (!valid_client(c)) return "";
    const auto sum = g_match->final_checksum(c);
    if (!sum) return "";
    char hex[17];
    std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(*sum));
    return text(hex);
}

// The room and its bodies once (bodies.csv, as `lockroll run --positions` writes it); then each
// dynamic body's shown position, by its index in that file, in metres.
EMSCRIPTEN_KEEPALIVE const char* lr_bodies_csv() {
    return g_match ? text(lockroll::harness::bodies_csv(g_match->world(0))) : "";
}
EMSCRIPTEN_KEEPALIVE int lr_body_count() {
    return g_match ? static_cast<int>(g_match->world(0).dynamic_count()) : 0;
}
EMSCRIPTEN_KEEPALIVE double lr_x(int c, int i) { return valid_body(c, i) ? metres(body_position(c, i).x) : 0; }
EMSCRIPTEN_KEEPALIVE double lr_z(int c, int i) { return valid_body(c, i) ? metres(body_position(c, i).z) : 0; }

// Error against time: rows (frames both clients have shown) so far; row r's fields (0 for a row
// that does not exist).
EMSCRIPTEN_KEEPALIVE int lr_row_count() { return g_match ? static_cast<int>(g_match->rows().size()) : 0; }
EMSCRIPTEN_KEEPALIVE double lr_row_time_s(int r) { return row(r).time_s; }
EMSCRIPTEN_KEEPALIVE double lr_row_mean_error(int r) { return row(r).mean_error; }
EMSCRIPTEN_KEEPALIVE double lr_row_max_error(int r) { return row(r).max_error; }
EMSCRIPTEN_KEEPALIVE double lr_row_ticks_per_second(int r) { return row(r).ticks_per_second; }
EMSCRIPTEN_KEEPALIVE int lr_row_rollbacks(int r) { return static_cast<int>(row(r).rollbacks); }

}  // extern "C"
