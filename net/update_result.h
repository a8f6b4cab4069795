// What a running session tells the game's loop (PeerRunner, RelayRunner and NetSession alike):
// what one update() did, how the run ended, the observer's callbacks with each tick's report,
// and the callback that gives the local input. Installed apart from the runners (net/
// peer_runner.h, not installed) so the builder's header names neither the runners nor the clock.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <span>

#include <lockroll/rollback/events.h>
#include <lockroll/rollback/session_types.h>
#include <lockroll/transport/transport.h>

namespace lockroll::net {

enum class RunOutcome {
    Completed,       // every peer confirmed target_frame (as far as this process can know)
    ConnectTimeout,  // not every peer connected in time
    FinishTimeout,   // target shown, but not confirmed everywhere within finish_timeout_us
    RunTimeout,      // target never shown within run_timeout_us
    Failed,          // the session failed (refused, kicked): Session::failure() says why
    Stopped,         // request_stop()
    Partitioned,     // the run ended (timed out, or would have completed) while the session was
                     // cut off from a majority of the view: PeerRunner::partitioned_since() says
                     // from which frame. Never "completed": nobody agreed on its end.
    ServerLost,      // relay: the server went silent past RelaySessionConfig::server_timeout_us
                     // (killed or unreachable); the session failed, failure() says how long.
};
const char* outcome_name(RunOutcome o);

struct TickReport {
    std::uint64_t tick = 0;           // ticks since frame 0 started
    std::uint64_t now_us = 0;         // when this tick ran
    std::uint64_t scheduled_us = 0;   // when it was due
    std::uint64_t length_us = 0;      // period until the next tick (stretched or not)
    rollback::AdvanceResult advance;
};

class RunnerObserver {
public:
    virtual ~RunnerObserver() = default;
    // Transport connection changes (Connected, Disconnected, Refused with a reason).
    virtual void on_transport_event(const transport::TransportEvent&, std::uint64_t /*now_us*/) {}
    // Session lifecycle events, as drained from Session::next_event().
    virtual void on_session_event(const rollback::SessionEvent&) {}
    // The session runs frame 0 (or its snapshot frame) from now on.
    virtual void on_synchronized(std::uint64_t /*now_us*/) {}
    // After advance() and poll() of each tick.
    virtual void on_tick(const TickReport&) {}
    // Every peer has confirmed the target (before lingering).
    virtual void on_all_confirmed(std::uint64_t /*now_us*/) {}
};

// What one update() did (PeerRunner, RelayRunner and NetSession return it): the game calls
// update() once per frame of its own loop, at its own rate, and draws from this.
struct UpdateResult {
    int frames = 0;                   // ticks run by this call (0 while none was due; several when
                                      // the game's frame was longer than a tick)
    std::uint32_t rollback_depth = 0; // the deepest rollback among them (frames resimulated)
    // Where this call's clock reading lies between the last tick and the next, in [0, 1): a game
    // that draws between ticks blends the previous frame's state with the current one by it.
    // 0 until the first tick.
    double interpolation = 0.0;
    // The session events these ticks drained, in order; valid until the next update(). (NetSession
    // also queues them for next_event().)
    std::span<const rollback::SessionEvent> events;
    // Set once the run is over, by the call that ended it and every call after it (which then
    // does nothing more).
    std::optional<RunOutcome> outcome;
};


// Writes the local input for `frame`: input_size bytes per local slot, in the order of
// Session::local_slots() (one slot unless SessionConfig::slot_hosts gives this process several).
using InputSource = std::function<void(std::uint32_t frame, std::span<std::uint8_t> out)>;

}  // namespace lockroll::net
