// The relay protocol: what a client and the relay server (server/) say to each other. The
// server runs no simulation; it collects every slot's inputs, confirms each frame once all are in
// or its deadline has passed, and broadcasts the confirmed input sets. Byte layout:
// docs/wire-format.md, "Relay messages".
//
// Contract (as protocol.h)
//  - Every field is written on its own, little-endian (rollback/bytes.h); no struct is copied
//    onto the wire.
//  - Decoding trusts nothing: counts and lengths are checked against the bytes present and fixed
//    limits before anything is read or allocated, trailing bytes are an error, and a failure is a
//    static description, never an assert or an exception.
//  - Frames travel as full 32-bit numbers: the server judges them against its own clock (an
//    input for a frame far from it is dropped and counted), so no unwrapping guess is needed.
//  - This file and its .cpp depend on the standard library only (the server links them without
//    rollback/ or sim/).
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "rollback/session_types.h"

namespace lockroll::rollback {

// 2: the hello carries a connect token (server/connect_token.h), refusals 9..14.
// 3: one connection plays several slots (the hello's also_slots, the input's slots mask).
inline constexpr std::uint16_t kRelayProtocolVersion = 3;
inline constexpr std::size_t kRelayMaxDatagramBytes = 1200;
inline constexpr int kRelayMaxPlayers = 16;
inline constexpr std::size_t kRelayMaxInputSize = 64;
inline constexpr int kRelayMaxChecksums = 4;
inline constexpr std::size_t kRelayMaxForwardBytes = 1100;
inline constexpr std::size_t kRelayMaxTokenBytes = 256;

// Kind bytes, disjoint from the peer-to-peer kinds (1..8 in protocol.h).
enum class RelayKind : std::uint8_t {
    Hello = 32,    // client -> server: join a room
    Welcome = 33,  // server -> client: accepted (or refused, with the reason)
    Input = 34,    // client -> server: own inputs, acks, checksums
    Frames = 35,   // server -> client: confirmed input sets, clock, acks
    Forward = 36,  // either way: an opaque message to / from another slot of the room (snapshots)
    Notice = 37,   // server -> client: a decision (desync verdict, snapshot source, drain)
};

std::optional<RelayKind> peek_relay_kind(std::span<const std::uint8_t> datagram);

// RelayRole: rollback/session_types.h (RelaySessionConfig names it).
inline constexpr std::uint8_t kLastRelayRole = 2;

enum class RelayRefusal : std::uint8_t {
    None = 0,
    Version = 1,      // protocol versions differ
    RoomParams = 2,   // the room exists with other players / input size / tick rate / scene
    SlotTaken = 3,    // a live connection holds the slot
    BadSlot = 4,      // slot out of range, or a spectator role naming a slot
    Full = 5,         // room or spectator limit reached
    Draining = 6,     // the server is shutting down and takes no new hellos
    Spoof = 7,        // this connection already holds another slot
    Ended = 8,        // the room's match is over
    // A server started with a key (connect tokens, server/connect_token.h):
    TokenMissing = 9,   // the hello carries no token
    TokenInvalid = 10,  // the token does not open under the server's key (forged, corrupted, another key)
    TokenExpired = 11,  // the token's expiry has passed
    TokenMismatch = 12, // the token is for another room, slot, role or room parameters
    TokenInUse = 13,    // a live connection of another process holds the slot with this token (a replay)
    SlotOwned = 14,     // the slot belongs to another client id: only its token's holder takes it back
    Kicked = 15,        // the slot was kicked from this room's match (a persistent checksum liar):
                        // no process takes it back while the match lasts
};
inline constexpr std::uint8_t kLastRelayRefusal = 15;
const char* relay_refusal_name(RelayRefusal r);

struct RelayHello {
    std::uint16_t version = kRelayProtocolVersion;
    std::uint64_t room_id = 0;
    std::uint64_t scene_checksum = 0;
    std::uint8_t players = 2;         // slots of the room (the first hello sets them)
    std::uint8_t input_size = 3;
    std::uint16_t tick_rate = 60;
    RelayRole role = RelayRole::Player;
    std::uint8_t slot = 0;            // wanted slot, the lowest this connection plays (ignored for spectators)
    // Bit s: this connection also plays slot s (couch + online: several local players in one
    // client). Every bit is above `slot` (one encoding per set of slots); 0 for a spectator.
    std::uint16_t also_slots = 0;
    std::uint16_t absent_slots = 0;   // bit s: nobody plays slot s at frame 0 (the first hello sets it)
    std::uint64_t incarnation = 0;    // a restarted process says so (its old connection is replaced)
    std::uint64_t stamp_us = 0;       // echoed in the welcome: the first round trip
    std::vector<std::uint8_t> token;  // connect token, opaque to the client (0..kRelayMaxTokenBytes)
};

struct RelayWelcome {
    RelayRefusal refusal = RelayRefusal::None;
    std::uint16_t version = kRelayProtocolVersion;
    std::uint8_t slot = 0;            // the id bound to this connection: its slot, or players + place
                                      // for a spectator (forwards name peers by these ids)
    std::uint8_t players = 2;
    std::uint8_t input_size = 3;
    std::uint16_t tick_rate = 60;
    std::uint16_t checksum_interval = 0;  // report confirmed checksums of multiples of this (0: never)
    std::uint8_t input_deadline = 8;  // ticks the server waits past a frame's time for its inputs
    bool started = false;             // the room clock runs (frame 0 has begun)
    std::uint32_t server_frame = 0;   // the room clock when sent
    std::uint32_t handoff_frame = 0;  // joiner: its own inputs start here
    std::uint8_t snapshot_from = 255; // joiner / spectator: the slot to pull a snapshot from
    std::uint64_t echo_us = 0;        // the hello's stamp
};

// confirmed_ack value: send no frames yet (a joiner still loading its snapshot).
inline constexpr std::uint32_t kRelayNoFrames = 0xFFFFFFFF;

// Client -> server, every tick.
// Each carried frame is one record: the inputs of the slots in `slots`, in slot order, input_size
// bytes each. The server takes them only when `slots` is exactly what the connection was
// admitted for: the mask names, it never grants.
struct RelayInput {
    std::uint32_t confirmed_ack = 0;  // next confirmed frame the client needs (or kRelayNoFrames)
    std::uint32_t first_frame = 0;    // frame of the first own record carried
    std::uint8_t frame_count = 0;
    std::uint16_t slots = 0;          // bit s: each record holds slot s's input (0: no records)
    std::vector<std::uint8_t> inputs; // frame_count * popcount(slots) * input_size
    std::uint16_t stamp = 0;          // round trip, as protocol.h: 100 µs units, wrapping
    std::uint16_t echo = 0;
    std::uint16_t hold = 0;
    std::uint8_t checksum_count = 0;
    std::uint32_t checksum_frames[kRelayMaxChecksums] = {};
    std::uint64_t checksums[kRelayMaxChecksums] = {};
};

// Per slot and frame: how the server confirmed it.
inline constexpr std::uint8_t kRelayAbsent = 0x01;    // nobody plays the slot: neutral input
inline constexpr std::uint8_t kRelayReplaced = 0x02;  // late: the server repeated the slot's last input

// Server -> client. Frames [first_frame, first_frame + frame_count) of the room's confirmed
// inputs. Each frame lists only the slots whose (flags, input) differ from the frame before it;
// the first frame of a message lists every slot (so a message never depends on another).
struct RelayFrames {
    std::uint32_t server_frame = 0;     // the room clock when sent
    std::uint16_t server_subframe = 0;  // and its fraction of a frame (1/65536 units)
    std::uint32_t input_ack = 0;        // next own input frame the server needs from this client
    std::uint32_t first_frame = 0;
    std::uint16_t frame_count = 0;
    std::uint8_t players = 0;
    std::uint8_t input_size = 0;
    // Decoded form: frame_count * players flags and frame_count * players * input_size inputs.
    std::vector<std::uint8_t> flags;
    std::vector<std::uint8_t> inputs;
    std::uint16_t stamp = 0;
    std::uint16_t echo = 0;
    std::uint16_t hold = 0;
};

// An opaque message between two slots of a room (snapshot transfer). Client -> server: `slot`
// is the destination; server -> client: the source, set by the server from the sender's
// connection (a client cannot speak for another).
struct RelayForward {
    std::uint8_t slot = 0;
    std::vector<std::uint8_t> payload;  // 1..kRelayMaxForwardBytes
};

enum class RelayNoticeKind : std::uint8_t {
    Desync = 1,     // your checksum of `frame` is in the minority: reload from slot `slot`
    Snapshot = 2,   // pull a snapshot from slot `slot` (the earlier source went away)
    Draining = 3,   // the server is draining: the room finishes, nothing new is accepted
    Kicked = 4,     // you were disconnected; `frame` carries the reason code (RelayRefusal)
};
inline constexpr std::uint8_t kLastRelayNotice = 4;
// A Desync notice's slot when no majority can settle the round (two voters that disagree): the
// match ends for the client, there is nobody to reload from.
inline constexpr std::uint8_t kRelayNoMajority = 255;

struct RelayNotice {
    RelayNoticeKind kind = RelayNoticeKind::Desync;
    std::uint8_t slot = 0;
    std::uint32_t frame = 0;
    std::uint64_t detail = 0;  // Desync: the majority checksum
};

// Most frames one Frames message can carry for these sizes (every slot changing every frame).
std::uint16_t relay_max_frames(int players, std::size_t input_size);
// Most own records one Input message can carry, a record being record_bytes long (one slot's
// input size times the slots a connection plays).
std::uint8_t relay_max_inputs(std::size_t record_bytes);
// The slots of a hello, lowest first: `slot` and every bit of `also_slots` (none for a spectator).
std::uint16_t relay_hello_slots(const RelayHello& h);
// Slots in a mask (its popcount).
int relay_slot_count(std::uint16_t slots);

// Preconditions (programming errors, std::invalid_argument): sizes match the counts, counts
// within the limits above.
void encode(const RelayHello& m, std::vector<std::uint8_t>& out);
void encode(const RelayWelcome& m, std::vector<std::uint8_t>& out);
void encode(const RelayInput& m, std::size_t input_size, std::vector<std::uint8_t>& out);
void encode(const RelayFrames& m, std::vector<std::uint8_t>& out);
// The same bytes, the frames read in place (the relay server's history, no copy into m first):
// record(context, i) is frame first_frame + i as m.players flags then m.players x input_size
// inputs; m's flags and inputs are not read.
using RelayFrameRecord = const std::uint8_t* (*)(const void* context, std::uint32_t i);
void encode_frames(const RelayFrames& m, const void* context, RelayFrameRecord record, std::vector<std::uint8_t>& out);
void encode(const RelayForward& m, std::vector<std::uint8_t>& out);
void encode(const RelayNotice& m, std::vector<std::uint8_t>& out);

// nullptr on success, else a static description (m is then unspecified). m is reused so that
// steady-state decoding does not allocate. A hello of another protocol version decodes to its
// version alone (every other field at its default): its layout is not this one's, and the
// server refuses it naming the version (a client of another version is told, not ignored).
// input_size: one slot's; an Input's records are sized by its own `slots` mask.
const char* decode(std::span<const std::uint8_t> d, RelayHello& m);
const char* decode(std::span<const std::uint8_t> d, RelayWelcome& m);
const char* decode(std::span<const std::uint8_t> d, std::size_t input_size, RelayInput& m);
// players and input_size: the room's, known to the client from its welcome.
const char* decode(std::span<const std::uint8_t> d, int players, std::size_t input_size, RelayFrames& m);
const char* decode(std::span<const std::uint8_t> d, RelayForward& m);
const char* decode(std::span<const std::uint8_t> d, RelayNotice& m);

}  // namespace lockroll::rollback
