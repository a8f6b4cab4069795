// SessionQueries: each query forwards to the SessionCore the facade pointed it at.
#include "rollback/session.h"

#include "rollback/session_core.h"

namespace lockroll::rollback {

SessionPhase SessionQueries::phase() const { return core_->phase(); }
bool SessionQueries::running() const { return core_->running(); }
const std::string& SessionQueries::failure() const { return core_->failure(); }
std::uint32_t SessionQueries::frame() const { return core_->frame(); }
std::uint32_t SessionQueries::confirmed_frame() const { return core_->confirmed_frame(); }
int SessionQueries::input_delay() const { return core_->input_delay(); }
bool SessionQueries::stalled() const { return core_->stalled(); }
int SessionQueries::recoveries() const { return core_->recoveries(); }
const SessionStats& SessionQueries::stats() const { return core_->stats(); }
std::optional<std::span<const std::uint8_t>> SessionQueries::saved_state(std::uint32_t frame) const {
    return core_->saved_state(frame);
}
bool SessionQueries::next_event(SessionEvent& out) noexcept { return core_->next_event(out); }
std::string SessionQueries::inject_fault(std::uint32_t frame, std::uint32_t body_id, int field, int bit) {
    return core_->inject_fault(frame, body_id, field, bit);
}

}  // namespace lockroll::rollback
