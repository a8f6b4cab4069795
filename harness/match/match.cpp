#include "harness/match/match.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <string_view>

#include "harness/match/atomic_file.h"
#include "harness/match/cli_error.h"
#include "harness/match/client_result.h"
#include "harness/match/match_recorder.h"
#include "harness/match/timed_simulation.h"
#include "rollback/desync_evidence.h"
#include "rollback/input_delay.h"
#include "rollback/playing_alone.h"
#include "rollback/session.h"
#include "rollback/world_simulation.h"
#include "sim/rng.h"
#include "transport/sim_network.h"

namespace lockroll::harness {

namespace {

using rollback::PlayerId;

// Thread CPU time: what "CPU per tick" means, unaffected by other processes on a shared box.
std::uint64_t thread_cpu_ns() {
    timespec ts{};
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return static_cast<std::uint64_t>(ts.tv_sec) * 1000000000ull + static_cast<std::uint64_t>(ts.tv_nsec);
}

struct Shared;

class Client final : public rollback::SessionObserver {
public:
    Client(Shared& shared, int index, const RunConfig& cfg, const sim::SceneDesc& scene, int input_delay, int prediction,
           transport::Transport& endpoint, std::int64_t drift_ppm, std::uint64_t start_us);

    void on_frame_simulated(const rollback::FrameSimulated& f) override;
    void on_rollback_begin(const rollback::RollbackInfo& r) override;
    void on_rollback_end(const rollback::RollbackInfo& r) override;
    void on_frame_confirmed(const rollback::FrameConfirmed& f) override;
    void on_desync_report(const rollback::DesyncReport& r) override;
    void on_desync(const rollback::DesyncEvent& e) override;

    std::uint64_t next_tick_us() const {
        // Tick k at start + k / (tick_rate * (1 + drift)) seconds, computed exactly in integers.
        const auto rate_ppm = static_cast<unsigned __int128>(1000000 + drift_ppm_);
        return start_us_ + static_cast<std::uint64_t>(static_cast<unsigned __int128>(tick_) * 1000000u * 1000000u /
                                                      (rate_ppm * static_cast<unsigned>(tick_rate_)));
    }
    void tick(std::uint64_t now);

    // Times the harness's own work inside an observer callback, so that CPU per tick and
    // resimulation CPU can leave it out: they describe the session, not the measuring.
    struct ObserverScope {
        Client& c;
        std::uint64_t t0;
        explicit ObserverScope(Client& client) : c(client), t0(client.cpu_clock_()) {
            if (c.on_observer_) c.on_observer_();
        }
        ~ObserverScope() {
            const std::uint64_t d = c.cpu_clock_() - t0;
            c.observer_ns_ += d;
            if (c.in_rollback_) c.rollback_observer_ns_ += d;
        }
        ObserverScope(const ObserverScope&) = delete;
        ObserverScope& operator=(const ObserverScope&) = delete;
    };
    std::uint64_t observer_ns_ = 0, rollback_observer_ns_ = 0;
    bool in_rollback_ = false;

    Shared& shared_;
    std::function<std::uint64_t()> cpu_clock_;
    std::function<void()> on_observer_;
    int index_;
    int tick_rate_;
    std::int64_t drift_ppm_;
    std::uint64_t start_us_;
    std::uint64_t tick_ = 0;
    int wait_ticks_ = 0;
    std::uint64_t now_ = 0;
    rollback::WorldSimulation sim_;
    MatchRecorder rec_;      // what this client measures, as a real process's recorder does
    TimedSimulation timed_;  // what the session steps: sim_, each step timed
    Bot bot_;
    transport::Transport& endpoint_;
    std::unique_ptr<rollback::Session> session_;
    std::uint64_t reached_target_us_ = 0;
    std::vector<rollback::Datagram> out_;
    transport::Datagram in_;
    transport::SimNetwork* net_ = nullptr;          // for loss events
    // Issue 21: dropped by the others (a healed partition's minority), this client starts again
    // as a joiner of its slot (Session::restart_as_joiner, as net::PeerRunner does) and rejoins
    // by snapshot. partitioned_since_: the open partition episode's frame; the rejoin keeps the
    // one it was dropped in, and the frame of the snapshot it loaded.
    std::optional<std::uint32_t> partitioned_since_, dropped_partitioned_since_, rejoined_at_;
    // Since when a drop left this client the only running voter of its view (the same rule as a
    // real process's runner: rollback/playing_alone.h).
    rollback::AloneSince alone_;
    std::optional<std::uint32_t> alone_at_final_;  // alone_.since() when it confirmed the final
    bool rejoined_ = false;
    void drain_events();
    std::map<int, std::uint64_t> alert_us_;         // peer -> when its checksum alert fired
    std::vector<double> recent_rtt_ms_;             // adaptive delay: last two seconds, ring
    std::size_t recent_next_ = 0;
    void adapt_delay();
    void event(const char* kind, double value) {
        shared_result().events.push_back({seconds(now_), index_, session_->frame(), kind, value});
    }
    RunResult& shared_result();
    double seconds(std::uint64_t t) const;
};

struct Shared {
    const RunConfig& cfg;
    std::vector<Client*> all;  // every client, by index
    int target;
    int clients;
    std::uint64_t start_us;
    PositionErrorTracker positions;
    RunResult& result;
};

Client::Client(Shared& shared, int index, const RunConfig& cfg, const sim::SceneDesc& scene, int input_delay,
               int prediction, transport::Transport& endpoint, std::int64_t drift_ppm, std::uint64_t start_us)
    : shared_(shared),
      cpu_clock_(cfg.cpu_clock ? cfg.cpu_clock : std::function<std::uint64_t()>(thread_cpu_ns)),
      on_observer_(cfg.on_observer),
      index_(index),
      tick_rate_(cfg.tick_rate),
      drift_ppm_(drift_ppm),
      start_us_(start_us),
      sim_(scene, cfg.players),
      rec_(index, cfg.players, static_cast<std::uint32_t>(cfg.frames), sim_, true, false),
      timed_(sim_, cpu_clock_, rec_.physics_step_us()),
      bot_(BotConfig{cfg.bot, cfg.seed, cfg.tick_rate, 4.0}, index),
      endpoint_(endpoint) {
    rollback::SessionConfig sc;
    sc.players = cfg.players;
    sc.local_player = static_cast<PlayerId>(index);
    sc.input_size = rollback::kWorldInputSize;
    sc.tick_rate = cfg.tick_rate;
    sc.input_delay = input_delay;
    sc.prediction_window = prediction;
    sc.checksum_interval = cfg.checksum_interval;
    sc.cpu_clock = cpu_clock_;
    session_ = std::make_unique<rollback::Session>(sc, timed_, this);
    rec_.frame0_shown(start_us - 1000000 / static_cast<std::uint64_t>(cfg.tick_rate));
}

RunResult& Client::shared_result() { return shared_.result; }
double Client::seconds(std::uint64_t t) const { return static_cast<double>(t - shared_.start_us) / 1e6; }

void Client::on_frame_simulated(const rollback::FrameSimulated& f) {
    const ObserverScope scope(*this);
    Shared& s = shared_;
    if (f.frame > static_cast<std::uint32_t>(s.target)) return;
    if (const std::vector<sim::Vec3>* shown = rec_.frame_simulated(now_, f)) {
        // Set before record(): when client 0 is the last to show the frame, record() reduces
        // the row at once.
        if (index_ == 0) s.positions.set_tick_rate(f.frame, rec_.recent_tick_rate(tick_rate_));
        s.positions.record(index_, f.frame, static_cast<double>(now_ - s.start_us) / 1e6, *shown);
    }
}

void Client::on_rollback_begin(const rollback::RollbackInfo&) {
    in_rollback_ = true;  // inside the session's resimulation timing until on_rollback_end
    const ObserverScope scope(*this);
    rec_.rollback_begin();
}

void Client::on_rollback_end(const rollback::RollbackInfo& r) {
    in_rollback_ = false;
    const ObserverScope scope(*this);
    if (r.displayed_frame > static_cast<std::uint32_t>(shared_.target)) return;
    const std::optional<double> jump = rec_.rollback_end(r);
    shared_.positions.note_rollback(r.displayed_frame, r.depth);
    event("rollback", r.depth);
    if (jump) event("correction", *jump);
}

void Client::on_frame_confirmed(const rollback::FrameConfirmed& f) {
    const ObserverScope scope(*this);
    if (f.frame > static_cast<std::uint32_t>(shared_.target)) return;
    rec_.frame_confirmed(f, session_->saved_state(f.frame));
    if (index_ == 0 && shared_.cfg.record_inputs) {
        shared_.result.confirmed_inputs.emplace_back(f.inputs.begin(), f.inputs.end());
        shared_.result.confirmed_checksums.push_back(f.checksum);
    }
}

void Client::on_desync_report(const rollback::DesyncReport& r) {
    const ObserverScope scope(*this);
    DesyncRecord rec;
    rec.client = index_;
    rec.summary = r.summary;
    rec.detected_frame = r.detected_frame;
    rec.frame = r.frame;
    rec.body = r.body_id;
    rec.field = r.field_name;
    // The diverging frame was first shown by whichever client showed it first.
    std::uint64_t first_shown = now_;
    for (const Client* c : shared_.all) {
        const ShownTimes& shown = c->rec_.samples().shown;  // frames 0, 1, 2, ... in order
        if (r.frame < shown.size()) first_shown = std::min(first_shown, shown[r.frame].second);
    }
    const auto alert = alert_us_.find(static_cast<int>(r.peer));
    rec.alert_ms = static_cast<double>((alert != alert_us_.end() ? alert->second : now_) - first_shown) / 1000.0;
    rec.report_ms = static_cast<double>(now_ - first_shown) / 1000.0;
    if (!shared_.cfg.evidence_dir.empty() && !r.local_state.empty()) {
        const auto path = std::filesystem::path(shared_.cfg.evidence_dir) /
                          rollback::desync_evidence_file_name(static_cast<rollback::PlayerId>(index_), r);
        std::filesystem::create_directories(path.parent_path());  // only now: no empty dir after a clean run
        write_file_atomic(path, rollback::desync_evidence_text(r, sim_));
        rec.evidence_file = path.string();
    }
    shared_.result.desyncs.push_back(rec);
}

void Client::on_desync(const rollback::DesyncEvent& e) {
    const ObserverScope scope(*this);
    alert_us_.emplace(static_cast<int>(e.peer), now_);
}

void Client::adapt_delay() {
    const rollback::SessionStats& st = session_->stats();
    std::uint64_t worst = 0;
    for (std::size_t p = 0; p < st.peers.size(); ++p)
        if (static_cast<int>(p) != index_) worst = std::max(worst, st.peers[p].rtt_us);
    if (worst == 0) return;
    const std::size_t keep = 2 * static_cast<std::size_t>(tick_rate_);
    if (recent_rtt_ms_.size() < keep)
        recent_rtt_ms_.push_back(static_cast<double>(worst) / 1000.0);
    else
        recent_rtt_ms_[recent_next_++ % keep] = static_cast<double>(worst) / 1000.0;
    if (recent_rtt_ms_.size() < keep || tick_ % static_cast<std::uint64_t>(tick_rate_) != 0) return;
    std::vector<double> v = recent_rtt_ms_;
    std::sort(v.begin(), v.end());
    const double p50 = v[v.size() / 2], p95 = v[std::min(v.size() - 1, v.size() * 95 / 100)];
    double deviation = 0;
    for (double x : v) deviation += std::abs(x - p50);
    deviation /= static_cast<double>(v.size());
    const int target = adaptive_input_delay(shared_.cfg.mode, p50, p95 + 2 * deviation, tick_rate_,
                                            session_->config().prediction_window);
    if (target == session_->input_delay()) return;
    session_->set_input_delay(target);
    ++shared_.result.input_delay_changes;
    event("delay_change", target);
}

void Client::tick(std::uint64_t now) {
    now_ = now;
    while (endpoint_.receive(in_, now)) session_->receive(static_cast<PlayerId>(in_.from), in_.bytes, now);
    RunResult& res = shared_.result;
    // Clients keep advancing past the last frame until every client has confirmed it (the
    // run loop stops then): the corrections that make it final happen inside advance(). Only
    // frames up to the target are measured.
    {
        if (wait_ticks_ > 0) {
            --wait_ticks_;
        } else {
            const std::uint32_t input_frame = session_->frame() + static_cast<std::uint32_t>(session_->input_delay());
            const sim::PlayerInput in = bot_.input(input_frame, sim_.world());
            const auto bytes = rollback::encode_input(in);
            const std::uint64_t obs0 = observer_ns_, robs0 = rollback_observer_ns_;
            const std::uint64_t t0 = cpu_clock_();
            const rollback::AdvanceResult r = session_->advance(bytes, now);
            const std::uint64_t spent = cpu_clock_() - t0, observed = observer_ns_ - obs0;
            const std::uint64_t resim_observed = rollback_observer_ns_ - robs0;
            rec_.tick(static_cast<double>(spent - std::min(spent, observed)) / 1000.0,
                      static_cast<double>(r.resim_ns - std::min(r.resim_ns, resim_observed)) / 1000.0);
            // The recorder times input changes until they show, here and (remote_input_latency,
            // at the end) on every peer.
            rec_.input_offered(now, input_frame, bytes);
            wait_ticks_ = r.wait_frames;
            if (!r.advanced) event("stall", r.blocking_player);
            res.input_delay_used.add(session_->input_delay());
            if (shared_.cfg.adaptive_delay) adapt_delay();
            if (r.wait_frames > 0) event("time_sync_wait", r.wait_frames);
            if (session_->frame() <= static_cast<std::uint32_t>(shared_.target)) {
                res.time_sync.push_back({seconds(now), index_, session_->frame(),
                                         session_->frames_ahead_x100() / 100.0, r.wait_frames});
                const rollback::SessionStats& st = session_->stats();
                for (std::size_t p = 0; p < st.peers.size(); ++p)
                    if (static_cast<int>(p) != index_ && st.peers[p].rtt_us > 0)
                        rec_.rtt(static_cast<int>(p), static_cast<double>(st.peers[p].rtt_us) / 1000.0);
            }
            if (session_->frame() == static_cast<std::uint32_t>(shared_.target) && r.advanced) reached_target_us_ = now;
            // A rejoined client starts behind the match, from a snapshot: it catches up faster
            // than real time, as a real process's runner steps a joiner.
            if (session_->config().role == rollback::Role::Joiner && session_->running() && session_->behind(now) > 0)
                session_->catch_up(now, 8);
        }
    }
    out_.clear();
    session_->poll(now, out_);
    for (const auto& d : out_) {
        const transport::LinkStats& ls = net_->link_stats(static_cast<transport::PeerId>(index_), d.peer);
        const std::uint64_t lost = ls.lost_random + ls.lost_burst + ls.lost_queue, cut = ls.lost_partition;
        endpoint_.send(d.peer, d.bytes, now);
        if (ls.lost_random + ls.lost_burst + ls.lost_queue != lost) event("loss", d.peer);
        if (ls.lost_partition != cut) event("partition", d.peer);
    }
    drain_events();
    ++tick_;
}

// The session's events, for the partition episodes and a rejoin after a drop: the rule is the
// session's (can_rejoin, rollback/rejoin.h), the rebuild in place restart_as_joiner()'s.
void Client::drain_events() {
    using K = rollback::SessionEvent::Kind;
    bool kicked = false;
    for (rollback::SessionEvent e; session_->next_event(e);) {
        if (e.kind == K::Partitioned && !partitioned_since_) partitioned_since_ = e.frame;
        if (e.kind == K::SnapshotLoaded && rejoined_ && !rejoined_at_) rejoined_at_ = e.frame;
        kicked = kicked || e.kind == K::Kicked;
        alone_.saw(e, session_->config().players);
    }
    alone_.settle(rollback::running_voters(*session_), session_->config().local_player);
    // The event gives the frame; should it have been lost (a full event queue), the session's
    // state still opens the episode, at its confirmed frame, as a real process's runner does.
    if (!partitioned_since_ && session_->partitioned()) partitioned_since_ = session_->confirmed_frame();
    // As of its final, as a real process says it: the match runs on for the others' sake.
    if (!rec_.final_checksum()) alone_at_final_ = alone_.since();
    if (!session_->partitioned() && session_->running() && partitioned_since_ && session_->confirmed_frame() > *partitioned_since_)
        partitioned_since_.reset();  // healed: confirming frames again
    if (!kicked || !session_->can_rejoin()) return;
    const std::optional<std::uint32_t> since = partitioned_since_;
    if (!session_->restart_as_joiner()) return;
    dropped_partitioned_since_ = since;
    rejoined_ = true;
    rejoined_at_.reset();
    wait_ticks_ = 0;
    event("rejoin", since.value_or(0));
}

// Ping phase for --input-delay auto: every client pings every other every 50 ms for one second
// of virtual time over the same links; returns the round-trip samples in ms.
std::vector<double> measure_rtt(transport::SimNetwork& net, int clients) {
    std::vector<double> rtts;
    constexpr transport::Micros kInterval = 50000, kDuration = 1000000, kDrain = 2000000;
    transport::Datagram d;
    for (transport::Micros t = 0; t <= kDuration + kDrain; t += 1000) {
        for (int c = 0; c < clients; ++c) {
            transport::Transport& ep = net.endpoint(static_cast<transport::PeerId>(c));
            while (ep.receive(d, t)) {
                if (d.bytes.size() != 9) continue;
                std::uint64_t sent = 0;
                for (int i = 0; i < 8; ++i) sent |= std::uint64_t{d.bytes[static_cast<std::size_t>(1 + i)]} << (8 * i);
                if (d.bytes[0] == 0) {  // ping: echo it back as a pong
                    d.bytes[0] = 1;
                    ep.send(d.from, d.bytes, t);
                } else {
                    rtts.push_back(static_cast<double>(t - sent) / 1000.0);
                }
            }
            if (t <= kDuration && t % kInterval == 0)
                for (int o = 0; o < clients; ++o) {
                    if (o == c) continue;
                    std::vector<std::uint8_t> ping(9, 0);
                    for (int i = 0; i < 8; ++i) ping[static_cast<std::size_t>(1 + i)] = static_cast<std::uint8_t>(t >> (8 * i));
                    ep.send(static_cast<transport::PeerId>(o), ping, t);
                }
        }
        if (t > kDuration && net.in_flight() == 0) break;
    }
    return rtts;
}

double to_m(sim::Fixed f) { return static_cast<double>(f.raw) / 4294967296.0; }


double percentile(std::vector<double> v, double p) {
    if (v.empty()) return 0;
    std::sort(v.begin(), v.end());
    const auto k = static_cast<std::size_t>(std::ceil(p / 100.0 * static_cast<double>(v.size())));
    return v[std::min(v.size() - 1, k == 0 ? 0 : k - 1)];
}

}  // namespace

transport::LinkConditions link_for(const NetConditions& n) {
    const auto to_us = [](double ms) { return static_cast<transport::Micros>(std::llround(ms * 1000.0)); };
    transport::LinkConditions l;
    l.latency_us = to_us(n.latency_ms);
    l.jitter_us = to_us(n.jitter_ms);
    l.loss = n.loss;
    l.duplicate = n.duplicate;
    l.reorder = n.reorder;
    if (n.burst_loss > 0) {
        l.burst_enter = n.burst_loss;
        l.burst_exit = 0.5;
        l.burst_loss = 1.0;
    }
    return l;
}

void validate(const NetConditions& n) {
    auto fail = [](const std::string& m) { throw UsageError(m); };
    if (!(n.latency_ms >= 0 && n.latency_ms <= 10000)) fail("--latency must be 0..10000 ms");
    if (!(n.jitter_ms >= 0 && n.jitter_ms <= n.latency_ms + 1e-9 + 10000)) fail("--jitter must be >= 0 ms");
    for (auto [v, name] : {std::pair{n.loss, "--loss"}, {n.duplicate, "--duplicate"}, {n.reorder, "--reorder"},
                           {n.burst_loss, "--burst-loss"}})
        if (!(v >= 0 && v <= 1)) fail(std::string(name) + " must be a probability in [0, 1]");
    if (n.loss >= 1) fail("--loss must be below 1 (nothing would ever arrive)");
    if (const std::string e = transport::validate(link_for(n)); !e.empty()) fail("network: " + e);
}

std::string injection_error(const sim::SceneDesc& scene, int players, const DesyncInjection& d) {
    if (d.client < 0 || d.client >= players) return "CLIENT must be 0..players-1";
    rollback::WorldSimulation sim(scene, players);
    rollback::SessionConfig sc;
    sc.players = players;
    sc.local_player = static_cast<PlayerId>(d.client);
    sc.input_size = rollback::kWorldInputSize;
    sc.tick_rate = scene.tick_rate > 0 ? scene.tick_rate : 60;
    rollback::Session session(sc, sim);
    return session.inject_fault(d.frame, d.body, d.field, d.bit);
}

const char* mode_name(Mode m) { return m == Mode::Lockstep ? "lockstep" : "rollback"; }

void validate(const RunConfig& c) {
    auto fail = [](const std::string& m) { throw UsageError(m); };
    if (c.players < 2 || c.players > 16) fail("--players must be 2..16");
    if (c.frames < 1) fail("--frames must be >= 1");
    if (c.tick_rate < 1 || c.tick_rate > 1000) fail("--tick-rate must be 1..1000");
    if (c.input_delay < -1 || c.input_delay > 60) fail("--input-delay must be 0..60 or auto");
    if (c.prediction < 1 || c.prediction > 60) fail("--prediction must be 1..60 (lockstep mode uses 0 itself)");
    if (c.checksum_interval < 1 || c.checksum_interval > 65535) fail("--checksum-interval must be 1..65535");
    validate(c.net);
    if (!(c.drift_ppm >= 0 && c.drift_ppm <= 10000)) fail("--drift-ppm must be 0..10000");
    for (const auto& inj : c.injections)
        if (inj.client < 0 || inj.client >= c.players) fail("--inject-desync: client must be 0..players-1");
    if (const std::string e = c.partitions.check_slots(c.players); !e.empty()) fail("--partition: " + e);
}

sim::SceneDesc with_players(const sim::SceneDesc& scene, int players) {
    sim::SceneDesc s = scene;
    int have = sim::player_count(s);
    const sim::BodyDesc* last = nullptr;
    for (const auto& b : s.bodies)
        if (b.player == have - 1) last = &b;
    sim::BodyDesc proto;
    if (last) {
        proto = *last;
    } else {
        proto.shape = sim::Shape::Box;
        proto.half_extents = {*sim::Fixed::parse("0.4"), *sim::Fixed::parse("0.9"), *sim::Fixed::parse("0.4")};
        proto.position = {sim::Fixed::zero(), *sim::Fixed::parse("0.9"), sim::Fixed::zero()};
        proto.mass = sim::Fixed::from_int(5);
    }
    const sim::Fixed step = *sim::Fixed::parse("1.5");
    for (int k = 1; have < players; ++have, ++k) {
        sim::BodyDesc b = proto;
        b.player = have;
        b.velocity = {};
        b.position.z = proto.position.z + step * static_cast<std::int64_t>(k % 2 ? (k + 1) / 2 : -(k / 2));
        s.bodies.push_back(b);
    }
    return s;
}

// Both delays are rollback/input_delay.h's policy; the harness only turns its round-trip
// percentile (ms) into the one-way reach (us) the policy takes.
static std::uint64_t one_way_reach_us(double rtt_ms) { return static_cast<std::uint64_t>(std::llround(std::max(0.0, rtt_ms) * 500.0)); }

int auto_input_delay(Mode mode, double rtt_p50_ms, double rtt_p95_ms, int tick_rate) {
    (void)rtt_p50_ms;
    return rollback::auto_input_delay(mode == Mode::Lockstep ? 0 : 1, one_way_reach_us(rtt_p95_ms), tick_rate);
}

int adaptive_input_delay(Mode mode, double rtt_p50_ms, double rtt_p95_ms, int tick_rate, int window) {
    (void)rtt_p50_ms;
    return rollback::adaptive_input_delay(mode == Mode::Lockstep ? 0 : std::max(window, 1), one_way_reach_us(rtt_p95_ms), tick_rate);
}

int auto_prediction_window(int configured, int lockstep_delay, int rollback_delay) {
    return std::min(60, std::max(configured, lockstep_delay - rollback_delay + 1));
}

std::string bodies_csv(const sim::World& w) {
    std::string out = "index,id,player,dynamic,shape,x,z,radius,hx,hz\n";
    char line[256];
    std::vector<long> index(w.body_count(), -1);
    for (std::size_t i = 0; i < w.dynamic_ids().size(); ++i) index[w.dynamic_ids()[i]] = static_cast<long>(i);
    for (std::size_t id = 0; id < w.body_count(); ++id) {
        const sim::BodyDesc& b = w.scene().bodies[id];
        const char* shape = b.shape == sim::Shape::Box ? "box" : b.shape == sim::Shape::Sphere ? "sphere" : "capsule";
        std::snprintf(line, sizeof line, "%ld,%zu,%d,%d,%s,%.6f,%.6f,%.6f,%.6f,%.6f\n", index[id], id, b.player,
                      index[id] >= 0 ? 1 : 0, shape, to_m(b.position.x), to_m(b.position.z), to_m(b.radius),
                      to_m(b.half_extents.x), to_m(b.half_extents.z));
        out += line;
    }
    return out;
}

// Everything a match holds between ticks. The network is built in place (it is neither copyable
// nor movable) and outlives the clients, whose endpoints refer to it.
struct Match::State {
    RunConfig cfg;
    sim::SceneDesc scene;
    transport::SimNetwork net;
    RunResult res;
    std::unique_ptr<Shared> shared;
    std::vector<std::unique_ptr<Client>> clients;
    std::uint64_t start = 0, limit = 0, now = 0;
    int last_progress = -1;
    bool timed_out = false;

    State(const RunConfig& config, sim::SceneDesc s)
        : cfg(config), scene(std::move(s)), net({.peers = cfg.players, .seed = cfg.seed, .link = link_for(cfg.net)}) {}

    // The client whose tick comes next (the lowest index on a tie).
    Client& next_client() const {
        Client* next = clients[0].get();
        for (const auto& c : clients)
            if (c->next_tick_us() < next->next_tick_us()) next = c.get();
        return *next;
    }
};

namespace {

sim::SceneDesc match_scene(const RunConfig& cfg) {
    validate(cfg);
    sim::SceneDesc scene = with_players(cfg.scene, cfg.players);
    scene.tick_rate = cfg.tick_rate;
    if (const std::string e = sim::validate(scene); !e.empty()) throw UsageError("scene: " + e);
    return scene;
}

}  // namespace

Match::Match(const RunConfig& config) : s_(std::make_unique<State>(config, match_scene(config))) {
    const RunConfig& cfg = s_->cfg;
    const sim::SceneDesc& scene = s_->scene;
    transport::SimNetwork& net = s_->net;
    RunResult& res = s_->res;
    res.mode = mode_name(cfg.mode);
    res.scene = scene.name;
    res.bot = bot_kind_name(cfg.bot);
    res.players = cfg.players;
    res.frames = cfg.frames;
    res.tick_rate = cfg.tick_rate;
    res.prediction = cfg.mode == Mode::Lockstep ? 0 : cfg.prediction;
    res.seed = cfg.seed;
    res.latency_ms = cfg.net.latency_ms;
    res.jitter_ms = cfg.net.jitter_ms;
    res.loss = cfg.net.loss;
    res.duplicate = cfg.net.duplicate;
    res.reorder = cfg.net.reorder;
    res.burst_loss = cfg.net.burst_loss;
    res.adaptive_delay = cfg.adaptive_delay;

    const std::vector<double> rtts = measure_rtt(net, cfg.players);
    res.rtt_p50_ms = percentile(rtts, 50);
    res.rtt_p95_ms = percentile(rtts, 95);
    res.input_delay = cfg.input_delay >= 0 ? cfg.input_delay
                                           : auto_input_delay(cfg.mode, res.rtt_p50_ms, res.rtt_p95_ms, cfg.tick_rate);
    if (cfg.input_delay < 0 && cfg.mode == Mode::Rollback)
        res.prediction = auto_prediction_window(
            cfg.prediction, auto_input_delay(Mode::Lockstep, res.rtt_p50_ms, res.rtt_p95_ms, cfg.tick_rate), res.input_delay);

    // The match starts after the ping phase; clients start within one tick of each other and
    // drift by a seeded amount, so time sync has real work to do.
    const std::uint64_t start = 4000000;
    // Frame 0 of --partition is the match's start; nothing is cut when none was given.
    if (!cfg.partitions.empty()) net.set_partitions(cfg.partitions.shifted(start));
    sim::SplitMix64 rng(cfg.seed ^ 0xC10C4u);
    const std::size_t bodies = sim::World(scene).dynamic_count();
    s_->shared.reset(new Shared{cfg, {}, cfg.frames, cfg.players, start,
                                PositionErrorTracker(cfg.players, bodies, cfg.record_positions), res});
    Shared& shared = *s_->shared;
    std::vector<std::unique_ptr<Client>>& clients = s_->clients;
    const auto tick_us = static_cast<std::uint64_t>(1000000 / cfg.tick_rate);
    const auto drift_range = static_cast<std::uint64_t>(std::llround(cfg.drift_ppm));
    for (int c = 0; c < cfg.players; ++c) {
        const std::uint64_t offset = rng.below(tick_us);
        const std::int64_t drift = drift_range ? static_cast<std::int64_t>(rng.below(2 * drift_range + 1)) -
                                                     static_cast<std::int64_t>(drift_range)
                                               : 0;
        clients.push_back(std::make_unique<Client>(shared, c, cfg, scene, res.input_delay, res.prediction,
                                                   net.endpoint(static_cast<transport::PeerId>(c)), drift, start + offset));
    }
    if (cfg.record_inputs) {
        std::vector<std::uint8_t> state(clients[0]->sim_.state_size());
        clients[0]->sim_.save(state);
        res.initial_checksum = clients[0]->sim_.checksum(state);
    }
    for (const auto& c : clients) {
        shared.all.push_back(c.get());
        c->net_ = &net;
    }
    {
        const sim::World w(scene);
        if (cfg.record_positions) res.bodies_csv = bodies_csv(w);
        res.body_ids.assign(w.dynamic_ids().begin(), w.dynamic_ids().end());
        res.body_player.assign(res.body_ids.size(), -1);
        for (int p = 0; p < w.player_count(); ++p)
            for (std::size_t b = 0; b < res.body_ids.size(); ++b)
                if (res.body_ids[b] == w.player_body(p)) res.body_player[b] = p;
    }
    for (const auto& inj : cfg.injections) {
        const std::string e = clients[static_cast<std::size_t>(inj.client)]->session_->inject_fault(
            inj.frame, inj.body, inj.field, inj.bit);
        if (!e.empty()) throw UsageError("--inject-desync " + std::to_string(inj.client) + ":" + std::to_string(inj.frame) +
                                         ":" + std::to_string(inj.body) + ": " + e);
    }

    // Stop when every client has confirmed the last frame, or at a generous time limit (a
    // network that loses everything must end the run, reported as incomplete).
    s_->start = start;
    s_->limit = start + static_cast<std::uint64_t>(cfg.frames) * tick_us * 10 + 30000000;
    s_->now = start;
}

Match::~Match() = default;

bool Match::finished() const {
    if (s_->timed_out) return true;
    for (const auto& c : s_->clients)
        if (!c->rec_.final_checksum()) return false;
    return true;
}

std::uint64_t Match::next_tick_us() const { return s_->next_client().next_tick_us(); }

void Match::step() {
    if (finished()) return;
    Client& next = s_->next_client();
    s_->now = next.next_tick_us();
    if (s_->now > s_->limit) {
        s_->timed_out = true;
        return;
    }
    next.tick(s_->now);
    if (s_->cfg.progress && next.index_ == 0) {
        const int shown = static_cast<int>(next.session_->frame());
        if (shown / 60 != s_->last_progress / 60) {
            s_->cfg.progress(shown, s_->cfg.frames);
            s_->last_progress = shown;
        }
    }
}

std::uint64_t Match::now_us() const { return s_->now; }
std::uint64_t Match::start_us() const { return s_->start; }
int Match::clients() const { return static_cast<int>(s_->clients.size()); }
int Match::input_delay() const { return static_cast<int>(s_->res.input_delay); }
int Match::prediction() const { return static_cast<int>(s_->res.prediction); }

const sim::World& Match::world(int client) const { return s_->clients.at(static_cast<std::size_t>(client))->sim_.world(); }

std::uint32_t Match::frame(int client) const {
    return s_->clients.at(static_cast<std::size_t>(client))->session_->frame();
}

const rollback::SessionStats& Match::stats(int client) const {
    return s_->clients.at(static_cast<std::size_t>(client))->session_->stats();
}

std::optional<std::uint64_t> Match::final_checksum(int client) const {
    const Client& c = *s_->clients.at(static_cast<std::size_t>(client));
    return c.rec_.final_checksum();
}

const std::vector<FrameRow>& Match::rows() const { return s_->shared->positions.rows(); }

void Match::set_conditions(const NetConditions& n) {
    validate(n);
    s_->net.set_all_links(link_for(n));
}

RunResult Match::finish() {
    const RunConfig& cfg = s_->cfg;
    RunResult& res = s_->res;
    const std::uint64_t now = s_->now;
    res.completed = true;
    res.virtual_seconds = 0;
    // Stats count every tick, including the few after the last frame spent confirming it.
    for (const auto& c : s_->clients) {
        const rollback::SessionStats& st = c->session_->stats();
        ClientResult cr = client_result(st);
        // Tick rate and stalls from when frames were shown, as a real process's (tick_figures).
        // Frame 0 counts as shown one period before frame 1 (the first tick): N frames take N
        // periods.
        const TickFigures tf = tick_figures(c->rec_.samples().shown, cfg.tick_rate);
        cr.ticks_per_second = tf.ticks_per_second;
        cr.stall_fraction = tf.stall_fraction;
        cr.final_checksum = c->rec_.final_checksum().value_or(0);
        cr.final_confirmed = c->rec_.final_checksum().has_value();
        cr.alone_since_frame = c->alone_at_final_;
        if (c->rejoined_at_) {
            cr.rejoined_at_frame = c->rejoined_at_;
            cr.partitioned_since_frame = c->dropped_partitioned_since_;
        }
        // Issue 21: cut off from a majority and not healed when the match ended (the others
        // finished, or the time limit came), it never confirmed the last frame: partitioned, with
        // the episode's frame, never completed. A real process's runner says the same (RunEnd).
        if (cr.final_confirmed) {
            cr.outcome = "completed";
        } else if (c->partitioned_since_) {
            cr.outcome = "partitioned";
            cr.partitioned_since_frame = c->partitioned_since_;
        } else {
            cr.outcome = "incomplete";
        }
        res.completed = res.completed && cr.final_confirmed;
        res.virtual_seconds = std::max(res.virtual_seconds, static_cast<double>(now - c->start_us_) / 1e6);
        res.clients.push_back(cr);
    }
    // The recorders' samples: the same reduction as a real-process run's (add_client_samples).
    std::vector<const RecordedSamples*> recorded;
    for (const auto& c : s_->clients) {
        const RecordedSamples& m = c->rec_.samples();
        recorded.push_back(&m);
        add_client_samples(res, m);
        for (int p = 0; p < cfg.players; ++p) {
            if (p == c->index_) continue;
            const auto it = m.rtt_ms.find(p);
            res.rtt.push_back(PeerRtt{c->index_, p, it != m.rtt_ms.end() ? it->second : Stat::keeping_samples()});
        }
    }
    res.input_latency_remote = remote_input_latency(recorded);
    const auto [compared, mismatches] = confirmed_agreement(recorded);
    res.confirmed_compared = compared;
    res.confirmed_mismatches = mismatches;
    res.input_delay_min = static_cast<int>(res.input_delay);
    res.input_delay_max = res.input_delay_min;
    for (const auto& e : res.events)
        if (std::string_view(e.kind) == "delay_change") {
            res.input_delay_min = std::min(res.input_delay_min, static_cast<int>(e.value));
            res.input_delay_max = std::max(res.input_delay_max, static_cast<int>(e.value));
        }
    PositionErrorTracker& positions = s_->shared->positions;
    positions.finish();  // an incomplete run: the frames only some clients showed count too
    res.position_error = positions.error();
    res.rows = positions.rows();
    res.positions_csv = positions.positions_csv();
    res.per_body_max_error = positions.per_body_max();
    res.pair_error = positions.pair_errors();
    res.body_error = positions.body_errors();
    res.partition_cuts = cfg.partitions.cuts().size();
    res.partitioned_datagrams = 0;
    for (int from = 0; from < cfg.players; ++from)
        for (int to = 0; to < cfg.players; ++to)
            res.partitioned_datagrams += s_->net.link_stats(static_cast<transport::PeerId>(from), static_cast<transport::PeerId>(to)).lost_partition;
    return std::move(res);
}

RunResult run_match(const RunConfig& cfg) {
    Match match(cfg);
    while (!match.finished()) match.step();
    return match.finish();
}

}  // namespace lockroll::harness
