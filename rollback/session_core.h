// SessionCore: what the peer-to-peer Session and the RelaySession share (issue 21, "one core
// under both sessions"). Each session derives from it and adds only its protocol; the core holds
// the frame loop's Sync, the phase, the sticky failure, the one event queue, the stats, the
// stall bookkeeping and the input delay, and answers the queries both sessions answer alike.
//
// Contract:
//  - Sans-IO like the sessions: no clock (time comes in as now_us), no socket.
//  - Failure is sticky: fail() sets phase() to Failed once, keeps the first reason in failure()
//    and emits one `failed` event naming this session's own id; later calls change nothing.
//  - Nothing thrown inside a per-tick call escapes: guarded() runs the call's body and turns any
//    exception (the game's step / save / load, an allocation, an invariant) into a failed
//    session "WHERE: WHY", and returns the caller's fallback; should even that message not be
//    built, the phase still becomes Failed.
//  - Events go to one bounded queue (EventQueue below); next_event() pops them in order.
//  - sync_ is built by the derived session's constructor; every query here needs it built.
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <utility>

#include <lockroll/rollback/events.h>
#include "rollback/predictor.h"
#include <lockroll/rollback/session_types.h>
#include "rollback/sync.h"

namespace lockroll::rollback {

// SessionPhase, phase_name, AdvanceResult: rollback/session_types.h (the game sees them).

// The one bounded event queue under next_event() (rollback/events.h). Contract: bounded by
// kCapacity; an owner that never drains it cannot make a session grow without bound, and when
// full the oldest event is dropped and counted in dropped(), so the newest (the one that says how
// the session ended) is never lost. One queue for both sessions (they held 4,096 and 1,024).
class EventQueue {
public:
    static constexpr std::size_t kCapacity = 4096;

    void push(SessionEvent e);
    // Takes the oldest event; false when there is none. Never throws.
    bool pop(SessionEvent& out) noexcept;
    std::size_t size() const { return events_.size(); }
    std::uint64_t dropped() const { return dropped_; }

private:
    std::deque<SessionEvent> events_;
    std::uint64_t dropped_ = 0;
};

// The stall bookkeeping both sessions share: a tick that cannot step starts or continues a
// stall, the next step ends it and adds its length to stall_time_us. Time comes from the caller
// and need not be monotonic: a stall never adds a negative (wrapped) length.
class StallTracker {
public:
    void stalled(std::uint64_t now_us, SessionStats& s) {
        ++s.stall_ticks;
        if (!since_) since_ = now_us;
    }
    // A step: true when it ended a stall.
    bool stepped(std::uint64_t now_us, SessionStats& s) {
        if (!since_) return false;
        s.stall_time_us += now_us >= *since_ ? now_us - *since_ : 0;
        since_.reset();
        return true;
    }
    bool stalled() const { return since_.has_value(); }

private:
    std::optional<std::uint64_t> since_;
};

class SessionCore {
public:
    SessionCore(const SessionCore&) = delete;
    SessionCore& operator=(const SessionCore&) = delete;

    SessionPhase phase() const { return phase_; }
    bool running() const { return phase_ == SessionPhase::Running; }
    const std::string& failure() const { return failure_; }
    // The others dropped this session: it emitted `kicked` (and so failed) before failing for
    // any other reason. Set by emit(), the one place events are made; read by the rejoin rule
    // (rollback/rejoin.h).
    bool kicked() const { return kicked_; }
    std::uint32_t frame() const { return sync_->frame(); }
    std::uint32_t confirmed_frame() const { return sync_->confirmed_frame(); }
    int input_delay() const { return input_delay_; }
    bool stalled() const { return stall_.stalled(); }
    // Snapshot reloads after a desync so far.
    int recoveries() const { return recoveries_; }
    // Updated in place as the session runs.
    const SessionStats& stats() const { return stats_; }
    // Saved state of a frame while the ring holds it (confirmed frames are final).
    std::optional<std::span<const std::uint8_t>> saved_state(std::uint32_t frame) const {
        return sync_->saved_state(frame);
    }
    // Lifecycle events in order; false when none is left.
    bool next_event(SessionEvent& out) noexcept { return events_.pop(out); }
    // Fault injection: every time frame `frame` is produced by a step on this client, flip
    // `bit` of `field` of body `body_id`. Empty string on success, else why not (the frame is
    // already simulated, or the simulation has no such body/field).
    std::string inject_fault(std::uint32_t frame, std::uint32_t body_id, int field, int bit);

protected:
    // self: the id the `failed` event names (the local slot). observer may be nullptr.
    SessionCore(SessionPhase initial, PlayerId self, int input_delay, SessionObserver* observer);
    ~SessionCore();

    void emit(SessionEvent::Kind kind, SessionEvent::Reason reason, PlayerId peer, std::uint32_t frame, std::uint64_t now_us,
              std::string detail = {});
    void fail(SessionEvent::Reason reason, const std::string& why, std::uint64_t now_us);
    // The frame loop's config from the fields both sessions' configs share (a spectator passes
    // local 0: its Sync is built as slot 0's, which it never feeds).
    static SyncConfig sync_config(int players, PlayerId local, std::size_t input_size, int prediction_window,
                                  int evidence_frames, std::uint32_t input_capacity);
    // No clock is read in rollback/: telemetry times come from the caller's clock, or are 0.
    static void default_to_zero(CpuClock& clock);
    // The predictor to use: the caller's, or a repeat-last one this core owns.
    Predictor& predictor_or_default(Predictor* predictor);
    // What a tick that did nothing returns: the shown frame, not advanced.
    AdvanceResult idle_result() const {
        AdvanceResult r;
        r.frame = frame();
        return r;
    }
    // Runs body(); anything it throws fails the session as "where: why" and fallback() answers.
    template <class Body, class Fallback>
    auto guarded(const char* where, std::uint64_t now_us, Body&& body, Fallback&& fallback) noexcept -> decltype(body()) {
        try {
            return body();
        } catch (...) {
            fail_from_exception(where, now_us);
        }
        return fallback();
    }
    template <class Body>
    void guarded(const char* where, std::uint64_t now_us, Body&& body) noexcept {
        guarded(where, now_us, std::forward<Body>(body), [] {});
    }

    SessionObserver* observer_;
    SessionStats stats_;
    std::unique_ptr<Sync> sync_;
    SessionPhase phase_;
    std::string failure_;
    int input_delay_;
    int recoveries_ = 0;
    StallTracker stall_;

private:
    // Called from inside a catch handler only.
    void fail_from_exception(const char* where, std::uint64_t now_us) noexcept;

    PlayerId self_;
    bool kicked_ = false;
    EventQueue events_;
    std::unique_ptr<Predictor> default_predictor_;
};

}  // namespace lockroll::rollback
