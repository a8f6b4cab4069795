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
// has finished or dropped it, so healing could only get it kicked.
//
// run_ticks: the loop both runners run on these two (PeerRunner after its connect phase).
#pragma once

#include <atomic>
#include <cstdint>
#include <optional>

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

// What a runner reports after each tick, for run_ticks to judge.
struct TickStatus {
    bool failed = false;        // the session failed (refused, kicked)
    bool running = false;       // the session runs frames (frame 0, or a joiner's snapshot frame)
    bool shown_target = false;  // frame() reached config.target_frame
    bool confirmed = false;     // the runner's own "everyone confirmed the target" condition
    bool partitioned = false;   // cut off from a majority and not healed since (P2P only)
};

// The runner's state the loop keeps up to date, so the runner can report it.
struct TickLoopState {
    std::uint64_t& started_us;       // when the session first ran (0 until then)
    std::uint64_t& schedule_resets;  // TickSchedule::resets()
};

// Ticks until the run is over: sleeps in service_until(due_us) (servicing the transport) until
// the next tick is due, runs tick(now_us, due_us), which returns the extra length of the tick
// after it (time-sync stretch), then asks status() and ends the run as the contracts say:
// Stopped at the first wake-up after `stop`, Failed with the session, ConnectTimeout when the
// session does not run within connect_timeout_us of begin_us, and after it runs, RunEnd's
// verdict (Partitioned included).
template <class ServiceUntil, class Tick, class Status>
RunOutcome run_ticks(const RunnerConfig& config, std::uint64_t begin_us, const std::atomic<bool>& stop,
                     RunnerObserver* observer, TickLoopState state, ServiceUntil service_until, Tick tick, Status status) {
    TickSchedule schedule(config.clock.now_us(), config.tick_rate, config.max_catch_up);
    RunEnd end(config);
    for (;;) {
        service_until(schedule.due());
        if (stop.load(std::memory_order_relaxed)) return RunOutcome::Stopped;
        const std::uint64_t now = config.clock.now_us();
        const std::uint64_t extra_us = tick(now, schedule.start_tick(now));
        state.schedule_resets = schedule.resets();
        schedule.finish_tick(extra_us);
        const TickStatus s = status();
        if (s.failed) return RunOutcome::Failed;
        if (!state.started_us) {
            if (s.running) {
                state.started_us = now;
                if (observer) observer->on_synchronized(now);
            } else if (now - begin_us > config.connect_timeout_us) {
                return RunOutcome::ConnectTimeout;
            }
            continue;
        }
        if (auto outcome = end.check(now, state.started_us, s.shown_target, s.confirmed, observer, s.partitioned)) return *outcome;
    }
}

}  // namespace lockroll::net
