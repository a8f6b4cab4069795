// SessionImpl::Effects: the rest of the P2P session as its parts see it (in-tree, private to
// SessionImpl). MembershipChanges (rollback/membership_changes.h) and AuthoredStreams
// (rollback/authored_streams.h) reach the session only through their narrow interfaces, which a
// test fakes; this adapter implements them over SessionImpl's state, one forward per call.
//
// Contract
//  - Owned by SessionImpl and built before the parts that borrow it; holds no state of its own.
//  - Only session.cpp includes this header (SessionImpl's constructor builds it); the calls are
//    in session_effects.cpp.
#pragma once

#include "rollback/session_impl.h"

namespace lockroll::rollback {

class SessionImpl::Effects final : public MembershipEffects, public AuthoringEffects {
public:
    explicit Effects(SessionImpl& s) : s_(s) {}
    void emit(SessionEvent::Kind kind, PlayerId peer, std::uint32_t frame, std::uint64_t now_us,
              std::string detail) override;
    void fail_dropped(std::uint64_t now_us) override;
    void slot_changed_hands(PlayerId slot) override;
    void peer_failed(PlayerId peer) override;
    void peer_replaced(PlayerId peer) override;
    void live_peers_changed() override;
    bool live_peer(PlayerId peer) const override;
    std::uint32_t frame() const override;
    std::uint32_t confirmed_frame() const override;
    const InputQueue& stream(PlayerId slot) const override;
    InputQueue::Add write(PlayerId slot, std::uint32_t frame, std::span<const std::uint8_t> input,
                          bool absent) override;

private:
    SessionImpl& s_;
};

}  // namespace lockroll::rollback
