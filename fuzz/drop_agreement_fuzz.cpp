// libFuzzer target: DropAgreement (rollback/drop_agreement.h) run by 3..8 processes, each a
// Membership and a DropAgreement as the session holds them, driven by a script (the format is in
// fuzz/drop_agreement_fuzz.h): votes cast and withdrawn by any process about any slot (and
// delivered, as that voter's vote, to the Memberships of the processes the script names),
// reports sent and then heard late, out of order, more than once or never, time passing (so
// proposers retry), drops learned from slot tables, and at most one hostile process that sends
// whatever AgreementReport it likes (forged ballots in others' names, huge rounds, accepted slots
// nobody proposed, reports of other instances), says whatever it likes about any slot, and
// claims drops it never applied. An honest process passes `wanted` as the session does (a slot
// a majority of its votes say is gone, its own vote among them), and applies what step()
// returns (the drop: a new view, the next instance); one that drops its own slot stops.
//
// It aborts on the first of:
//  1. (every process honest only) two processes that decide different slots *by acceptance* in
//     one instance (the same view), or a process that applies a drop nobody chose by
//     acceptance. A decision is by acceptance when a majority of the decision's electorate
//     (Membership::electorate, as step() counts it) accepted that slot under one ballot in that
//     instance (their acceptances are recorded as they happen, not as the decider heard them);
//     any other decision is learned (from the tables of voters that applied the drop,
//     heard_drop, alone or with some acceptances), and must be a slot some process already
//     decided by acceptance, in any instance. So every honest process's set of applied drops is
//     a subset of the drops chosen by acceptance, one per view: the sets never conflict, though a
//     learner may apply two chosen drops in another order than they were chosen and pass through
//     a view nobody else held (fuzz/findings/drop_agreement/learns_a_later_drop_first: learning,
//     not a second choice). Not checked with a hostile process: its forged acceptance under a high
//     ballot can make two slots that honest voters vote gone each gather a majority in one view,
//     a limit DropAgreement states ("What a hostile voter can still do", rollback/
//     drop_agreement.h: Byzantine quorums are not claimed; findings/drop_agreement/
//     hostile_splits_a_view). Property 2 is what it does promise against one liar.
//     DROP_AGREEMENT_FUZZ_SPLITS=1 checks it with the hostile process too, counted as accepting
//     every slot under every ballot: to replay that limit (findings/drop_agreement/
//     hostile_splits_by_lying), not for CI.
//  2. an honest process that decides, in the starting view, a slot that fewer than a majority
//     of the view's voters ever said is gone: the honest voters that ever cast that vote (about
//     the slot as the starting view holds it), plus the hostile process, counted as backing every
//     slot (it may vote and claim anything). So the hostile process alone, or with fewer honest
//     voters than Membership's own rule needs, never drops anyone. (Honest acceptances are not
//     counted: a decision is a majority of acceptances, so that would hold by construction; what
//     is checked is where the accepted slot came from.)
//  3. memory that grows: every operation on the built processes frees whatever it allocates
//     (counted with the sanitizer allocator's hooks; ASan builds only); crashes and sanitizer
//     reports as every target.
// DROP_AGREEMENT_FUZZ_TRACE=1 in the environment prints every operation as it runs (to read a
// finding: build-asan/fuzz/drop_agreement_fuzz CRASH-FILE); DROP_AGREEMENT_FUZZ_HONEST=1 makes
// every process honest whatever the header says (honest mode: properties 1 and 2; a header's
// hostile bit 7 does the same for one input).
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <optional>
#include <vector>

#include "fuzz/drop_agreement_fuzz.h"
#include "rollback/drop_agreement.h"
#include "rollback/membership.h"

#if defined(__has_feature)
#if __has_feature(address_sanitizer)
#include <sanitizer/allocator_interface.h>
#define DROP_AGREEMENT_FUZZ_COUNT_ALLOCATIONS 1
#endif
#endif

using namespace lockroll::rollback;
namespace fz = lockroll::fuzz;

namespace {

// The checks and the bookkeeping are not what is fuzzed: left out of the coverage instrumentation.
#define NOT_FUZZED __attribute__((no_sanitize("coverage")))

bool trace = false;
bool all_honest = false;
bool check_splits = false;  // property 1 with a hostile process too (DROP_AGREEMENT_FUZZ_SPLITS)

#define TRACE(...)                                      \
    do {                                                \
        if (trace) std::fprintf(stderr, __VA_ARGS__);   \
    } while (0)

[[noreturn]] void fail(const char* what) {
    std::fprintf(stderr, "drop_agreement_fuzz: property broken: %s\n", what);
    std::abort();
}

// Live allocations made on this thread while `armed`: back to zero after every operation.
thread_local bool armed = false;
thread_local long live = 0;
#ifdef DROP_AGREEMENT_FUZZ_COUNT_ALLOCATIONS
void on_malloc(const volatile void*, std::size_t) {
    if (armed) ++live;
}
void on_free(const volatile void* p) {
    if (armed && p != nullptr) --live;
}
#endif

constexpr int kMax = fz::kAgreeMaxPlayers;
constexpr int kMaxFlights = fz::kAgreeMaxFlights;

struct Node {
    Membership view;
    DropAgreement agreement;
    bool stopped = false;  // it dropped its own slot (the session's Kicked)
    Node(int players, PlayerId local) : view(players, local, TwoPlayerRule::PlayOnAlone), agreement(players, local) {}
    // What the session passes as `wanted`: a slot a majority votes gone, its own vote among them.
    PlayerId wanted() const {
        for (PlayerId s = 0; s < static_cast<PlayerId>(view.players()); ++s)
            if (s != view.local() && view.decided_gone(s) && view.vote_of(view.local(), s) == Vote::Gone) return s;
        return kNoSlot;
    }
};

// An honest voter's acceptance, as its report stated it after a step.
struct Acceptance {
    std::uint32_t instance = 0;
    std::uint16_t ballot = 0;
    PlayerId slot = kNoSlot;
};
constexpr int kMaxAcceptances = fz::kAgreeMaxOps;  // one step makes at most one new acceptance
constexpr int kMaxDecisions = kMax * kMax;          // a process decides at most once per view, n views

// A decision by acceptance: the slot `slot` was chosen in the instance (view) `instance`.
struct Choice {
    std::uint32_t instance = 0;
    PlayerId slot = kNoSlot, by = kNoSlot;
};

struct Flight {
    PlayerId to = 0, from = 0;
    AgreementReport r;
};

struct World {
    int n = 0;
    PlayerId hostile = kNoSlot;  // kNoSlot: every process is honest
    std::uint64_t retry_us = 0;
    std::uint64_t now_us = 0;
    std::uint32_t start_id = 0;
    std::vector<Node> nodes;
    Flight flights[kMaxFlights];
    int in_flight = 0;
    AgreementReport forged;
    bool ever_gone[kMax][kMax] = {};  // [honest voter][slot], about the slot as the starting view holds it
    // Property 1 (every process honest): what each voter accepted, and the decisions by acceptance.
    // Fixed arrays: the memory check counts every allocation made during an operation.
    Acceptance accepted[kMax][kMaxAcceptances];
    int accepted_count[kMax] = {};
    Choice choices[kMaxDecisions];
    int choice_count = 0;
    bool chosen[kMax] = {};  // some process decided this slot by acceptance, in any view

    bool honest(PlayerId p) const { return p != hostile; }
    void send(PlayerId from, PlayerId to, const AgreementReport& r) {
        if (to == from || in_flight == kMaxFlights) return;  // a full network loses it
        flights[in_flight++] = {to, from, r};
    }
};

NOT_FUZZED void record_acceptance(World& w, PlayerId p, const AgreementReport& r) {
    if (r.accepted == 0) return;
    int& count = w.accepted_count[p];
    const Acceptance& last = w.accepted[p][count > 0 ? count - 1 : 0];
    if (count > 0 && last.instance == r.instance && last.ballot == r.accepted && last.slot == r.accepted_slot) return;
    if (count == kMaxAcceptances) fail("more acceptances than steps");
    w.accepted[p][count++] = {r.instance, r.accepted, r.accepted_slot};
}

// 1. (every process honest) One slot per view by acceptance; a learned drop is one chosen so.
NOT_FUZZED void check_choice(World& w, PlayerId p, const Membership& view, std::uint32_t instance, PlayerId x) {
    // The most voters of this view that accepted x under one ballot in this instance.
    int most = 0;
    for (int v = 0; v < w.n; ++v)
        for (int i = 0; i < w.accepted_count[v]; ++i) {
            const Acceptance& a = w.accepted[v][i];
            if (a.instance != instance || a.slot != x) continue;
            int n = 0;
            for (int u = 0; u < w.n; ++u) {
                if (!view.is_voter(static_cast<PlayerId>(u))) continue;
                for (int j = 0; j < w.accepted_count[u]; ++j) {
                    const Acceptance& b = w.accepted[u][j];
                    if (b.instance == instance && b.ballot == a.ballot && b.slot == x) {
                        ++n;
                        break;
                    }
                }
            }
            most = std::max(most, n);
        }
    // With DROP_AGREEMENT_FUZZ_SPLITS, the hostile voter is taken to accept whatever it is asked.
    if (most > 0 && w.hostile != kNoSlot && view.is_voter(w.hostile)) ++most;
    const int needed = view.majority_of(view.electorate(x));
    if (most < needed) {
        // Learned: the drop must be one some process chose by acceptance.
        TRACE("  (learned: %d of the %d acceptances a choice needs)\n", most, needed);
        if (!w.chosen[x]) {
            std::fprintf(stderr,
                         "drop_agreement_fuzz: process %u decided slot %u in view %08x, which %d voters accepted under "
                         "one ballot there (%d needed), and no process chose by acceptance in any view\n",
                         p, x, instance, most, needed);
            fail("a drop is applied only once some view chose it");
        }
        return;
    }
    for (int i = 0; i < w.choice_count; ++i) {
        const Choice& c = w.choices[i];
        if (c.instance == instance && c.slot != x) {
            std::fprintf(stderr, "drop_agreement_fuzz: process %u chose slot %u by acceptance, process %u slot %u, both in view %08x\n",
                         p, x, c.by, c.slot, instance);
            fail("one view chooses one slot");
        }
    }
    if (w.choice_count < kMaxDecisions) w.choices[w.choice_count++] = {instance, x, p};
    w.chosen[x] = true;
}

// 2. Backed by a majority of the view's voters that ever said so (the hostile one counted for all).
NOT_FUZZED void check_backing(const World& w, PlayerId p, PlayerId x) {
    int backers = w.hostile != kNoSlot ? 1 : 0;
    for (int v = 0; v < w.n; ++v) backers += w.honest(static_cast<PlayerId>(v)) && w.ever_gone[v][x];
    if (backers < w.n / 2 + 1) {
        std::fprintf(stderr,
                     "drop_agreement_fuzz: process %u decided slot %u, which %d of %d voters ever voted gone "
                     "(the hostile process %s counted)\n",
                     p, x, backers, w.n, w.hostile != kNoSlot ? "is" : "is not");
        fail("no slot drops without a majority of voters saying it is gone");
    }
}

NOT_FUZZED void trace_report(const char* what, PlayerId from, PlayerId to, const AgreementReport& r) {
    TRACE("  %s %u -> %u: instance %08x promised %u:%u accepted %u:%u slot %u proposal %u:%u slot %u\n", what, from, to,
          r.instance, ballot_round(r.promised), ballot_proposer(r.promised), ballot_round(r.accepted),
          ballot_proposer(r.accepted), r.accepted_slot, ballot_round(r.proposal), ballot_proposer(r.proposal),
          r.proposal_slot);
}

void step(World& w, PlayerId p, bool broadcast) {
    Node& node = w.nodes[p];
    if (node.stopped) return;
    const bool in_start = node.view.view_id() == w.start_id;
    const PlayerId wanted = node.wanted();
    const std::optional<PlayerId> x = node.agreement.step(node.view, wanted, w.now_us, w.retry_us);
    TRACE("step %u (wanted %u) at %llu us%s\n", p, wanted, static_cast<unsigned long long>(w.now_us),
          in_start ? "" : " (a later view)");
    trace_report("report", p, p, node.agreement.report());
    if (w.honest(p)) record_acceptance(w, p, node.agreement.report());
    if (x) {
        TRACE("  process %u decides slot %u%s\n", p, *x, in_start ? " in the starting view" : "");
        if (w.honest(p) && (w.hostile == kNoSlot || check_splits)) check_choice(w, p, node.view, node.agreement.instance(), *x);
        if (in_start && w.honest(p)) check_backing(w, p, *x);
        node.view.leave(*x);  // the session applies it: a new view, the next instance
        if (*x == p) {
            node.stopped = true;  // Kicked
            return;
        }
    }
    if (broadcast)
        for (int q = 0; q < w.n; ++q) w.send(p, static_cast<PlayerId>(q), node.agreement.report());
}

void vote(World& w, PlayerId v, PlayerId s, Vote what, std::uint8_t mask, std::uint8_t c) {
    if (!w.honest(v)) {
        // Any word the hostile process likes, at any epoch, to every honest process.
        w.nodes[v].view.vote_local(s, what == Vote::Gone);
        for (int q = 0; q < w.n; ++q) {
            Node& r = w.nodes[static_cast<std::size_t>(q)];
            if (static_cast<PlayerId>(q) == v) continue;
            r.view.vote(v, s, what, static_cast<std::uint8_t>(r.view.epoch(s) + c - 128));
        }
        TRACE("hostile %u says %d about slot %u (epoch + %d) to all\n", v, static_cast<int>(what), s, c - 128);
        return;
    }
    Node& voter = w.nodes[v];
    if (voter.stopped) return;
    const bool gone = what == Vote::Gone;
    const Tally t = voter.view.vote_local(s, gone);
    if (t != Tally::Counted && t != Tally::Repeated) return;  // nothing its table would say
    const std::uint8_t e = voter.view.advertised_epoch(s);
    if (gone && e == 1) w.ever_gone[v][s] = true;  // about the slot as the starting view holds it (epoch 0)
    TRACE("process %u says %d about slot %u (epoch %u) to mask %02x\n", v, static_cast<int>(what), s, e, mask);
    for (int q = 0; q < w.n; ++q)
        if (static_cast<PlayerId>(q) != v && (mask >> q & 1u)) w.nodes[static_cast<std::size_t>(q)].view.vote(v, s, what, e);
}

void deliver(World& w, std::uint8_t b, std::uint8_t c) {
    if (w.in_flight == 0) return;
    const int i = b % w.in_flight;
    const Flight f = w.flights[i];
    if (!(c & 2)) {
        trace_report("heard", f.from, f.to, f.r);
        w.nodes[f.to].agreement.heard(f.from, f.r);
    } else {
        TRACE("  lost %u -> %u\n", f.from, f.to);
    }
    if (c & 1 && !(c & 2)) return;  // stays in flight: heard again later
    w.flights[i] = w.flights[--w.in_flight];
}

void table(World& w, PlayerId from, std::uint8_t b, std::uint8_t c) {
    if (!w.honest(from)) {
        const auto s = static_cast<PlayerId>(b % w.n);
        for (int q = 0; q < w.n; ++q) {
            Node& r = w.nodes[static_cast<std::size_t>(q)];
            if (static_cast<PlayerId>(q) == from) continue;
            const auto e = static_cast<std::uint8_t>(r.view.epoch(s) + c - 128);
            r.agreement.heard_drop(from, s, e);
        }
        TRACE("hostile %u claims it dropped slot %u (epoch + %d) to all\n", from, s, c - 128);
        return;
    }
    const Node& sender = w.nodes[from];
    if (sender.stopped) return;
    for (int s = 0; s < w.n; ++s) {
        const auto slot = static_cast<PlayerId>(s);
        if (sender.view.running(slot) || sender.view.epoch(slot) == 0) continue;  // not dropped since the start
        for (int q = 0; q < w.n; ++q)
            if (static_cast<PlayerId>(q) != from && (c >> q & 1u)) {
                TRACE("table of %u to %u: it dropped slot %u into epoch %u\n", from, q, slot, sender.view.epoch(slot));
                w.nodes[static_cast<std::size_t>(q)].agreement.heard_drop(from, slot, sender.view.epoch(slot));
            }
    }
}

void forge(World& w, std::uint8_t field, std::uint8_t lo, std::uint8_t hi) {
    AgreementReport& r = w.forged;
    auto ballot = [&]() -> std::uint16_t {
        if (!(field & fz::kForgeCopy)) return static_cast<std::uint16_t>(lo | hi << 8);
        const AgreementReport& of = w.nodes[static_cast<std::size_t>(lo % w.n)].agreement.report();
        const std::uint16_t base = lo & 0x80 ? of.promised : of.proposal;
        return static_cast<std::uint16_t>(base + static_cast<std::int8_t>(hi));
    };
    switch (field % 8) {
        case fz::kForgeInstance: {
            const std::uint32_t ids[4] = {w.start_id, w.start_id + 1, static_cast<std::uint32_t>(lo | hi << 8), 0};
            r.instance = ids[lo % 4];
            break;
        }
        case fz::kForgePromised: r.promised = ballot(); break;
        case fz::kForgeAccepted: r.accepted = ballot(); break;
        case fz::kForgeAcceptedSlot: r.accepted_slot = lo; break;
        case fz::kForgeProposal: r.proposal = ballot(); break;
        case fz::kForgeProposalSlot: r.proposal_slot = lo; break;
        case fz::kForgeAllBallots: r.promised = r.accepted = r.proposal = ballot(); break;
        default: r = AgreementReport{.instance = w.start_id}; break;
    }
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
    const char* t = std::getenv("DROP_AGREEMENT_FUZZ_TRACE");
    trace = t != nullptr && *t != '\0' && *t != '0';
    const char* h = std::getenv("DROP_AGREEMENT_FUZZ_HONEST");
    all_honest = h != nullptr && *h != '\0' && *h != '0';
    const char* sp = std::getenv("DROP_AGREEMENT_FUZZ_SPLITS");
    check_splits = sp != nullptr && *sp != '\0' && *sp != '0';
#ifdef DROP_AGREEMENT_FUZZ_COUNT_ALLOCATIONS
    __sanitizer_install_malloc_and_free_hooks(on_malloc, on_free);
#endif
    return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    if (size < 4) return 0;
    World w;
    w.n = fz::kAgreeMinPlayers + data[0] % (fz::kAgreeMaxPlayers - fz::kAgreeMinPlayers + 1);
    w.hostile = all_honest || data[1] & fz::kNoHostile ? kNoSlot : static_cast<PlayerId>(data[1] % w.n);
    w.retry_us = 100u * (1u + data[2] % 16u);
    w.nodes.reserve(static_cast<std::size_t>(w.n));
    for (int p = 0; p < w.n; ++p) w.nodes.emplace_back(w.n, static_cast<PlayerId>(p));
    w.start_id = w.nodes[0].view.view_id();
    w.forged.instance = w.start_id;
    TRACE("%d processes, hostile %u, retry %llu us\n", w.n, w.hostile, static_cast<unsigned long long>(w.retry_us));

    armed = true;
    live = 0;
    const std::size_t ops = std::min<std::size_t>((size - 4) / 4, fz::kAgreeMaxOps);
    for (std::size_t i = 0; i < ops; ++i) {
        const std::uint8_t* op = data + 4 + 4 * i;
        const int kind = op[0] % fz::kAgreeOpCount;
        const auto what = static_cast<Vote>(op[0] / fz::kAgreeOpCount % 3);
        const std::uint8_t a = op[1], b = op[2], c = op[3];
        const auto p = static_cast<PlayerId>(a % w.n);
        switch (kind) {
            case fz::kAgreeVote: vote(w, p, static_cast<PlayerId>(b % w.n), what, c, c); break;
            case fz::kAgreeStep: step(w, p, b & 1); break;
            case fz::kAgreeSend:
                if (w.nodes[p].stopped) break;
                for (int q = 0; q < w.n; ++q)
                    if (c >> q & 1u) w.send(p, static_cast<PlayerId>(q), w.nodes[p].agreement.report());
                break;
            case fz::kAgreeDeliver: deliver(w, b, c); break;
            case fz::kAgreeTime: w.now_us += 50u * (1u + a); break;
            case fz::kAgreeTable: table(w, p, b, c); break;
            case fz::kAgreeForge:
                if (w.hostile != kNoSlot) forge(w, a, b, c);
                break;
            default:  // kAgreeForged
                if (w.hostile == kNoSlot) break;
                for (int q = 0; q < w.n; ++q) {
                    if (!(c >> q & 1u)) continue;
                    AgreementReport r = w.forged;
                    if (b & 1) r.instance = w.nodes[static_cast<std::size_t>(q)].view.view_id();
                    w.send(w.hostile, static_cast<PlayerId>(q), r);
                }
                break;
        }
        if (live != 0) fail("an operation on the built processes keeps memory it allocated");
    }
    armed = false;
    return 0;
}
