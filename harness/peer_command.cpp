#include "harness/peer_command.h"

#include "harness/cli_validators.h"

#include <csignal>
#include <ctime>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <memory>
#include <random>
#include <set>

#include <nlohmann/json.hpp>
#include <spdlog/sinks/basic_file_sink.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include "harness/match/atomic_file.h"
#include "harness/match/bots.h"
#include "harness/match/cli_error.h"
#include "harness/match/client_result.h"
#include "harness/match/hex.h"
#include "harness/live/loopback_address.h"
#include "harness/match/match_recorder.h"
#include "harness/match/match.h"
#include "harness/report/report.h"
#include "harness/run_command.h"
#include "harness/match/scene_loader.h"
#include "harness/match/timed_simulation.h"
#include "net/clock.h"
#include "net/peer_runner.h"
#include "net/relay_runner.h"
#include "rollback/desync_evidence.h"
#include "rollback/playing_alone.h"
#include "rollback/relay_session.h"
#include "rollback/session.h"
#include "rollback/world_simulation.h"
#include "server/connect_token.h"
#include "transport/enet_transport.h"

namespace lockroll::harness {

namespace {
namespace fs = std::filesystem;
using nlohmann::json;
using rollback::PlayerId;

struct PeerOptions {
    std::vector<int> slots;          // --slot as given: one, or (`lockroll client`) several: 0,1
    int slot = -1;                   // the lowest of them (plan() sets it)
    int players = 2;
    std::string listen;
    std::vector<std::string> peers;
    std::string scene = "paper";
    std::string bot = "random";
    int frames = 720;
    int tick_rate = 60;
    std::string out;
    std::string mode = "rollback";
    int input_delay = 2;
    int prediction = 8;
    int checksum_interval = 1;
    std::uint64_t seed = 1;
    bool join = false;
    bool spectate = false;
    int spectators = 0;
    std::vector<int> absent;
    double disconnect_timeout = 5;
    int recoveries = 0;
    std::string log_level = "info";
    std::string match_id;
    std::vector<std::string> injections;
    double connect_timeout = 30;
    double finish_timeout = 15;
    bool progress = false;
    // `lockroll client`: through the relay server instead of a mesh.
    bool relay = false;
    std::string connect;
    std::string room;
    std::string token_file;         // --token: the connect token a keyed server needs
    bool fixed_delay = false;       // --input-delay given: no adaptive delay
    bool prediction_given = false;
    int clock_skew_ppm = 0;      // fault test: this process's clock runs fast (> 0) or slow
    int corrupt_snapshot = 0;    // fault test: flip a bit in the first N snapshot chunks sent
    int truncate_snapshot = 0;   // fault test: drop the last byte of the first N chunks sent
};

// Validated flags: everything checked before a socket is bound or a file written.
struct PeerPlan {
    PeerOptions o;
    Mode mode = Mode::Rollback;
    BotKind bot = BotKind::Random;
    sim::SceneDesc scene;
    Endpoint listen;
    Endpoint server;  // relay: the server's address
    std::vector<std::uint8_t> token;  // relay: the connect token (empty: none)
    std::uint16_t also_slots = 0;     // relay: the further slots this client plays (`--slot 0,1`)
    std::vector<net::PeerAddress> peers;
    std::vector<DesyncInjection> injections;  // client field = this slot
    spdlog::level::level_enum log_level = spdlog::level::info;
};

double raw_to_m(sim::Fixed f) { return static_cast<double>(f.raw) / 4294967296.0; }

PeerPlan plan(const PeerOptions& given) {
    PeerPlan p;
    PeerOptions o = given;
    if (o.players < 2 || o.players > 16) throw UsageError("--players must be 2..16");
    if (o.slots.empty()) throw UsageError("--slot is required");
    o.slot = *std::min_element(o.slots.begin(), o.slots.end());
    if (o.slots.size() > 1) {
        // Several local players: through the server only (one connection plays them all).
        if (!o.relay) throw UsageError("--slot: a peer plays one slot (several local players: lockroll client --slot 0,1)");
        if (o.spectate) throw UsageError("--slot: a spectator has one id, not several");
        try {
            p.also_slots = static_cast<std::uint16_t>(slot_mask(o.slots, o.players, "--slot") & ~(1u << o.slot));
        } catch (const std::invalid_argument& e) {
            throw UsageError(e.what());
        }
    }
    p.o = o;
    if (o.spectators < 0 || o.spectators > 16) throw UsageError("--spectators must be 0..16");
    if (o.spectate && o.relay && o.slot < o.players)
        throw UsageError("--slot must be >= players with --spectate (the server assigns the spectator's place)");
    if (o.spectate && !o.relay && (o.slot < o.players || o.slot >= o.players + o.spectators))
        throw UsageError("--slot must be players..players+spectators-1 with --spectate (a spectator's id)");
    if (!o.spectate && (o.slot < 0 || o.slot >= o.players)) throw UsageError("--slot must be 0..players-1");
    if (o.join && o.spectate) throw UsageError("--join and --spectate exclude each other");
    for (int a : o.absent)
        if (a < 0 || a >= o.players) throw UsageError("--absent must name slots 0..players-1");
    if (o.recoveries < 0 || o.recoveries > 100) throw UsageError("--recoveries must be 0..100");
    if (!(o.disconnect_timeout >= 0.5 && o.disconnect_timeout <= 600)) throw UsageError("--disconnect-timeout must be 0.5..600 s");
    if (o.frames < 1) throw UsageError("--frames must be >= 1");
    if (o.tick_rate < 1 || o.tick_rate > 1000) throw UsageError("--tick-rate must be 1..1000");
    if (o.input_delay < 0 || o.input_delay > 60) throw UsageError("--input-delay must be 0..60");
    if (o.prediction < 1 || o.prediction > 60) throw UsageError("--prediction must be 1..60 (lockstep mode uses 0 itself)");
    if (o.checksum_interval < 1) throw UsageError("--checksum-interval must be >= 1");
    if (!(o.connect_timeout > 0 && o.connect_timeout <= 3600)) throw UsageError("--connect-timeout must be 0..3600 s");
    if (!(o.finish_timeout > 0 && o.finish_timeout <= 3600)) throw UsageError("--finish-timeout must be 0..3600 s");
    if (o.out.empty()) throw UsageError("--out is required");
    if (o.clock_skew_ppm < -net::Clock::kMaxSkewPpm || o.clock_skew_ppm > net::Clock::kMaxSkewPpm)
        throw UsageError("--clock-skew-ppm " + std::to_string(o.clock_skew_ppm) + ": must be -500000..500000");
    if (o.corrupt_snapshot < 0 || o.corrupt_snapshot > 1000) throw UsageError("--corrupt-snapshot must be 0..1000");
    if (o.truncate_snapshot < 0 || o.truncate_snapshot > 1000) throw UsageError("--truncate-snapshot must be 0..1000");
    if ((o.corrupt_snapshot > 0 || o.truncate_snapshot > 0) && (o.join || o.spectate))
        throw UsageError("--corrupt-snapshot and --truncate-snapshot act on snapshots sent: not with --join or --spectate");
    p.mode = o.mode == "lockstep" ? Mode::Lockstep : Mode::Rollback;
    p.bot = *parse_bot_kind(o.bot);
    const auto level = spdlog::level::from_str(o.log_level);
    if (level == spdlog::level::off && o.log_level != "off")
        throw UsageError("--log-level " + o.log_level + ": expected trace, debug, info, warn, error, critical or off");
    p.log_level = level;
    if (o.relay) {
        p.server = parse_loopback_endpoint(o.connect, "--connect", false);
        if (o.room.empty()) throw UsageError("--room is required");
        if (o.players > rollback::kRelayMaxPlayers) throw UsageError("--players must be 2..16");
        if (!o.token_file.empty()) {
            try {
                p.token = server::read_token_file(o.token_file);
            } catch (const std::invalid_argument& e) {
                throw UsageError(std::string("--token: ") + e.what());
            }
        }
    } else {
        p.listen = parse_loopback_endpoint(o.listen, "--listen", true);
    }
    std::set<int> seen;
    for (const auto& text : o.peers) {
        const auto [slot, address] = parse_slot_address(text, "--peer", "SLOT=HOST:PORT");
        if (slot < 0 || slot >= o.players || slot == o.slot)
            throw UsageError("--peer " + text + ": slot must be 0..players-1 and not --slot");
        if (!seen.insert(static_cast<int>(slot)).second) throw UsageError("--peer " + text + ": slot given twice");
        Endpoint e;
        try {
            e = parse_loopback_endpoint(address, "--peer", false);
        } catch (const UsageError& err) {
            const std::string why = err.what();
            throw UsageError("--peer " + text + why.substr(why.find(": ")));
        }
        p.peers.push_back({static_cast<PlayerId>(slot), e.host, e.port});
    }
    const int others = o.spectate ? o.players : o.players - 1;
    if (!o.relay && static_cast<int>(seen.size()) != others)
        throw UsageError("--peer: need an address for every other slot (" + std::to_string(others) + "), got " +
                         std::to_string(seen.size()));
    // Same syntax as run's; only this process's CLIENT applies (live passes every one to all).
    for (const auto& text : o.injections)
        if (const DesyncInjection d = parse_injection(text); d.client == o.slot) p.injections.push_back(d);
    p.scene = client_scene(o.scene, o.players, o.tick_rate);
    for (const auto& d : p.injections)  // refused before a socket is bound or a file written
        if (const std::string e = injection_error(p.scene, o.players, d); !e.empty())
            throw UsageError("--inject-desync " + std::to_string(d.client) + ":" + std::to_string(d.frame) + ":" +
                             std::to_string(d.body) + ": " + e);
    return p;
}

// Everything one process measures: the match's figures through MatchRecorder (the same
// recorder a virtual-time client uses; times on CLOCK_MONOTONIC, comparable across processes),
// plus what only a real process has: its log, events.jsonl (appended and flushed as events
// happen, so a killed process still leaves its events behind) and frames.csv's wall-clock rows.
class PeerRecorder final : public rollback::SessionObserver, public net::RunnerObserver {
public:
    PeerRecorder(const PeerPlan& p, rollback::WorldSimulation& sim, std::shared_ptr<spdlog::logger> log, const net::Clock& clock)
        : match(p.o.slot, p.o.players, static_cast<std::uint32_t>(p.o.frames), sim, true, true),
          p_(p),
          sim_(sim),
          log_(std::move(log)),
          clock_(clock),
          process_start_us_(clock.now_us()) {
        events_.open(fs::path(p.o.out) / "events.jsonl", std::ios::out | std::ios::trunc);
        if (!events_) throw std::runtime_error("cannot create " + (fs::path(p.o.out) / "events.jsonl").string());
        rows_.reserve(static_cast<std::size_t>(p.o.frames) + 1);
    }

    // What the recorder reads of the session (a P2P Session or a RelaySession).
    struct View {
        std::function<std::uint32_t()> frame, confirmed_frame;
        std::function<int()> input_delay;
        std::function<std::optional<std::span<const std::uint8_t>>(std::uint32_t)> saved_state;
        std::function<void(MatchRecorder&)> sample_rtt;  // one RTT sample per measured peer
    };
    template <class S>
    void watch(const S& s) {
        view.frame = [&s] { return s.frame(); };
        view.confirmed_frame = [&s] { return s.confirmed_frame(); };
        view.input_delay = [&s] { return s.input_delay(); };
        view.saved_state = [&s](std::uint32_t f) { return s.saved_state(f); };
    }
    View view;
    std::uint64_t synced_us = 0, reached_us = 0;
    // This process's clock (skewed only for the clock-skew fault tests).
    std::uint64_t now_us() const { return clock_.now_us(); }
    std::uint64_t mono_us(std::uint64_t t) const { return clock_.to_monotonic_us(t); }
    MatchRecorder match;
    std::vector<DesyncRecord> desyncs;
    double longest_stall_ms = 0;
    std::uint64_t last_advance_us = 0;
    std::uint32_t last_progress = 0;

    void event(const std::string& name, std::uint64_t now, json extra = json::object()) {
        json e = {{"t_ms", static_cast<double>(now - process_start_us_) / 1000.0},
                  {"mono_ms", static_cast<double>(clock_.to_monotonic_us(now)) / 1000.0},
                  {"frame", view.frame ? view.frame() : 0},
                  {"event", name},
                  {"slot", p_.o.slot}};
        for (auto& [k, v] : extra.items()) e[k] = v;
        events_ << e.dump() << "\n";
        events_.flush();
    }

    // Session side.
    void on_frame_simulated(const rollback::FrameSimulated& f) override {
        const std::uint64_t now = now_;
        if (!synced_us) synced_us = now;  // the first frame shown: the match (or this joiner's part) starts
        if (!match.frame_simulated(mono_us(now), f)) return;
        rows_.push_back({f.frame, static_cast<double>(now - synced_us) / 1000.0, view.confirmed_frame(), 0,
                         match.recent_tick_rate(p_.o.tick_rate), 0.0});
    }
    void on_rollback_begin(const rollback::RollbackInfo&) override { match.rollback_begin(); }
    void on_rollback_end(const rollback::RollbackInfo& r) override {
        match.rollback_end(r);
        if (r.displayed_frame > static_cast<std::uint32_t>(p_.o.frames)) return;
        for (auto it = rows_.rbegin(); it != rows_.rend(); ++it)
            if (it->frame == r.displayed_frame) {
                it->depth = std::max(it->depth, r.depth);
                break;
            }
    }
    void on_frame_confirmed(const rollback::FrameConfirmed& f) override {
        match.frame_confirmed(f, view.saved_state(f.frame));
        if (f.frame == static_cast<std::uint32_t>(p_.o.frames))
            log_->info("confirmed the last frame {}: checksum {}", f.frame, hex16(f.checksum));
    }
    void on_desync(const rollback::DesyncEvent& d) override {
        // The session's DesyncDetected event goes to events.jsonl; the checksums to the log.
        log_->error("desync with slot {} at confirmed frame {}: local {} remote {:08x} (low 32 bits, as input messages carry it)",
                    d.peer, d.frame, hex16(d.local_checksum), static_cast<std::uint32_t>(d.remote_checksum));
    }
    void on_desync_report(const rollback::DesyncReport& r) override {
        log_->error("desync report: {}", r.summary);
        DesyncRecord rec;
        rec.client = p_.o.slot;
        rec.summary = r.summary;
        rec.detected_frame = r.detected_frame;
        rec.frame = r.frame;
        rec.body = r.body_id;
        rec.field = r.field_name;
        if (!r.local_state.empty()) {
            const auto path = fs::path(p_.o.out) / rollback::desync_evidence_file_name(static_cast<PlayerId>(p_.o.slot), r);
            write_file_atomic(path, rollback::desync_evidence_text(r, sim_));
            rec.evidence_file = path.string();
        }
        event("desync_report", clock_.now_us(),
              {{"peer", r.peer}, {"first_frame", r.frame}, {"outcome", rollback::narrow_outcome_name(r.outcome)},
               {"body", r.body_id}, {"field", r.field_name}, {"summary", r.summary}});
        desyncs.push_back(rec);
    }
    void on_peer_error(PlayerId peer, const std::string& why) override {
        log_->warn("slot {} sent too many malformed packets ({}); ignoring it from now on", peer, why);
        event("peer_error", clock_.now_us(), {{"peer", peer}, {"why", why}});
    }

    // Runner side.
    void on_transport_event(const transport::TransportEvent& e, std::uint64_t now) override {
        using T = transport::TransportEvent::Type;
        const char* name = e.type == T::Connected ? "connected" : e.type == T::Disconnected ? "connection_lost" : "connection_refused";
        if (e.type == T::Connected) log_->info("connected to peer {}", e.peer);
        else log_->warn("peer {}: {} {}", e.peer, name, e.reason);
        event(name, now, {{"peer", e.peer}, {"reason", e.reason}});
    }
    void on_session_event(const rollback::SessionEvent& e) override {
        using K = rollback::SessionEvent::Kind;
        const bool bad = e.kind == K::Refused || e.kind == K::Disconnected || e.kind == K::Interrupted || e.kind == K::Kicked ||
                         e.kind == K::Failed || e.kind == K::DesyncDetected || e.kind == K::SnapshotRejected;
        log_->log(bad ? spdlog::level::warn : spdlog::level::info, "{} peer {} frame {}{}{}", rollback::event_name(e.kind),
                  e.peer, e.frame, e.detail.empty() ? "" : ": ", e.detail);
        json extra = {{"peer", e.peer}, {"event_frame", e.frame}};
        if (!e.detail.empty()) extra["detail"] = e.detail;
        if (e.reason != rollback::SessionEvent::Reason::None) extra["reason"] = rollback::reason_name(e.reason);
        if (e.kind == K::Synchronized) extra["input_delay"] = view.input_delay();
        event(rollback::event_name(e.kind), e.at_us ? e.at_us : clock_.now_us(), extra);
    }
    void on_synchronized(std::uint64_t now) override {
        if (!synced_us) synced_us = now;
        log_->info("running from frame {} (input delay {}, {} mode)", view.frame(), view.input_delay(), mode_name(p_.mode));
    }
    void on_all_confirmed(std::uint64_t now) override {
        log_->info("every peer has confirmed frame {}", p_.o.frames);
        event("all_confirmed", now);
    }
    void on_tick(const net::TickReport& t) override {
        const rollback::AdvanceResult& r = t.advance;
        const double cpu = static_cast<double>(r.resim_ns + r.forward_ns) / 1000.0;
        match.tick(cpu, static_cast<double>(r.resim_ns) / 1000.0);
        if (view.sample_rtt && r.frame <= static_cast<std::uint32_t>(p_.o.frames)) view.sample_rtt(match);
        if (r.advanced && last_advance_us == 0) last_advance_us = t.now_us;  // the first frame
        if (r.advanced) {
            if (!rows_.empty() && rows_.back().frame == r.frame) rows_.back().cpu_us = cpu;
            const double gap = static_cast<double>(t.now_us - last_advance_us) / 1000.0;
            if (gap > longest_stall_ms) longest_stall_ms = gap;
            if (gap > 250) log_->info("stalled {:.0f} ms before frame {}", gap, r.frame);
            last_advance_us = t.now_us;
        } else if (r.blocking_player >= 0) {
            log_->trace("tick {} stalled waiting for slot {}", t.tick, r.blocking_player);
        }
        if (r.wait_frames > 0) log_->debug("time sync: {} frames ahead, lengthening ticks", r.wait_frames);
        if (t.now_us > t.scheduled_us + 4000) log_->debug("tick {} ran {} us late", t.tick, t.now_us - t.scheduled_us);
        if (!reached_us && r.frame >= static_cast<std::uint32_t>(p_.o.frames)) reached_us = t.now_us;
        if (p_.o.progress && r.frame != last_progress) {
            last_progress = r.frame;
            std::printf("progress %u\n", r.frame);
            std::fflush(stdout);
        }
    }

    // Called by the input source, just before advance(): the time of this tick, and the input.
    void before_advance(std::uint64_t now, std::uint32_t input_frame, const std::array<std::uint8_t, 3>& bytes) {
        now_ = now;
        match.input_offered(mono_us(now), input_frame, bytes);
    }

    std::string frames_csv() const {
        std::string out = "frame,wall_ms,confirmed_frame,rollback_depth,ticks_per_second,cpu_us\n";
        char line[200];
        for (const auto& r : rows_) {
            std::snprintf(line, sizeof line, "%u,%.3f,%u,%u,%.3f,%.3f\n", r.frame, r.wall_ms, r.confirmed, r.depth, r.tps, r.cpu_us);
            out += line;
        }
        return out;
    }
    std::string positions_csv() const {
        std::string out = "frame,client,body_index,x,y,z,x_raw,y_raw,z_raw\n";
        char line[200];
        for (const auto& [frame, bodies] : match.shown_positions())
            for (std::size_t b = 0; b < bodies.size(); ++b) {
                const sim::Vec3& v = bodies[b];
                std::snprintf(line, sizeof line, "%u,%d,%zu,%.9f,%.9f,%.9f,%lld,%lld,%lld\n", frame, p_.o.slot, b, raw_to_m(v.x),
                              raw_to_m(v.y), raw_to_m(v.z), static_cast<long long>(v.x.raw), static_cast<long long>(v.y.raw),
                              static_cast<long long>(v.z.raw));
                out += line;
            }
        return out;
    }

private:
    struct Row {
        std::uint32_t frame = 0;
        double wall_ms = 0;
        std::uint32_t confirmed = 0, depth = 0;
        double tps = 0, cpu_us = 0;
    };

    const PeerPlan& p_;
    rollback::WorldSimulation& sim_;
    std::shared_ptr<spdlog::logger> log_;
    const net::Clock& clock_;
    std::uint64_t process_start_us_;
    std::ofstream events_;
    std::vector<Row> rows_;
    std::uint64_t now_ = 0;
};

std::shared_ptr<spdlog::logger> make_logger(const PeerPlan& p) {
    auto file = std::make_shared<spdlog::sinks::basic_file_sink_mt>((fs::path(p.o.out) / "peer.log").string(), true);
    auto err = std::make_shared<spdlog::sinks::stderr_color_sink_mt>();
    auto log = std::make_shared<spdlog::logger>("peer" + std::to_string(p.o.slot), spdlog::sinks_init_list{file, err});
    log->set_pattern("[%Y-%m-%d %H:%M:%S.%e] [%^%l%$] [slot " + std::to_string(p.o.slot) + "] %v");
    log->set_level(p.log_level);
    log->flush_on(spdlog::level::info);
    return log;
}

// What both kinds of session leave behind: summary.json, frames.csv, positions.csv and the
// final line on stdout. Returns the exit status.
template <class SessionT, class RunnerT>
int write_outputs(const PeerPlan& p, PeerRecorder& rec, const SessionT& session, const RunnerT& runner,
                  transport::EnetTransport& enet, net::RunOutcome outcome, int prediction,
                  const std::shared_ptr<spdlog::logger>& log, json extra) {
    const std::uint64_t end_us = rec.now_us();
    const std::optional<std::uint64_t> final_checksum = rec.match.final_checksum();
    const bool ok = outcome == net::RunOutcome::Completed && final_checksum;
    // What the outcome does not say by its name (the P2P runner only; the relay has a server):
    // a completion played alone (a drop by the two-player rule left this process the only
    // running player of its view, in a match of two or of more shrunk to two), a partition, a rejoin by
    // snapshot after the others dropped this slot (a healed partition's minority), and why it
    // failed.
    std::optional<std::uint32_t> partitioned_since, alone_since, rejoined_at;
    std::optional<json> running_voters;  // the view's running processes at the end, by slot
    std::string rejoin;  // "had been partitioned since frame F, rejoined at frame G"
    if constexpr (requires { runner.partitioned_since(); }) {
        partitioned_since = runner.partitioned_since();
        alone_since = runner.alone_since();
        running_voters = json::array();
        for (const rollback::PlayerId v : rollback::running_voters(session)) running_voters->push_back(v);
        if (const std::optional<net::RejoinRecord>& rj = runner.rejoined(); rj && rj->at_frame) {
            rejoined_at = rj->at_frame;
            // The episode it was dropped in, healed by the rejoin (unless cut off again since).
            if (!partitioned_since) partitioned_since = rj->partitioned_since;
            rejoin = (rj->partitioned_since ? "had been partitioned since frame " + std::to_string(*rj->partitioned_since)
                                            : "dropped by the others at frame " + std::to_string(rj->dropped_at_frame)) +
                     ", rejoined at frame " + std::to_string(*rj->at_frame);
        }
    }
    std::string detail = net::outcome_name(outcome);
    if (outcome == net::RunOutcome::Completed && alone_since) detail += " alone since frame " + std::to_string(*alone_since);
    if (outcome == net::RunOutcome::Partitioned)
        detail += " since frame " + std::to_string(partitioned_since.value_or(0)) + " (heard no majority of the match; did not complete)";
    if (outcome == net::RunOutcome::ServerLost) detail += ": " + session.failure();
    if (outcome == net::RunOutcome::Failed) detail += ": " + session.failure();
    if (!rejoin.empty() && outcome != net::RunOutcome::Partitioned)
        detail += "; " + rejoin;
    else if (outcome == net::RunOutcome::Failed && partitioned_since)
        detail += "; had been partitioned since frame " + std::to_string(*partitioned_since);
    json finished = {{"outcome", net::outcome_name(outcome)}, {"detail", detail},
                     {"final_checksum", final_checksum ? json(hex16(*final_checksum)) : json(nullptr)}};
    if (partitioned_since) finished["partitioned_since_frame"] = *partitioned_since;
    if (alone_since) finished["alone_since_frame"] = *alone_since;
    if (rejoined_at) finished["rejoined_at_frame"] = *rejoined_at;
    rec.event("finished", end_us, finished);
    log->log(ok ? spdlog::level::info : spdlog::level::err, "finished: {}, shown frame {}, confirmed {}", detail, session.frame(),
             session.confirmed_frame());

    // summary.json: run's keys through the same code, for a "match" of this one process.
    const rollback::SessionStats& st = session.stats();
    const RecordedSamples& m = rec.match.samples();
    RunResult r;
    r.mode = mode_name(p.mode);
    r.scene = p.scene.name;
    r.bot = bot_kind_name(p.bot);
    r.players = p.o.players;
    r.frames = p.o.frames;
    r.tick_rate = p.o.tick_rate;
    r.input_delay = session.input_delay();
    r.prediction = prediction;
    r.seed = p.o.seed;
    r.completed = ok;
    const std::uint64_t since = rec.synced_us ? rec.synced_us : end_us;
    r.virtual_seconds = static_cast<double>(end_us - since) / 1e6;  // wall seconds of the match
    r.cpu_us_per_tick = m.cpu_us_per_tick;
    r.resim_us_per_tick = m.resim_us_per_tick;
    r.physics_step_us = m.physics_step_us;
    r.rollback_depth = m.rollback_depth;
    r.rollback_depth_histogram = m.rollback_depth_histogram;
    r.correction_jump = m.correction_jump;
    r.input_latency_local = m.input_latency_local;
    r.displayed_vs_confirmed = {m.displayed_vs_confirmed};
    for (const auto& [peer, ms] : m.rtt_ms) r.rtt.push_back({p.o.slot, peer, ms});
    r.desyncs = rec.desyncs;
    ClientResult cr = client_result(st);
    // Tick rate and stalls from when frames were shown (frames from this process's first one;
    // a frame late by more than a period is a stall, whether or not a tick ran meanwhile).
    const TickFigures tf = tick_figures(m.shown, p.o.tick_rate);
    cr.ticks_per_second = tf.ticks_per_second;
    cr.stall_fraction = tf.stall_fraction;
    cr.final_checksum = final_checksum.value_or(0);
    cr.final_confirmed = final_checksum.has_value();
    r.clients.push_back(cr);
    json s = summary_json(r);
    s["slot"] = p.o.slot;
    s["match_id"] = p.o.match_id;
    s["outcome"] = net::outcome_name(outcome);
    s["outcome_detail"] = detail;
    // Present only when true of this run: a reader can test for the key.
    if (partitioned_since) s["partitioned_since_frame"] = *partitioned_since;
    if (alone_since) s["alone_since_frame"] = *alone_since;
    if (rejoined_at) s["rejoined_at_frame"] = *rejoined_at;
    // What a claim of "alone" is checked against (harness/live/outcome_claims.h).
    if (running_voters) s["running_voters"] = *running_voters;
    s["final_checksum"] = final_checksum ? json(hex16(*final_checksum)) : json(nullptr);
    json cps = json::array();
    for (const auto& [f, c] : m.confirmed) cps.push_back({{"frame", f}, {"checksum", hex16(c)}});
    s["confirmed_checksums"] = cps;
    s["shown_frame"] = session.frame();
    s["confirmed_frame"] = session.confirmed_frame();
    s["wall_seconds"] = r.virtual_seconds;
    s["longest_stall_ms"] = rec.longest_stall_ms;
    s["runner"] = {{"stretched_ticks", runner.stretched_ticks()},
                   {"stretch_total_ms", static_cast<double>(runner.stretch_total_us()) / 1000.0},
                   {"schedule_resets", runner.schedule_resets()}};
    s["transport"] = {{"datagrams_sent", enet.counters().datagrams_sent},
                      {"datagrams_received", enet.counters().datagrams_received},
                      {"rejected", enet.counters().rejected},
                      {"dropped", enet.counters().dropped},
                      {"wire_bytes_sent", enet.wire_bytes_sent()},
                      {"wire_bytes_received", enet.wire_bytes_received()}};
    for (auto& [k, v] : extra.items()) s[k] = v;
    if (enet.counters().rejected) log->warn("transport refused {} datagrams", enet.counters().rejected);
    write_file_atomic(fs::path(p.o.out) / "frames.csv", rec.frames_csv());
    write_file_atomic(fs::path(p.o.out) / "positions.csv", rec.positions_csv());
    write_file_atomic(fs::path(p.o.out) / "samples.json", m.to_json().dump() + "\n");
    write_file_atomic(fs::path(p.o.out) / "summary.json", s.dump(2) + "\n");
    std::printf("slot %d: %s, frame %u shown, %u confirmed, final checksum %s\n", p.o.slot, detail.c_str(), session.frame(),
                session.confirmed_frame(), final_checksum ? hex16(*final_checksum).c_str() : "none");
    std::fflush(stdout);
    return ok ? 0 : 1;
}

net::RunnerConfig runner_config(const PeerPlan& p, const net::Clock& clock) {
    net::RunnerConfig rc;
    rc.clock = clock;
    rc.tick_rate = p.o.tick_rate;
    rc.target_frame = static_cast<std::uint32_t>(p.o.frames);
    rc.peers = p.peers;
    rc.connect_timeout_us = static_cast<std::uint64_t>(p.o.connect_timeout * 1e6);
    rc.finish_timeout_us = static_cast<std::uint64_t>(p.o.finish_timeout * 1e6);
    // A match that cannot advance (a peer gone for good) must still end: ten times its length.
    rc.run_timeout_us = static_cast<std::uint64_t>(10.0 * p.o.frames / p.o.tick_rate * 1e6) + rc.finish_timeout_us;
    return rc;
}

// The bots' inputs for a frame, one per local slot in slot order (a client of several slots:
// `--slot 0,1`); the first slot's is recorded for the input-latency figures.
net::InputSource bot_input(const std::vector<Bot>& bots, const rollback::WorldSimulation& sim, PeerRecorder& rec) {
    return [&bots, &sim, &rec](std::uint32_t frame, std::span<std::uint8_t> out) {
        for (std::size_t k = 0; k < bots.size(); ++k) {
            const auto bytes = rollback::encode_input(bots[k].input(frame, sim.world()));
            if (k == 0) rec.before_advance(rec.now_us(), frame, bytes);
            std::copy(bytes.begin(), bytes.end(), out.begin() + static_cast<std::ptrdiff_t>(k * bytes.size()));
        }
    };
}

template <class SessionT>
void inject_faults(const PeerPlan& p, SessionT& session) {
    for (const auto& inj : p.injections)
        if (const std::string e = session.inject_fault(inj.frame, inj.body, inj.field, inj.bit); !e.empty())
            throw UsageError("--inject-desync " + std::to_string(inj.client) + ":" + std::to_string(inj.frame) + ":" +
                             std::to_string(inj.body) + ": " + e);
}

template <class RunnerT>
net::RunOutcome run_with_signals(RunnerT& runner) {
    static std::atomic<RunnerT*> target{nullptr};
    target.store(&runner);
    std::signal(SIGTERM, [](int) {
        if (RunnerT* r = target.load()) r->request_stop();
    });
    std::signal(SIGINT, [](int) {
        if (RunnerT* r = target.load()) r->request_stop();
    });
    const net::RunOutcome outcome = runner.run();
    target.store(nullptr);
    return outcome;
}

// `lockroll client`: the same player (or spectator) through the relay server.
int do_client(const PeerPlan& p, rollback::WorldSimulation& sim, PeerRecorder& rec, const std::shared_ptr<spdlog::logger>& log,
              const net::Clock& clock) {
    rollback::RelaySessionConfig rc;
    rc.players = p.o.players;
    rc.local_slot = static_cast<PlayerId>(p.o.spectate ? 0 : p.o.slot);
    rc.also_slots = p.also_slots;
    rc.role = p.o.spectate ? rollback::RelayRole::Spectator : p.o.join ? rollback::RelayRole::Joiner : rollback::RelayRole::Player;
    rc.input_size = rollback::kWorldInputSize;
    rc.tick_rate = p.o.tick_rate;
    rc.input_delay = p.o.input_delay;
    rc.auto_input_delay = !p.o.fixed_delay;
    rc.prediction_window = p.mode == Mode::Lockstep ? 0 : (p.o.prediction_given ? p.o.prediction : 20);
    rc.room_id = match_hash(p.o.room);
    rc.connect_token = p.token;
    for (int a : p.o.absent) rc.absent_slots = static_cast<std::uint16_t>(rc.absent_slots | (1u << a));
    rc.max_recoveries = std::max(p.o.recoveries, 0);
    rc.cpu_clock = net::thread_cpu_ns;
    // The token a reconnect resumes the slot with: random, so no other client can take it over.
    std::random_device rd;
    rc.incarnation = (static_cast<std::uint64_t>(rd()) << 32 | rd()) | 1;
    TimedSimulation timed(sim, net::thread_cpu_ns, rec.match.physics_step_us());
    rollback::RelaySession session(rc, timed, &rec);
    rec.watch(session);
    // The relay client's one round trip, to the server (peer -1 in the report).
    rec.view.sample_rtt = [&session](MatchRecorder& m) {
        if (session.rtt_us() > 0) m.rtt(-1, static_cast<double>(session.rtt_us()) / 1000.0);
    };
    inject_faults(p, session);
    // One connection, to the server: closed only after 30 s of silence (and long ENet timeouts
    // while it connects), so a lossy link never closes it under a live server (a reconnect resumes, but costs seconds); the session watches the
    // server's silence itself.
    transport::EnetTransport enet({.local_id = static_cast<transport::PeerId>(p.o.slot),
                                   .bind_host = "127.0.0.1",
                                   .port = 0,
                                   .max_peers = 4,
                                   .dead_after_us = 30'000'000,
                                   .timeout_limit = 32,
                                   .timeout_min_ms = 5000,
                                   .timeout_max_ms = 30000});
    std::string slots;  // "0,1" for a client of several slots
    for (PlayerId s : session.local_slots()) slots += (slots.empty() ? "" : ",") + std::to_string(s);
    log->info("connecting to the relay server {}:{} for room '{}' as {} {} of {} ({} mode)", p.server.host, p.server.port, p.o.room,
              p.o.spectate ? "spectator" : "slot", p.o.spectate ? std::to_string(p.o.slot) : slots, p.o.players, mode_name(p.mode));
    rec.event("listening", rec.now_us(), {{"port", enet.port()}, {"room", p.o.room}});
    std::vector<Bot> bots;  // one per local slot, in slot order
    if (session.local_slots().empty()) bots.emplace_back(BotConfig{p.bot, p.o.seed, p.o.tick_rate, 4.0}, p.o.slot);
    for (PlayerId s : session.local_slots()) bots.emplace_back(BotConfig{p.bot, p.o.seed, p.o.tick_rate, 4.0}, s);
    net::RelayRunner runner(runner_config(p, clock), p.server.host, p.server.port, session, enet, bot_input(bots, sim, rec), &rec);
    const net::RunOutcome outcome = run_with_signals(runner);
    if (outcome == net::RunOutcome::Failed || outcome == net::RunOutcome::ServerLost)
        log->error("session failed: {}", session.failure());
    const rollback::RelayStats& rs = session.relay_stats();
    json extra = {{"topology", "relay"},
                  {"local_slots", session.local_slots()},
                  {"clock_skew_ppm", p.o.clock_skew_ppm},
                  {"room", p.o.room},
                  {"rtt_ms", {{"server", static_cast<double>(session.rtt_us()) / 1000.0}}},
                  {"relay", {{"own_replaced", rs.own_replaced},
                             {"replaced_any", rs.replaced_any},
                             {"desync_notices", rs.desync_notices},
                             {"recoveries", session.recoveries()},
                             {"catch_up_frames", runner.catch_up_frames()},
                             {"lead_frames", static_cast<double>(rs.lead_x100) / 100.0},
                             {"target_lead", rs.target_lead},
                             {"jitter_ms", static_cast<double>(session.jitter_us()) / 1000.0}}}};
    return write_outputs(p, rec, session, runner, enet, outcome, rc.prediction_window, log, extra);
}

int do_peer(const PeerOptions& options) {
    const PeerPlan p = plan(options);
    fs::create_directories(p.o.out);
    auto log = make_logger(p);

    rollback::WorldSimulation sim(p.scene, p.o.players);
    // Every time this process measures or acts on; skewed only for the clock-skew fault tests.
    const net::Clock clock(p.o.clock_skew_ppm);
    PeerRecorder rec(p, sim, log, clock);
    if (p.o.relay) return do_client(p, sim, rec, log, clock);
    rollback::SessionConfig sc;
    sc.players = p.o.players;
    sc.local_player = static_cast<PlayerId>(p.o.slot);
    sc.input_size = rollback::kWorldInputSize;
    sc.tick_rate = p.o.tick_rate;
    sc.input_delay = p.o.input_delay;
    sc.prediction_window = p.mode == Mode::Lockstep ? 0 : p.o.prediction;
    sc.checksum_interval = p.o.checksum_interval;
    sc.cpu_clock = net::thread_cpu_ns;
    // Real networks: hello/welcome with match id and scene checksum, an RTT phase before frame 0,
    // agreed disconnects, joins and spectators by snapshot (docs/sessions.md).
    sc.handshake = true;
    sc.match_id = match_hash(p.o.match_id);
    sc.max_spectators = p.o.spectators;
    for (int a : p.o.absent) sc.absent_slots |= std::uint64_t{1} << a;
    sc.role = p.o.spectate ? rollback::Role::Spectator : p.o.join ? rollback::Role::Joiner : rollback::Role::Player;
    sc.disconnect_us = static_cast<std::uint64_t>(p.o.disconnect_timeout * 1e6);
    sc.max_recoveries = p.o.recoveries;
    TimedSimulation timed(sim, net::thread_cpu_ns, rec.match.physics_step_us());
    rollback::Session session(sc, timed, &rec);
    rec.watch(session);
    rec.view.sample_rtt = [&session, slot = p.o.slot](MatchRecorder& m) {
        const rollback::SessionStats& st = session.stats();
        for (std::size_t peer = 0; peer < st.peers.size(); ++peer)
            if (static_cast<int>(peer) != slot && st.peers[peer].rtt_us > 0)
                m.rtt(static_cast<int>(peer), static_cast<double>(st.peers[peer].rtt_us) / 1000.0);
    };
    inject_faults(p, session);
    if (p.o.corrupt_snapshot > 0) session.damage_outgoing_chunks(p.o.corrupt_snapshot, rollback::ChunkDamage::FlipBit);
    if (p.o.truncate_snapshot > 0) session.damage_outgoing_chunks(p.o.truncate_snapshot, rollback::ChunkDamage::Truncate);

    transport::EnetTransport enet({.local_id = static_cast<transport::PeerId>(p.o.slot),
                                   .bind_host = p.listen.host,
                                   .port = p.listen.port,
                                   .max_peers = 32});
    log->info("listening on {}:{} as slot {} of {} ({} mode, match '{}')", p.listen.host, enet.port(), p.o.slot,
              p.o.players, mode_name(p.mode), p.o.match_id);
    if (p.o.clock_skew_ppm != 0) log->info("clock skew {} ppm (fault test)", p.o.clock_skew_ppm);
    rec.event("listening", rec.now_us(), {{"port", enet.port()}, {"match_id", p.o.match_id}});

    const std::vector<Bot> bots{Bot(BotConfig{p.bot, p.o.seed, p.o.tick_rate, 4.0}, p.o.slot)};
    net::PeerRunner runner(runner_config(p, clock), session, enet, bot_input(bots, sim, rec), &rec);
    const net::RunOutcome outcome = run_with_signals(runner);
    const rollback::SessionStats& st = session.stats();
    json rtts = json::object();
    for (std::size_t peer = 0; peer < st.peers.size(); ++peer)
        if (peer != static_cast<std::size_t>(p.o.slot)) rtts[std::to_string(peer)] = static_cast<double>(st.peers[peer].rtt_us) / 1000.0;
    json extra = {{"topology", "p2p"},
                  {"listen_port", enet.port()},
                  {"rtt_ms", rtts},
                  {"clock_skew_ppm", p.o.clock_skew_ppm},
                  {"snapshot_chunks_damaged", session.damaged_chunks()}};
    return write_outputs(p, rec, session, runner, enet, outcome, sc.prediction_window, log, extra);
}

}  // namespace

namespace {
// The options `peer` and `client` share: the player, the game, the outputs.
void add_player_options(CLI::App* cmd, const std::shared_ptr<PeerOptions>& o) {
    cmd->add_option("--slot", o->slots, "This process's player slot 0..players-1 (`lockroll client`: several, as 0,1)")
        ->required()
        ->allow_extra_args(false)
        ->delimiter(',');
    cmd->add_option("--players", o->players, "Players in the match (2..16)")->capture_default_str();
    cmd->add_option("--scene", o->scene, "Scene file or shipped scene name")->capture_default_str();
    cmd->add_option("--bot", o->bot, "Input bot: random or chase")->check(CLI::IsMember({"random", "chase"}))->capture_default_str();
    cmd->add_option("--frames", o->frames, "Frames to play")->capture_default_str();
    cmd->add_option("--tick-rate", o->tick_rate, "Ticks per second")->capture_default_str();
    cmd->add_option("--out", o->out, "Output directory")->required();
    cmd->add_option("--mode", o->mode, "rollback or lockstep")->check(CLI::IsMember({"rollback", "lockstep"}))->capture_default_str();
    cmd->add_option("--input-delay", o->input_delay, "Input delay in frames")->capture_default_str();
    cmd->add_option("--prediction", o->prediction, "Prediction window W in rollback mode")->capture_default_str();
    cmd->add_option("--seed", o->seed, "Seed for the bots")->capture_default_str();
    cmd->add_flag("--join", o->join, "Join (or rejoin) a running match in --slot by snapshot");
    cmd->add_flag("--spectate", o->spectate, "Watch without playing; --slot is then the spectator id (players..)");
    cmd->add_option("--absent", o->absent, "Slot nobody plays at frame 0 (joins later; the same on every process)");
    cmd->add_option("--recoveries", o->recoveries, "Desync recoveries (reload the majority's state) before giving up")
        ->capture_default_str();
    cmd->add_option("--log-level", o->log_level, "trace, debug, info, warn, error, critical or off")->capture_default_str();
    cmd->add_option("--inject-desync", o->injections, "CLIENT:FRAME:BODY[:FIELD:BIT] flip one bit of one body at a frame, when CLIENT is --slot");
    cmd->add_option("--connect-timeout", o->connect_timeout, "Seconds to wait for every peer to connect")->capture_default_str();
    cmd->add_option("--finish-timeout", o->finish_timeout, "Seconds after the last frame to wait for every peer to confirm it")
        ->capture_default_str();
    cmd->add_flag("--progress", o->progress, "Print 'progress FRAME' on stdout as frames are shown");
    cmd->add_option("--clock-skew-ppm", o->clock_skew_ppm,
                    "Fault test: this process's clock runs PPM parts per million fast (> 0) or slow (< 0), -500000..500000")
        ->capture_default_str();
}
}  // namespace

std::uint64_t match_hash(const std::string& id) {
    std::uint64_t h = 0xcbf29ce484222325ull;
    for (unsigned char c : id) h = (h ^ c) * 0x100000001b3ull;
    return h;
}

sim::SceneDesc client_scene(const std::string& scene, int players, int tick_rate) {
    sim::SceneDesc d;
    try {
        d = with_players(load_scene(scene), players);
    } catch (const SceneError& e) {
        throw UsageError(e.what());
    }
    d.tick_rate = tick_rate;
    if (const std::string e = sim::validate(d); !e.empty()) throw UsageError("scene: " + e);
    return d;
}

void add_peer_command(CLI::App& app) {
    auto o = std::make_shared<PeerOptions>();
    CLI::App* cmd = app.add_subcommand("peer", "One player of a P2P match as a real process over ENet on loopback; write DIR/summary.json");
    add_player_options(cmd, o);
    cmd->add_option("--listen", o->listen, "HOST:PORT to bind (loopback only; port 0 = any free one)")->required();
    cmd->add_option("--peer", o->peers, "SLOT=HOST:PORT of every other slot (repeatable; loopback only)");
    cmd->add_option("--checksum-interval", o->checksum_interval, "Compare confirmed checksums every K frames")->capture_default_str();
    cmd->add_option("--spectators", o->spectators, "Spectator ids the match admits (the same on every process)")->capture_default_str();
    cmd->add_option("--disconnect-timeout", o->disconnect_timeout, "Seconds of silence before a peer's slot is dropped")
        ->capture_default_str();
    cmd->add_option("--match-id", o->match_id, "Name of the match: processes of another match are refused");
    cmd->add_option("--corrupt-snapshot", o->corrupt_snapshot,
                    "Fault test: flip one bit in each of the first N snapshot chunks this process sends (the receiver must reject the snapshot and ask again)")
        ->capture_default_str();
    cmd->add_option("--truncate-snapshot", o->truncate_snapshot,
                    "Fault test: drop the last byte of each of the first N snapshot chunks this process sends (the receiver must refuse them and ask again)")
        ->capture_default_str();
    cmd->callback([o] {
        const int status = do_peer(*o);
        if (status != 0) throw std::runtime_error("the match did not complete (see peer.log)");
    });

    auto c = std::make_shared<PeerOptions>();
    c->relay = true;
    CLI::App* client = app.add_subcommand(
        "client", "One player (or spectator) of a match through the relay server (lockroll server), as a real process; write DIR/summary.json");
    add_player_options(client, c);
    client->add_option("--connect", c->connect, "HOST:PORT of the relay server (loopback only)")->required();
    client->add_option("--token", c->token_file,
                       "FILE with the connect token a server started with --key needs (lockroll token writes one)")
        ->type_name("FILE");
    client->add_option("--room", c->room, "Room to join (created by its first player; every client of a match names the same)")->required();
    client->callback([c, client] {
        // Without --input-delay the delay adapts to the round trip and jitter; without
        // --prediction the window covers a 300 ms round trip (20 frames).
        c->fixed_delay = client->count("--input-delay") > 0;
        c->prediction_given = client->count("--prediction") > 0;
        const int status = do_peer(*c);
        if (status != 0) throw std::runtime_error("the match did not complete (see peer.log)");
    });
}

}  // namespace lockroll::harness
