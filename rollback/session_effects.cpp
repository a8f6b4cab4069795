#include "rollback/session_effects.h"

#include <string>
#include <utility>

#include "rollback/input_authority.h"
#include "rollback/rejoin.h"

namespace lockroll::rollback {

void SessionImpl::Effects::emit(SessionEvent::Kind kind, SessionEvent::Reason reason, PlayerId peer, std::uint32_t frame, std::uint64_t now_us,
                                std::string detail) {
    s_.emit(kind, reason, peer, frame, now_us, std::move(detail));
}

bool SessionImpl::Effects::live_peer(PlayerId peer) const { return s_.live_peer(peer); }

const InputQueue& SessionImpl::Effects::stream(PlayerId slot) const { return s_.sync_->queue(slot); }

void SessionImpl::Effects::fail_dropped(std::uint64_t now_us) { s_.fail(SessionEvent::Reason::Dropped, drop_failure(s_.config_), now_us); }

void SessionImpl::Effects::slot_changed_hands(PlayerId slot) { s_.authority_->reset_slot(slot); }

void SessionImpl::Effects::peer_failed(PlayerId peer) { s_.detector_->peer_failed(peer); }

void SessionImpl::Effects::peer_replaced(PlayerId peer) { s_.detector_->reset_peer(peer); }

void SessionImpl::Effects::live_peers_changed() { s_.refresh_resend_floor(); }

std::uint32_t SessionImpl::Effects::frame() const { return s_.frame(); }

std::uint32_t SessionImpl::Effects::confirmed_frame() const { return s_.confirmed_frame(); }

InputQueue::Add SessionImpl::Effects::write(PlayerId slot, std::uint32_t frame, std::span<const std::uint8_t> input,
                                            bool absent) {
    return s_.sync_->add_remote_input(slot, frame, input, absent);
}

void SessionImpl::Effects::malformed(PlayerId from, const char* why) { s_.malformed(from, why); }

void SessionImpl::Effects::acked() { s_.refresh_resend_floor(); }

void SessionImpl::Effects::adopt_slot(PlayerId slot, const SlotEntry& e, std::uint64_t now_us) { s_.changes_.adopt_slot(slot, e, now_us); }

void SessionImpl::Effects::count_vote(PlayerId voter, PlayerId slot, Vote vote, std::uint8_t epoch) {
    s_.changes_.count_vote(voter, slot, vote, epoch);
}

void SessionImpl::Effects::heard_agreement(PlayerId voter, const AgreementReport& r) { s_.changes_.heard_agreement(voter, r); }
void SessionImpl::Effects::heard_drop(PlayerId voter, PlayerId slot, std::uint8_t epoch) {
    s_.changes_.heard_drop(voter, slot, epoch);
}
void SessionImpl::Effects::settle_membership(std::uint64_t now_us) { s_.changes_.settle_membership(now_us); }

void SessionImpl::Effects::remote_checksum(PlayerId from, std::uint32_t frame, std::uint64_t checksum) {
    s_.detector_->add_remote(from, frame, checksum);
}

void SessionImpl::Effects::neutral_from(PlayerId slot, std::uint32_t frame) {
    s_.emit(SessionEvent::Kind::NeutralFrom, SessionEvent::Reason::NeutralAgreed, slot, frame, s_.last_now_us_);
}

bool SessionImpl::Effects::failed() const { return s_.phase_ == SessionPhase::Failed; }

void SessionImpl::Effects::send(PlayerId to, std::vector<std::uint8_t> bytes) { s_.send_control(to, std::move(bytes)); }

bool SessionImpl::Effects::desynced(PlayerId peer) const { return s_.detector_->desynced(peer); }

std::uint32_t SessionImpl::Effects::handoff_target(PlayerId slot) const {
    return s_.local_target() + s_.lead_frames(s_.links_[slot].rtt_us());
}

void SessionImpl::Effects::joined(PlayerId slot, std::uint32_t handoff, std::uint32_t frame, std::uint64_t now_us) {
    s_.detector_->reset_peer(slot);
    s_.emit(SessionEvent::Kind::Joined, SessionEvent::Reason::Handoff, slot, handoff, now_us, "snapshot of frame " + std::to_string(frame));
}

void SessionImpl::Effects::spectator_joined(PlayerId peer, std::uint32_t frame, std::uint64_t now_us) {
    s_.emit(SessionEvent::Kind::SpectatorJoined, SessionEvent::Reason::None, peer, frame, now_us);
}

}  // namespace lockroll::rollback
