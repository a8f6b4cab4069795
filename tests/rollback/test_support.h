// Shared fixtures for rollback tests: scenes with any number of players, a seeded input walk,
// and a discrete-event "network" that delays, drops, duplicates and reorders datagrams between
// in-process sessions. Deliberately independent of transport/ (tested on its own).
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <queue>
#include <vector>

#include "rollback/replay.h"
#include "rollback/session.h"
#include "rollback/world_simulation.h"
#include "sim/rng.h"
#include "sim/scene.h"

namespace lockroll::rollback::testing {

inline sim::Fixed fx(double v) { return sim::Fixed::from_raw(static_cast<std::int64_t>(v * 4294967296.0)); }

// A closed room with `players` player boxes in a row and `balls` spawned spheres.
inline sim::SceneDesc make_scene(int players, int balls, std::uint64_t seed = 7) {
    sim::SceneDesc s;
    s.name = "test";
    sim::add_room(s, {fx(-8), fx(0), fx(-8)}, {fx(8), fx(5), fx(8)}, fx(1));
    for (int p = 0; p < players; ++p) {
        sim::BodyDesc b;
        b.shape = sim::Shape::Box;
        b.position = {fx(-6 + 12.0 * (p + 0.5) / players), fx(0.9), fx(-6)};
        b.half_extents = {fx(0.3), fx(0.9), fx(0.3)};
        b.mass = fx(5);
        b.player = p;
        s.bodies.push_back(b);
    }
    if (balls > 0) {
        sim::SpawnerDesc sp;
        sp.count = balls;
        sp.radius = fx(0.25);
        sp.region_min = {fx(-6), fx(0.5), fx(-4)};
        sp.region_max = {fx(6), fx(4.5), fx(6)};
        sp.max_speed = fx(4);
        sp.seed = seed;
        sim::expand_spawner(s, sp);
    }
    return s;
}

// Seeded random walk: holds a direction for a random number of frames (~4 changes per second).
class WalkBot {
public:
    explicit WalkBot(std::uint64_t seed) : rng_(seed) {}
    std::array<std::uint8_t, 3> next() {
        if (hold_ == 0) {
            hold_ = 1 + static_cast<int>(rng_.below(30));
            for (auto& a : axis_) a = static_cast<std::uint8_t>(static_cast<std::int8_t>(static_cast<int>(rng_.below(255)) - 127));
            if (rng_.below(3) == 0) axis_[2] = 0;
        }
        --hold_;
        return axis_;
    }

private:
    sim::SplitMix64 rng_;
    int hold_ = 0;
    std::array<std::uint8_t, 3> axis_{};
};

// A session as the lifecycle tests run it: handshake, a match id, and timeouts that let a cut of
// a few seconds be noticed (interrupted at 0.75 s) without a drop (5 s).
inline SessionConfig real_config(int players, int window) {
    SessionConfig c;
    c.players = players;
    c.prediction_window = window;
    c.input_delay = window == 0 ? 4 : 2;
    c.handshake = true;
    c.match_id = 0xC0FFEE;
    c.interrupt_us = 750000;
    c.disconnect_us = 5000000;
    return c;
}

struct NetParams {
    std::uint64_t latency_us = 30000;  // one way
    std::uint64_t jitter_us = 0;       // uniform extra delay 0..jitter
    std::uint32_t loss_ppm = 0;
    std::uint32_t duplicate_ppm = 0;
    std::uint32_t reorder_ppm = 0;     // extra delay of 1..3 ticks for this packet
};

// Delivers datagrams at their arrival times; all randomness from one seed.
class TestNet {
public:
    TestNet(NetParams p, std::uint64_t seed) : p_(p), rng_(seed) {}

    void send(PlayerId from, PlayerId to, std::vector<std::uint8_t> bytes, std::uint64_t now) {
        if (chance(p_.loss_ppm)) return;
        const int copies = chance(p_.duplicate_ppm) ? 2 : 1;
        for (int c = 0; c < copies; ++c) {
            std::uint64_t at = now + p_.latency_us + (p_.jitter_us ? rng_.below(p_.jitter_us + 1) : 0);
            if (chance(p_.reorder_ppm)) at += 16667 * (1 + rng_.below(3));
            q_.push({at, seq_++, from, to, bytes});
        }
    }
    std::optional<std::uint64_t> next_time() const {
        if (q_.empty()) return std::nullopt;
        return q_.top().at;
    }
    // Pops every datagram due at or before `now`.
    template <class F>
    void deliver(std::uint64_t now, F&& f) {
        while (!q_.empty() && q_.top().at <= now) {
            Packet pk = q_.top();
            q_.pop();
            f(pk.from, pk.to, pk.bytes, pk.at);
        }
    }
    std::size_t in_flight() const { return q_.size(); }

private:
    struct Packet {
        std::uint64_t at, seq;
        PlayerId from, to;
        std::vector<std::uint8_t> bytes;
        bool operator>(const Packet& o) const { return at != o.at ? at > o.at : seq > o.seq; }
    };
    bool chance(std::uint32_t ppm) { return ppm != 0 && rng_.below(1000000) < ppm; }
    NetParams p_;
    sim::SplitMix64 rng_;
    std::uint64_t seq_ = 0;
    std::priority_queue<Packet, std::vector<Packet>, std::greater<Packet>> q_;
};

// One client: simulation, session, bot, and an observer that records what tests check.
struct Client : SessionObserver {
    Client(const sim::SceneDesc& scene, const SessionConfig& cfg, std::uint64_t bot_seed)
        : sim(scene, cfg.players),
          recorder(header(cfg, sim)),
          bot(bot_seed) {
        session = std::make_unique<Session>(cfg, sim, this);
    }
    static Replay header(const SessionConfig& cfg, WorldSimulation& s) {
        Replay r;
        r.players = static_cast<std::uint32_t>(cfg.players);
        r.input_size = static_cast<std::uint32_t>(cfg.input_size);
        r.tick_rate = static_cast<std::uint32_t>(cfg.tick_rate);
        std::vector<std::uint8_t> st(s.state_size());
        s.save(st);
        r.initial_checksum = s.checksum(st);
        r.scene_name = "test";
        return r;
    }

    void on_frame_simulated(const FrameSimulated& f) override {
        if (f.resimulation) ++resimulated;
        else ++forward;
        if (f.predicted_mask) ++predicted_frames;
        if (!f.resimulation && f.frame <= last_forward) ++forward_order_errors;
        if (!f.resimulation) last_forward = f.frame;
    }
    void on_rollback_end(const RollbackInfo& r) override {
        rollback_depths.push_back(r.depth);
        if (r.displayed_changed()) ++corrections;
    }
    void on_frame_confirmed(const FrameConfirmed& f) override {
        // A joiner starts confirming at its snapshot's frame, a recovering peer confirms again:
        // the replay takes the in-order prefix, `confirmed` every frame's latest checksum.
        if (record_replay && f.frame == recorder.replay().frames() + 1) recorder.add(f);
        confirmed[f.frame] = f.checksum;
        confirmed_inputs[f.frame].assign(f.inputs.begin(), f.inputs.end());
        // Long runs keep a window, so the test's own memory stays flat.
        while (history_limit != 0 && confirmed.size() > history_limit) {
            confirmed_inputs.erase(confirmed.begin()->first);
            confirmed.erase(confirmed.begin());
        }
    }
    void on_desync(const DesyncEvent& e) override { desyncs.push_back(e); }
    void on_desync_report(const DesyncReport& r) override { reports.push_back(r); }
    void on_peer_error(PlayerId p, const std::string&) override { peer_errors.push_back(p); }

    WorldSimulation sim;
    ReplayRecorder recorder;
    WalkBot bot;
    std::unique_ptr<Session> session;
    std::uint64_t forward = 0, resimulated = 0, predicted_frames = 0, corrections = 0, forward_order_errors = 0;
    std::uint32_t last_forward = 0;
    std::vector<std::uint32_t> rollback_depths;
    std::vector<DesyncEvent> desyncs;
    std::vector<DesyncReport> reports;
    std::vector<PlayerId> peer_errors;
    std::map<std::uint32_t, std::uint64_t> confirmed;  // frame -> checksum, every confirmation
    std::map<std::uint32_t, std::vector<std::uint8_t>> confirmed_inputs;  // frame -> inputs of frame - 1
    bool record_replay = true;
    std::size_t history_limit = 0;  // frames kept in `confirmed` (0: all)
    bool frozen = false;       // tests can stop a client from ticking
    bool catches_up = false;   // a joiner or spectator: steps extra frames while behind
    std::int64_t drift_ppm = 0;  // this client's clock runs this much fast (negative: slow)
    std::vector<SessionEvent> events;  // drained after every tick
    int skip_ticks = 0;        // time-sync waits being served
    AdvanceResult last_advance;  // of the latest tick (a test may follow its tick_stretch_ppm)
    std::uint64_t start_offset_us = 0;
    std::uint64_t ticks = 0;
};

// N clients in one discrete-event loop over a TestNet. Client i ticks at
// start_offset + k * 1e6 / tick_rate; datagrams arrive in between.
class Cluster {
public:
    Cluster(const sim::SceneDesc& scene, SessionConfig base, NetParams net, std::uint64_t seed)
        : net_(net, seed ^ 0x5eed), tick_rate_(base.tick_rate) {
        for (int p = 0; p < base.players; ++p) {
            // A guest slot (SessionConfig::slot_hosts) is played by its host's client: no client.
            if (!base.slot_hosts.empty() && base.slot_hosts[static_cast<std::size_t>(p)] != static_cast<PlayerId>(p)) {
                clients.push_back(nullptr);
                continue;
            }
            SessionConfig c = base;
            c.local_player = static_cast<PlayerId>(p);
            if (c.absent_slots >> p & 1) c.role = Role::Joiner;  // its own slot absent: a joiner-to-be
            clients.push_back(std::make_unique<Client>(scene, c, seed * 1000 + static_cast<std::uint64_t>(p)));
        }
    }

    bool obey_time_sync = true;
    // Called before a client ticks (to change delay, inject faults, ...).
    std::function<void(PlayerId, Client&)> before_tick;
    // Lets a test intercept datagrams; return false to drop.
    std::function<bool(PlayerId from, PlayerId to, const std::vector<std::uint8_t>&)> filter;
    // Lets a test alter datagrams a client sends (an attacker's), before the filter sees them.
    std::function<void(PlayerId from, PlayerId to, std::vector<std::uint8_t>&)> rewrite;

    std::uint64_t now() const { return now_; }
    TestNet& net() { return net_; }

    // The process of `id` dies: it stops ticking and nothing reaches it or leaves it any more.
    void kill(PlayerId id) {
        clients[id]->frozen = true;
        if (dead_.size() <= id) dead_.resize(id + 1, false);
        dead_[id] = true;
    }
    // A new process takes id `id` (a rejoin, a late join or a spectator), ticking from now on.
    Client& start(PlayerId id, const sim::SceneDesc& scene, const SessionConfig& cfg, std::uint64_t bot_seed) {
        if (clients.size() <= id) clients.resize(id + 1);
        clients[id] = std::make_unique<Client>(scene, cfg, bot_seed);
        clients[id]->start_offset_us = now_ + 1;
        clients[id]->catches_up = true;
        if (dead_.size() > id) dead_[id] = false;
        return *clients[id];
    }
    bool dead(PlayerId id) const { return id < dead_.size() && dead_[id]; }
    // Whether client i takes part in run_frames / settle (alive, running or about to).
    bool counts(std::size_t i) const {
        return clients[i] && !dead(static_cast<PlayerId>(i)) && !clients[i]->frozen &&
               clients[i]->session->phase() != SessionPhase::Failed;
    }

    // Runs the event loop until `until(*this)` or for at most `limit_us` more virtual µs.
    void run(const std::function<bool(const Cluster&)>& until, std::uint64_t limit_us) {
        const std::uint64_t end = now_ + limit_us;
        while (!until(*this) && now_ <= end) step_event();
    }
    void run_frames(std::uint32_t frames, std::uint64_t limit_us = 600'000'000) {
        run([frames](const Cluster& c) {
                for (std::size_t i = 0; i < c.clients.size(); ++i)
                    if (c.counts(i) && c.clients[i]->session->frame() < frames) return false;
                return true;
            },
            limit_us);
    }
    // Keeps going until every client has confirmed `frame`.
    void settle(std::uint32_t frame, std::uint64_t limit_us = 60'000'000) {
        run([frame](const Cluster& c) {
                for (std::size_t i = 0; i < c.clients.size(); ++i)
                    if (c.counts(i) && c.clients[i]->session->confirmed_frame() < frame) return false;
                return true;
            },
            limit_us);
    }

    void step_event() {
        std::uint64_t next_tick = UINT64_MAX;
        std::size_t who = 0;
        for (std::size_t i = 0; i < clients.size(); ++i) {
            if (!clients[i] || dead(static_cast<PlayerId>(i))) continue;
            const std::uint64_t t = tick_time(*clients[i]);
            if (t < next_tick) {
                next_tick = t;
                who = i;
            }
        }
        const auto arrival = net_.next_time();
        if (arrival && *arrival <= next_tick) {
            now_ = *arrival;
            net_.deliver(now_, [&](PlayerId from, PlayerId to, const std::vector<std::uint8_t>& b, std::uint64_t at) {
                if (to < clients.size() && clients[to] && !dead(to)) clients[to]->session->receive(from, b, at);
            });
            return;
        }
        now_ = next_tick;
        tick(static_cast<PlayerId>(who));
    }

    std::vector<std::unique_ptr<Client>> clients;

private:
    std::uint64_t tick_time(const Client& c) const {
        // A clock running drift_ppm fast ticks that much more often.
        return c.start_offset_us + c.ticks * 1'000'000'000'000ull /
                                       (static_cast<std::uint64_t>(tick_rate_) * static_cast<std::uint64_t>(1'000'000 + c.drift_ppm));
    }
    void tick(PlayerId id) {
        Client& c = *clients[id];
        ++c.ticks;
        if (c.frozen) return;
        if (before_tick) before_tick(id, c);
        if (c.skip_ticks > 0) {
            --c.skip_ticks;
        } else {
            // One bot input per local slot (a host plays its guests' too); a spectator, which
            // has none, passes one as net::PeerRunner does (Session::advance takes at least
            // one: with none, every tick was a bad local input that did nothing, and it moved
            // only by catch_up, which never lets its queues' floors rise).
            in_.clear();
            for (std::size_t k = 0; k < std::max<std::size_t>(c.session->local_slots().size(), 1); ++k) {
                const auto one = c.bot.next();
                in_.insert(in_.end(), one.begin(), one.end());
            }
            const AdvanceResult r = c.session->advance(in_, now_);
            c.last_advance = r;
            if (obey_time_sync) c.skip_ticks = r.wait_frames;
            if (c.catches_up) c.session->catch_up(now_, 16);
        }
        for (SessionEvent e; c.session->next_event(e);) c.events.push_back(e);
        out_.clear();
        c.session->poll(now_, out_);
        for (auto& d : out_) {
            if (rewrite) rewrite(id, d.peer, d.bytes);
            if (filter && !filter(id, d.peer, d.bytes)) continue;
            net_.send(id, d.peer, std::move(d.bytes), now_);
        }
    }

    TestNet net_;
    std::vector<bool> dead_;
    int tick_rate_;
    std::uint64_t now_ = 0;
    std::vector<Datagram> out_;
    std::vector<std::uint8_t> in_;  // a tick's local input: one bot input per local slot
};

// A new process comes into the match `cfg` describes: a joiner for slot `id`, or a spectator.
inline Client& start_newcomer(Cluster& cluster, const sim::SceneDesc& scene, const SessionConfig& cfg, Role role,
                              PlayerId id, std::uint64_t bot_seed) {
    SessionConfig c = cfg;
    c.role = role;
    c.local_player = id;
    return cluster.start(id, scene, c, bot_seed);
}

}  // namespace lockroll::rollback::testing
