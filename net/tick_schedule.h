// When a runner's ticks are due, and when its run is over: the timing PeerRunner and
// RelayRunner share.
//
// TickSchedule: tick k is due at start + k / tick_rate seconds (exact integers) plus every
// stretch so far. A tick that is late runs at once; more than max_behind ticks late, the schedule
// restarts from now, so a process that froze does not then fast-forward in a burst.
//
// RunEnd: after the session started, the run completes once the target frame was shown and
// everyone confirmed it, plus linger_us (so the last acknowledgements get out); it times out
// finish_timeout_us after showing the target, or run_timeout_us after starting without showing
// it. A run that ends (any of those three) while its session is partitioned -- cut off from a
// majority of the view, not healed since -- ends Partitioned instead: the process cannot know
// the match's end was agreed, so it must not say it completed, nor blame a timeout. A partitioned
// session also waits for the network to heal only until the match should have been over (the
// target's time at the tick rate, plus finish_timeout_us, after starting): by then any majority
// has finished or dropped it, so healing could only get it kicked. A session that never ran (a
// joiner) and is cut off when connect_timeout_us passes ends Partitioned too, not ConnectTimeout.
//
// TickLoop: the loop both runners run on these two, one update() per call of the game's loop.
#pragma once

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <optional>
#include <thread>

#include "net/clock.h"
#include "net/peer_runner.h"

namespace lockroll::net {

class TickSchedule {
public:
    TickSchedule(std::uint64_t start_us, int tick_rate, int max_behind)
        : start_(start_us), rate_(static_cast<std::uint64_t>(tick_rate)), max_behind_(static_cast<std::uint64_t>(max_behind)) {}

    std::uint64_t due() const { return start_ + k_ * 1000000u / rate_ + offset_; }
    // The next tick runs at `now`: returns when it was due (now, after a restart).
    std::uint64_t start_tick(std::uint64_t now) {
        std::uint64_t d = due();
        if (now > d + max_behind_ * (1000000u / rate_)) {
            offset_ += now - d;
            d = now;
            ++resets_;
        }
        return d;
    }
    // That tick ran; the one after it comes extra_us later than the rate says.
    void finish_tick(std::uint64_t extra_us) {
        offset_ += extra_us;
        ++k_;
    }
    std::uint64_t resets() const { return resets_; }

private:
    std::uint64_t start_, rate_, max_behind_;
    std::uint64_t offset_ = 0, k_ = 0, resets_ = 0;
};

class RunEnd {
public:
    explicit RunEnd(const RunnerConfig& config) : config_(config) {}
    // Called every tick after the session started (at started_us): nullopt while the run goes on.
    // partitioned: the session is in an unhealed partition episode (the runner's TickStatus).
    std::optional<RunOutcome> check(std::uint64_t now, std::uint64_t started_us, bool shown_target, bool everyone_confirmed,
                                    RunnerObserver* observer, bool partitioned = false) {
        const std::optional<RunOutcome> end = verdict(now, started_us, shown_target, everyone_confirmed, observer);
        // The one place a partition changes how a run ends: whatever would have ended it.
        if (partitioned && (end || now - started_us > partition_wait_us())) return RunOutcome::Partitioned;
        return end;
    }
    // A session that never ran within connect_timeout_us: ConnectTimeout, or Partitioned when it is
    // cut off from a majority (a joiner that cannot reach one: rollback/joiner_reach.h). The
    // timeout is not the cause then, and the outcome says what is.
    static RunOutcome never_ran(bool partitioned) { return partitioned ? RunOutcome::Partitioned : RunOutcome::ConnectTimeout; }
    bool reached() const { return reached_ != 0; }
    // How long after starting a partitioned session waits for the network to heal.
    std::uint64_t partition_wait_us() const {
        const auto rate = static_cast<std::uint64_t>(config_.tick_rate > 0 ? config_.tick_rate : 1);
        return static_cast<std::uint64_t>(config_.target_frame) * 1000000u / rate + config_.finish_timeout_us;
    }

private:
    std::optional<RunOutcome> verdict(std::uint64_t now, std::uint64_t started_us, bool shown_target, bool everyone_confirmed,
                                      RunnerObserver* observer) {
        if (!reached_ && shown_target) reached_ = now;
        if (reached_ && !all_confirmed_ && everyone_confirmed) {
            all_confirmed_ = now;
            if (observer) observer->on_all_confirmed(now);
        }
        if (all_confirmed_ && now - all_confirmed_ >= config_.linger_us) return RunOutcome::Completed;
        if (reached_ && !all_confirmed_ && now - reached_ > config_.finish_timeout_us) return RunOutcome::FinishTimeout;
        if (!reached_ && config_.run_timeout_us && now - started_us > config_.run_timeout_us) return RunOutcome::RunTimeout;
        return std::nullopt;
    }
    const RunnerConfig& config_;
    std::uint64_t reached_ = 0, all_confirmed_ = 0;
};

// What a runner reports after each tick, for TickLoop to judge.
struct TickStatus {
    bool failed = false;        // the session failed (refused, kicked)
    bool running = false;       // the session runs frames (frame 0, or a joiner's snapshot frame)
    bool shown_target = false;  // frame() reached config.target_frame
    bool confirmed = false;     // the runner's own "everyone confirmed the target" condition
    bool partitioned = false;   // cut off from a majority and not healed since (P2P only)
    bool server_lost = false;   // failed because the relay server went silent (relay only)
};

// What a runner's tick tells the loop: how much longer the tick after it is (time-sync
// stretch), and how deep this tick rolled back.
struct TickDone {
    std::uint64_t extra_us = 0;
    std::uint32_t rollback_depth = 0;
};

// The loop both runners run on TickSchedule and RunEnd, one update() at a time: a game calls it
// once per frame of its own loop (NetSession::update), or run_until_over() calls it in a loop and
// sleeps in between (the runners' run()).
//
// update(now, stop, observer, service, tick, status):
//  - the first call begins the run (connect timeout from then); after the run is over every call
//    returns its outcome and does nothing more;
//  - service(now) services the transport and returns whether ticking may start (a runner that
//    waits for its connections first says false until they are up; ConnectTimeout past
//    connect_timeout_us); the schedule starts at the first call that may tick;
//  - then every tick that is due runs, each as tick(now, due) (re-reading now() and servicing the
//    transport between them, as run() always did), at most max_catch_up + 1 per call; status()
//    after each judges the run as the contracts say: Stopped at the first call after `stop`,
//    Failed with the session, ConnectTimeout when the session does not run within
//    connect_timeout_us of the start (Partitioned if it is cut off then: RunEnd::never_ran), and
//    after it runs, RunEnd's verdict (Partitioned included);
//  - the result's interpolation is where the last clock reading lies between the last tick's due
//    time and the next's, in [0, 1).
// Every time comes from now(): the loop reads no clock of its own, so tests drive it in virtual
// microseconds.
class TickLoop {
public:
    explicit TickLoop(const RunnerConfig& config) : config_(config), end_(config) {}

    template <class Now, class Service, class Tick, class Status>
    UpdateResult update(Now now_fn, const std::atomic<bool>& stop, RunnerObserver* observer, Service service, Tick tick,
                        Status status) {
        UpdateResult r;
        if (outcome_) {
            r.outcome = outcome_;
            return r;
        }
        std::uint64_t now = now_fn();
        if (!begun_) {
            begin_us_ = now;
            begun_ = true;
        }
        const bool may_tick = service(now);
        if (stop.load(std::memory_order_relaxed)) return over(r, RunOutcome::Stopped);
        if (!scheduled_) {
            if (!may_tick) {
                if (now - begin_us_ > config_.connect_timeout_us) return over(r, RunOutcome::ConnectTimeout);
                return r;
            }
            schedule_ = TickSchedule(now, config_.tick_rate, config_.max_catch_up);
            scheduled_ = true;
        }
        const int most = config_.max_catch_up + 1;
        while (r.frames < most && schedule_.due() <= now) {
            last_due_ = schedule_.start_tick(now);
            ticked_ = true;
            const TickDone done = tick(now, last_due_);
            schedule_.finish_tick(done.extra_us);
            ++r.frames;
            r.rollback_depth = std::max(r.rollback_depth, done.rollback_depth);
            const TickStatus s = status();
            if (s.failed) return over(r, s.server_lost ? RunOutcome::ServerLost : RunOutcome::Failed);
            if (!started_us_) {
                if (s.running) {
                    started_us_ = now;
                    if (observer) observer->on_synchronized(now);
                } else if (now - begin_us_ > config_.connect_timeout_us) {
                    return over(r, RunEnd::never_ran(s.partitioned));
                }
            } else if (auto outcome = end_.check(now, started_us_, s.shown_target, s.confirmed, observer, s.partitioned)) {
                return over(r, *outcome);
            }
            now = now_fn();
            service(now);
            if (stop.load(std::memory_order_relaxed)) return over(r, RunOutcome::Stopped);
        }
        r.interpolation = fraction(now);
        return r;
    }

    // When the next tick is due (the loop's time); nullopt before the schedule started or after
    // the run is over.
    std::optional<std::uint64_t> next_due() const {
        if (!scheduled_ || outcome_) return std::nullopt;
        return schedule_.due();
    }
    std::optional<RunOutcome> outcome() const { return outcome_; }
    std::uint64_t started_us() const { return started_us_; }  // when the session first ran; 0 until then
    std::uint64_t schedule_resets() const { return schedule_.resets(); }

private:
    UpdateResult& over(UpdateResult& r, RunOutcome o) {
        outcome_ = o;
        r.outcome = o;
        return r;
    }
    double fraction(std::uint64_t now) const {
        if (!ticked_) return 0.0;
        const std::uint64_t last = last_due_, next = schedule_.due();
        if (now <= last || next <= last) return 0.0;
        if (now >= next) return kBelowOne;
        return std::min(kBelowOne, static_cast<double>(now - last) / static_cast<double>(next - last));
    }

    static constexpr double kBelowOne = 1.0 - 1.0 / 65536.0;  // the largest fraction reported
    const RunnerConfig& config_;
    RunEnd end_;
    TickSchedule schedule_{0, 1, 1};  // replaced when ticking may start
    bool scheduled_ = false;
    std::optional<RunOutcome> outcome_;
    bool begun_ = false;
    std::uint64_t begin_us_ = 0, started_us_ = 0;
    bool ticked_ = false;
    std::uint64_t last_due_ = 0;  // when the last tick was due
};

// The runners' run(): update() until the run is over, sleeping in between as wait() says.
template <class Update, class Wait>
RunOutcome run_until_over(Update update, Wait wait) {
    for (;;) {
        const UpdateResult r = update();
        if (r.outcome) return *r.outcome;
        wait();
    }
}

// A runner's wait(): sleeps until the loop's next tick is due in config.clock's time, at most
// config.service_interval_us (a whole interval when no tick is scheduled yet).
inline void wait_for_tick(const RunnerConfig& config, const TickLoop& loop) {
    std::uint64_t us = config.service_interval_us;
    if (const std::optional<std::uint64_t> due = loop.next_due()) {
        const std::uint64_t now = config.clock.now_us();
        us = std::min(*due > now ? config.clock.monotonic_span_us(*due - now) : 0, us);
    }
    std::this_thread::sleep_for(std::chrono::microseconds(us));
}

}  // namespace lockroll::net
