// Field-by-field little-endian encoding for everything rollback/ puts on the wire or on disk.
//
// Why a reader with a sticky failure flag instead of exceptions or asserts: bytes from the network
// or a file are untrusted. Every read is bounds-checked; the first short read sets ok() to false
// and every later read returns 0, so a decoder reads all fields straight through and checks ok()
// once, and no length in the input can make it read outside the buffer.
#pragma once

#include <bit>
#include <cstddef>
#include <cstring>
#include <cstdint>
#include <span>
#include <vector>

namespace lockroll::rollback {

class ByteWriter {
public:
    explicit ByteWriter(std::vector<std::uint8_t>& out) : out_(out) {}

    void u8(std::uint8_t v) { out_.push_back(v); }
    void i8(std::int8_t v) { out_.push_back(static_cast<std::uint8_t>(v)); }
    void u16(std::uint16_t v) { put(v, 2); }
    void u32(std::uint32_t v) { put(v, 4); }
    void u64(std::uint64_t v) { put(v, 8); }
    void i64(std::int64_t v) { put(static_cast<std::uint64_t>(v), 8); }
    void bytes(std::span<const std::uint8_t> b) { out_.insert(out_.end(), b.begin(), b.end()); }

    std::size_t size() const { return out_.size(); }

private:
    void put(std::uint64_t v, int n) {
        for (int i = 0; i < n; ++i) out_.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
    }
    std::vector<std::uint8_t>& out_;
};

class ByteReader {
public:
    explicit ByteReader(std::span<const std::uint8_t> in) : in_(in) {}

    std::uint8_t u8() { return static_cast<std::uint8_t>(get<1>()); }
    std::int8_t i8() { return static_cast<std::int8_t>(static_cast<std::uint8_t>(get<1>())); }
    std::uint16_t u16() { return static_cast<std::uint16_t>(get<2>()); }
    std::uint32_t u32() { return static_cast<std::uint32_t>(get<4>()); }
    std::uint64_t u64() { return get<8>(); }
    std::int64_t i64() { return static_cast<std::int64_t>(get<8>()); }
    // A view of the next n bytes (empty and failed when fewer remain).
    std::span<const std::uint8_t> bytes(std::size_t n) {
        if (!ok_ || n > remaining()) {
            ok_ = false;
            return {};
        }
        auto s = in_.subspan(pos_, n);
        pos_ += n;
        return s;
    }

    bool ok() const { return ok_; }
    std::size_t position() const { return pos_; }
    std::size_t remaining() const { return in_.size() - pos_; }
    bool at_end() const { return pos_ == in_.size(); }

private:
    // Little-endian: on a little-endian machine the value is its bytes in memory order (one
    // load; the relay server decodes an input per datagram).
    template <std::size_t N>
    std::uint64_t get() {
        if (!ok_ || N > remaining()) {
            ok_ = false;
            return 0;
        }
        std::uint64_t v = 0;
        if constexpr (std::endian::native == std::endian::little) {
            std::memcpy(&v, in_.data() + pos_, N);
        } else {
            for (std::size_t i = 0; i < N; ++i) v |= std::uint64_t{in_[pos_ + i]} << (8 * i);
        }
        pos_ += N;
        return v;
    }
    std::span<const std::uint8_t> in_;
    std::size_t pos_ = 0;
    bool ok_ = true;
};

}  // namespace lockroll::rollback
