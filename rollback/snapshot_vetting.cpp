#include "rollback/snapshot_vetting.h"

#include <cstdio>

namespace lockroll::rollback {

void SnapshotVetting::start(std::uint32_t frame, std::uint64_t checksum, PlayerId provider, const Membership& view,
                            std::uint64_t now_us, std::uint64_t deadline_us, AtDeadline at_deadline) {
    active_ = true;
    at_deadline_ = at_deadline;
    frame_ = frame;
    checksum_ = checksum;
    provider_ = provider;
    deadline_us_ = now_us + deadline_us;
    rule_ = view.rule();
    running_ = view.running_voters();
    const PlayerId local = view.local();
    const bool counted = local < static_cast<PlayerId>(view.players()) && view.running(local) && view.host_of(local) == local;
    // A view of two with this process in it: the other is the provider, and no majority of
    // distinct others exists -- the two-player rule says whether its word is enough (as it says
    // whether one vote drops). Any other view: a strict majority, whoever is missing.
    two_player_ = counted && running_ == 2;
    needed_ = two_player_ ? view.majority_size() : running_ / 2 + 1;
    voters_.clear();
    for (int s = 0; s < view.players(); ++s) {
        const auto p = static_cast<PlayerId>(s);
        if (p != local && view.running(p) && view.host_of(p) == p) voters_.push_back({p});
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

// Even if every voter still silent agreed, too few would.
bool SnapshotVetting::impossible() const {
    return static_cast<int>(voters_.size()) - disagreeing() < needed_;
}

bool SnapshotVetting::uncontested() const {
    return at_deadline_ == AtDeadline::AcceptUncontested && agreeing() > 0 && disagreeing() == 0;
}

bool SnapshotVetting::cut_off(std::uint64_t now_us) const {
    return agreeing() < needed_ && !impossible() && now_us >= deadline_us_;
}

std::vector<PlayerId> SnapshotVetting::silent(std::uint64_t now_us) const {
    std::vector<PlayerId> out;
    if (!cut_off(now_us) || uncontested()) return out;
    for (const Voter& v : voters_)
        if (!v.answered) out.push_back(v.peer);
    return out;
}

SnapshotVetting::Verdict SnapshotVetting::verdict(std::uint64_t now_us) const {
    if (!active_) return Verdict::Rejected;
    if (agreeing() >= needed_) return Verdict::Accepted;
    if (impossible()) return Verdict::Rejected;
    if (now_us < deadline_us_) return Verdict::Pending;
    // Silence is no agreement: past the deadline without a majority a joiner's offer is rejected
    // and the caller asks again, rather than load on a minority's word or wait for ever. A
    // spectator reaches only its host between processes: its uncontested word is enough.
    return uncontested() ? Verdict::Accepted : Verdict::Rejected;
}

std::string SnapshotVetting::detail(std::uint64_t now_us) const {
    char head[192];
    std::snprintf(head, sizeof head,
                  "checksum %016llx of frame %u: %d agree, %d differ, %d needed of the view's %d running processes",
                  static_cast<unsigned long long>(checksum_), frame_, agreeing(), disagreeing(), needed_, running_);
    std::string s = head;
    if (two_player_)
        s += std::string("; a view of two has no majority of distinct others: the two-player rule ") +
             two_player_rule_name(rule_) +
             (needed_ == 1 ? " lets the provider's word decide" : " does not let the provider's word alone decide");
    for (const Voter& v : voters_) {
        if (!v.answered || v.agrees) continue;
        char d[64];
        std::snprintf(d, sizeof d, "; peer %u confirmed %016llx", v.peer, static_cast<unsigned long long>(v.value));
        s += d;
    }
    if (cut_off(now_us)) {
        s += uncontested() ? "; a spectator: accepted uncontested, no answer in time from peer"
                           : "; cut off from a majority of the view: no answer in time from peer";
        const char* sep = " ";
        for (const Voter& v : voters_) {
            if (v.answered) continue;
            s += sep + std::to_string(v.peer);
            sep = ", ";
        }
    }
    return s;
}

}  // namespace lockroll::rollback
