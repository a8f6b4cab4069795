// Who authored each input of a running slot's stream: its own process (the owner), or a third
// peer that relayed it to fill a gap the owner's stream had not delivered yet (issue 21).
//
// While a slot is in the view only its owner authors its inputs. A relayed input is a claim:
// the session stores it so the frame can be simulated, and records it here as unverified. When
// the owner's own copy of that frame arrives, it either verifies the relayed one (equal) or
// contradicts it; then the owner wins (the session replaces the input where no confirmed frame
// rests on it yet), and the relay is counted and its relayed blocks ignored from then on. The
// owner is never blamed for a relay's word. The session's confirmation waits on the oldest
// unverified frame (first_unverified) for as long as its saved states allow; docs/sessions.md
// ("Relayed inputs") has the whole rule.
//
// Past that bound the relayed input is confirmed on the relay's word: trust, then verify. The
// other rule -- confirm only what the owner sent or a majority of relays agree on, else wait --
// was weighed and refused: with three players a slot cut from one peer has one relay, so every
// honest one-way cut longer than the bound would stall the match until it healed. A lie
// confirmed this way costs its victim a recovery: the owner's copy exposes it (this class counts
// the relay and ignores it from then on), the checksums find the divergence, and desync
// recovery reloads the majority's state (tests/rollback/relay_equivocation_test.cpp).
//
// Contract
//  - Records are kept per slot in frame order. Each (slot, frame) holds at most one record: the
//    queue accepts one input per frame, so a second relay's copy of a held frame is no record.
//  - Memory is bounded by the input queues: forget_before drops what the queue has discarded,
//    so a slot never holds more records than its queue's capacity.
//  - Pure bookkeeping: no clock, no I/O, no exceptions beyond allocation.
#pragma once

#include <cstdint>
#include <deque>
#include <optional>
#include <vector>

#include <lockroll/rollback/session_types.h>

namespace lockroll::rollback {

class InputAuthority {
public:
    // players: slots with streams; peers: every peer id a relay may have (players + spectators).
    InputAuthority(int players, int peers);

    // A relay's input of `slot` at `frame` was stored (it filled a gap of the owner's stream).
    // Frames must come in increasing order per slot; an older or repeated one is not recorded.
    void note_relayed(PlayerId slot, std::uint32_t frame, PlayerId relay);
    // Another relay delivered the same bytes for a recorded frame. Two distinct relays that agree
    // vouch for the input: with at most one lying peer one of them is honest, so the frame no
    // longer waits for the owner's copy (first_unverified skips it). The owner still wins later.
    void vouch(PlayerId slot, std::uint32_t frame, PlayerId relay);
    // The relay whose input of that frame the queue holds, while the record is kept (not yet
    // verified, or contradicted when a confirmed frame already rested on it).
    std::optional<PlayerId> relay_of(PlayerId slot, std::uint32_t frame) const;
    // Another relay delivered different bytes for a recorded frame: a claim against a claim,
    // which the owner settles. Remembered (relays with peer ids below 64, which every player
    // has) so that the owner's copy, if it verifies the recorded input, counts this one.
    void dispute(PlayerId slot, std::uint32_t frame, PlayerId relay);
    // The owner's own copy of the frame arrived and equals the relayed input: the record goes.
    // Every relay that disputed it contradicted the owner: each is counted and ignored from then
    // on, and returned (bit r: relay r), so the session can report it.
    std::uint64_t verified(PlayerId slot, std::uint32_t frame);
    // The owner's copy differs. The first time for this frame the relay is counted and ignored
    // from then on (true); again for the same frame (an owner's resend) nothing more (false).
    // Its disputers are not counted: their bytes are not kept, so they may be the owner's.
    // replaced: the owner's input took its place (the record goes); otherwise a confirmed frame
    // rests on the relayed input, which stands, and the record stays, marked, so the owner's
    // resends are known for what they are.
    bool owner_disagrees(PlayerId slot, std::uint32_t frame, bool replaced);
    // A relay's input contradicts one the owner's own stream delivered: counted and ignored.
    void relay_disagrees(PlayerId relay);
    // The oldest frame at or after `from`, over all slots, whose input is a relay's and neither
    // verified nor contradicted by its owner, nor vouched for by a second relay.
    std::optional<std::uint32_t> first_unverified(std::uint32_t from = 0) const;
    // The same for one slot: what this session may relay onward stops there.
    std::optional<std::uint32_t> first_unverified_of(PlayerId slot, std::uint32_t from = 0) const;
    // Records of `slot` before `frame` will never be looked at again (the queue discarded them).
    void forget_before(PlayerId slot, std::uint32_t frame);
    // The slot's stream starts over (it left or rejoined the view, or a snapshot was loaded).
    void reset_slot(PlayerId slot);
    void reset_all();

    bool ignored(PlayerId relay) const { return relay < ignored_.size() && ignored_[relay]; }
    std::uint64_t disagreements(PlayerId relay) const { return relay < counts_.size() ? counts_[relay] : 0; }

private:
    struct Record {
        std::uint32_t frame;
        PlayerId relay;
        bool contradicted = false;
        bool vouched = false;
        std::uint64_t disputers = 0;  // bit r: relay r sent different bytes (dispute())
    };
    using Records = std::deque<Record>;
    Records::iterator find(PlayerId slot, std::uint32_t frame);  // end() of records_[slot] if none
    Records::const_iterator find(PlayerId slot, std::uint32_t frame) const;
    std::vector<Records> records_;  // per slot, ascending frames
    std::vector<bool> ignored_;                // per peer
    std::vector<std::uint64_t> counts_;        // per peer
};

}  // namespace lockroll::rollback
