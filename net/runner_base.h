// RunnerBase: what PeerRunner (net/peer_runner.h) and RelayRunner (net/relay_runner.h) share --
// their config (RunnerConfig), the game's side of their loop (update / wait / run /
// request_stop), the time-sync stretch tally and the tick schedule (net/tick_schedule.h's
// TickLoop). A runner adds only what its kind of session makes different: how it services its
// transport, what one tick does, and when its run may start and is done.
//
// Contract
//  - The constructor checks the config every runner needs (tick rate 1..1000, max_stretch
//    0..0.5, max_catch_up >= 1, service_interval_us >= 100, an input source) and throws
//    std::invalid_argument otherwise; a runner checks what only it needs after it.
//  - update() is one non-blocking step of the game's loop on TickLoop: service(now) (whether
//    ticking may start), every tick that is due as tick(now, due), status() after each; the
//    session events drained during the call (events_) come back in the result. wait() sleeps
//    until the next tick is due, at most service_interval_us; run() is update() and wait() until
//    the run is over. request_stop() (thread- and signal-safe) ends it at the next wake-up.
//  - Every time it reads comes from config.clock.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "net/clock.h"
#include "net/update_result.h"
#include "rollback/session.h"
#include "transport/transport.h"

namespace lockroll::net {

struct PeerAddress {
    rollback::PlayerId slot = 0;
    std::string host;
    std::uint16_t port = 0;
};

struct RunnerConfig {
    int tick_rate = 60;
    std::uint32_t target_frame = 600;
    std::vector<PeerAddress> peers;              // every remote slot this process may connect to
    std::uint64_t connect_timeout_us = 30000000;
    std::uint64_t finish_timeout_us = 15000000;  // after showing target_frame
    std::uint64_t run_timeout_us = 0;            // whole run after synchronizing; 0 = no bound
    std::uint64_t linger_us = 300000;
    std::uint64_t service_interval_us = 1000;
    double max_stretch = 0.10;                   // longest tick = (1 + max_stretch) periods
    int max_catch_up = 8;
    int catch_up_frames = 8;                     // joiner: extra frames per tick while behind
    bool rejoin_when_dropped = true;             // kicked: rejoin by snapshot (false: end Failed)
    Clock clock;                                 // this process's time (skewed only in fault tests)
};

// Time-sync stretches so far: how many ticks were lengthened, by how much in all, and the
// extra length of the tick just run (what the runner's tick returns to TickLoop).
struct StretchTally {
    std::uint64_t ticks = 0, total_us = 0, last_us = 0;
    void record(std::uint64_t extra_us) {
        last_us = extra_us;
        if (extra_us == 0) return;
        ++ticks;
        total_us += extra_us;
    }
};

class TickLoop;     // net/tick_schedule.h
struct TickStatus;  // net/tick_schedule.h

class RunnerBase {
public:
    RunnerBase(const RunnerBase&) = delete;
    RunnerBase& operator=(const RunnerBase&) = delete;

    // One frame of the game's loop, never blocking: reads config.clock, services the transport
    // (connections, arrivals), runs every tick that is due (at most max_catch_up + 1), and says
    // what happened (UpdateResult). The first call starts the run (the connect timeout counts
    // from it). Call it often: arrivals are stamped, and pings answered, only when it runs.
    UpdateResult update();
    // Sleeps until the next tick is due, at most service_interval_us (for a loop with nothing else
    // to do between updates: run()).
    void wait() const;
    // update() and wait() until the run is over.
    RunOutcome run();
    void request_stop() { stop_.store(true, std::memory_order_relaxed); }

    // Ticks that were lengthened for time sync, and the total extra time (µs).
    std::uint64_t stretched_ticks() const { return stretch_.ticks; }
    std::uint64_t stretch_total_us() const { return stretch_.total_us; }
    // Times the schedule restarted because the process fell too far behind.
    std::uint64_t schedule_resets() const;

protected:
    // Checks the shared part of the config (the contract above). Transport and observer must
    // outlive the runner.
    RunnerBase(const RunnerConfig& config, transport::Transport& transport, InputSource input, RunnerObserver* observer);
    virtual ~RunnerBase();

    // Services the transport (connections, arrivals) at `now`; whether ticking may start.
    virtual bool service(std::uint64_t now) = 0;
    // One tick at `now`, due at `scheduled`; records its stretch in stretch_ and returns its
    // rollback depth.
    virtual std::uint32_t tick(std::uint64_t now, std::uint64_t scheduled) = 0;
    // The session's state after a tick, for TickLoop to judge the run by.
    virtual TickStatus status() = 0;

    // A tick's end, after the session's poll() filled out_: sends out_ (reliably what the session
    // marks so); a reliable datagram the transport refuses (no connection yet) goes to hold(d),
    // which keeps it for when the connection is up or lets it go.
    template <class Hold>
    void send_polled(std::uint64_t now, Hold hold) {
        for (const auto& d : out_) {
            if (!d.reliable) transport_.send(d.peer, d.bytes, now);
            else if (!transport_.send_reliable(d.peer, d.bytes, now)) hold(d);
        }
    }
    // The tick's report, once it ran extra_us longer than the period: to the observer, and the
    // tick counted. Returns the tick's rollback depth (what tick() returns).
    std::uint32_t report_tick(TickReport& report, std::uint64_t extra_us) {
        report.length_us = period_us_ + extra_us;
        if (observer_) observer_->on_tick(report);
        ++ticks_;
        return report.advance.rollback_depth;
    }

    RunnerConfig config_;
    transport::Transport& transport_;
    InputSource input_;
    RunnerObserver* observer_;
    std::atomic<bool> stop_{false};
    std::unique_ptr<TickLoop> loop_;
    std::vector<std::uint8_t> input_bytes_;
    std::vector<rollback::Datagram> out_;
    std::vector<rollback::SessionEvent> events_;  // drained by the current update()
    transport::Datagram in_;
    std::uint64_t period_us_ = 0;                 // one tick at config.tick_rate
    std::uint64_t ticks_ = 0;
    StretchTally stretch_;
};

}  // namespace lockroll::net
