// PeerRunner: one sans-IO rollback::Session bound to a real transport (any transport::Transport:
// ENet over UDP by default through the builder, or the game's own) and to the monotonic clock,
// run at the tick rate. This is the real-time twin of harness/match (which runs
// N sessions in one process in virtual time); it knows nothing of sim/ or harness/: the game is
// whatever Simulation the caller built the Session on, and local input comes from a callback.
//
// Contract
//  - Connections: a player (joiners too) connects to every higher peer id it has an address
//    for, a spectator (highest ids, address known to nobody) to every peer, retrying for the
//    whole run while not connected (the transport lets a restarted process take its id back),
//    so a killed and restarted peer is reconnected by the lower survivors. Retries back off
//    (net/redial_backoff.h): at once, then 0.5 s doubling to a cap of 4 s per peer, starting
//    over once the peer was connected again; so a gone address costs 18 dials in its first
//    minute, not 120, and a restarted peer or a healed partition is dialed again at most 4 s
//    after it is back. A dial connect() refuses (the last attempt still pending) is not
//    charged, and a slot the session reports joined is due at once (its process is back).
//  - Start: with a handshaking session (SessionConfig::handshake) the session's own hello/RTT
//    phase is the start barrier and the runner ticks from the beginning; without one, the runner
//    waits until every remote slot is connected and then starts frame 0. Either way the session
//    must be running within connect_timeout_us ("synchronized" is when it first runs).
//  - Each tick: drain the transport -> Session::receive(from, bytes, arrival time) -> local
//    input for frame() + input_delay() -> Session::advance -> catch_up() while behind() (a
//    joiner after its snapshot; players are evened out by time sync instead) -> drain Session::next_event() -> Session::poll -> transport
//    send (send_reliable for datagrams the session marks reliable; those for a peer not yet
//    connected -- snapshot requests and chunks -- are held, the newest 64 per peer, and sent in
//    order once it connects; hellos and welcomes are unreliable and never held: they carry their
//    send time for the round trip, and the session resends hellos until welcomed, so the
//    start-up RTT is the network's from the connection's start).
//  - Time sync without hitches: the session's tick_stretch_ppm lengthens the next tick (at most
//    max_stretch); a session that only says wait_frames has that many frames of time repaid by
//    lengthening the following ticks by at most max_stretch -- never by skipping whole ticks (a
//    visible freeze). A newer wait recommendation replaces the unpaid rest.
//  - The game's loop or the runner's: update() is one non-blocking step (service the transport,
//    run the ticks that are due, report them), for a game that owns its loop and calls it once
//    per frame at any rate; run() is update() and wait() until the run is over. run() never
//    busy-spins: between ticks it sleeps, waking every service_interval_us to let the transport
//    answer pings and stamp arrivals. A tick that is late runs at once; more than max_catch_up
//    ticks behind, the schedule restarts from now (a frozen process does not then fast-forward
//    in a burst).
//  - Finishing: target_frame is the last frame simulated (Session::set_last_frame): after
//    showing it it keeps ticking (receiving, advancing without stepping, polling, so resends and
//    corrections still flow) until it has confirmed target_frame and every running,
//    connected player slot has acknowledged its inputs up to target_frame (so it can confirm it
//    too); dropped slots, disconnected peers and spectators are not waited for (spectators send
//    no inputs and get the last ones from the resends while the players linger). Then it lingers
//    linger_us more so its last acknowledgements reach the others. Bounded by
//    finish_timeout_us after showing the target, and by run_timeout_us overall.
//  - A session that fails (refused handshake, desync beyond its recoveries) ends run() with
//    Failed. A session the others dropped (`kicked`: a healed partition's minority, or a
//    restarted player's process refused as dropped) is not an end while rejoin_when_dropped:
//    the runner starts it again in place as a joiner of its slot (Session::restart_as_joiner,
//    rollback/rejoin.h decides whether it can) on the same transport, and it rejoins by a
//    snapshot vetted by the majority's confirmed checksum, then catches up; nobody pauses. The
//    `failed` that followed the `kicked` is not passed on (the run goes on), nor is the `kicked`
//    of a session that never ran (a restart: the game never saw it play). rejoined() says when.
//    The run then ends as any other: completed only once it showed and confirmed the last
//    frame on the majority's view.
//  - Partitioned: a run that would end (completed, finish or run timeout) while the session is
//    partitioned and not healed ends Partitioned; a partitioned session waits for the network to
//    heal only until the match should have been over plus finish_timeout_us (RunEnd). A joiner
//    (started with join, or rejoining after a drop) is partitioned when it cannot reach a
//    majority of the view (rollback/joiner_reach.h); one that never ran ends Partitioned, not
//    ConnectTimeout, when connect_timeout_us passes so.
//  - request_stop() (thread- and signal-safe) ends run() at the next wake-up.
//  - Every time it reads or passes on (ticks, arrival stamps, timeouts) comes from config.clock:
//    the monotonic clock, or one running fast or slow for the clock-skew fault tests.
#pragma once

#include <cstdint>
#include <deque>
#include <optional>
#include <vector>

#include "net/redial_backoff.h"
#include "net/runner_base.h"
#include "rollback/playing_alone.h"
#include "rollback/session.h"
#include "transport/transport.h"

namespace lockroll::net {

// PeerAddress, RunnerConfig, StretchTally, and the loop and API both runners share (update,
// wait, run, request_stop, the stretch and schedule counters): net/runner_base.h.
// RunOutcome, TickReport, RunnerObserver, UpdateResult, InputSource: net/update_result.h.

// A rejoin after a drop (PeerRunner::rejoined()): the session was kicked at dropped_at_frame (its
// shown frame then), while in the partition episode since partitioned_since (if it was cut off),
// and started again as a joiner; at_frame is the frame of the snapshot it loaded, once loaded.
struct RejoinRecord {
    std::optional<std::uint32_t> partitioned_since;
    std::uint32_t dropped_at_frame = 0;
    std::optional<std::uint32_t> at_frame;
};

class PeerRunner final : public RunnerBase {
public:
    // Session, transport and observer must outlive the runner. Throws std::invalid_argument for
    // a bad config (RunnerBase's checks, then catch_up_frames < 0, a peer slot out of range or
    // equal to the local one, a transport whose local_id() is not the session's local player).
    PeerRunner(const RunnerConfig& config, rollback::Session& session, transport::Transport& transport,
               InputSource input, RunnerObserver* observer = nullptr);

    std::uint64_t started_us() const;
    // The confirmed frame at which the session reported Partitioned, while that episode has not
    // healed (healed: the session hears a majority again and confirms frames beyond it, or,
    // dropped by the majority meanwhile, rejoined by snapshot: rejoined() keeps the frame then).
    // Still set after a Failed run that was kicked out of a partition (rejoin_when_dropped off).
    std::optional<std::uint32_t> partitioned_since() const { return partitioned_since_; }
    // The frame from which this process played on alone: a drop (the two-player rule, in a match
    // of two or in one of three or more shrunk to two) left it the only running voter of its
    // view, and nobody joined it since (rollback/playing_alone.h).
    std::optional<std::uint32_t> alone_since() const { return alone_.since(); }
    // The last rejoin after a drop (rejoin_when_dropped), if the session was ever kicked and
    // started again as a joiner.
    const std::optional<RejoinRecord>& rejoined() const { return rejoined_; }

private:
    // RunnerBase's: ticking may start once all_connected().
    bool service(std::uint64_t now) override;
    std::uint32_t tick(std::uint64_t now, std::uint64_t scheduled) override;
    TickStatus status() override;

    bool all_connected() const;
    void drain_session_events();
    bool track_partition();
    void track_connections(std::uint64_t now);
    bool everyone_confirmed() const;
    void rejoin();

    rollback::Session& session_;
    std::vector<bool> connected_;      // by peer id (slots, then spectators)
    std::vector<std::deque<std::vector<std::uint8_t>>> held_;  // reliable sends before connecting
    std::uint64_t debt_us_ = 0;        // time-sync delay still to be paid by stretching
    RedialBackoff redial_;             // when to dial each peer id not connected (again)
    std::optional<std::uint32_t> partitioned_since_;
    rollback::AloneSince alone_;       // since when a drop left this process alone in its view
    std::uint32_t confirmed_while_partitioned_ = 0;  // confirmed frame on the last partitioned tick
    bool ran_ = false;                 // the session has run frames (this one or a predecessor)
    bool rejoining_ = false;           // a kick drained this tick: restart as a joiner after the drain
    std::optional<RejoinRecord> rejoined_;
};

}  // namespace lockroll::net
