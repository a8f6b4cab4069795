#include "rollback/recovery_source.h"

#include <array>
#include <bit>
#include <vector>

#include "rollback/arbitration.h"

namespace lockroll::rollback {

std::optional<PlayerId> recovery_source(PlayerId me, std::uint64_t mine,
                                        std::span<const std::pair<PlayerId, std::uint64_t>> theirs, DesyncKeep keep) {
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
    if (v.is_winner(me)) return std::nullopt;  // the odd ones reload
    return static_cast<PlayerId>(v.lowest_winner());
}

RecoveryStep next_recovery_step(const RecoveryCase& c) {
    using Act = RecoveryStep::Act;
    if (c.investigating && c.now_us < c.mismatch_since_us + 3'000'000) return {};
    if (!c.mine) return {Act::Forget};
    std::vector<std::pair<PlayerId, std::uint64_t>> theirs;
    for (const auto& [peer, value] : c.peers) {
        if (!value) {
            if (c.now_us < c.mismatch_since_us + 5'000'000) return {};  // wait for everyone's word
            continue;
        }
        theirs.emplace_back(peer, *value);
    }
    const auto source = recovery_source(c.me, *c.mine, theirs, c.keep);
    if (!source) return {Act::Forget};  // we are in the majority: the odd ones reload
    if (c.recoveries >= c.max_recoveries) return {Act::GiveUp};
    return {Act::Reload, *source};
}

}  // namespace lockroll::rollback
