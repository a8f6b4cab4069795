#include "rollback/replay.h"

#define XXH_INLINE_ALL
#include <xxhash.h>

#include <algorithm>
#include <stdexcept>

#include "rollback/bytes.h"

namespace lockroll::rollback {

namespace {
constexpr std::size_t kFixedHeaderBytes = 32;  // magic .. initial checksum

std::string range(std::uint64_t a, std::uint64_t b) { return std::to_string(a) + ".." + std::to_string(b); }
}  // namespace

std::span<const std::uint8_t> Replay::inputs_of(std::uint32_t i) const {
    const std::size_t n = std::size_t{players} * input_size;
    return std::span(inputs).subspan(std::size_t{i} * n, n);
}

std::vector<std::uint8_t> encode_replay(const Replay& r) {
    const std::size_t frame_bytes = std::size_t{r.players} * r.input_size;
    if (r.inputs.size() != frame_bytes * r.checksums.size())
        throw std::invalid_argument("replay: inputs do not match players * input_size * frames");
    if (r.scene_name.size() > kReplayMaxNameBytes || r.scene_text.size() > kReplayMaxSceneBytes)
        throw std::invalid_argument("replay: scene name or text too long");
    std::vector<std::uint8_t> out;
    out.reserve(64 + r.scene_name.size() + r.scene_text.size() + r.checksums.size() * (frame_bytes + 8) +
                (r.checksums.size() / kReplayBlockFrames + 1) * 8);
    ByteWriter w(out);
    w.u32(kReplayMagic);
    w.u16(kReplayVersion);
    w.u16(0);
    w.u32(r.players);
    w.u32(r.input_size);
    w.u32(r.tick_rate);
    w.u32(r.frames());
    w.u64(r.initial_checksum);
    w.u32(static_cast<std::uint32_t>(r.scene_name.size()));
    w.bytes({reinterpret_cast<const std::uint8_t*>(r.scene_name.data()), r.scene_name.size()});
    w.u32(static_cast<std::uint32_t>(r.scene_text.size()));
    w.bytes({reinterpret_cast<const std::uint8_t*>(r.scene_text.data()), r.scene_text.size()});
    w.u64(XXH3_64bits(out.data(), out.size()));
    for (std::uint32_t b = 0; b * kReplayBlockFrames < r.frames(); ++b) {
        const std::size_t block_start = out.size();
        const std::uint32_t end = std::min(r.frames(), (b + 1) * kReplayBlockFrames);
        for (std::uint32_t i = b * kReplayBlockFrames; i < end; ++i) {
            w.bytes(r.inputs_of(i));
            w.u64(r.checksums[i]);
        }
        w.u64(XXH3_64bits_withSeed(out.data() + block_start, out.size() - block_start, b));
    }
    return out;
}

std::optional<ReplayError> decode_replay(std::span<const std::uint8_t> bytes, Replay& out) {
    const std::uint64_t size = bytes.size();
    if (size < kFixedHeaderBytes + 4)
        return ReplayError{"file is " + std::to_string(size) + " bytes, shorter than a replay header (" +
                               std::to_string(kFixedHeaderBytes + 4) + "): truncated or not a replay",
                           size};
    ByteReader r(bytes);
    if (r.u32() != kReplayMagic) return ReplayError{"not a lockroll replay: magic is not \"LRRP\"", 0};
    const std::uint16_t version = r.u16();
    if (version != kReplayVersion)
        return ReplayError{"replay format version " + std::to_string(version) + " is not supported (this build reads " +
                               std::to_string(kReplayVersion) + ")",
                           4};
    if (const std::uint16_t flags = r.u16(); flags != 0)
        return ReplayError{"header flags are " + std::to_string(flags) + ", must be 0", 6};
    out.players = r.u32();
    out.input_size = r.u32();
    out.tick_rate = r.u32();
    const std::uint32_t frames = r.u32();
    out.initial_checksum = r.u64();
    if (out.players < 1 || out.players > static_cast<std::uint32_t>(kMaxPlayers))
        return ReplayError{"players is " + std::to_string(out.players) + ", must be 1.." + std::to_string(kMaxPlayers), 8};
    if (out.input_size < 1 || out.input_size > 64)
        return ReplayError{"input_size is " + std::to_string(out.input_size) + ", must be 1..64", 12};
    if (out.tick_rate < 1 || out.tick_rate > 10000)
        return ReplayError{"tick_rate is " + std::to_string(out.tick_rate) + ", must be 1..10000", 16};
    const std::uint64_t name_at = r.position();
    const std::uint32_t name_len = r.u32();
    if (name_len > kReplayMaxNameBytes)
        return ReplayError{"scene name length " + std::to_string(name_len) + " exceeds " +
                               std::to_string(kReplayMaxNameBytes),
                           name_at};
    const auto name = r.bytes(name_len);
    if (!r.ok())
        return ReplayError{"file ends inside the scene name (needs bytes " + range(name_at + 4, name_at + 4 + name_len) +
                               ", file has " + std::to_string(size) + "): truncated",
                           size};
    const std::uint64_t text_at = r.position();
    const std::uint32_t text_len = r.u32();
    if (!r.ok()) return ReplayError{"file ends before the scene text length: truncated", size};
    if (text_len > kReplayMaxSceneBytes)
        return ReplayError{"scene text length " + std::to_string(text_len) + " exceeds " +
                               std::to_string(kReplayMaxSceneBytes),
                           text_at};
    const auto text = r.bytes(text_len);
    if (!r.ok())
        return ReplayError{"file ends inside the scene text (needs bytes " + range(text_at + 4, text_at + 4 + text_len) +
                               ", file has " + std::to_string(size) + "): truncated",
                           size};
    const std::uint64_t header_end = r.position();
    const std::uint64_t header_hash = r.u64();
    if (!r.ok()) return ReplayError{"file ends inside the header hash: truncated", size};
    if (header_hash != XXH3_64bits(bytes.data(), header_end))
        return ReplayError{"header (bytes " + range(0, header_end) + ") fails its XXH3-64 check: corrupted", header_end};
    out.scene_name.assign(name.begin(), name.end());
    out.scene_text.assign(text.begin(), text.end());

    const std::uint64_t frame_bytes = std::uint64_t{out.players} * out.input_size;
    const std::uint64_t record = frame_bytes + 8;
    const std::uint64_t blocks = (std::uint64_t{frames} + kReplayBlockFrames - 1) / kReplayBlockFrames;
    const std::uint64_t body_start = header_end + 8;
    const std::uint64_t expected = body_start + std::uint64_t{frames} * record + blocks * 8;
    if (size < expected) {
        const std::uint64_t block = std::min(blocks - 1, (size - body_start) / (kReplayBlockFrames * record + 8));
        const std::uint64_t first = block * kReplayBlockFrames;
        const std::uint64_t last = std::min<std::uint64_t>(frames, first + kReplayBlockFrames) - 1;
        return ReplayError{"file ends at byte " + std::to_string(size) + " but " + std::to_string(frames) +
                               " frames need " + std::to_string(expected) + " bytes: truncated in block " +
                               std::to_string(block) + " (frames " + range(first, last) + ")",
                           size};
    }
    if (size > expected)
        return ReplayError{std::to_string(size - expected) + " unexpected bytes after the last block", expected};

    out.inputs.resize(static_cast<std::size_t>(frames * frame_bytes));
    out.checksums.resize(frames);
    std::uint64_t at = body_start;
    for (std::uint64_t b = 0; b < blocks; ++b) {
        const std::uint64_t first = b * kReplayBlockFrames;
        const std::uint64_t end = std::min<std::uint64_t>(frames, first + kReplayBlockFrames);
        const std::uint64_t len = (end - first) * record;
        const std::uint8_t* p = bytes.data() + at;
        ByteReader hr(bytes.subspan(static_cast<std::size_t>(at + len), 8));
        if (hr.u64() != XXH3_64bits_withSeed(p, static_cast<std::size_t>(len), b))
            return ReplayError{"block " + std::to_string(b) + " (frames " + range(first, end - 1) + ", bytes " +
                                   range(at, at + len + 8) + ") fails its XXH3-64 check: corrupted",
                               at};
        ByteReader br(bytes.subspan(static_cast<std::size_t>(at), static_cast<std::size_t>(len)));
        for (std::uint64_t i = first; i < end; ++i) {
            const auto in = br.bytes(static_cast<std::size_t>(frame_bytes));
            std::copy(in.begin(), in.end(), out.inputs.begin() + static_cast<std::ptrdiff_t>(i * frame_bytes));
            out.checksums[static_cast<std::size_t>(i)] = br.u64();
        }
        at += len + 8;
    }
    return std::nullopt;
}

ReplayRecorder::ReplayRecorder(Replay header) : replay_(std::move(header)) {
    replay_.inputs.clear();
    replay_.checksums.clear();
}

void ReplayRecorder::add(const FrameConfirmed& f) { add(f.frame, f.inputs, f.checksum); }

void ReplayRecorder::add(std::uint32_t frame, std::span<const std::uint8_t> inputs, std::uint64_t checksum) {
    if (frame != replay_.frames() + 1)
        throw std::logic_error("replay recorder: frame " + std::to_string(frame) + " out of order (expected " +
                               std::to_string(replay_.frames() + 1) + ")");
    if (inputs.size() != std::size_t{replay_.players} * replay_.input_size)
        throw std::logic_error("replay recorder: inputs are not players * input_size bytes");
    replay_.inputs.insert(replay_.inputs.end(), inputs.begin(), inputs.end());
    replay_.checksums.push_back(checksum);
}

std::optional<ReplayMismatch> verify_replay(const Replay& replay, Simulation& sim) {
    if (replay.inputs.size() != std::size_t{replay.players} * replay.input_size * replay.frames())
        throw std::invalid_argument("replay inputs do not match its frame count");
    std::vector<std::uint8_t> state(sim.state_size());
    if (const std::uint64_t c = sim.checksum(sim.save_to(state)); c != replay.initial_checksum)
        return ReplayMismatch{0, replay.initial_checksum, c};
    for (std::uint32_t i = 0; i < replay.frames(); ++i) {
        sim.step(replay.inputs_of(i));
        const std::uint64_t c = sim.checksum(sim.save_to(state));
        if (c != replay.checksums[i]) return ReplayMismatch{i + 1, replay.checksums[i], c};
    }
    return std::nullopt;
}

}  // namespace lockroll::rollback
