// What rollback/ needs from a game: a deterministic state machine it can step, save, load and
// checksum. rollback/ never names sim/ types; world_simulation.h adapts sim::World, and tests
// plug in toy simulations through the same interface.
//
// Contract
//  - Determinism: step() must be a pure function of (state, inputs). Everything rollback does
//    (prediction, resimulation, lockstep, desync alerts, replays) relies on it.
//  - Inputs are opaque fixed-size blobs: step() receives players * input_size bytes, player p's
//    input at [p * input_size, (p + 1) * input_size). The session owns the sizes.
//  - Each frame's inputs come with a per-slot InputStatus. Absent slots (nobody playing: not
//    joined yet, or disconnected) get the neutral input (all zero bytes), flagged Absent, on
//    every peer from the same agreed frame, so a game may act on it (despawn, freeze, AI). A
//    state may depend on Absent vs present, never on Predicted vs Confirmed: that difference is
//    for presentation only (a prediction that turned out right is not resimulated). The
//    two-argument step() forwards to the one-argument one unless a game overrides it.
//  - save/load: state_size() is constant for the simulation's life -- the capacity, so snapshot
//    buffers are allocated once. A state that grows and shrinks (games spawn and despawn)
//    overrides saved_size(): the bytes save() writes now, at most state_size(); lockroll keeps
//    that many per saved frame and hands exactly those bytes to load(), checksum() and the
//    narrowing functions (save_to() does both steps). A saved_size() above state_size() is a
//    bug in the game: the session fails with a message saying so. save(); load() of those
//    bytes; step() gives the same state as step() without the round trip, bit for bit. load()
//    validates before touching anything.
//  - checksum(state) hashes a *saved* state, so confirmed frames can be checksummed long after
//    the live state moved on. Equal states must give equal checksums on every platform.
//  - The optional part (bodies, fields, describe_state, flip_bit) exists for desync narrowing and
//    fault injection; a simulation without it still gets checksum alerts, just not the body.
//  - A game that names fields (field_count() > 0, field_value()) gets a body_hash() of them for
//    free, so narrowing finds the body and field without more code. A game overriding
//    body_hash() must make it cover every field, or a differing field hides behind equal hashes
//    and narrowing can only say that every body hash agrees.
//    Functions that take a state are only ever given buffers of state_size() bytes that came
//    from save().
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>

namespace lockroll::rollback {

// How a slot's input for one frame came about.
enum class InputStatus : std::uint8_t {
    Confirmed = 0,  // the player's own input, final
    Predicted = 1,  // a guess; the frame is resimulated if the real input differs
    Absent = 2,     // nobody plays the slot: the neutral input, final
};

class Simulation {
public:
    virtual ~Simulation() = default;

    virtual void step(std::span<const std::uint8_t> inputs) = 0;
    // status: one entry per slot. Default: ignore it (absent slots' neutral input is all zeros).
    virtual void step(std::span<const std::uint8_t> inputs, std::span<const InputStatus> status) {
        (void)status;
        step(inputs);
    }

    // The most bytes a saved state can take (fixed for the simulation's life).
    virtual std::size_t state_size() const = 0;
    // Bytes save() writes for the current state (<= state_size()). Default: state_size().
    virtual std::size_t saved_size() const { return state_size(); }
    // Writes exactly saved_size() bytes into out (out.size() >= saved_size()).
    virtual void save(std::span<std::uint8_t> out) const = 0;
    // save() into `buffer` (state_size() bytes); returns the bytes written, or an empty span
    // when saved_size() broke its promise (then nothing was written).
    std::span<std::uint8_t> save_to(std::span<std::uint8_t> buffer) const;
    // Empty string on success; otherwise what was wrong, and the state is unchanged.
    virtual std::string load(std::span<const std::uint8_t> in) = 0;

    // Default: XXH3-64 of the saved bytes.
    virtual std::uint64_t checksum(std::span<const std::uint8_t> state) const;

    // ---- optional: desync narrowing ----
    // Bodies are the units a desync report names; index is the position in a saved state
    // (0..body_count()-1), body_id() the name people know them by (sim::BodyId for the World).
    virtual std::uint32_t body_count() const { return 0; }
    virtual std::uint32_t body_id(std::uint32_t index) const { return index; }
    // Default: 0 when the simulation names no fields, else XXH3-64, seeded with body_id(index),
    // of field_value(state, index, 0 .. field_count()-1), each as 8 bytes little-endian.
    virtual std::uint64_t body_hash(std::span<const std::uint8_t> state, std::uint32_t index) const;
    // Every body has field_count() integer fields (for the World: position.x .. velocity.z).
    virtual int field_count() const { return 0; }
    virtual const char* field_name(int field) const;
    virtual std::int64_t field_value(std::span<const std::uint8_t> state, std::uint32_t index, int field) const;
    // Text a person can diff between two peers' evidence files: one line per body. Default: a
    // hex dump, 32 bytes per line.
    virtual std::string describe_state(std::span<const std::uint8_t> state) const;

    // ---- optional: fault injection ----
    // Flips one bit of one field of one body in the live state. False when unsupported or when
    // (body_id, field) does not name a stored field (then nothing changed).
    virtual bool flip_bit(std::uint32_t body_id, int field, int bit);
};

}  // namespace lockroll::rollback
