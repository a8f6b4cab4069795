#include "rollback/snapshot_transfer.h"

#include <algorithm>

#define XXH_INLINE_ALL
#include <xxhash.h>

#include "rollback/bytes.h"

namespace lockroll::rollback {

namespace {
constexpr std::uint32_t kMagic = 0x5453524Cu;  // "LRST" little-endian
}

std::uint64_t transfer_hash(std::span<const std::uint8_t> blob) { return XXH3_64bits(blob.data(), blob.size()); }

std::vector<std::uint8_t> pack_transfer(const TransferContents& t, std::size_t input_size) {
    std::vector<std::uint8_t> out;
    ByteWriter w(out);
    w.u32(kMagic);
    w.u32(t.frame);
    w.u32(static_cast<std::uint32_t>(t.state.size()));
    w.bytes(t.state);
    w.u8(static_cast<std::uint8_t>(t.streams.size()));
    w.u16(static_cast<std::uint16_t>(input_size));
    for (const StreamInputs& s : t.streams) {
        w.u32(s.count);
        for (std::uint32_t i = 0; i < s.count; ++i) {
            w.u8(s.absent[i]);
            w.bytes(std::span(s.inputs).subspan(std::size_t{i} * input_size, input_size));
        }
    }
    return out;
}

std::string unpack_transfer(std::span<const std::uint8_t> blob, std::size_t state_size, int players,
                            std::size_t input_size, std::uint32_t max_inputs_per_stream, TransferContents& out) {
    ByteReader r(blob);
    if (r.u32() != kMagic || !r.ok()) return "snapshot transfer: bad magic";
    out.frame = r.u32();
    const std::uint32_t size = r.u32();
    if (!r.ok()) return "snapshot transfer: truncated header";
    if (size > state_size)
        return "snapshot transfer: state size " + std::to_string(size) + ", above the capacity " + std::to_string(state_size);
    const auto state = r.bytes(size);
    if (!r.ok()) return "snapshot transfer: truncated state";
    out.state.assign(state.begin(), state.end());
    const std::uint8_t streams = r.u8();
    const std::uint16_t isz = r.u16();
    if (!r.ok()) return "snapshot transfer: truncated stream header";
    if (streams != players) return "snapshot transfer: stream count differs from the player count";
    if (isz != input_size) return "snapshot transfer: input size differs";
    out.streams.assign(streams, {});
    for (StreamInputs& s : out.streams) {
        s.count = r.u32();
        if (!r.ok()) return "snapshot transfer: truncated stream";
        if (s.count > max_inputs_per_stream) return "snapshot transfer: too many inputs in a stream";
        if (r.remaining() < std::size_t{s.count} * (1 + input_size)) return "snapshot transfer: truncated inputs";
        s.inputs.resize(std::size_t{s.count} * input_size);
        s.absent.resize(s.count);
        for (std::uint32_t i = 0; i < s.count; ++i) {
            const std::uint8_t flag = r.u8();
            if (flag > 1) return "snapshot transfer: bad absent flag";
            s.absent[i] = flag;
            const auto b = r.bytes(input_size);
            std::copy(b.begin(), b.end(), s.inputs.begin() + static_cast<std::ptrdiff_t>(std::size_t{i} * input_size));
        }
    }
    if (!r.ok()) return "snapshot transfer: truncated";
    if (!r.at_end()) return "snapshot transfer: trailing bytes";
    return {};
}

TransferSender::Transfer& TransferSender::offer(PlayerId peer, TransferReason reason, const TransferContents& t,
                                                std::size_t input_size, std::uint64_t now_us) {
    Transfer out;
    out.peer = peer;
    out.blob = pack_transfer(t, input_size);
    out.created_us = now_us;
    out.offer.reason = reason;
    out.offer.transfer_id = next_id_;
    next_id_ = next_transfer_id(next_id_);
    out.offer.frame = t.frame;
    out.offer.size = static_cast<std::uint32_t>(out.blob.size());
    out.offer.hash = transfer_hash(out.blob);
    // Old transfers go: bounded memory whatever newcomers ask. (A caller's time that steps back
    // expires nothing.)
    std::erase_if(transfers_, [&](const Transfer& o) { return o.peer == peer || now_us > o.created_us + lifetime_us_; });
    if (transfers_.size() >= kMaxTransfers) transfers_.erase(transfers_.begin());
    transfers_.push_back(std::move(out));
    return transfers_.back();
}

const TransferSender::Transfer* TransferSender::find(std::uint32_t id, PlayerId peer) const {
    for (const Transfer& t : transfers_)
        if (t.offer.transfer_id == id && t.peer == peer) return &t;
    return nullptr;
}

bool TransferSender::chunk(const Transfer& t, std::uint32_t index, SnapshotChunkMessage& out) {
    const std::size_t begin = std::size_t{index} * kSnapshotChunkBytes;
    if (begin >= t.blob.size()) return false;
    const std::size_t end = std::min(t.blob.size(), begin + kSnapshotChunkBytes);
    out.transfer_id = t.offer.transfer_id;
    out.chunk = index;
    out.bytes.assign(t.blob.begin() + static_cast<std::ptrdiff_t>(begin), t.blob.begin() + static_cast<std::ptrdiff_t>(end));
    return true;
}

TransferReceiver::TransferReceiver(const SnapshotOfferMessage& offer)
    : offer_(offer),
      chunk_count_(static_cast<std::uint32_t>((std::uint64_t{offer.size} + kSnapshotChunkBytes - 1) / kSnapshotChunkBytes)),
      blob_(offer.size),
      have_(chunk_count_, false),
      asked_us_(chunk_count_, 0),
      asked_(chunk_count_, false) {}

bool TransferReceiver::add(const SnapshotChunkMessage& c) {
    if (c.transfer_id != offer_.transfer_id || c.chunk >= chunk_count_) return false;
    const std::size_t begin = std::size_t{c.chunk} * kSnapshotChunkBytes;
    const std::size_t expect = std::min<std::size_t>(kSnapshotChunkBytes, blob_.size() - begin);
    if (c.bytes.size() != expect) return false;
    if (have_[c.chunk]) return true;
    std::copy(c.bytes.begin(), c.bytes.end(), blob_.begin() + static_cast<std::ptrdiff_t>(begin));
    have_[c.chunk] = true;
    ++received_;
    return true;
}

void TransferReceiver::due_requests(std::uint64_t now_us, std::uint64_t resend_us, int budget,
                                    std::vector<std::uint32_t>& out) {
    int outstanding = 0;
    for (std::uint32_t i = 0; i < chunk_count_; ++i)
        if (!have_[i] && asked_[i] && now_us < asked_us_[i] + resend_us) ++outstanding;
    for (std::uint32_t i = 0; i < chunk_count_ && outstanding < budget; ++i) {
        if (have_[i] || (asked_[i] && now_us < asked_us_[i] + resend_us)) continue;
        asked_[i] = true;
        asked_us_[i] = now_us;
        out.push_back(i);
        ++outstanding;
    }
}

std::optional<std::span<const std::uint8_t>> TransferReceiver::verified() const {
    if (!complete() || transfer_hash(blob_) != offer_.hash) return std::nullopt;
    return std::span<const std::uint8_t>(blob_);
}

}  // namespace lockroll::rollback
