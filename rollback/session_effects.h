// The rest of the P2P session as its parts see it (in-tree, private to SessionImpl):
// MembershipChanges (rollback/membership_changes.h), AuthoredStreams (rollback/authored_streams.h),
// InputIntake (rollback/input_intake.h) and JoinHandoff (rollback/join_handoff.h) reach the session
// only through their narrow interfaces, which their tests fake; these adapters implement them over
// SessionImpl's state, one forward per call (Effects', out of line, in session_effects.cpp).
//
// Contract
//  - Effects is owned by SessionImpl and built before the parts that borrow it; IntakeFx and
//    JoinFx live for one message. None holds state of its own.
//  - Only session.cpp includes this header (it builds them).
#pragma once

#include "rollback/join_handoff.h"
#include "rollback/session_impl.h"

namespace lockroll::rollback {

class SessionImpl::Effects final : public MembershipEffects, public AuthoringEffects {
public:
    explicit Effects(SessionImpl& s) : s_(s) {}
    void emit(SessionEvent::Kind kind, SessionEvent::Reason reason, PlayerId peer, std::uint32_t frame, std::uint64_t now_us,
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

// What a peer's input message asks of the session (InputIntake, rollback/input_intake.h).
class SessionImpl::IntakeFx final : public IntakeEffects {
public:
    explicit IntakeFx(SessionImpl& s) : s_(s) {}
    void malformed(PlayerId from, const char* why) override { s_.malformed(from, why); }
    void acked() override { s_.refresh_resend_floor(); }
    void adopt_slot(PlayerId slot, const SlotEntry& e, std::uint64_t now_us) override { s_.adopt_slot(slot, e, now_us); }
    void count_vote(PlayerId voter, PlayerId slot, Vote vote, std::uint8_t epoch) override {
        s_.count_vote(voter, slot, vote, epoch);
    }
    void settle_membership(std::uint64_t now_us) override { s_.settle_membership(now_us); }
    void remote_checksum(PlayerId from, std::uint32_t frame, std::uint64_t checksum) override {
        s_.detector_->add_remote(from, frame, checksum);
    }
    void neutral_from(PlayerId slot, std::uint32_t frame) override {
        s_.emit(SessionEvent::Kind::NeutralFrom, SessionEvent::Reason::NeutralAgreed, slot, frame, s_.last_now_us_);
    }
    bool failed() const override { return s_.phase_ == SessionPhase::Failed; }

private:
    SessionImpl& s_;
};

// What a snapshot request asks of the session (JoinHandoff, rollback/join_handoff.h).
class SessionImpl::JoinFx final : public JoinEffects {
public:
    explicit JoinFx(SessionImpl& s) : s_(s) {}
    void send(PlayerId to, std::vector<std::uint8_t> bytes) override { s_.send_control(to, std::move(bytes)); }
    void malformed(PlayerId from, const char* why) override { s_.malformed(from, why); }
    bool desynced(PlayerId peer) const override { return s_.detector_->desynced(peer); }
    std::uint32_t handoff_target(PlayerId slot) const override {
        return s_.local_target() + s_.lead_frames(s_.links_[slot].rtt_us());
    }
    void joined(PlayerId slot, std::uint32_t handoff, std::uint32_t frame, std::uint64_t now_us) override {
        s_.detector_->reset_peer(slot);
        s_.emit(SessionEvent::Kind::Joined, SessionEvent::Reason::Handoff, slot, handoff, now_us, "snapshot of frame " + std::to_string(frame));
    }
    void spectator_joined(PlayerId peer, std::uint32_t frame, std::uint64_t now_us) override {
        s_.emit(SessionEvent::Kind::SpectatorJoined, SessionEvent::Reason::None, peer, frame, now_us);
    }
    void acked() override { s_.refresh_resend_floor(); }

private:
    SessionImpl& s_;
};

}  // namespace lockroll::rollback
