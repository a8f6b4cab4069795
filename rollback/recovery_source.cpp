#include "rollback/recovery_source.h"

#include <array>
#include <bit>
#include <string>
#include <utility>
#include <vector>

#include "rollback/arbitration.h"

namespace lockroll::rollback {

std::optional<PlayerId> recovery_source(PlayerId me, std::uint64_t mine,
                                        std::span<const std::pair<PlayerId, std::uint64_t>> theirs, DesyncKeep keep) {
    return choose_recovery(me, mine, theirs, keep).source;
}

RecoveryChoice choose_recovery(PlayerId me, std::uint64_t mine, std::span<const std::pair<PlayerId, std::uint64_t>> theirs,
                               DesyncKeep keep) {
    // An input message carries the low 32 bits of a checksum: compare only those.
    std::array<std::uint64_t, kMaxPlayers> values{};
    std::uint64_t voted = 0;
    const auto vote = [&](PlayerId slot, std::uint64_t value) {
        if (slot >= kMaxPlayers) return;
        values[slot] = static_cast<std::uint32_t>(value);
        voted |= std::uint64_t{1} << slot;
    };
    vote(me, mine);
    for (const auto& [slot, value] : theirs)
        if (slot != me) vote(slot, value);
    // P2P always keeps one side of a tie (two players included): two_player_keep names it.
    const ArbitrationRule rule{keep == DesyncKeep::LowestSlot ? ArbitrationTie::LowestSlot : ArbitrationTie::HighestSlot,
                               false};
    const ArbitrationVerdict v = arbitrate(values, voted, std::popcount(voted), rule);
    RecoveryChoice c;
    c.tie = v.tie_broken;
    const std::string n = std::to_string(std::popcount(v.winners));
    c.rule = c.tie ? "no majority (a tie, " + n + " against " + n + "): the tie rule (two_player_keep: " +
                         (keep == DesyncKeep::LowestSlot ? "lowest_slot" : "highest_slot") + ") keeps slot " +
                         std::to_string(v.lowest_winner()) + "'s group"
                   : "the biggest group, " + n + " of " + std::to_string(v.voters);
    if (!v.is_winner(me)) c.source = static_cast<PlayerId>(v.lowest_winner());  // the odd ones reload
    return c;
}

RecoveryStep next_recovery_step(const RecoveryCase& c) {
    using Act = RecoveryStep::Act;
    const auto only = [](Act a) {
        RecoveryStep s;
        s.act = a;
        return s;
    };
    if (c.investigating && c.now_us < c.mismatch_since_us + 3'000'000) return {};
    if (!c.mine) return only(Act::Forget);
    std::vector<std::pair<PlayerId, std::uint64_t>> theirs;
    for (const auto& [peer, value] : c.peers) {
        if (!value) {
            if (c.now_us < c.mismatch_since_us + 5'000'000) return {};  // wait for everyone's word
            continue;
        }
        theirs.emplace_back(peer, *value);
    }
    RecoveryChoice choice = choose_recovery(c.me, *c.mine, theirs, c.keep);
    if (!choice.source) return only(Act::Forget);  // we are in the majority: the odd ones reload
    if (c.recoveries >= c.max_recoveries) return only(Act::GiveUp);
    return {Act::Reload, *choice.source, choice.tie, std::move(choice.rule)};
}

}  // namespace lockroll::rollback
