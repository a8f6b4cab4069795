#include "rollback/protocol.h"

#include <algorithm>
#include <stdexcept>

#include "rollback/bytes.h"

namespace lockroll::rollback {

namespace {
// Kind byte, ack, first frame, frame count; time sync; checksum.
constexpr std::size_t kInputHeaderBytes = 1 + 2 + 2 + 1;
constexpr std::size_t kTimeSyncBytes = 2 + 1;
constexpr std::size_t kChecksumBytes = (2 + 8) * kMaxChecksumsPerMessage;

bool valid_what(std::uint8_t w) { return w >= 1 && w <= 3; }

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

std::optional<MessageKind> peek_kind(std::span<const std::uint8_t> d) {
    if (d.empty()) return std::nullopt;
    const std::uint8_t k = d[0] & kKindMask;
    if (k < 1 || k > 3) return std::nullopt;
    return static_cast<MessageKind>(k);
}

void encode(const InputMessage& m, std::size_t input_size, std::vector<std::uint8_t>& out) {
    if (input_size == 0 || input_size > kMaxInputSize) throw std::invalid_argument("input size out of range");
    if (m.inputs.size() != std::size_t{m.frame_count} * input_size)
        throw std::invalid_argument("input message: inputs do not match frame_count");
    if (m.frame_count > max_frames_per_message(input_size))
        throw std::invalid_argument("input message: too many frames for one datagram");
    if (m.checksum_count > kMaxChecksumsPerMessage) throw std::invalid_argument("input message: too many checksums");
    ByteWriter w(out);
    std::uint8_t kind = static_cast<std::uint8_t>(MessageKind::Input);
    if (m.has_time_sync) kind |= kFlagTimeSync;
    kind |= static_cast<std::uint8_t>(m.checksum_count << kChecksumCountShift);
    w.u8(kind);
    w.u16(m.ack);
    w.u16(m.first_frame);
    w.u8(m.frame_count);
    // Runs of identical inputs: u8 length (1..255), then the input bytes.
    std::size_t i = 0;
    while (i < m.frame_count) {
        const auto at = [&](std::size_t k) { return std::span(m.inputs).subspan(k * input_size, input_size); };
        std::size_t j = i + 1;
        while (j < m.frame_count && j - i < 255 && std::ranges::equal(at(j), at(i))) ++j;
        w.u8(static_cast<std::uint8_t>(j - i));
        w.bytes(at(i));
        i = j;
    }
    if (m.has_time_sync) {
        w.u16(m.sender_frame);
        w.i8(m.advantage);
    }
    for (int i = 0; i < m.checksum_count; ++i) {
        w.u16(m.checksum_frames[i]);
        w.u32(static_cast<std::uint32_t>(m.checksums[i]));  // low 32 bits: see protocol.h
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
    ByteReader r(d);
    const std::uint8_t kind = r.u8();
    if (!r.ok()) return "empty datagram";
    if ((kind & kKindMask) != static_cast<std::uint8_t>(MessageKind::Input)) return "not an input message";
    if (kind & ~(kKindMask | kFlagTimeSync | kChecksumCountMask)) return "input message: unknown flag bits";
    m.has_time_sync = (kind & kFlagTimeSync) != 0;
    m.checksum_count = static_cast<std::uint8_t>((kind & kChecksumCountMask) >> kChecksumCountShift);
    m.ack = r.u16();
    m.first_frame = r.u16();
    m.frame_count = r.u8();
    if (!r.ok()) return "input message: truncated header";
    if (m.frame_count > max_frames_per_message(input_size)) return "input message: too many frames";
    m.inputs.resize(std::size_t{m.frame_count} * input_size);
    std::size_t covered = 0;
    while (covered < m.frame_count) {
        const std::uint8_t run = r.u8();
        const auto bytes = r.bytes(input_size);
        if (!r.ok()) return "input message: truncated input run";
        if (run == 0) return "input message: empty input run";
        if (covered + run > m.frame_count) return "input message: runs exceed frame count";
        for (std::size_t k = 0; k < run; ++k)
            std::copy(bytes.begin(), bytes.end(),
                      m.inputs.begin() + static_cast<std::ptrdiff_t>((covered + k) * input_size));
        covered += run;
    }
    if (m.has_time_sync) {
        m.sender_frame = r.u16();
        m.advantage = r.i8();
    }
    for (int i = 0; i < m.checksum_count; ++i) {
        m.checksum_frames[i] = r.u16();
        m.checksums[i] = r.u32();
    }
    if (!r.ok()) return "input message: truncated trailer";
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
