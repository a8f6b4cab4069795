#include "rollback/input_intake.h"

#include <algorithm>
#include <bit>

#include "rollback/input_authority.h"
#include "rollback/input_frames.h"
#include "rollback/slot_hosts.h"
#include "rollback/sync.h"

namespace lockroll::rollback {

PlayerId InputIntake::host_of(PlayerId slot) const { return lockroll::rollback::host_of(s_.config, slot); }

bool InputIntake::mine(PlayerId slot) const {
    const PlayerId me = s_.config.local_player;
    return s_.config.role != Role::Spectator && (slot == me || (host_of(slot) != slot && host_of(slot) == me));
}

std::uint32_t InputIntake::count_of(PlayerId slot) const { return s_.sync.queue(slot).confirmed_count(); }

void InputIntake::apply(PlayerId from, const InputMessage& m, std::uint64_t now_us) {
    PeerLink& link = s_.links[from];
    const bool from_player = is_slot(from);
    const bool i_play = s_.config.role != Role::Spectator;
    const PlayerId me = s_.config.local_player;
    // Unwrap every frame before applying anything, so a bad packet changes nothing.
    InputReferences refs;
    refs.from_player = from_player;
    refs.takes_ack = from_player && i_play;
    refs.our_count = i_play ? count_of(me) : 0;
    refs.its_count = from_player ? count_of(from) : 0;
    refs.frame = s_.sync.frame();
    refs.newest_checksum = s_.newest_checksum;
    refs.players = s_.config.players;
    InputFrames frames;
    if (const char* e = unwrap_input(m, refs, frames)) return fx_.malformed(from, e);
    const auto& [ack, first, sender_frame, checksum_frames] = frames;

    if (ack && link.take_ack(*ack)) fx_.acked();
    if (first) {
        const std::size_t n = s_.config.input_size;
        for (std::uint32_t k = 0; k < m.frame_count; ++k) {
            const std::uint32_t f = *first + k;
            const auto in = std::span(m.inputs).subspan(k * n, n);
            const auto r = s_.sync.add_remote_input(from, f, in);
            if (!owner_copy(from, f, in, r)) return fx_.malformed(from, "input message: rewrites a confirmed input");
            if (r == InputQueue::Add::Gap || r == InputQueue::Add::TooFarAhead) break;  // resent later
        }
    }
    if (m.has_extension) {
        apply_slot_table(from, m, now_us);
        if (fx_.failed()) return;
        apply_blocks(from, m);
    }
    if (sender_frame) {
        // An honest peer is never farther from us than input delay plus prediction window (plus
        // the time sync's own slack); a claim beyond that is clipped, so one forged message
        // cannot make us wait thousands of frames.
        const std::int64_t bound = s_.advantage_bound;
        const std::int64_t clipped = std::clamp<std::int64_t>(m.advantage, -bound, bound);
        link.note_remote_frame(*sender_frame, static_cast<std::int8_t>(std::clamp<std::int64_t>(clipped, -127, 127)),
                               now_us);
        link.take_stamps(m.stamp, m.echo, m.hold, now_us);
    }
    for (int i = 0; i < m.checksum_count; ++i) fx_.remote_checksum(from, checksum_frames[i], m.checksums[i]);
}

// The sender's table: its counts (relays, agreement), and its vote about every running slot.
// About a running slot, "disconnected" in a newer epoch is the sender's vote that it is gone and
// "running" in our epoch its vote that it runs; only a majority of such votes drops the slot
// (settle_membership). "Running" in a newer epoch is a hand-over to a new process (the owner's
// word, adopted as before), and so is any newer epoch of a slot that does not run here (a join,
// or a drop we missed). The sender's entries about itself and its guests say nothing new, and
// nobody but this session's own process hands over this session's slots.
void InputIntake::apply_slot_table(PlayerId from, const InputMessage& m, std::uint64_t now_us) {
    PeerLink& link = s_.links[from];
    const Membership& view = s_.membership;
    for (const SlotEntry& e : m.slots) {
        const std::size_t s = e.slot;
        const auto count = unwrap_frame(e.count, count_of(e.slot));
        link.table[s] = e;
        link.table_seen[s] = true;
        link.counts_at_us = now_us;
        if (count) {
            link.counts[s] = *count;
            link.has_count[s] = true;
        }
        if (!is_slot(from)) continue;            // spectators report counts, never vote
        if (host_of(e.slot) == from) continue;   // a player's own entry says nothing new
        if (s_.config.role == Role::Spectator) {
            // A spectator follows the view of the players that serve it (they send it the view,
            // not their votes).
            if (newer_epoch(e.epoch, view.epoch(e.slot))) fx_.adopt_slot(e.slot, e, now_us);
            continue;
        }
        const bool newer = newer_epoch(e.epoch, view.epoch(e.slot));
        if (!view.running(e.slot)) {
            if (newer && !mine(e.slot)) fx_.adopt_slot(e.slot, e, now_us);
        } else if (e.state == SlotState::Running && newer) {
            if (!mine(e.slot)) fx_.adopt_slot(e.slot, e, now_us);
        } else {
            fx_.count_vote(from, e.slot, e.state == SlotState::Running ? Vote::Runs : Vote::Gone, e.epoch);
            // A drop it applied (not a vote): its word that the view agreed on it.
            if (e.state != SlotState::Running && !e.voted && newer) fx_.heard_drop(from, e.slot, e.epoch);
        }
        if (fx_.failed()) return;
    }
    if (m.has_agreement && s_.config.role != Role::Spectator) fx_.heard_agreement(from, m.agreement);
    fx_.settle_membership(now_us);
    if (fx_.failed()) return;
    if (s_.config.role == Role::Spectator) return;
    // What the sender holds of our stream (a spectator or joiner reports it here).
    const PlayerId me = s_.config.local_player;
    if (link.has_count[me] && link.counts[me] > link.remote_ack && link.counts[me] <= count_of(me)) {
        link.remote_ack = link.counts[me];
        fx_.acked();
    }
}

// Inputs of other slots' streams, forwarded by the sender. Accepted only for streams whose
// player is not the sender's connection itself (that is the base message's job) and, for a
// running slot, never from anyone while the slot's own process sends them: only gaps are filled,
// and a forwarded input that contradicts a confirmed one is a protocol violation like any other.
void InputIntake::apply_blocks(PlayerId from, const InputMessage& m) {
    const std::size_t n = s_.config.input_size;
    for (const StreamBlock& b : m.blocks) {
        if (is_slot(from) && b.slot == from) continue;
        if (mine(b.slot)) continue;
        const auto first = unwrap_frame(b.first_frame, count_of(b.slot));
        if (!first) continue;
        if (relayed_block(from, b, *first)) {
            if (fx_.failed() || s_.links[from].error()) return;
            continue;
        }
        for (std::uint32_t k = 0; k < b.frame_count; ++k) {
            const auto r = s_.sync.add_remote_input(b.slot, *first + k, std::span(b.inputs).subspan(k * n, n), b.absent);
            if (r == InputQueue::Add::Conflict) return fx_.malformed(from, "input message: relayed input contradicts a confirmed one");
            if (r == InputQueue::Add::Gap || r == InputQueue::Add::TooFarAhead) break;
        }
        SlotView& v = s_.slots[b.slot];
        if (b.absent && !v.neutral_reported && !s_.membership.running(b.slot)) {
            v.neutral_reported = true;
            // The first absent input of this epoch tells the agreed frame.
            std::uint32_t f = count_of(b.slot);
            const InputQueue& q = s_.sync.queue(b.slot);
            while (f > q.floor() && q.confirmed_absent(f - 1)) --f;
            fx_.neutral_from(b.slot, f);
        }
    }
}

// Equal to a relayed copy: verified, and any relay that disputed it with other bytes is counted
// and ignored. Different from a relayed copy: the owner wins -- its input
// replaces the relay's where no confirmed frame rests on it yet, and the relay is counted and
// ignored; if a confirmed frame already rests on it, it stands (the checksums tell; recovery
// repairs) and the owner is not blamed.
bool InputIntake::owner_copy(PlayerId slot, std::uint32_t f, std::span<const std::uint8_t> input, InputQueue::Add added) {
    if (added == InputQueue::Add::Duplicate) {
        // Relays that disputed the verified input with other bytes contradicted the owner.
        const std::uint64_t wrong = s_.authority.verified(slot, f);
        for (std::uint64_t w = wrong; w != 0; w &= w - 1) {
            const auto r = static_cast<std::size_t>(std::countr_zero(w));
            if (r < s_.peer_stats.size()) s_.peer_stats[r].relay_disagreements = s_.authority.disagreements(static_cast<PlayerId>(r));
        }
    }
    if (added != InputQueue::Add::Conflict) return true;
    const auto relay = s_.authority.relay_of(slot, f);
    if (!relay) return false;
    const bool replaced = s_.sync.replace_remote_input(slot, f, input);
    if (s_.authority.owner_disagrees(slot, f, replaced) && *relay < s_.peer_stats.size())
        s_.peer_stats[*relay].relay_disagreements = s_.authority.disagreements(*relay);
    return true;
}

// A block of a running slot's stream, not from this session's own streams: its owner's (a host
// sends its guests' streams as blocks), or a relay's claim that fills only what the owner's
// stream has not delivered. True when handled here; false for every other block (absent
// streams, spectators' views), which apply_blocks takes as before.
bool InputIntake::relayed_block(PlayerId from, const StreamBlock& b, std::uint32_t first) {
    if (s_.config.role == Role::Spectator || b.absent || !s_.membership.running(b.slot)) return false;
    const std::size_t n = s_.config.input_size;
    const bool owner = is_slot(from) && host_of(b.slot) == from;
    if (!owner && s_.authority.ignored(from)) {
        ++s_.peer_stats[from].ignored_packets;
        return true;
    }
    for (std::uint32_t k = 0; k < b.frame_count; ++k) {
        const std::uint32_t f = first + k;
        const auto in = std::span(b.inputs).subspan(k * n, n);
        const auto r = s_.sync.add_remote_input(b.slot, f, in, false);
        if (owner) {
            if (!owner_copy(b.slot, f, in, r)) {
                fx_.malformed(from, "input message: rewrites a confirmed input of its guest");
                return true;
            }
        } else if (r == InputQueue::Add::Stored) {
            s_.authority.note_relayed(b.slot, f, from);
        } else if (r == InputQueue::Add::Duplicate) {
            s_.authority.vouch(b.slot, f, from);
        } else if (r == InputQueue::Add::Conflict) {
            // Against another relay's claim the owner decides later (its copy, if it verifies
            // the claim held, counts this relay); against the owner's own input this relay is
            // wrong: counted and ignored, never a drop of the owner.
            if (s_.authority.relay_of(b.slot, f)) {
                s_.authority.dispute(b.slot, f, from);
            } else {
                s_.authority.relay_disagrees(from);
                s_.peer_stats[from].relay_disagreements = s_.authority.disagreements(from);
            }
            return true;
        }
        if (r == InputQueue::Add::Gap || r == InputQueue::Add::TooFarAhead) break;
    }
    return true;
}

}  // namespace lockroll::rollback
