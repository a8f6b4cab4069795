#include "rollback/session_effects.h"

#include "rollback/input_authority.h"
#include "rollback/rejoin.h"

namespace lockroll::rollback {

void SessionImpl::Effects::emit(SessionEvent::Kind kind, SessionEvent::Reason reason, PlayerId peer, std::uint32_t frame, std::uint64_t now_us,
                                std::string detail) {
    s_.emit(kind, reason, peer, frame, now_us, std::move(detail));
}

void SessionImpl::Effects::fail_dropped(std::uint64_t now_us) { s_.fail(SessionEvent::Reason::Dropped, drop_failure(s_.config_), now_us); }

void SessionImpl::Effects::slot_changed_hands(PlayerId slot) { s_.authority_->reset_slot(slot); }

void SessionImpl::Effects::peer_failed(PlayerId peer) { s_.detector_->peer_failed(peer); }

void SessionImpl::Effects::peer_replaced(PlayerId peer) { s_.detector_->reset_peer(peer); }

void SessionImpl::Effects::live_peers_changed() { s_.refresh_resend_floor(); }

bool SessionImpl::Effects::live_peer(PlayerId peer) const { return s_.live_peer(peer); }

std::uint32_t SessionImpl::Effects::frame() const { return s_.frame(); }

std::uint32_t SessionImpl::Effects::confirmed_frame() const { return s_.confirmed_frame(); }

const InputQueue& SessionImpl::Effects::stream(PlayerId slot) const { return s_.sync_->queue(slot); }

InputQueue::Add SessionImpl::Effects::write(PlayerId slot, std::uint32_t frame, std::span<const std::uint8_t> input,
                                            bool absent) {
    return s_.sync_->add_remote_input(slot, frame, input, absent);
}

}  // namespace lockroll::rollback
