#include "rollback/control_messages.h"

#include <stdexcept>

#include "rollback/bytes.h"

namespace lockroll::rollback {

const char* refusal_name(Refusal r) {
    switch (r) {
        case Refusal::None: return "welcome";
        case Refusal::Version: return "protocol version differs";
        case Refusal::MatchId: return "match id differs";
        case Refusal::Scene: return "scene checksum differs";
        case Refusal::SlotTaken: return "slot already running";
        case Refusal::Full: return "no spectator place left";
        case Refusal::Retry: return "not ready, retry";
        case Refusal::Disconnected: return "dropped from the match";
        case Refusal::BadRole: return "role not allowed for this id";
    }
    return "unknown refusal";
}

namespace {
std::uint8_t kind_byte(MessageKind k) { return static_cast<std::uint8_t>(k); }

const char* expect_kind(ByteReader& r, MessageKind k) {
    const std::uint8_t b = r.u8();
    if (!r.ok()) return "empty datagram";
    if (b != kind_byte(k)) return "unexpected message kind";
    return nullptr;
}

const char* finish(const ByteReader& r, const char* truncated) {
    if (!r.ok()) return truncated;
    if (!r.at_end()) return "control message: trailing bytes";
    return nullptr;
}
}  // namespace

void encode(const HelloMessage& m, std::vector<std::uint8_t>& out) {
    ByteWriter w(out);
    w.u8(kind_byte(MessageKind::Hello));
    w.u16(m.version);
    w.u64(m.match_id);
    w.u64(m.scene_checksum);
    w.u8(static_cast<std::uint8_t>(m.role));
    w.u64(m.stamp_us);
    w.u64(m.incarnation);
}

const char* decode(std::span<const std::uint8_t> d, HelloMessage& m) {
    ByteReader r(d);
    if (const char* e = expect_kind(r, MessageKind::Hello)) return e;
    m.version = r.u16();
    m.match_id = r.u64();
    m.scene_checksum = r.u64();
    const std::uint8_t role = r.u8();
    m.stamp_us = r.u64();
    m.incarnation = r.u64();
    if (!r.ok()) return "hello: truncated";
    if (role > kLastRole) return "hello: unknown role";
    m.role = static_cast<Role>(role);
    return finish(r, "hello: truncated");
}

void encode(const WelcomeMessage& m, std::vector<std::uint8_t>& out) {
    ByteWriter w(out);
    w.u8(kind_byte(MessageKind::Welcome));
    w.u8(static_cast<std::uint8_t>(m.refusal));
    w.u16(m.version);
    w.u64(m.match_id);
    w.u64(m.scene_checksum);
    w.u64(m.echo_us);
    w.u8(m.running ? 1 : 0);
    w.u8(m.slot_epoch);
}

const char* decode(std::span<const std::uint8_t> d, WelcomeMessage& m) {
    ByteReader r(d);
    if (const char* e = expect_kind(r, MessageKind::Welcome)) return e;
    const std::uint8_t refusal = r.u8();
    m.version = r.u16();
    m.match_id = r.u64();
    m.scene_checksum = r.u64();
    m.echo_us = r.u64();
    const std::uint8_t running = r.u8();
    m.slot_epoch = r.u8();
    if (!r.ok()) return "welcome: truncated";
    if (refusal > kLastRefusal) return "welcome: unknown refusal";
    if (running > 1) return "welcome: bad running flag";
    m.refusal = static_cast<Refusal>(refusal);
    m.running = running == 1;
    return finish(r, "welcome: truncated");
}

void encode(const SnapshotRequestMessage& m, std::vector<std::uint8_t>& out) {
    ByteWriter w(out);
    w.u8(kind_byte(MessageKind::SnapshotRequest));
    w.u8(static_cast<std::uint8_t>(m.reason));
    w.u32(m.transfer_id);
    w.u32(m.chunk);
}

const char* decode(std::span<const std::uint8_t> d, SnapshotRequestMessage& m) {
    ByteReader r(d);
    if (const char* e = expect_kind(r, MessageKind::SnapshotRequest)) return e;
    const std::uint8_t reason = r.u8();
    m.transfer_id = r.u32();
    m.chunk = r.u32();
    if (!r.ok()) return "snapshot request: truncated";
    if (reason > kLastTransferReason) return "snapshot request: unknown reason";
    m.reason = static_cast<TransferReason>(reason);
    return finish(r, "snapshot request: truncated");
}

void encode(const SnapshotOfferMessage& m, std::vector<std::uint8_t>& out) {
    if (m.transfer_id == 0) throw std::invalid_argument("snapshot offer: transfer id 0");
    if (m.slots.size() > static_cast<std::size_t>(kMaxSlotEntries)) throw std::invalid_argument("snapshot offer: too many slots");
    ByteWriter w(out);
    w.u8(kind_byte(MessageKind::SnapshotOffer));
    w.u8(static_cast<std::uint8_t>(m.reason));
    w.u32(m.transfer_id);
    w.u32(m.frame);
    w.u32(m.size);
    w.u64(m.hash);
    w.u32(m.handoff_frame);
    w.u8(static_cast<std::uint8_t>(m.slots.size()));
    for (const SlotEntry& e : m.slots) {
        w.u8(e.slot);
        w.u8(static_cast<std::uint8_t>(e.state));
        w.u8(e.epoch);
    }
}

const char* decode(std::span<const std::uint8_t> d, SnapshotOfferMessage& m) {
    ByteReader r(d);
    if (const char* e = expect_kind(r, MessageKind::SnapshotOffer)) return e;
    const std::uint8_t reason = r.u8();
    m.transfer_id = r.u32();
    m.frame = r.u32();
    m.size = r.u32();
    m.hash = r.u64();
    m.handoff_frame = r.u32();
    const std::uint8_t n = r.u8();
    if (!r.ok()) return "snapshot offer: truncated";
    if (reason > kLastTransferReason) return "snapshot offer: unknown reason";
    if (m.transfer_id == 0) return "snapshot offer: transfer id 0";
    if (n > kMaxSlotEntries) return "snapshot offer: too many slots";
    if (r.remaining() < std::size_t{n} * 3) return "snapshot offer: truncated slot table";
    m.reason = static_cast<TransferReason>(reason);
    m.slots.resize(n);
    for (SlotEntry& e : m.slots) {
        e.slot = r.u8();
        const std::uint8_t state = r.u8();
        e.epoch = r.u8();
        if (state > kLastSlotState) return "snapshot offer: unknown slot state";
        e.state = static_cast<SlotState>(state);
        e.count = 0;
    }
    return finish(r, "snapshot offer: truncated");
}

void encode(const SnapshotChunkMessage& m, std::vector<std::uint8_t>& out) {
    if (m.bytes.empty() || m.bytes.size() > kSnapshotChunkBytes) throw std::invalid_argument("snapshot chunk: bad size");
    ByteWriter w(out);
    w.u8(kind_byte(MessageKind::SnapshotChunk));
    w.u32(m.transfer_id);
    w.u32(m.chunk);
    w.u16(static_cast<std::uint16_t>(m.bytes.size()));
    w.bytes(m.bytes);
}

const char* decode(std::span<const std::uint8_t> d, SnapshotChunkMessage& m) {
    ByteReader r(d);
    if (const char* e = expect_kind(r, MessageKind::SnapshotChunk)) return e;
    m.transfer_id = r.u32();
    m.chunk = r.u32();
    const std::uint16_t n = r.u16();
    if (!r.ok()) return "snapshot chunk: truncated";
    if (n == 0 || n > kSnapshotChunkBytes) return "snapshot chunk: bad length";
    const auto b = r.bytes(n);
    if (!r.ok()) return "snapshot chunk: truncated bytes";
    m.bytes.assign(b.begin(), b.end());
    return finish(r, "snapshot chunk: truncated");
}

}  // namespace lockroll::rollback
