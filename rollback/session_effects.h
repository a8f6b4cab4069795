// The rest of the P2P session as its parts see it (in-tree, private to SessionImpl):
// MembershipChanges (rollback/membership_changes.h), AuthoredStreams (rollback/authored_streams.h),
// InputIntake (rollback/input_intake.h) and JoinHandoff (rollback/join_handoff.h) reach the session
// only through their narrow interfaces, which their tests fake; this one adapter implements them
// all over SessionImpl's state, one forward per hook, each hook once: the hooks the interfaces
// share (PartEffects' emit, live_peer, stream; IntakeEffects' and JoinEffects' malformed and
// acked) have one definition. The forwards are out of line, in session_effects.cpp.
//
// Contract
//  - Owned by SessionImpl and built before the parts that borrow it (MembershipChanges,
//    AuthoredStreams for the session's life; InputIntake, JoinHandoff for one message). It holds
//    no state of its own.
//  - Only session.cpp includes this header (it builds it).
#pragma once

#include "rollback/join_handoff.h"
#include "rollback/session_impl.h"

namespace lockroll::rollback {

class SessionImpl::Effects final : public MembershipEffects,
                                   public AuthoringEffects,
                                   public IntakeEffects,
                                   public JoinEffects {
public:
    explicit Effects(SessionImpl& s) : s_(s) {}

    // PartEffects (MembershipEffects and AuthoringEffects alike)
    void emit(SessionEvent::Kind kind, SessionEvent::Reason reason, PlayerId peer, std::uint32_t frame, std::uint64_t now_us,
              std::string detail) override;
    bool live_peer(PlayerId peer) const override;
    const InputQueue& stream(PlayerId slot) const override;
    // MembershipEffects
    void fail_dropped(std::uint64_t now_us) override;
    void slot_changed_hands(PlayerId slot) override;
    void peer_failed(PlayerId peer) override;
    void peer_replaced(PlayerId peer) override;
    void live_peers_changed() override;
    std::uint32_t frame() const override;
    std::uint32_t confirmed_frame() const override;
    // AuthoringEffects
    InputQueue::Add write(PlayerId slot, std::uint32_t frame, std::span<const std::uint8_t> input,
                          bool absent) override;
    // IntakeEffects and JoinEffects alike
    void malformed(PlayerId from, const char* why) override;
    void acked() override;
    // IntakeEffects
    void adopt_slot(PlayerId slot, const SlotEntry& e, std::uint64_t now_us) override;
    void count_vote(PlayerId voter, PlayerId slot, Vote vote, std::uint8_t epoch) override;
    void heard_agreement(PlayerId voter, const AgreementReport& r) override;
    void heard_drop(PlayerId voter, PlayerId slot, std::uint8_t epoch) override;
    void settle_membership(std::uint64_t now_us) override;
    void remote_checksum(PlayerId from, std::uint32_t frame, std::uint64_t checksum) override;
    void neutral_from(PlayerId slot, std::uint32_t frame) override;
    bool failed() const override;
    // JoinEffects
    void send(PlayerId to, std::vector<std::uint8_t> bytes) override;
    bool desynced(PlayerId peer) const override;
    std::uint32_t handoff_target(PlayerId slot) const override;
    void joined(PlayerId slot, std::uint32_t handoff, std::uint32_t frame, std::uint64_t now_us) override;
    void spectator_joined(PlayerId peer, std::uint32_t frame, std::uint64_t now_us) override;

private:
    SessionImpl& s_;
};

}  // namespace lockroll::rollback
