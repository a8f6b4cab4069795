#include "rollback/relay_messages.h"

#include <algorithm>
#include <bit>
#include <cstring>
#include <stdexcept>

#include "rollback/bytes.h"

namespace lockroll::rollback {

namespace {
constexpr std::size_t kFramesHeaderBytes = 1 + 4 + 2 + 4 + 4 + 2 + 1 + 1 + 2 + 2 + 2;
constexpr std::size_t kInputHeaderBytes = 1 + 4 + 4 + 1 + 2 + 2 + 2 + 2 + 1;
constexpr std::size_t kChecksumBytes = 4 + 8;
constexpr std::uint8_t kMaxInputsPerMessage = 64;

std::uint8_t kind_byte(RelayKind k) { return static_cast<std::uint8_t>(k); }

const char* expect(ByteReader& r, RelayKind k) {
    const std::uint8_t b = r.u8();
    if (!r.ok()) return "relay: empty datagram";
    if (b != kind_byte(k)) return "relay: unexpected message kind";
    return nullptr;
}

const char* finish(const ByteReader& r, const char* truncated) {
    if (!r.ok()) return truncated;
    if (!r.at_end()) return "relay: trailing bytes";
    return nullptr;
}

std::size_t mask_bytes(int players) { return static_cast<std::size_t>(players + 7) / 8; }
}  // namespace

const char* relay_refusal_name(RelayRefusal r) {
    switch (r) {
        case RelayRefusal::None: return "welcome";
        case RelayRefusal::Version: return "relay protocol version differs";
        case RelayRefusal::RoomParams: return "room exists with other parameters";
        case RelayRefusal::SlotTaken: return "slot held by a live connection";
        case RelayRefusal::BadSlot: return "no such slot for this role";
        case RelayRefusal::Full: return "room or server full";
        case RelayRefusal::Draining: return "server draining: no new rooms or players";
        case RelayRefusal::Spoof: return "connection already holds another slot";
        case RelayRefusal::Ended: return "the room's match is over";
        case RelayRefusal::TokenMissing: return "this server requires a connect token";
        case RelayRefusal::TokenInvalid: return "connect token invalid (forged, corrupted or sealed with another key)";
        case RelayRefusal::TokenExpired: return "connect token expired";
        case RelayRefusal::TokenMismatch: return "connect token is for another room, slot, role or room parameters";
        case RelayRefusal::TokenInUse: return "connect token already in use by a live connection (replay)";
        case RelayRefusal::SlotOwned: return "slot belongs to another client (only its token's holder takes it back)";
        case RelayRefusal::Kicked: return "slot was kicked from this match (its checksums were in the minority round after round)";
    }
    return "unknown refusal";
}

std::optional<RelayKind> peek_relay_kind(std::span<const std::uint8_t> d) {
    if (d.empty()) return std::nullopt;
    if (d[0] < kind_byte(RelayKind::Hello) || d[0] > kind_byte(RelayKind::Notice)) return std::nullopt;
    return static_cast<RelayKind>(d[0]);
}

std::uint16_t relay_max_frames(int players, std::size_t input_size) {
    const std::size_t per_frame = mask_bytes(players) + static_cast<std::size_t>(players) * (1 + input_size);
    return static_cast<std::uint16_t>(std::max<std::size_t>(1, (kRelayMaxDatagramBytes - kFramesHeaderBytes) / per_frame));
}

std::uint8_t relay_max_inputs(std::size_t record_bytes) {
    const std::size_t room = kRelayMaxDatagramBytes - kInputHeaderBytes - kRelayMaxChecksums * kChecksumBytes;
    return static_cast<std::uint8_t>(std::min<std::size_t>(kMaxInputsPerMessage, room / std::max<std::size_t>(1, record_bytes)));
}

int relay_slot_count(std::uint16_t slots) {
    int n = 0;
    for (; slots; slots = static_cast<std::uint16_t>(slots & (slots - 1))) ++n;
    return n;
}

std::uint16_t relay_hello_slots(const RelayHello& h) {
    if (h.role == RelayRole::Spectator || h.slot >= kRelayMaxPlayers) return 0;
    return static_cast<std::uint16_t>(h.also_slots | (1u << h.slot));
}

void encode(const RelayHello& m, std::vector<std::uint8_t>& out) {
    ByteWriter w(out);
    w.u8(kind_byte(RelayKind::Hello));
    w.u16(m.version);
    w.u64(m.room_id);
    w.u64(m.scene_checksum);
    w.u8(m.players);
    w.u8(m.input_size);
    w.u16(m.tick_rate);
    w.u8(static_cast<std::uint8_t>(m.role));
    w.u8(m.slot);
    w.u16(m.also_slots);
    w.u16(m.absent_slots);
    w.u64(m.incarnation);
    w.u64(m.stamp_us);
    if (m.token.size() > kRelayMaxTokenBytes) throw std::invalid_argument("RelayHello: token too long");
    w.u16(static_cast<std::uint16_t>(m.token.size()));
    w.bytes(m.token);
}

const char* decode(std::span<const std::uint8_t> d, RelayHello& m) {
    ByteReader r(d);
    if (const char* e = expect(r, RelayKind::Hello)) return e;
    const std::uint16_t version = r.u16();
    if (!r.ok()) return "relay hello: truncated";
    if (version != kRelayProtocolVersion) {
        m = RelayHello{};
        m.version = version;
        return nullptr;
    }
    m.version = version;
    m.room_id = r.u64();
    m.scene_checksum = r.u64();
    m.players = r.u8();
    m.input_size = r.u8();
    m.tick_rate = r.u16();
    const std::uint8_t role = r.u8();
    m.slot = r.u8();
    m.also_slots = r.u16();
    m.absent_slots = r.u16();
    m.incarnation = r.u64();
    m.stamp_us = r.u64();
    const std::uint16_t token_bytes = r.u16();
    if (!r.ok()) return "relay hello: truncated";
    if (token_bytes > kRelayMaxTokenBytes) return "relay hello: token too long";
    const auto token = r.bytes(token_bytes);
    if (const char* e = finish(r, "relay hello: truncated token")) return e;
    m.token.assign(token.begin(), token.end());
    if (role > kLastRelayRole) return "relay hello: unknown role";
    m.role = static_cast<RelayRole>(role);
    if (m.also_slots != 0) {
        if (m.role == RelayRole::Spectator) return "relay hello: a spectator plays no slot";
        // One encoding per set of slots: `slot` is the lowest.
        const std::uint32_t at_or_below = m.slot >= 15 ? 0xFFFFu : (2u << m.slot) - 1;
        if (m.also_slots & at_or_below) return "relay hello: further slots must be above the first";
    }
    return nullptr;
}

void encode(const RelayWelcome& m, std::vector<std::uint8_t>& out) {
    ByteWriter w(out);
    w.u8(kind_byte(RelayKind::Welcome));
    w.u8(static_cast<std::uint8_t>(m.refusal));
    w.u16(m.version);
    w.u8(m.slot);
    w.u8(m.players);
    w.u8(m.input_size);
    w.u16(m.tick_rate);
    w.u16(m.checksum_interval);
    w.u8(m.input_deadline);
    w.u8(m.started ? 1 : 0);
    w.u32(m.server_frame);
    w.u32(m.handoff_frame);
    w.u8(m.snapshot_from);
    w.u64(m.echo_us);
}

const char* decode(std::span<const std::uint8_t> d, RelayWelcome& m) {
    ByteReader r(d);
    if (const char* e = expect(r, RelayKind::Welcome)) return e;
    const std::uint8_t refusal = r.u8();
    m.version = r.u16();
    m.slot = r.u8();
    m.players = r.u8();
    m.input_size = r.u8();
    m.tick_rate = r.u16();
    m.checksum_interval = r.u16();
    m.input_deadline = r.u8();
    const std::uint8_t started = r.u8();
    m.server_frame = r.u32();
    m.handoff_frame = r.u32();
    m.snapshot_from = r.u8();
    m.echo_us = r.u64();
    if (const char* e = finish(r, "relay welcome: truncated")) return e;
    if (refusal > kLastRelayRefusal) return "relay welcome: unknown refusal";
    if (started > 1) return "relay welcome: bad started flag";
    m.refusal = static_cast<RelayRefusal>(refusal);
    m.started = started == 1;
    return nullptr;
}

void encode(const RelayInput& m, std::size_t input_size, std::vector<std::uint8_t>& out) {
    const std::size_t record = static_cast<std::size_t>(relay_slot_count(m.slots)) * input_size;
    if ((m.frame_count > 0 && record == 0) || m.frame_count > relay_max_inputs(record) ||
        m.inputs.size() != m.frame_count * record || m.checksum_count > kRelayMaxChecksums)
        throw std::invalid_argument("RelayInput: counts out of range");
    ByteWriter w(out);
    w.u8(kind_byte(RelayKind::Input));
    w.u32(m.confirmed_ack);
    w.u32(m.first_frame);
    w.u8(m.frame_count);
    w.u16(m.slots);
    w.bytes(m.inputs);
    w.u16(m.stamp);
    w.u16(m.echo);
    w.u16(m.hold);
    w.u8(m.checksum_count);
    for (int i = 0; i < m.checksum_count; ++i) {
        w.u32(m.checksum_frames[i]);
        w.u64(m.checksums[i]);
    }
}

const char* decode(std::span<const std::uint8_t> d, std::size_t input_size, RelayInput& m) {
    ByteReader r(d);
    if (const char* e = expect(r, RelayKind::Input)) return e;
    m.confirmed_ack = r.u32();
    m.first_frame = r.u32();
    m.frame_count = r.u8();
    m.slots = r.u16();
    if (!r.ok()) return "relay input: truncated";
    const std::size_t record = static_cast<std::size_t>(relay_slot_count(m.slots)) * input_size;
    if (m.frame_count > 0 && record == 0) return "relay input: inputs for no slot";
    if (m.frame_count > relay_max_inputs(record)) return "relay input: too many inputs";
    const auto bytes = r.bytes(m.frame_count * record);
    if (!r.ok()) return "relay input: truncated inputs";
    m.inputs.assign(bytes.begin(), bytes.end());
    m.stamp = r.u16();
    m.echo = r.u16();
    m.hold = r.u16();
    m.checksum_count = r.u8();
    if (!r.ok()) return "relay input: truncated";
    if (m.checksum_count > kRelayMaxChecksums) return "relay input: too many checksums";
    for (int i = 0; i < m.checksum_count; ++i) {
        m.checksum_frames[i] = r.u32();
        m.checksums[i] = r.u64();
    }
    return finish(r, "relay input: truncated checksums");
}

namespace {
// frame(f) gives frame f's flags (players bytes) and inputs (players x n bytes).
template <class Frame>
void encode_frames_with(const RelayFrames& m, Frame&& frame, std::vector<std::uint8_t>& out) {
    const std::size_t n = m.input_size;
    const std::size_t slots = m.players;
    // The relay server encodes one of these per client per tick: written through a pointer into
    // space sized for the most it can take (the header, then per frame a mask and every slot's
    // flag and input), then trimmed; no per-byte growth checks.
    const std::size_t mb = mask_bytes(m.players);
    const std::size_t at = out.size();
    out.resize(at + kFramesHeaderBytes + m.frame_count * (mb + slots * (1 + n)));
    std::uint8_t* p = out.data() + at;
    // Little-endian fields: on a little-endian machine each is its bytes in memory order.
    auto put = [&p]<class T>(T v) {
        if constexpr (std::endian::native == std::endian::little) {
            std::memcpy(p, &v, sizeof v);
            p += sizeof v;
        } else {
            for (std::size_t i = 0; i < sizeof v; ++i) *p++ = static_cast<std::uint8_t>(static_cast<std::uint64_t>(v) >> (8 * i));
        }
    };
    put(kind_byte(RelayKind::Frames));
    put(std::uint32_t{m.server_frame});
    put(std::uint16_t{m.server_subframe});
    put(std::uint32_t{m.input_ack});
    put(std::uint32_t{m.first_frame});
    put(std::uint16_t{m.frame_count});
    put(std::uint8_t{m.players});
    put(std::uint8_t{m.input_size});
    put(std::uint16_t{m.stamp});
    put(std::uint16_t{m.echo});
    put(std::uint16_t{m.hold});
    const std::uint8_t* prev_flags = nullptr;
    const std::uint8_t* prev_inputs = nullptr;
    for (std::size_t f = 0; f < m.frame_count; ++f) {
        const auto [flags, inputs] = frame(f);
        // Delta against the frame before (all zero before the first): a mask, then the changes.
        std::uint8_t* mask = p;
        std::fill_n(mask, mb, std::uint8_t{0});
        p += mb;
        for (std::size_t s = 0; s < slots; ++s) {
            const std::uint8_t flag = flags[s];
            const std::uint8_t* cur = inputs + s * n;
            bool same;
            if (f == 0) {
                same = flag == 0 && std::all_of(cur, cur + n, [](std::uint8_t v) { return v == 0; });
            } else {
                same = flag == prev_flags[s] && std::equal(cur, cur + n, prev_inputs + s * n);
            }
            if (same) continue;
            mask[s / 8] = static_cast<std::uint8_t>(mask[s / 8] | (1u << (s % 8)));
            *p++ = flag;
            p = std::copy_n(cur, n, p);
        }
        prev_flags = flags;
        prev_inputs = inputs;
    }
    out.resize(static_cast<std::size_t>(p - out.data()));
}

struct FramePointers {
    const std::uint8_t* flags;
    const std::uint8_t* inputs;
};
}  // namespace

void encode(const RelayFrames& m, std::vector<std::uint8_t>& out) {
    const std::size_t n = m.input_size;
    const std::size_t slots = m.players;
    if (m.players < 1 || m.players > kRelayMaxPlayers || n < 1 || n > kRelayMaxInputSize ||
        m.frame_count > relay_max_frames(m.players, n) || m.flags.size() != m.frame_count * slots ||
        m.inputs.size() != m.frame_count * slots * n)
        throw std::invalid_argument("RelayFrames: counts out of range");
    encode_frames_with(
        m, [&](std::size_t f) { return FramePointers{m.flags.data() + f * slots, m.inputs.data() + f * slots * n}; }, out);
}

void encode_frames(const RelayFrames& m, const void* context, RelayFrameRecord record, std::vector<std::uint8_t>& out) {
    const std::size_t n = m.input_size;
    if (m.players < 1 || m.players > kRelayMaxPlayers || n < 1 || n > kRelayMaxInputSize ||
        m.frame_count > relay_max_frames(m.players, n))
        throw std::invalid_argument("RelayFrames: counts out of range");
    const std::size_t slots = m.players;
    encode_frames_with(
        m,
        [&](std::size_t f) {
            const std::uint8_t* rec = record(context, static_cast<std::uint32_t>(f));
            return FramePointers{rec, rec + slots};
        },
        out);
}

const char* decode(std::span<const std::uint8_t> d, int players, std::size_t input_size, RelayFrames& m) {
    ByteReader r(d);
    if (const char* e = expect(r, RelayKind::Frames)) return e;
    m.server_frame = r.u32();
    m.server_subframe = r.u16();
    m.input_ack = r.u32();
    m.first_frame = r.u32();
    m.frame_count = r.u16();
    m.players = r.u8();
    m.input_size = r.u8();
    m.stamp = r.u16();
    m.echo = r.u16();
    m.hold = r.u16();
    if (!r.ok()) return "relay frames: truncated header";
    if (m.players != players || m.input_size != input_size) return "relay frames: room sizes differ";
    if (players < 1 || players > kRelayMaxPlayers || input_size < 1 || input_size > kRelayMaxInputSize)
        return "relay frames: sizes out of range";
    if (m.frame_count > relay_max_frames(players, input_size)) return "relay frames: too many frames";
    const std::size_t slots = static_cast<std::size_t>(players);
    m.flags.assign(m.frame_count * slots, 0);
    m.inputs.assign(m.frame_count * slots * input_size, 0);
    const std::size_t mb = mask_bytes(players);
    for (std::size_t f = 0; f < m.frame_count; ++f) {
        std::uint8_t mask[(kRelayMaxPlayers + 7) / 8] = {};
        for (std::size_t b = 0; b < mb; ++b) mask[b] = r.u8();
        if (!r.ok()) return "relay frames: truncated mask";
        for (std::size_t s = 0; s < slots; ++s) {
            std::uint8_t* cur = &m.inputs[(f * slots + s) * input_size];
            if (mask[s / 8] & (1u << (s % 8))) {
                const std::uint8_t flags = r.u8();
                const auto bytes = r.bytes(input_size);
                if (!r.ok()) return "relay frames: truncated input";
                if (flags & ~(kRelayAbsent | kRelayReplaced)) return "relay frames: unknown flags";
                m.flags[f * slots + s] = flags;
                std::copy(bytes.begin(), bytes.end(), cur);
            } else if (f > 0) {
                m.flags[f * slots + s] = m.flags[(f - 1) * slots + s];
                std::copy_n(&m.inputs[((f - 1) * slots + s) * input_size], input_size, cur);
            }
        }
        // Bits for slots past `players` must be clear: one encoding per message.
        for (std::size_t s = slots; s < mb * 8; ++s)
            if (mask[s / 8] & (1u << (s % 8))) return "relay frames: mask names a slot past the room";
    }
    return finish(r, "relay frames: truncated");
}

void encode(const RelayForward& m, std::vector<std::uint8_t>& out) {
    if (m.payload.empty() || m.payload.size() > kRelayMaxForwardBytes)
        throw std::invalid_argument("RelayForward: payload size out of range");
    ByteWriter w(out);
    w.u8(kind_byte(RelayKind::Forward));
    w.u8(m.slot);
    w.u16(static_cast<std::uint16_t>(m.payload.size()));
    w.bytes(m.payload);
}

const char* decode(std::span<const std::uint8_t> d, RelayForward& m) {
    ByteReader r(d);
    if (const char* e = expect(r, RelayKind::Forward)) return e;
    m.slot = r.u8();
    const std::uint16_t n = r.u16();
    if (!r.ok()) return "relay forward: truncated";
    if (n == 0 || n > kRelayMaxForwardBytes) return "relay forward: payload size out of range";
    const auto bytes = r.bytes(n);
    if (!r.ok()) return "relay forward: truncated payload";
    m.payload.assign(bytes.begin(), bytes.end());
    return finish(r, "relay forward: truncated");
}

void encode(const RelayNotice& m, std::vector<std::uint8_t>& out) {
    ByteWriter w(out);
    w.u8(kind_byte(RelayKind::Notice));
    w.u8(static_cast<std::uint8_t>(m.kind));
    w.u8(m.slot);
    w.u32(m.frame);
    w.u64(m.detail);
}

const char* decode(std::span<const std::uint8_t> d, RelayNotice& m) {
    ByteReader r(d);
    if (const char* e = expect(r, RelayKind::Notice)) return e;
    const std::uint8_t kind = r.u8();
    m.slot = r.u8();
    m.frame = r.u32();
    m.detail = r.u64();
    if (const char* e = finish(r, "relay notice: truncated")) return e;
    if (kind < 1 || kind > kLastRelayNotice) return "relay notice: unknown kind";
    m.kind = static_cast<RelayNoticeKind>(kind);
    return nullptr;
}

}  // namespace lockroll::rollback
