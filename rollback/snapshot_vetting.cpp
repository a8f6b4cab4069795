#include "rollback/snapshot_vetting.h"

#include <cstdio>

namespace lockroll::rollback {

void SnapshotVetting::start(std::uint32_t frame, std::uint64_t checksum, PlayerId provider, std::vector<PlayerId> voters,
                            std::uint64_t now_us, std::uint64_t deadline_us) {
    active_ = true;
    frame_ = frame;
    checksum_ = checksum;
    provider_ = provider;
    deadline_us_ = now_us + deadline_us;
    voters_.clear();
    for (PlayerId p : voters) {
        bool seen = false;
        for (const Voter& v : voters_) seen = seen || v.peer == p;
        if (!seen) voters_.push_back({p});
    }
}

void SnapshotVetting::on_reply(PlayerId peer, std::uint32_t frame, bool available, std::uint64_t value) {
    if (!active_ || frame != frame_ || !available) return;
    for (Voter& v : voters_) {
        if (v.peer != peer || v.answered) continue;
        v.answered = true;
        v.value = value;
        v.agrees = value == checksum_;
    }
}

void SnapshotVetting::due(std::uint64_t now_us, std::uint64_t resend_us, std::vector<PlayerId>& out) {
    out.clear();
    if (!active_) return;
    for (Voter& v : voters_) {
        if (v.answered || (v.asked && now_us < v.asked_us + resend_us)) continue;
        v.asked = true;
        v.asked_us = now_us;
        out.push_back(v.peer);
    }
}

int SnapshotVetting::agreeing() const {
    int n = 0;
    for (const Voter& v : voters_) n += v.answered && v.agrees ? 1 : 0;
    return n;
}

int SnapshotVetting::disagreeing() const {
    int n = 0;
    for (const Voter& v : voters_) n += v.answered && !v.agrees ? 1 : 0;
    return n;
}

SnapshotVetting::Verdict SnapshotVetting::verdict(std::uint64_t now_us) const {
    if (!active_ || voters_.empty()) return Verdict::Rejected;
    if (agreeing() >= needed()) return Verdict::Accepted;
    if (disagreeing() > static_cast<int>(voters_.size()) - needed()) return Verdict::Rejected;
    if (now_us < deadline_us_) return Verdict::Pending;
    // Past the deadline, peers that never answered (not reachable yet: between real processes a
    // connection may come up only after the newcomer runs) do not block it: agreeing answers and
    // no disagreeing one accept. Any one honest answer that differs still rejects a forgery.
    return agreeing() > 0 && disagreeing() == 0 ? Verdict::Accepted : Verdict::Rejected;
}

std::string SnapshotVetting::detail(std::uint64_t now_us) const {
    char head[160];
    std::snprintf(head, sizeof head, "checksum %016llx of frame %u: %d of %zu peers agree, %d differ (%d needed)",
                  static_cast<unsigned long long>(checksum_), frame_, agreeing(), voters_.size(), disagreeing(), needed());
    std::string s = head;
    if (voters_.size() == 1) s += "; two players: no majority exists, the provider's word decides";
    for (const Voter& v : voters_) {
        if (!v.answered || v.agrees) continue;
        char d[64];
        std::snprintf(d, sizeof d, "; peer %u confirmed %016llx", v.peer, static_cast<unsigned long long>(v.value));
        s += d;
    }
    if (agreeing() < needed() && disagreeing() <= static_cast<int>(voters_.size()) - needed() && now_us >= deadline_us_)
        s += agreeing() > 0 && disagreeing() == 0 ? "; the others did not answer in time, none disagreed"
                                                  : "; no majority answered in time";
    return s;
}

}  // namespace lockroll::rollback
