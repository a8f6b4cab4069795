#include "rollback/membership.h"

#include <utility>

namespace lockroll::rollback {

const char* two_player_rule_name(TwoPlayerRule r) {
    switch (r) {
        case TwoPlayerRule::PlayOnAlone: return "play_on_alone";
        case TwoPlayerRule::NoDrop: return "no_drop";
    }
    return "unknown";
}

Membership::Membership(int players, PlayerId local, TwoPlayerRule rule, std::vector<PlayerId> hosts)
    : local_(local), rule_(rule), hosts_(std::move(hosts)) {
    const auto n = static_cast<std::size_t>(players > 0 ? players : 0);
    if (!hosts_.empty() && hosts_.size() != n) hosts_.clear();
    slots_.assign(n, Slot{});
    words_.assign(n * n, Word{});
}

int Membership::running_voters() const {
    int n = 0;
    for (std::size_t s = 0; s < slots_.size(); ++s)
        if (voter(static_cast<PlayerId>(s))) ++n;
    return n;
}

std::uint32_t Membership::view_id() const {
    std::uint32_t h = 2166136261u;
    const auto mix = [&h](std::uint8_t b) { h = (h ^ b) * 16777619u; };
    for (const Slot& s : slots_) {
        mix(static_cast<std::uint8_t>(s.state));
        mix(s.epoch);
    }
    return h;
}

void Membership::forget(PlayerId s) {
    for (std::size_t v = 0; v < slots_.size(); ++v) {
        word(static_cast<PlayerId>(v), s) = Word{};
        word(s, static_cast<PlayerId>(v)) = Word{};
    }
}

void Membership::set(PlayerId s, SlotState state, std::uint8_t epoch) {
    if (s >= slots_.size()) return;
    slots_[s] = {state, epoch};
    forget(s);
}

void Membership::hand_over(PlayerId s, std::uint8_t epoch) {
    if (s >= slots_.size()) return;
    set(s, SlotState::Running, epoch);
    slots_[s].joining = true;
}

void Membership::started(PlayerId s) {
    if (s < slots_.size()) slots_[s].joining = false;
}

void Membership::leave(PlayerId s) {
    if (s >= slots_.size()) return;
    set(s, SlotState::Disconnected, static_cast<std::uint8_t>(slots_[s].epoch + 1));
}

Tally Membership::vote(PlayerId voter_id, PlayerId s, Vote v, std::uint8_t epoch) {
    if (!voter(voter_id)) return Tally::NotAVoter;
    if (s >= slots_.size()) return Tally::NotRunning;
    if (host_of(s) == voter_id) return Tally::AboutItself;
    if (!running(s)) return Tally::NotRunning;
    if (host_of(s) != s) return Tally::AboutAGuest;
    const std::uint8_t now = slots_[s].epoch;
    if (v == Vote::Gone && !newer_epoch(epoch, now)) return Tally::Stale;
    if (v == Vote::Runs && epoch != now) return Tally::Stale;
    Word& w = word(voter_id, s);
    const Word next = v == Vote::None ? Word{} : Word{v, epoch};
    if (w.vote == next.vote && w.epoch == next.epoch) return Tally::Repeated;
    w = next;
    return Tally::Counted;
}

Tally Membership::vote_local(PlayerId s, bool gone) {
    if (s >= slots_.size()) return Tally::NotRunning;
    const std::uint8_t e = slots_[s].epoch;
    return gone ? vote(local_, s, Vote::Gone, static_cast<std::uint8_t>(e + 1)) : vote(local_, s, Vote::Runs, e);
}

Vote Membership::vote_of(PlayerId voter_id, PlayerId s) const {
    if (!voter(voter_id) || s >= slots_.size() || !running(s)) return Vote::None;
    return word(voter_id, s).vote;
}

int Membership::gone_votes(PlayerId s) const {
    int n = 0;
    for (std::size_t v = 0; v < slots_.size(); ++v)
        if (vote_of(static_cast<PlayerId>(v), s) == Vote::Gone) ++n;
    return n;
}

// Strict majority; two have none of the other's, and the rule says whether one vote is enough.
int Membership::majority_of(int n) const {
    if (n == 2 && rule_ == TwoPlayerRule::PlayOnAlone) return 1;
    return n / 2 + 1;
}

int Membership::majority_size() const { return majority_of(running_voters()); }

bool Membership::majority(int votes) const { return votes >= majority_size(); }

bool Membership::decided_gone(PlayerId s) const {
    // A running host slot, voter or joiner (a joiner's handoff may lapse: SlotView::watch_handoff).
    if (s >= slots_.size() || !running(s) || host_of(s) != s) return false;
    // The view this decision is taken in: the voters, and the slot itself if it is joining (so
    // a survivor whose only other voter died while a joiner's handoff was in flight decides by
    // the two-player rule, and a joiner lapsing beside two voters needs both).
    const int n = electorate(s);
    // A view of two has no majority: each side decides for itself, on its own evidence. The
    // other's word about this process's slot is a claim, never a drop (a stale table still
    // carrying a withdrawn vote kicked a survivor of a three-player match once the third was
    // dropped: issue 21); if the other really drops this one it stops talking to it, and this
    // one's own silence vote drops the other.
    if (n == 2) return rule_ == TwoPlayerRule::PlayOnAlone && s != local_ && vote_of(local_, s) == Vote::Gone;
    // A majority is at least one vote, so no vote decides nothing; checked first because the
    // session asks about every slot every tick and counting walks the whole view.
    const int votes = gone_votes(s);
    return votes > 0 && votes >= majority_of(n);
}

PlayerId Membership::next_gone() const {
    for (std::size_t s = 0; s < slots_.size(); ++s)
        if (decided_gone(static_cast<PlayerId>(s))) return static_cast<PlayerId>(s);
    return static_cast<PlayerId>(slots_.size());
}

SlotState Membership::advertised_state(PlayerId s) const {
    return vote_of(local_, s) == Vote::Gone ? SlotState::Disconnected : slots_[s].state;
}

std::uint8_t Membership::advertised_epoch(PlayerId s) const {
    return vote_of(local_, s) == Vote::Gone ? word(local_, s).epoch : slots_[s].epoch;
}

bool Membership::votes_any_gone() const {
    for (std::size_t s = 0; s < slots_.size(); ++s)
        if (vote_of(local_, static_cast<PlayerId>(s)) == Vote::Gone) return true;
    return false;
}

// The voters it hears are the voters it does not vote gone; each drop it wants must find a
// majority of its own electorate among them (a joining slot's counts the joiner too, and under
// NoDrop a survivor beside a joiner that lapses is cut off as a survivor of two would be).
bool Membership::partitioned() const {
    if (!voter(local_)) return false;
    int heard = running_voters();
    for (std::size_t s = 0; s < slots_.size(); ++s)
        if (voter(static_cast<PlayerId>(s)) && vote_of(local_, static_cast<PlayerId>(s)) == Vote::Gone) --heard;
    for (std::size_t s = 0; s < slots_.size(); ++s) {
        const auto p = static_cast<PlayerId>(s);
        if (vote_of(local_, p) == Vote::Gone && heard < majority_of(electorate(p))) return true;
    }
    return false;
}

}  // namespace lockroll::rollback
