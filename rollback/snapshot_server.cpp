#include "rollback/snapshot_server.h"

#include <algorithm>

namespace lockroll::rollback {

namespace {

// The two tables name the same view: every slot in the same state and epoch.
bool same_view(std::span<const SlotEntry> a, std::span<const SlotEntry> b) {
    return std::equal(a.begin(), a.end(), b.begin(), b.end(), [](const SlotEntry& x, const SlotEntry& y) {
        return x.slot == y.slot && x.state == y.state && x.epoch == y.epoch;
    });
}

}  // namespace

SnapshotServer::Ask SnapshotServer::consider(PlayerId peer, TransferReason reason, std::uint64_t now_us,
                                             std::span<const SlotEntry> view, const SnapshotOfferMessage** repeat) const {
    const std::uint64_t reuse_us = reason == TransferReason::Recover ? 300'000 : 2'000'000;
    for (const TransferSender::Transfer& t : sender_.transfers()) {
        if (t.peer != peer || t.offer.reason != reason) continue;
        if (now_us < t.created_us + reuse_us) {
            if (!same_view(t.offer.slots, view)) return Ask::Pack;  // the view changed: a fresh offer
            *repeat = &t.offer;
            return Ask::Repeat;
        }
        if (reason == TransferReason::Recover && now_us < t.created_us + kRecoveryIntervalUs) return Ask::TooSoon;
    }
    return Ask::Pack;
}

SnapshotServer::Chunk SnapshotServer::chunk(PlayerId peer, const SnapshotRequestMessage& m, SnapshotChunkMessage& out) const {
    const TransferSender::Transfer* t = sender_.find(m.transfer_id, peer);
    if (!t) return Chunk::NotOurs;  // an old transfer, or not ours
    return TransferSender::chunk(*t, m.chunk, out) ? Chunk::Ready : Chunk::OutOfRange;
}

void SnapshotServer::damage(int count, ChunkDamage how) {
    if (count > 0) damage_.insert(damage_.end(), static_cast<std::size_t>(count), how);
}

void SnapshotServer::damage_next(SnapshotChunkMessage& c) {
    if (damaged_ >= damage_.size() || c.bytes.empty()) return;
    if (damage_[damaged_] == ChunkDamage::FlipBit) c.bytes.back() ^= 0x01;
    else c.bytes.pop_back();
    ++damaged_;
}

}  // namespace lockroll::rollback
