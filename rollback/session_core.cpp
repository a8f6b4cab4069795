#include "rollback/session_core.h"

#include <exception>
#include <utility>

namespace lockroll::rollback {

const char* phase_name(SessionPhase p) {
    switch (p) {
        case SessionPhase::Synchronizing: return "synchronizing";
        case SessionPhase::Transferring: return "transferring";
        case SessionPhase::Running: return "running";
        case SessionPhase::Failed: return "failed";
    }
    return "unknown";
}

void EventQueue::push(SessionEvent e) {
    if (events_.size() >= kCapacity) {
        events_.pop_front();
        ++dropped_;
    }
    events_.push_back(std::move(e));
}

bool EventQueue::pop(SessionEvent& out) noexcept {
    if (events_.empty()) return false;
    out = std::move(events_.front());
    events_.pop_front();
    return true;
}

SessionCore::SessionCore(SessionPhase initial, PlayerId self, int input_delay, SessionObserver* observer)
    : observer_(observer), phase_(initial), input_delay_(input_delay), self_(self) {}

SessionCore::~SessionCore() = default;

void SessionCore::emit(SessionEvent::Kind kind, SessionEvent::Reason reason, PlayerId peer, std::uint32_t frame,
                       std::uint64_t now_us, std::string detail) {
    // Only a drop that ends the session counts as its end (not one heard after another failure).
    if (kind == SessionEvent::Kind::Kicked && phase_ != SessionPhase::Failed) kicked_ = true;
    events_.push({kind, peer, frame, now_us, std::move(detail), reason});
}

void SessionCore::fail(SessionEvent::Reason reason, const std::string& why, std::uint64_t now_us) {
    if (phase_ == SessionPhase::Failed) return;
    phase_ = SessionPhase::Failed;
    failure_ = why;
    emit(SessionEvent::Kind::Failed, reason, self_, frame(), now_us, why);
}

// Per-tick calls never throw (a game loop has nowhere to catch). What could -- the game's own
// step/save/load, an allocation, an invariant of ours -- fails the session instead, with the
// exception's message as the reason.
void SessionCore::fail_from_exception(const char* where, std::uint64_t now_us) noexcept {
    try {
        std::string why;
        try {
            throw;
        } catch (const std::exception& e) {
            why = e.what();
        } catch (...) {
            why = "an exception that is not a std::exception";
        }
        fail(SessionEvent::Reason::Exception, std::string(where) + ": " + why, now_us);
    } catch (...) {
        phase_ = SessionPhase::Failed;  // not even the message could be built
    }
}

SyncConfig SessionCore::sync_config(int players, PlayerId local, std::size_t input_size, int prediction_window,
                                     int evidence_frames, std::uint32_t input_capacity) {
    SyncConfig sc;
    sc.players = players;
    sc.local_player = local;
    sc.input_size = input_size;
    sc.prediction_window = prediction_window;
    sc.evidence_frames = evidence_frames;
    sc.input_capacity = input_capacity;
    return sc;
}

void SessionCore::default_to_zero(CpuClock& clock) {
    if (!clock) clock = [] { return std::uint64_t{0}; };
}

Predictor& SessionCore::predictor_or_default(Predictor* predictor) {
    if (predictor) return *predictor;
    default_predictor_ = std::make_unique<RepeatLastPredictor>();
    return *default_predictor_;
}

std::string SessionCore::inject_fault(std::uint32_t frame, std::uint32_t body_id, int field, int bit) {
    return sync_->add_fault(frame, body_id, field, bit);
}

}  // namespace lockroll::rollback
