// MembershipChanges: the P2P session's side of the view (issue 21). Membership (rollback/
// membership.h) holds who plays and every voter's word and decides; this is what the session does
// about it: the votes it counts (a peer's table, a refusal's), the slots it drops once a majority
// says they are gone (their guests with them) or adopts when a peer's table hands them over, its
// own vote on silence, a kick and a lapsed handoff, and whether it is cut off from a majority
// (Partitioned). One per session, owned by SessionImpl (rollback/session_impl.h).
//
// Contract
//  - Borrows the session's long-lived state (config, view, the per-slot SlotViews, the per-peer
//    links, the stats; all outlive it) and does everything else through MembershipEffects, which
//    SessionImpl implements and a test fakes: events, failing when dropped, who authored a slot's
//    inputs, checksum comparison with a peer, the resend floor, frames and streams read. No clock
//    (now_us comes in), nothing sent from here; slots and peers are ids.
//  - count_vote(): Membership decides what counts (an old epoch, a guest, a voter not running are
//    ignored). A counted "gone" from another player about a slot we do not vote gone ourselves is
//    counted in stats.drop_votes_unheeded.
//  - settle_membership(): drops every running slot a majority voted gone (drop_slot); when the
//    majority says this session's own slot: emits `kicked` and fails (fail_dropped), nothing more.
//    Then `partitioned` once per episode of being cut off from a majority (partitioned()).
//    Spectators never settle: they follow the players' view (adopt_slot).
//  - joiner_cut_off(): a joiner that has not loaded yet, cut off from a majority by its reach
//    (rollback/joiner_reach.h): the same `partitioned` event, once per episode (frame: its
//    confirmed frame), and partitioned() says so until its reach does not (or it loads: the
//    caller passes a verdict that is not cut off). The one Partitioned of the session either way.
//  - drop_slot(): a running slot leaves the view into its next epoch with every slot its process
//    hosts; `disconnected` with its stream's count. A slot not running: nothing. Every joining
//    slot it handed over (SlotView::maker) is orphaned: its handoff lapses as soon as it is
//    pending, with no backoff after, and its drop's detail is "handoff orphaned: its owner left".
//    Every other joining slot's lapse clock starts over (the view it was judged in changed), and
//    our vote from its lapse, unless a kick or a restart claim votes too, is withdrawn.
//  - adopt_slot(): a peer's table says a slot changed hands (a join handed over, a drop we
//    missed): the view takes its state and epoch. Our own slot or guest not running in it:
//    `kicked`, and the session fails. A handoff's maker is taken to be our view's owner (the
//    lowest running slot but this one); a drop learned so does to pending handoffs what
//    drop_slot does.
//  - check_silence(): per tick, over live peers: `interrupted` once per silence; a player silent
//    for disconnect_us gets our vote (kept until heard again); a spectator silent that long is no
//    longer served. Over every other process's running slot, live or never welcomed here: one
//    whose handoff lapsed (SlotView::watch_handoff, our own stream of it) gets our vote, kept
//    until the drop or until its stream starts here (then withdrawn, unless a kick or a restart
//    claim votes too). A joiner whose stream started becomes a voter (Membership::started). Then
//    settle_membership().
//  - disconnect_player(): a kick is our vote, as if the slot had been silent, kept until the drop.
//    Throws std::invalid_argument for a slot that is not another process's (the caller's bug).
//  - refused_as_dropped(): a peer's refusal "dropped from the match" (its view dropped our slot
//    into a newer epoch). With three or more running processes it is that peer's vote
//    (count_vote, then settle_membership): a majority of them kicks us. In a view of two under
//    PlayOnAlone it is no vote but the other's own decision made (each side of two decides for
//    itself): it plays on alone without us, and its refusals are heard, so our silence rule
//    would never drop it: `kicked` and the session fails (the rejoin path, rollback/rejoin.h).
//    The other's vote in its slot table never does that (Membership::decided_gone).
//  - claim_restart(): a hello from another process of a running slot claims its process
//    restarted. Every such hello (doubted or not) is noted in the slot's RestartClaim
//    (rollback/restart_claim.h); once the claim has stood for restart_confirm_us with the old
//    process unheard since it began, a hello that admit_hello lets in (`restarted`: the old
//    process quiet, rollback/session_admission.h) is our vote that the slot is gone, as
//    disconnect_us of silence is, and like that vote it is withdrawn when the old process is
//    heard again. Then settle_membership(): the slot leaves when a majority agrees (with two
//    players, under PlayOnAlone, this one vote; a genuine restart says hello to every peer, so the
//    others' votes follow within a round trip). A hello is a claim, never a fact: it used to drop
//    the slot at once, and one forged hello froze a 3-player match (issue 21); then it was the
//    vote at once, and a forged hello landing in a genuine loss burst of interrupt_us / 2 dropped
//    an honest player of two. The drop's detail is "restarted" (a player's hello) or "rejoining"
//    (a joiner's) and the votes.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "rollback/drop_agreement.h"
#include "rollback/events.h"
#include "rollback/input_queue.h"
#include "rollback/joiner_reach.h"
#include "rollback/membership.h"
#include "rollback/part_effects.h"
#include "rollback/peer_link.h"
#include "rollback/protocol.h"
#include "rollback/session.h"
#include "rollback/slot_view.h"

namespace lockroll::rollback {

// What a change of the view does to the rest of the session, beyond the hooks every part has
// (PartEffects: emit, live_peer, stream). SessionImpl implements it.
class MembershipEffects : public virtual PartEffects {
public:
    // The others dropped this session's slot: it fails (rollback/rejoin.h, drop_failure).
    virtual void fail_dropped(std::uint64_t now_us) = 0;
    // The slot changed hands: who authored its unverified inputs starts over (InputAuthority).
    virtual void slot_changed_hands(PlayerId slot) = 0;
    // The peer left: its checksums are no longer compared (DesyncDetector::peer_failed).
    virtual void peer_failed(PlayerId peer) = 0;
    // A new process plays the slot: its predecessor's checksums are forgotten.
    virtual void peer_replaced(PlayerId peer) = 0;
    // The set of live peers changed: the floor our stream is kept back to moves.
    virtual void live_peers_changed() = 0;
    virtual std::uint32_t frame() const = 0;            // displayed
    virtual std::uint32_t confirmed_frame() const = 0;

protected:
    ~MembershipEffects() = default;
};

class MembershipChanges {
public:
    MembershipChanges(const SessionConfig& config, Membership& view, std::vector<SlotView>& slots,
                      std::vector<PeerLink>& links, SessionStats& stats, MembershipEffects& effects)
        : config_(config), view_(view), slots_(slots), links_(links), stats_(stats), effects_(effects),
          agreement_(config.players, config.local_player) {}

    void count_vote(PlayerId voter, PlayerId slot, Vote vote, std::uint8_t epoch);
    // A peer's agreement report (rollback/drop_agreement.h), on its own connection.
    void heard_agreement(PlayerId voter, const AgreementReport& r) { agreement_.heard(voter, r); }
    // A peer's table says it applied the drop of `slot` into `epoch` (an entry not voted).
    void heard_drop(PlayerId voter, PlayerId slot, std::uint8_t epoch) { agreement_.heard_drop(voter, slot, epoch); }
    const DropAgreement& agreement() const { return agreement_; }
    void settle_membership(std::uint64_t now_us);
    void drop_slot(PlayerId slot, std::uint64_t now_us, SessionEvent::Reason reason, const char* why);
    // e: the peer's table entry about `slot` (its state and a newer epoch).
    void adopt_slot(PlayerId slot, const SlotEntry& e, std::uint64_t now_us);
    void check_silence(std::uint64_t now_us);
    void disconnect_player(PlayerId slot, std::uint64_t now_us);
    // A peer refused our traffic as dropped (its view dropped our slot into `epoch`).
    void refused_as_dropped(PlayerId from, std::uint8_t epoch, std::uint64_t now_us);
    // A hello from another process of running slot `slot` claims it restarted (admit_hello's
    // `restarted` or `doubted`). as_player: the hello's role was Player; quiet: admit_hello let the
    // claim in (`restarted`: the old process has been silent for restart_quiet_us). True when the
    // slot has left the view.
    bool claim_restart(PlayerId slot, bool as_player, bool quiet, std::uint64_t now_us);
    void joiner_cut_off(const JoinerReach::Verdict& reach, std::uint64_t now_us);
    // Reported Partitioned and not yet heard a majority again.
    bool partitioned() const { return partitioned_ || joiner_cut_off_; }

private:
    // A handed-over slot whose own stream never starts is voted gone (SlotView::watch_handoff).
    void check_handoff(PlayerId slot, std::uint64_t now_us);
    // The next slot to leave, if any: by the two-player rule in a view of two, else once a
    // majority agreed on it (DropAgreement); this session's own slot means it was dropped.
    std::optional<PlayerId> next_drop(std::uint64_t now_us);
    void apply_drop(PlayerId slot, std::uint64_t now_us);
    // The lowest running slot other than `except` (kNoSlot: none): the owner that hands slots over.
    PlayerId owner_but(PlayerId except) const;
    // `slot` leaves: the pending handoffs it made are orphaned (SlotView::orphaned), every other
    // one's lapse clock starts over.
    void pending_handoffs_after(PlayerId slot);
    bool is_slot(PlayerId p) const { return p < static_cast<PlayerId>(config_.players); }
    bool mine(PlayerId slot) const;  // this session's slot or one of its guests
    std::uint32_t count_of(PlayerId slot) const { return effects_.stream(slot).confirmed_count(); }

    const SessionConfig& config_;
    Membership& view_;
    std::vector<SlotView>& slots_;
    std::vector<PeerLink>& links_;
    SessionStats& stats_;
    MembershipEffects& effects_;
    DropAgreement agreement_;
    bool partitioned_ = false;
    bool joiner_cut_off_ = false;
};

}  // namespace lockroll::rollback
