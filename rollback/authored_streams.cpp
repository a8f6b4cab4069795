#include "rollback/authored_streams.h"

#include <algorithm>

#include "rollback/protocol.h"

namespace lockroll::rollback {

AuthoredStreams::AuthoredStreams(const SessionConfig& config, const Membership& view, std::vector<SlotView>& slots,
                                 const std::vector<PeerLink>& links, AuthoringEffects& effects)
    : config_(config), view_(view), slots_(slots), links_(links), effects_(effects), scratch_(kMaxInputSize, 0) {}

std::optional<PlayerId> AuthoredStreams::owner() const {
    for (int s = 0; s < config_.players; ++s)
        if (view_.running(static_cast<PlayerId>(s))) return static_cast<PlayerId>(s);
    return std::nullopt;
}

// Every live player peer reported the slot as we see it, holding no more of its stream than we do.
// A vote ("disconnected" in the next epoch, flagged voted) looks the same but is no drop: while
// the slot runs at that peer, its process's inputs still reach it (a kick or a lapse: the process
// lives), and it confirms frames on them that our neutral input would contradict. Only a drop
// applied freezes what it holds, save relays of what some peer holds already.
bool AuthoredStreams::ready_to_author(PlayerId slot) const {
    for (std::size_t p = 0; p < links_.size(); ++p) {
        const auto pid = static_cast<PlayerId>(p);
        if (!effects_.live_peer(pid) || pid >= static_cast<PlayerId>(config_.players)) continue;
        const PeerLink& l = links_[p];
        if (!(l.table_seen[slot] && !l.table[slot].voted && l.table[slot].epoch == view_.epoch(slot) &&
              l.table[slot].state == view_.state(slot) && l.has_count[slot] && l.counts[slot] <= count_of(slot)))
            return false;
    }
    return true;
}

// The owner (lowest running slot) writes every non-running slot's neutral inputs. For a slot
// just dropped it first waits until every running peer has reported the drop with what it holds
// of the slot's stream, and holds at least as much itself (peers relay what it lacks): then the
// neutral inputs start right after the last real input anyone received, and nobody has confirmed
// anything else.
void AuthoredStreams::author_absent_streams(std::uint32_t target, std::uint64_t now_us) {
    const auto own = owner();
    if (!own || *own != config_.local_player || config_.role == Role::Spectator) return;
    static const std::vector<std::uint8_t> neutral_storage(kMaxInputSize, 0);
    const std::span<const std::uint8_t> neutral(neutral_storage.data(), config_.input_size);
    for (int s = 0; s < config_.players; ++s) {
        const auto slot = static_cast<PlayerId>(s);
        SlotView& v = slots_[static_cast<std::size_t>(s)];
        if (view_.running(slot)) continue;
        if (!v.authoring) {
            if (!ready_to_author(slot)) continue;
            v.authoring = true;
            if (!v.neutral_reported) {
                v.neutral_reported = true;
                effects_.emit(SessionEvent::Kind::NeutralFrom, SessionEvent::Reason::WritesNeutral, slot, count_of(slot), now_us,
                              "this peer writes the neutral input");
            }
        }
        while (count_of(slot) <= target) {
            if (effects_.write(slot, count_of(slot), neutral, true) != InputQueue::Add::Stored) break;
        }
    }
}

// The slots this session hosts follow its own stream frame for frame: their inputs are
// confirmed at once (the gap a longer input delay opens repeats each one's last input, as the
// local stream does) and reach the peers as stream blocks (StreamRelay::fill_extension).
void AuthoredStreams::author_guest_streams(std::span<const PlayerId> local_slots, std::span<const std::uint8_t> inputs) {
    const std::size_t n = config_.input_size;
    const std::uint32_t want = count_of(config_.local_player);
    for (std::size_t i = 1; i < local_slots.size(); ++i) {
        const PlayerId g = local_slots[i];
        if (!view_.running(g)) continue;
        const auto input = inputs.subspan((i - 1) * n, n);
        const InputQueue& q = effects_.stream(g);
        while (count_of(g) < want) {
            const std::uint32_t f = count_of(g);
            const auto last = q.last_confirmed();
            std::copy(input.begin(), input.end(), scratch_.begin());
            if (f + 1 < want && !last.empty()) std::copy(last.begin(), last.end(), scratch_.begin());
            if (f + 1 < want && last.empty()) std::fill(scratch_.begin(), scratch_.end(), std::uint8_t{0});
            if (effects_.write(g, f, std::span(scratch_).first(n), false) != InputQueue::Add::Stored) break;
        }
    }
}

}  // namespace lockroll::rollback
