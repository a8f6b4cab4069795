#include "rollback/protocol.h"

#include <algorithm>
#include <stdexcept>

#include "rollback/bytes.h"

namespace lockroll::rollback {

namespace {
// Kind byte, ack, first frame, frame count; time sync; checksum.
constexpr std::size_t kInputHeaderBytes = 1 + 2 + 2 + 1;
constexpr std::size_t kTimeSyncBytes = 2 + 1 + 2 + 2 + 2;
constexpr std::size_t kChecksumBytes = (2 + 8) * kMaxChecksumsPerMessage;

bool valid_what(std::uint8_t w) { return w >= 1 && w <= 3; }

// Runs of identical inputs: u8 length (1..255), then the input bytes.
void write_runs(ByteWriter& w, std::span<const std::uint8_t> inputs, std::size_t count, std::size_t input_size) {
    const auto at = [&](std::size_t k) { return inputs.subspan(k * input_size, input_size); };
    std::size_t i = 0;
    while (i < count) {
        std::size_t j = i + 1;
        // std::equal, not std::ranges::equal: emscripten 3.1.6's libc++ 14 lacks the latter.
        while (j < count && j - i < 255 && std::equal(at(j).begin(), at(j).end(), at(i).begin(), at(i).end())) ++j;
        w.u8(static_cast<std::uint8_t>(j - i));
        w.bytes(at(i));
        i = j;
    }
}

const char* read_runs(ByteReader& r, std::vector<std::uint8_t>& inputs, std::size_t count, std::size_t input_size) {
    inputs.resize(count * input_size);
    std::size_t covered = 0;
    while (covered < count) {
        const std::uint8_t run = r.u8();
        const auto bytes = r.bytes(input_size);
        if (!r.ok()) return "input message: truncated input run";
        if (run == 0) return "input message: empty input run";
        if (covered + run > count) return "input message: runs exceed frame count";
        for (std::size_t k = 0; k < run; ++k)
            std::copy(bytes.begin(), bytes.end(), inputs.begin() + static_cast<std::ptrdiff_t>((covered + k) * input_size));
        covered += run;
    }
    return nullptr;
}

// Limits shared by queries and replies.
const char* check_query_shape(QueryWhat what, std::uint32_t start, std::uint16_t count) {
    switch (what) {
        case QueryWhat::FrameChecksums:
            if (start != 0) return "frame-checksum query with a non-zero start";
            if (count == 0 || count > kMaxQueryItems) return "query count out of range";
            return nullptr;
        case QueryWhat::BodyHashes:
            if (count == 0 || count > kMaxQueryItems) return "query count out of range";
            return nullptr;
        case QueryWhat::BodyFields:
            if (count != 1) return "body-fields query count is not 1";
            return nullptr;
    }
    return "unknown query";
}
}  // namespace

std::uint8_t max_frames_per_message(std::size_t input_size) {
    const std::size_t budget = kMaxDatagramBytes - kInputHeaderBytes - kTimeSyncBytes - kChecksumBytes;
    return static_cast<std::uint8_t>(std::min<std::size_t>(255, budget / (1 + input_size)));
}

std::size_t max_base_input_message_bytes(std::size_t input_size) {
    return kInputHeaderBytes + std::size_t{max_frames_per_message(input_size)} * (1 + input_size) + kTimeSyncBytes +
           kChecksumBytes;
}

std::size_t encoded_block_bytes(const StreamBlock& b, std::size_t input_size) {
    std::vector<std::uint8_t> tmp;
    ByteWriter w(tmp);
    write_runs(w, b.inputs, b.frame_count, input_size);
    return 1 + 1 + 2 + 1 + tmp.size();
}

std::optional<MessageKind> peek_kind(std::span<const std::uint8_t> d) {
    if (d.empty()) return std::nullopt;
    const std::uint8_t k = d[0] & kKindMask;
    if (k < 1 || k > kLastMessageKind) return std::nullopt;
    return static_cast<MessageKind>(k);
}

void encode(const InputMessage& m, std::size_t input_size, std::vector<std::uint8_t>& out) {
    if (input_size == 0 || input_size > kMaxInputSize) throw std::invalid_argument("input size out of range");
    if (m.inputs.size() != std::size_t{m.frame_count} * input_size)
        throw std::invalid_argument("input message: inputs do not match frame_count");
    if (m.frame_count > max_frames_per_message(input_size))
        throw std::invalid_argument("input message: too many frames for one datagram");
    if (m.checksum_count > kMaxChecksumsPerMessage) throw std::invalid_argument("input message: too many checksums");
    if (m.has_extension) {
        if (m.slots.size() > static_cast<std::size_t>(kMaxSlotEntries) || m.blocks.size() > static_cast<std::size_t>(kMaxStreamBlocks))
            throw std::invalid_argument("input message: too many slot entries or blocks");
        for (const StreamBlock& b : m.blocks)
            if (b.frame_count == 0 || b.inputs.size() != std::size_t{b.frame_count} * input_size)
                throw std::invalid_argument("input message: bad stream block");
    }
    // One allocation for the whole message instead of a doubling per few bytes (the input
    // message goes out to every peer every tick): runs take at most 1 + input_size bytes a frame.
    std::size_t bound = kInputHeaderBytes + std::size_t{m.frame_count} * (1 + input_size) + kTimeSyncBytes + kChecksumBytes;
    if (m.has_extension) {
        bound += 2 + m.slots.size() * 5 + kAgreementBytes;
        for (const StreamBlock& b : m.blocks) bound += 5 + std::size_t{b.frame_count} * (1 + input_size);
    }
    out.reserve(out.size() + bound);
    ByteWriter w(out);
    std::uint8_t kind = static_cast<std::uint8_t>(MessageKind::Input);
    if (m.has_time_sync) kind |= kFlagTimeSync;
    if (m.has_extension) kind |= kFlagExtension;
    kind |= static_cast<std::uint8_t>(m.checksum_count << kChecksumCountShift);
    w.u8(kind);
    w.u16(m.ack);
    w.u16(m.first_frame);
    w.u8(m.frame_count);
    write_runs(w, m.inputs, m.frame_count, input_size);
    if (m.has_time_sync) {
        w.u16(m.sender_frame);
        w.i8(m.advantage);
        w.u16(m.stamp);
        w.u16(m.echo);
        w.u16(m.hold);
    }
    for (int i = 0; i < m.checksum_count; ++i) {
        w.u16(m.checksum_frames[i]);
        w.u32(static_cast<std::uint32_t>(m.checksums[i]));  // low 32 bits: see protocol.h
    }
    if (!m.has_extension) return;
    w.u8(static_cast<std::uint8_t>(m.slots.size() | (m.has_agreement ? kFlagAgreement : 0)));
    for (const SlotEntry& e : m.slots) {
        w.u8(e.slot);
        w.u8(static_cast<std::uint8_t>(static_cast<std::uint8_t>(e.state) | (e.voted ? kFlagVoted : 0)));
        w.u8(e.epoch);
        w.u16(e.count);
    }
    if (m.has_agreement) {
        const AgreementReport& a = m.agreement;
        w.u32(a.instance);
        w.u16(a.promised);
        w.u16(a.accepted);
        w.u8(a.accepted_slot);
        w.u16(a.proposal);
        w.u8(a.proposal_slot);
    }
    w.u8(static_cast<std::uint8_t>(m.blocks.size()));
    for (const StreamBlock& b : m.blocks) {
        w.u8(b.slot);
        w.u8(b.absent ? 1 : 0);
        w.u16(b.first_frame);
        w.u8(b.frame_count);
        write_runs(w, b.inputs, b.frame_count, input_size);
    }
}

void encode(const QueryMessage& m, std::vector<std::uint8_t>& out) {
    if (const char* e = check_query_shape(m.what, m.start, m.count)) throw std::invalid_argument(e);
    ByteWriter w(out);
    w.u8(static_cast<std::uint8_t>(MessageKind::Query));
    w.u8(static_cast<std::uint8_t>(m.what));
    w.u32(m.frame);
    w.u32(m.start);
    w.u16(m.count);
}

void encode(const ReplyMessage& m, std::vector<std::uint8_t>& out) {
    if (const char* e = check_query_shape(m.what, m.start, m.count)) throw std::invalid_argument(e);
    if (m.available) {
        if (m.what == QueryWhat::BodyFields) {
            if (m.fields.empty() || m.fields.size() > static_cast<std::size_t>(kMaxFields))
                throw std::invalid_argument("reply: field count out of range");
        } else if (m.values.size() != m.count) {
            throw std::invalid_argument("reply: value count does not match count");
        }
    }
    ByteWriter w(out);
    w.u8(static_cast<std::uint8_t>(MessageKind::Reply));
    w.u8(static_cast<std::uint8_t>(m.what));
    w.u8(m.available ? 1 : 0);
    w.u32(m.frame);
    w.u32(m.start);
    w.u16(m.count);
    if (!m.available) return;
    if (m.what == QueryWhat::BodyFields) {
        w.u8(static_cast<std::uint8_t>(m.fields.size()));
        for (std::int64_t f : m.fields) w.i64(f);
    } else {
        for (std::uint64_t v : m.values) w.u64(v);
    }
}

const char* decode(std::span<const std::uint8_t> d, std::size_t input_size, InputMessage& m) {
    if (input_size == 0 || input_size > kMaxInputSize) return "input size out of range";
    if (d.size() > kMaxDatagramBytes) return "input message: larger than a datagram";
    ByteReader r(d);
    const std::uint8_t kind = r.u8();
    if (!r.ok()) return "empty datagram";
    if ((kind & kKindMask) != static_cast<std::uint8_t>(MessageKind::Input)) return "not an input message";
    m.has_time_sync = (kind & kFlagTimeSync) != 0;
    m.has_extension = (kind & kFlagExtension) != 0;
    m.checksum_count = static_cast<std::uint8_t>((kind & kChecksumCountMask) >> kChecksumCountShift);
    m.ack = r.u16();
    m.first_frame = r.u16();
    m.frame_count = r.u8();
    if (!r.ok()) return "input message: truncated header";
    if (m.frame_count > max_frames_per_message(input_size)) return "input message: too many frames";
    if (const char* e = read_runs(r, m.inputs, m.frame_count, input_size)) return e;
    if (m.has_time_sync) {
        m.sender_frame = r.u16();
        m.advantage = r.i8();
        m.stamp = r.u16();
        m.echo = r.u16();
        m.hold = r.u16();
    }
    for (int i = 0; i < m.checksum_count; ++i) {
        m.checksum_frames[i] = r.u16();
        m.checksums[i] = r.u32();
    }
    if (!r.ok()) return "input message: truncated trailer";
    m.slots.clear();
    m.blocks.clear();
    m.has_agreement = false;
    if (m.has_extension) {
        const std::uint8_t head = r.u8();
        if (!r.ok()) return "input message: truncated extension";
        m.has_agreement = (head & kFlagAgreement) != 0;
        const std::uint8_t entries = head & static_cast<std::uint8_t>(~kFlagAgreement);
        if (entries > kMaxSlotEntries) return "input message: too many slot entries";
        if (r.remaining() < std::size_t{entries} * 5) return "input message: truncated slot table";
        for (int i = 0; i < entries; ++i) {
            SlotEntry e;
            e.slot = r.u8();
            const std::uint8_t state_byte = r.u8();
            const std::uint8_t state = state_byte & static_cast<std::uint8_t>(~kFlagVoted);
            if (state > kLastSlotState) return "input message: unknown slot state";
            e.state = static_cast<SlotState>(state);
            e.voted = (state_byte & kFlagVoted) != 0;
            if (e.voted && e.state != SlotState::Disconnected) return "input message: a vote that is not \"gone\"";
            e.epoch = r.u8();
            e.count = r.u16();
            m.slots.push_back(e);
        }
        if (m.has_agreement) {
            AgreementReport& a = m.agreement;
            a.instance = r.u32();
            a.promised = r.u16();
            a.accepted = r.u16();
            a.accepted_slot = r.u8();
            a.proposal = r.u16();
            a.proposal_slot = r.u8();
            if (!r.ok()) return "input message: truncated agreement";
            if ((a.accepted_slot != kNoSlot && a.accepted_slot >= kMaxSlotEntries) ||
                (a.proposal_slot != kNoSlot && a.proposal_slot >= kMaxSlotEntries))
                return "input message: agreement names no slot";
            if ((a.accepted == 0) != (a.accepted_slot == kNoSlot)) return "input message: agreement accepted without a slot";
            if (a.proposal == 0 && a.proposal_slot != kNoSlot) return "input message: agreement slot without a proposal";
        } else {
            m.agreement = AgreementReport{};
        }
        const std::uint8_t blocks = r.u8();
        if (!r.ok()) return "input message: truncated block count";
        if (blocks > kMaxStreamBlocks) return "input message: too many stream blocks";
        m.blocks.resize(blocks);
        for (StreamBlock& b : m.blocks) {
            b.slot = r.u8();
            const std::uint8_t flags = r.u8();
            b.first_frame = r.u16();
            b.frame_count = r.u8();
            if (!r.ok()) return "input message: truncated stream block";
            if (flags > 1) return "input message: unknown stream block flags";
            b.absent = flags == 1;
            if (b.frame_count == 0) return "input message: empty stream block";
            if (const char* e = read_runs(r, b.inputs, b.frame_count, input_size)) return e;
        }
    }
    if (!r.at_end()) return "input message: trailing bytes";
    return nullptr;
}

const char* decode(std::span<const std::uint8_t> d, QueryMessage& m) {
    ByteReader r(d);
    const std::uint8_t kind = r.u8();
    const std::uint8_t what = r.u8();
    m.frame = r.u32();
    m.start = r.u32();
    m.count = r.u16();
    if (!r.ok()) return "query: truncated";
    if (kind != static_cast<std::uint8_t>(MessageKind::Query)) return "not a query";
    if (!valid_what(what)) return "query: unknown subject";
    m.what = static_cast<QueryWhat>(what);
    if (const char* e = check_query_shape(m.what, m.start, m.count)) return e;
    if (!r.at_end()) return "query: trailing bytes";
    return nullptr;
}

const char* decode(std::span<const std::uint8_t> d, ReplyMessage& m) {
    ByteReader r(d);
    const std::uint8_t kind = r.u8();
    const std::uint8_t what = r.u8();
    const std::uint8_t available = r.u8();
    m.frame = r.u32();
    m.start = r.u32();
    m.count = r.u16();
    if (!r.ok()) return "reply: truncated header";
    if (kind != static_cast<std::uint8_t>(MessageKind::Reply)) return "not a reply";
    if (!valid_what(what)) return "reply: unknown subject";
    if (available > 1) return "reply: bad availability flag";
    m.what = static_cast<QueryWhat>(what);
    m.available = available == 1;
    if (const char* e = check_query_shape(m.what, m.start, m.count)) return e;
    m.values.clear();
    m.fields.clear();
    if (m.available) {
        if (m.what == QueryWhat::BodyFields) {
            const std::uint8_t n = r.u8();
            if (!r.ok()) return "reply: truncated field count";
            if (n == 0 || n > kMaxFields) return "reply: field count out of range";
            if (r.remaining() < std::size_t{n} * 8) return "reply: truncated fields";
            for (int i = 0; i < n; ++i) m.fields.push_back(r.i64());
        } else {
            if (r.remaining() < std::size_t{m.count} * 8) return "reply: truncated values";
            for (int i = 0; i < m.count; ++i) m.values.push_back(r.u64());
        }
    }
    if (!r.ok()) return "reply: truncated";
    if (!r.at_end()) return "reply: trailing bytes";
    return nullptr;
}

std::optional<std::uint32_t> unwrap_frame(std::uint16_t low, std::uint32_t reference) {
    const std::int64_t ref = reference;
    const std::int64_t base = ref - (ref & 0xFFFF);
    std::int64_t v = base + low;
    if (v - ref > 32768) v -= 65536;
    else if (ref - v > 32768) v += 65536;
    if (v < 0 || v > 0xFFFFFFFFll) return std::nullopt;
    return static_cast<std::uint32_t>(v);
}

}  // namespace lockroll::rollback
