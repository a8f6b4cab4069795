#include "rollback/joiner_reach.h"

#include "rollback/membership.h"

namespace lockroll::rollback {

void JoinerReach::begin(std::uint64_t now_us) {
    if (begun_) return;
    begun_ = true;
    begun_us_ = now_us;
}

void JoinerReach::heard(PlayerId p, std::uint64_t) {
    if (peers_.size() <= p) peers_.resize(static_cast<std::size_t>(p) + 1);
    peers_[p] = {true, false};
}

void JoinerReach::named_silent(std::span<const PlayerId> voters) {
    for (PlayerId p : voters) {
        if (peers_.size() <= p) peers_.resize(static_cast<std::size_t>(p) + 1);
        peers_[p].named_silent = true;
    }
}

JoinerReach::Verdict JoinerReach::judge(const SessionConfig& c, std::uint64_t now_us) const {
    Verdict v;
    if (!begun_) return v;
    const auto peer = [&](PlayerId p) { return p < peers_.size() ? peers_[p] : Peer{}; };
    Membership view(c.players, c.local_player, c.two_player_rule, c.slot_hosts);
    for (int s = 0; s < c.players; ++s)
        if (c.absent_slots >> s & 1) view.set(static_cast<PlayerId>(s), SlotState::Absent, 0);
    for (const SlotEntry& e : table_)
        if (e.slot < static_cast<PlayerId>(c.players)) view.set(e.slot, e.state, e.epoch);
    for (int s = 0; s < c.players; ++s) {
        const auto p = static_cast<PlayerId>(s);
        if ((p == c.local_player || peer(p).heard) && !view.running(p)) view.set(p, SlotState::Running, view.epoch(p));
    }
    const bool long_unheard = c.disconnect_us != 0 && now_us >= begun_us_ + c.disconnect_us;
    for (int s = 0; s < c.players; ++s) {
        const auto p = static_cast<PlayerId>(s);
        if (p == c.local_player || !view.running(p) || view.host_of(p) != p) continue;
        ++v.others;
        const Peer w = peer(p);
        if (w.named_silent || (!w.heard && long_unheard)) v.unreached.push_back(p);
        else ++v.reached;
    }
    v.needed = view.majority_size();
    v.cut_off = !v.unreached.empty() && v.reached < v.needed;
    return v;
}

}  // namespace lockroll::rollback
