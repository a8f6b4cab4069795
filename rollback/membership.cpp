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

// Strict majority of the running processes; a view of two has none of the other's, and the
// rule says whether one vote is enough there.
int Membership::majority_size() const {
    const int n = running_voters();
    if (n == 2 && rule_ == TwoPlayerRule::PlayOnAlone) return 1;
    return n / 2 + 1;
}

bool Membership::majority(int votes) const { return votes >= majority_size(); }

bool Membership::decided_gone(PlayerId s) const {
    if (s >= slots_.size() || !voter(s)) return false;
    // A view of two has no majority: each side decides for itself, on its own evidence. The
    // other's word about this process's slot is a claim, never a drop (a stale table still
    // carrying a withdrawn vote kicked a survivor of a three-player match once the third was
    // dropped: issue 21); if the other really drops this one it stops talking to it, and this
    // one's own silence vote drops the other.
    if (running_voters() == 2) return rule_ == TwoPlayerRule::PlayOnAlone && s != local_ &&
                                      vote_of(local_, s) == Vote::Gone;
    // A majority is at least one vote, so no vote decides nothing; checked first because the
    // session asks about every slot every tick and majority() walks the whole view.
    const int votes = gone_votes(s);
    return votes > 0 && majority(votes);
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

bool Membership::partitioned() const {
    if (!voter(local_)) return false;
    int unheard = 0;
    for (std::size_t s = 0; s < slots_.size(); ++s)
        if (vote_of(local_, static_cast<PlayerId>(s)) == Vote::Gone) ++unheard;
    return unheard > 0 && !majority(running_voters() - unheard);
}

}  // namespace lockroll::rollback
