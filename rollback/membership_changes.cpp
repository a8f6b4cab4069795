#include "rollback/membership_changes.h"

#include <algorithm>
#include <stdexcept>

#include "rollback/restart_claim.h"
#include "rollback/slot_hosts.h"

namespace lockroll::rollback {

bool MembershipChanges::mine(PlayerId slot) const {
    if (config_.role == Role::Spectator) return false;
    return slot == config_.local_player || (host_of(config_, slot) != slot && host_of(config_, slot) == config_.local_player);
}

// The owner of the view: the lowest running slot, the one that writes absent slots' inputs and
// hands slots over (AuthoredStreams::owner), leaving `except` aside (a slot being handed over).
PlayerId MembershipChanges::owner_but(PlayerId except) const {
    for (PlayerId s = 0; s < static_cast<PlayerId>(config_.players); ++s)
        if (s != except && view_.running(s)) return s;
    return kNoSlot;
}

// `slot` leaves, and with it the view every pending handoff was judged in. One it made is
// orphaned (SlotView::orphaned): nobody can serve it any more. Any other starts its lapse clock
// over, our vote from its lapse withdrawn: its joiner's vetting needed the leaving slot's answer
// while the view named it running, and its maker serves it again with the new view
// (JoinHandoff::serve_again), so the joiner gets disconnect_us in the view it can load in (issue
// 21: a player killed during a handoff made the handoff lapse, and the joiner waited 2 x
// disconnect_us more). A stall on a pending handoff is so bounded by disconnect_us per change of
// the view. Safe: only our vote and the backoff depend on this, a drop still takes a majority,
// and the agreement that chose `slot` chose nothing else (one slot per instance; the new view is
// a new instance). Called before the view changes, inside the settle loop.
void MembershipChanges::pending_handoffs_after(PlayerId slot) {
    for (PlayerId s = 0; s < static_cast<PlayerId>(config_.players); ++s) {
        SlotView& v = slots_[s];
        if (s == slot || !view_.joining(s)) continue;
        if (v.maker == slot) {
            v.orphaned = true;
            continue;
        }
        v.pending_since_us = 0;
        v.lapsed = false;
        if (!v.lapse_vote) continue;
        v.lapse_vote = false;
        if (!v.kick_vote && !v.restart_vote) view_.vote_local(s, false);
    }
}

void MembershipChanges::drop_slot(PlayerId slot, std::uint64_t now_us, SessionEvent::Reason reason, const char* why) {
    SlotView& v = slots_[slot];
    if (!view_.running(slot)) return;
    pending_handoffs_after(slot);
    view_.leave(slot);
    agreement_.forget(slot);
    effects_.slot_changed_hands(slot);
    v.dropped(now_us, config_.disconnect_us);
    links_[slot].interrupted = false;
    effects_.peer_failed(slot);
    effects_.emit(SessionEvent::Kind::Disconnected, reason, slot, count_of(slot), now_us, why);
    // The slots its process played go with it.
    for (int s = slot + 1; s < config_.players; ++s)
        if (host_of(config_, static_cast<PlayerId>(s)) == slot) drop_slot(static_cast<PlayerId>(s), now_us, SessionEvent::Reason::HostDropped, "its host was dropped");
    effects_.live_peers_changed();
}

// A peer's vote (or the local one): counted by Membership, which ignores what does not count.
void MembershipChanges::count_vote(PlayerId voter, PlayerId slot, Vote vote, std::uint8_t epoch) {
    const Tally t = view_.vote(voter, slot, vote, epoch);
    if (t == Tally::Counted && vote == Vote::Gone && voter != config_.local_player &&
        view_.vote_of(config_.local_player, slot) != Vote::Gone)
        ++stats_.drop_votes_unheeded;
}

// The two-player rule decides at once (each side of a view of two for itself); any other drop
// is proposed by the votes and applied only once a majority of the view agreed on that very slot
// (rollback/drop_agreement.h): votes counted as decisions split the view after a machine stall.
std::optional<PlayerId> MembershipChanges::next_drop(std::uint64_t now_us) {
    const auto players = static_cast<PlayerId>(config_.players);
    PlayerId wanted = kNoSlot;
    for (PlayerId s = 0; s < players; ++s) {
        if (!view_.decided_gone(s)) continue;
        if (view_.electorate(s) == 2) return s;  // the two-player rule: never this session's own slot
        if (wanted == kNoSlot && s != config_.local_player && view_.vote_of(config_.local_player, s) == Vote::Gone) wanted = s;
    }
    const std::uint64_t retry_us = std::max<std::uint64_t>(config_.interrupt_us, 200'000);
    return agreement_.step(view_, wanted, now_us, retry_us);
}

// Drops every running slot the view agreed to drop (this session's own slot: it was kicked),
// then notes whether this session is cut off from a majority (Partitioned, once per episode).
void MembershipChanges::settle_membership(std::uint64_t now_us) {
    if (config_.role == Role::Spectator) return;
    for (std::optional<PlayerId> s = next_drop(now_us); s; s = next_drop(now_us)) {
        const bool me = *s == config_.local_player;
        apply_drop(*s, now_us);
        if (me) return;
    }
    const bool cut_off = view_.partitioned();
    if (cut_off && !partitioned()) {
        int heard = 0;
        for (int s = 0; s < config_.players; ++s) {
            const auto pid = static_cast<PlayerId>(s);
            if (view_.is_voter(pid) && view_.vote_of(config_.local_player, pid) != Vote::Gone) ++heard;
        }
        effects_.emit(SessionEvent::Kind::Partitioned, SessionEvent::Reason::NoMajority, config_.local_player, effects_.confirmed_frame(), now_us,
                      "hears " + std::to_string(heard) + " of " + std::to_string(view_.running_voters()) +
                          " players: no majority, nobody is dropped");
    }
    partitioned_ = cut_off;
}

void MembershipChanges::apply_drop(PlayerId s, std::uint64_t now_us) {
    const int electorate = view_.electorate(s);
    const bool two_player_rule = electorate == 2;
    // The voters that back it: the votes (two-player rule) or the agreement.
    const int backing = two_player_rule ? view_.gone_votes(s) : agreement_.backing(view_, s);
    if (s == config_.local_player) {
        effects_.emit(SessionEvent::Kind::Kicked, SessionEvent::Reason::VotedOut, s, effects_.frame(), now_us,
                      std::to_string(backing) + " of " + std::to_string(electorate) + " players agreed to drop this slot");
        effects_.fail_dropped(now_us);
        return;
    }
    const SlotView& v = slots_[s];
    const bool restart = v.restart_vote && view_.vote_of(config_.local_player, s) == Vote::Gone;
    using R = SessionEvent::Reason;
    const std::string why = v.kick_vote ? "kicked"
                            : v.lapsed  ? (v.orphaned ? "handoff orphaned: its owner left" : "handoff lapsed")
                            : restart   ? (v.restart_by_player ? "restarted" : "rejoining")
                                        : "timed out";
    // A view of two has no majority of the other's: the two-player rule decided, and this
    // process now plays on alone (its outcome says so: rollback/playing_alone.h).
    // (A joining slot's electorate counts it beside the voters: Membership::electorate.)
    const R reason = v.kick_vote ? (two_player_rule ? R::KickVoteTwoPlayerRule : R::KickVote)
                     : v.lapsed  ? (two_player_rule ? R::HandoffLapsedTwoPlayerRule : R::HandoffLapsed)
                     : restart   ? (v.restart_by_player ? (two_player_rule ? R::RestartedTwoPlayerRule : R::Restarted)
                                                        : (two_player_rule ? R::RejoiningTwoPlayerRule : R::Rejoining))
                                 : (two_player_rule ? R::TimedOutTwoPlayerRule : R::TimedOut);
    drop_slot(s, now_us, reason,
              (why + (two_player_rule ? ", by " + std::to_string(backing) + " of " + std::to_string(electorate) + " votes" +
                                            " (the two-player rule, " + two_player_rule_name(view_.rule()) +
                                            ": this process plays on alone)"
                                      : ", agreed by " + std::to_string(backing) + " of " + std::to_string(electorate) + " players"))
                  .c_str());
}

void MembershipChanges::joiner_cut_off(const JoinerReach::Verdict& reach, std::uint64_t now_us) {
    if (reach.cut_off && !partitioned()) {
        std::string silent;
        for (PlayerId p : reach.unreached) silent += (silent.empty() ? " " : ", ") + std::to_string(p);
        effects_.emit(SessionEvent::Kind::Partitioned, SessionEvent::Reason::NoMajority, config_.local_player, effects_.confirmed_frame(),
                      now_us,
                      "joining: reaches " + std::to_string(reach.reached) + " of the view's " + std::to_string(reach.others) +
                          " other players, " + std::to_string(reach.needed) +
                          " needed: no majority, no snapshot is loaded; no word from peer" + silent);
    }
    joiner_cut_off_ = reach.cut_off;
}

void MembershipChanges::adopt_slot(PlayerId slot, const SlotEntry& e, std::uint64_t now_us) {
    SlotView& v = slots_[slot];
    const SlotState before = view_.state(slot);
    // The owner as we see it now made the handoff, if this is one (SlotView::maker).
    const PlayerId maker = owner_but(slot);
    if (before == SlotState::Running && e.state != SlotState::Running) pending_handoffs_after(slot);
    // Running in a newer epoch: handed to a new process, a voter once its stream starts here
    // (Membership::hand_over; check_silence notes the start).
    const bool handed_over = e.state == SlotState::Running && !mine(slot);
    if (handed_over) view_.hand_over(slot, e.epoch);
    else view_.set(slot, e.state, e.epoch);
    agreement_.forget(slot);
    effects_.slot_changed_hands(slot);
    v.new_epoch();
    if (handed_over) v.maker = maker;
    if (mine(slot) && e.state != SlotState::Running) {
        effects_.emit(SessionEvent::Kind::Kicked, SessionEvent::Reason::LearnedFromPeer, slot, effects_.frame(), now_us,
                      "the other peers dropped this slot");
        effects_.fail_dropped(now_us);
        return;
    }
    PeerLink& link = links_[slot];
    if (e.state == SlotState::Running && before != SlotState::Running) {
        // Someone handed the slot to a (re)joining process: listen to it from now on, and forget
        // what its predecessor told us.
        link.reset_lifecycle(static_cast<std::size_t>(config_.players));
        link.clear_error();
        effects_.peer_replaced(slot);
        link.mark_heard(now_us);
        link.interrupted = false;
        effects_.emit(SessionEvent::Kind::Joined, SessionEvent::Reason::LearnedFromPeer, slot, count_of(slot), now_us,
                      "learned from a peer");
    } else if (e.state != SlotState::Running && before == SlotState::Running) {
        effects_.emit(SessionEvent::Kind::Disconnected, SessionEvent::Reason::LearnedFromPeer, slot, count_of(slot), now_us,
                      "learned from a peer");
        effects_.peer_failed(slot);
        link.interrupted = false;
    }
    effects_.live_peers_changed();
}

// A kick is this session's vote, as if the slot had been silent for disconnect_us; it is not
// withdrawn by hearing the slot. With three or more players the others must agree.
void MembershipChanges::disconnect_player(PlayerId slot, std::uint64_t now_us) {
    if (!is_slot(slot) || slot == config_.local_player || mine(slot))
        throw std::invalid_argument("disconnect_player: not a remote slot");
    if (view_.vote_local(slot, true) == Tally::AboutAGuest)
        throw std::invalid_argument("disconnect_player: a guest goes with its host");
    slots_[slot].kick_vote = view_.running(slot);
    settle_membership(now_us);
}

void MembershipChanges::refused_as_dropped(PlayerId from, std::uint8_t epoch, std::uint64_t now_us) {
    const PlayerId me = config_.local_player;
    const bool other_voter = is_slot(from) && view_.is_voter(from);
    if (other_voter && !mine(from) && view_.running_voters() == 2 && view_.rule() == TwoPlayerRule::PlayOnAlone &&
        view_.running(me) && newer_epoch(epoch, view_.epoch(me))) {
        effects_.emit(SessionEvent::Kind::Kicked, SessionEvent::Reason::VotedOut, me, effects_.frame(), now_us,
                      "peer " + std::to_string(from) + " dropped this slot (the two-player rule: it plays on alone)");
        effects_.fail_dropped(now_us);
        return;
    }
    if (is_slot(from)) {
        count_vote(from, me, Vote::Gone, epoch);
        agreement_.heard_drop(from, me, epoch);  // it applied our drop: its word that it was agreed
    }
    settle_membership(now_us);
}

// The claim is noted at every hello and counts only once it has stood, the old process unheard,
// for restart_confirm_us (rollback/restart_claim.h): an outsider's hello that lands in a genuine
// loss burst is then no vote unless the burst outlasts that window too.
bool MembershipChanges::claim_restart(PlayerId slot, bool as_player, bool quiet, std::uint64_t now_us) {
    const bool stood = slots_[slot].restart_claim.claim(now_us, links_[slot].last_heard_us,
                                                        restart_confirm_us(config_.interrupt_us));
    if (!quiet || !stood) return !view_.running(slot);
    view_.vote_local(slot, true);  // ignored when it does not count (not a voter, a guest, ...)
    if (view_.vote_of(config_.local_player, slot) == Vote::Gone) {
        slots_[slot].restart_vote = true;
        slots_[slot].restart_by_player = as_player;
    }
    settle_membership(now_us);
    return !view_.running(slot);
}

void MembershipChanges::check_silence(std::uint64_t now_us) {
    // A joiner whose own stream has started plays: it votes and counts from now on.
    for (int s = 0; s < config_.players; ++s) {
        const auto pid = static_cast<PlayerId>(s);
        if (view_.joining(pid) && stream_started(effects_.stream(pid))) view_.started(pid);
    }
    for (std::size_t p = 0; p < links_.size(); ++p) {
        const auto pid = static_cast<PlayerId>(p);
        // A handoff's lapse is judged on our own stream of the slot, whether or not we ever
        // welcomed its process: a joiner that reaches only the owner is never welcomed here, and
        // our vote was missing for good (issue 21: both players waited at the handoff frame).
        if (is_slot(pid) && !mine(pid) && host_of(config_, pid) == pid) check_handoff(pid, now_us);
        if (!effects_.live_peer(pid)) continue;
        PeerLink& l = links_[p];
        const PeerLink::Silence silence = l.check_silence(now_us, config_.interrupt_us, config_.disconnect_us);
        if (silence.interrupted_now)
            effects_.emit(SessionEvent::Kind::Interrupted, SessionEvent::Reason::Silent, pid, effects_.frame(), now_us,
                          std::to_string(silence.silent_us / 1000) + " ms silent");
        if (silence.timed_out) {
            if (is_slot(pid)) {
                // A restart vote withdrawn (its old process was heard again): silence votes now.
                if (view_.vote_of(config_.local_player, pid) != Vote::Gone) slots_[pid].restart_vote = false;
                view_.vote_local(pid, true);  // our vote; the slot goes when a majority agrees
            } else {
                l.welcomed = false;  // a spectator that went away: stop serving it
                effects_.emit(SessionEvent::Kind::Disconnected, SessionEvent::Reason::SpectatorTimedOut, pid, effects_.frame(), now_us,
                              "spectator timed out");
            }
        }
    }
    settle_membership(now_us);
}

// A lapse is our vote; once the joiner's stream starts here it plays, and that vote is withdrawn
// unless another stands (a kick, a restart claim; silence votes again at its next check). The
// drop may still come: a majority may have accepted it already (rollback/drop_agreement.h).
void MembershipChanges::check_handoff(PlayerId slot, std::uint64_t now_us) {
    SlotView& v = slots_[slot];
    switch (v.watch_handoff(view_.running(slot), effects_.stream(slot), effects_.frame(), now_us, config_.disconnect_us)) {
        case SlotView::Watch::Lapsed: view_.vote_local(slot, true); break;  // settle_membership drops it once a majority agrees
        case SlotView::Watch::Started:
            if (!v.kick_vote && !v.restart_vote) view_.vote_local(slot, false);
            break;
        case SlotView::Watch::Nothing: break;
    }
}

}  // namespace lockroll::rollback
