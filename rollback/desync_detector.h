// Catching desyncs between peers and narrowing them down to a body and a field.
//
// Contract
//  - Only confirmed frames are ever compared (their inputs are final on both sides, so equal
//    code gives equal checksums); predicted frames never are, so a misprediction can never raise
//    a false alarm.
//  - A peer's reported checksum is compared as soon as this client has confirmed the same frame;
//    reports for frames not confirmed here yet wait (bounded), reports for frames already
//    forgotten are dropped.
//  - The first mismatch with a peer fires one DesyncEvent and starts narrowing; every mismatch is
//    counted. Narrowing, all by query/reply over the same unreliable channel, resent until
//    answered (max_tries), never more than max_outstanding queries in flight:
//      1. if frames between the last agreed one and this one went uncompared (checksum interval
//         > 1, or announcements lost), fetch the peer's checksums of those frames and pick the
//         first that differs;
//      2. fetch the peer's per-body hashes at that frame, in order, and find the first body whose
//         hash differs from ours;
//      3. fetch that body's fields and name the first that differs.
//    Then one DesyncReport, with this client's state at that frame for an evidence file.
//  - Evidence: at detection the saved states from the last agreed frame to the mismatch (at most
//    max_pinned_frames) are copied out of the snapshot ring, so they survive the ring moving on
//    while queries travel. Queries from the peer are answered from the ring or these copies.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <vector>

#include <lockroll/rollback/events.h>
#include "rollback/protocol.h"
#include <lockroll/rollback/session_types.h>
#include <lockroll/rollback/simulation.h>
#include "rollback/snapshot_ring.h"

namespace lockroll::rollback {

struct DesyncConfig {
    std::uint32_t history = 1024;       // confirmed checksums remembered (power of two)
    int max_pinned_frames = 64;         // evidence states copied per investigation
    std::uint64_t resend_us = 100000;   // re-ask an unanswered query after this long
    int max_tries = 50;
    int max_outstanding = 4;
    std::size_t max_pending_reports = 256;  // per peer, for frames not confirmed here yet
};

class DesyncDetector {
public:
    // observer may be null. The simulation and ring must outlive the detector.
    DesyncDetector(const DesyncConfig& config, int players, PlayerId local, const Simulation& sim,
                   const SnapshotRing& ring, SessionObserver* observer, SessionStats& stats);

    // This client confirmed `frame` (called for every frame, in order, starting with frame 0).
    void add_local(std::uint32_t frame, std::uint64_t checksum);
    // A peer reported the checksum of one of its confirmed frames.
    void add_remote(PlayerId peer, std::uint32_t frame, std::uint64_t checksum);

    std::optional<std::uint64_t> local_checksum(std::uint32_t frame) const;
    std::uint32_t newest_local() const { return newest_local_; }

    // The answer to a peer's query, from this client's evidence.
    ReplyMessage answer(const QueryMessage& q) const;
    void on_reply(PlayerId peer, const ReplyMessage& r);
    // Queries due now (first sends and resends), as (peer, query).
    void collect_queries(std::uint64_t now_us, std::vector<std::pair<PlayerId, QueryMessage>>& out);
    // The peer can no longer answer: an investigation with it ends as NoReply.
    void peer_failed(PlayerId peer);
    // The peer's process was replaced (a rejoin): forget its verdicts and pending reports.
    void reset_peer(PlayerId peer);
    // This client loaded a snapshot of confirmed `frame` (join or desync recovery): everything
    // known about earlier frames and every verdict is forgotten; comparison resumes from here.
    void restart_at(std::uint32_t frame, std::uint64_t checksum);
    // The checksum a peer reported for `frame`, while it waits or was the last compared, or
    // the answer to ask_checksum() about that frame.
    std::optional<std::uint64_t> remote_checksum(PlayerId peer, std::uint32_t frame) const;
    // Recovery arbitrates on every live player's checksum of the first differing frame, but
    // checksums ride only on input messages, newest first: a peer whose messages were lost while
    // it confirmed that frame (a one-way cut) never tells it again by itself. This asks it (a
    // FrameChecksums query of that one frame, resent like narrowing's, max_tries at most), one
    // frame per peer at a time; remote_checksum() then holds the answer. Called again for the
    // same frame after max_tries went unanswered, it asks again. A peer that no longer holds the
    // frame answers "unavailable", and is asked no more about it.
    void ask_checksum(PlayerId peer, std::uint32_t frame);

    bool investigating(PlayerId peer) const;
    bool desynced(PlayerId peer) const { return peers_[peer].desynced; }

private:
    enum class Stage { None, FrameChecksums, BodyHashes, BodyFields, Done };

    struct Chunk {
        QueryMessage query;
        bool received = false;
        std::uint64_t last_sent_us = 0;
        int tries = 0;
        std::vector<std::uint64_t> values;
        std::vector<std::int64_t> fields;
    };

    struct PeerState {
        bool desynced = false;
        std::optional<std::uint32_t> last_agreed;
        std::uint32_t last_compared_plus1 = 0;
        std::map<std::uint32_t, std::uint64_t> pending;  // frame -> remote checksum
        std::map<std::uint32_t, std::uint64_t> recent;   // frame -> remote checksum, last few compared
        // investigation
        Stage stage = Stage::None;
        DesyncReport report;
        std::uint32_t range_first = 0;
        std::uint32_t body_index = 0;
        std::vector<Chunk> chunks;
        // ask_checksum(): the frame asked about, and its answer once received.
        std::optional<Chunk> asked;
        std::optional<std::uint64_t> asked_answer;
    };

    void compare(PlayerId peer, std::uint32_t frame, std::uint64_t local, std::uint64_t remote);
    void start_investigation(PlayerId peer, std::uint32_t frame, std::uint64_t local, std::uint64_t remote);
    void begin_body_hashes(PlayerId peer);
    void begin_body_fields(PlayerId peer);
    void advance(PlayerId peer);
    void finish(PlayerId peer, NarrowOutcome outcome);
    std::optional<std::span<const std::uint8_t>> evidence(std::uint32_t frame) const;

    DesyncConfig config_;
    PlayerId local_;
    const Simulation& sim_;
    const SnapshotRing& ring_;
    SessionObserver* observer_;
    SessionStats& stats_;
    // Confirmed checksums by frame & (history - 1); tag is frame + 1, 0 = empty. One zeroed
    // block (make_unique<[]> is a memset) rather than vectors filled element by element: a
    // session builds its detector on construction, with at least 1,024 entries.
    struct Remembered {
        std::uint64_t checksum;
        std::uint64_t tag;
    };
    std::unique_ptr<Remembered[]> history_;
    std::uint32_t newest_local_ = 0;
    bool any_local_ = false;
    std::vector<PeerState> peers_;
    std::map<std::uint32_t, std::vector<std::uint8_t>> pinned_;
};

}  // namespace lockroll::rollback
