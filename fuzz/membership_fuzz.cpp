// libFuzzer target: Membership (rollback/membership.h) driven directly by a script of votes from
// any voter about any slot (out-of-range ids, voters that left, guests, repeated and
// contradictory words, stale and wrapped epochs), the local process's votes, joins handed over by
// the owner (and their joiners starting to play), and the session's tick that drops whatever the votes decide (the format is in
// fuzz/membership_fuzz.h). Membership reads no clock: time passes only as those ticks.
//
// Beside it the target keeps its own record of the view and of every voter's latest word, built
// from the rules as docs/sessions.md states them (not from Membership's code), and after every
// step it checks, aborting on the first that breaks:
//  - Membership answers as the record says: the view (state, epoch, host of every slot), each
//    vote as it counts, the vote counts, the decisions, the majority size, what the local process
//    advertises, Partitioned; and each vote's Tally is Counted or Repeated exactly when the rules
//    take it (else one of the reasons that apply);
//  - a running slot leaves only when a strict majority of the view's running processes voted it
//    gone (a joiner is no voter until it plays; a decision about a joining slot counts that slot
//    too), each voter counted once (its latest word: the record keeps one per voter); with three
//    or more voters one voter alone never removes anyone; with two the configured TwoPlayerRule
//    applies (PlayOnAlone: one vote; NoDrop: never); and once a slot has a majority, the tick
//    drops it (no decision is lost);
//  - the view only moves forward: a vote changes no slot's state or epoch; a drop moves the slot
//    to Disconnected in the next epoch; a slot that left keeps that state and epoch (what its
//    neutral inputs are agreed on) until a join hands it over in a newer epoch;
//  - memory stays bounded: no call on the Membership allocates once it is built, however many
//    votes arrive (counted with the sanitizer allocator's hooks; ASan builds only).
// The session's frame from which a dropped slot is neutral lives in Session, not here; session_fuzz
// and the lifecycle tests cover it.
//
// Speed: the record is a few fixed arrays, an input allocates only the Membership itself, and
// the record and the checks are left out of the coverage instrumentation. The whole-view check
// (O(players^2) calls) runs after every tick that drops someone and at the end; every other
// operation is checked on what it can change: the words it wrote, its slot's view, count,
// decision and advertised entry, and the local summaries (votes_any_gone, partitioned).
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <utility>
#include <vector>

#include "fuzz/membership_fuzz.h"
#include "rollback/membership.h"

#if defined(__has_feature)
#if __has_feature(address_sanitizer)
#include <sanitizer/allocator_interface.h>
#define MEMBERSHIP_FUZZ_COUNT_ALLOCATIONS 1
#endif
#endif

using namespace lockroll::rollback;
namespace fz = lockroll::fuzz;

namespace {

#define CHECK(cond)                                                                          \
    do {                                                                                     \
        if (!(cond)) fail(#cond, __LINE__);                                                  \
    } while (0)

[[noreturn]] void fail(const char* what, int line) {
    std::fprintf(stderr, "membership_fuzz: property broken at line %d: %s\n", line, what);
    std::abort();
}

// Allocations on this thread while `armed`: the operations on a built Membership must make none.
thread_local bool armed = false;
thread_local std::size_t allocations = 0;
#ifdef MEMBERSHIP_FUZZ_COUNT_ALLOCATIONS
void on_malloc(const volatile void*, std::size_t) {
    if (armed) ++allocations;
}
void on_free(const volatile void*) {}
#endif

constexpr int kMax = fz::kMaxFuzzPlayers;

// The record and the checks are not what is fuzzed: left out of the coverage instrumentation,
// whose trace-cmp hook on every comparison in them would otherwise cost most of an execution.
#define NOT_FUZZED __attribute__((no_sanitize("coverage")))

// The rules, as docs/sessions.md ("Drop") states them, over plain arrays.
struct Record {
    struct Word {
        Vote vote = Vote::None;
        std::uint8_t epoch = 0;
    };
    int n = 0;
    PlayerId local = 0;
    TwoPlayerRule rule = TwoPlayerRule::PlayOnAlone;
    // Plain arrays: std::array's operator[] is an uninlined, instrumented call at -O1.
    PlayerId host[kMax] = {};
    SlotState state[kMax] = {};
    std::uint8_t epoch[kMax] = {};
    bool joining[kMax] = {};     // handed over, its process not playing yet
    Word word[kMax][kMax] = {};  // [voter][slot]

    NOT_FUZZED bool in_range(PlayerId p) const { return p < static_cast<PlayerId>(n); }
    NOT_FUZZED bool running(PlayerId s) const { return in_range(s) && state[s] == SlotState::Running; }
    // A voter is a running process that plays: a running slot that hosts itself and is not a
    // joiner that has not started yet.
    NOT_FUZZED bool voter(PlayerId p) const { return running(p) && host[p] == p && !joining[p]; }
    NOT_FUZZED int voters() const {
        int k = 0;
        for (int p = 0; p < n; ++p) k += voter(static_cast<PlayerId>(p));
        return k;
    }
    // v's word about s as it counts: only a voter's, only about a running slot.
    NOT_FUZZED Vote counted(PlayerId v, PlayerId s) const {
        return voter(v) && running(s) ? word[v][s].vote : Vote::None;
    }
    NOT_FUZZED int gone(PlayerId s) const {
        int k = 0;
        for (int v = 0; v < n; ++v) k += counted(static_cast<PlayerId>(v), s) == Vote::Gone;
        return k;
    }
    // Who a decision about running slot s counts: the voters, and s itself if it is joining.
    NOT_FUZZED int electorate(PlayerId s) const { return voters() + (joining[s] ? 1 : 0); }
    // "A strict majority of the view's running players"; a view of two has none of the other's
    // and follows the rule.
    NOT_FUZZED bool strict_majority_of(int votes, int of) const {
        if (of == 2) return rule == TwoPlayerRule::PlayOnAlone && votes >= 1;
        return 2 * votes > of;
    }
    NOT_FUZZED bool strict_majority(int votes) const { return strict_majority_of(votes, voters()); }
    // A view of two: each side decides for itself -- only the local process's own vote, and
    // never about its own slot (the other's word about it is a claim: rollback/membership.h).
    NOT_FUZZED bool decided(PlayerId s) const {
        if (!running(s) || host[s] != s) return false;
        if (electorate(s) == 2)
            return rule == TwoPlayerRule::PlayOnAlone && s != local && counted(local, s) == Vote::Gone;
        return strict_majority_of(gone(s), electorate(s));
    }
    // The local process votes some slot gone whose drop the voters it hears (itself included)
    // cannot decide.
    NOT_FUZZED bool partitioned() const {
        if (!voter(local)) return false;
        int heard = 0;
        for (int v = 0; v < n; ++v)
            heard += voter(static_cast<PlayerId>(v)) && counted(local, static_cast<PlayerId>(v)) != Vote::Gone;
        for (int s = 0; s < n; ++s) {
            const auto p = static_cast<PlayerId>(s);
            if (counted(local, p) == Vote::Gone && !strict_majority_of(heard, electorate(p))) return true;
        }
        return false;
    }
    NOT_FUZZED void forget(PlayerId s) {
        for (std::size_t v = 0; v < static_cast<std::size_t>(n); ++v) {
            word[v][s] = Word{};
            word[s][v] = Word{};
        }
    }
    NOT_FUZZED void set(PlayerId s, SlotState st, std::uint8_t e) {
        state[s] = st;
        epoch[s] = e;
        joining[s] = false;
        forget(s);
    }
    // What a vote should come to. The reasons a vote is not taken are not exclusive (a voter that
    // left, about a slot that left); Membership may name any that applies.
    struct Expected {
        bool taken = false;
        unsigned reasons = 0;  // bit per Tally
    };
    NOT_FUZZED Expected expect(PlayerId v, PlayerId s, Vote what, std::uint8_t e) const {
        Expected x;
        auto because = [&](Tally t) { x.reasons |= 1u << static_cast<unsigned>(t); };
        if (!voter(v)) because(Tally::NotAVoter);
        if (!running(s)) because(Tally::NotRunning);
        if (in_range(s) && host[s] == v) because(Tally::AboutItself);
        if (in_range(s) && host[s] != s) because(Tally::AboutAGuest);
        if (in_range(s) && what == Vote::Gone && !newer_epoch(e, epoch[s])) because(Tally::Stale);
        if (in_range(s) && what == Vote::Runs && e != epoch[s]) because(Tally::Stale);
        x.taken = x.reasons == 0;
        return x;
    }
};

struct ViewCopy {
    SlotState state[kMax] = {};
    std::uint8_t epoch[kMax] = {};
};

NOT_FUZZED ViewCopy copy_view(const Membership& m) {
    ViewCopy c;
    for (int s = 0; s < m.players(); ++s) {
        c.state[static_cast<std::size_t>(s)] = m.state(static_cast<PlayerId>(s));
        c.epoch[static_cast<std::size_t>(s)] = m.epoch(static_cast<PlayerId>(s));
    }
    return c;
}

// Ids a datagram may claim: in range, just past it, or far past it.
PlayerId id(std::uint8_t x, int n) {
    return x >= 0xF0 ? 0xFFFFFFF0u + (x & 15u) : static_cast<PlayerId>(x % (n + 2));
}

// The local summaries (cheap: O(players) calls each).
NOT_FUZZED void check_summaries(const Membership& m, const Record& r) {
    CHECK(m.running_voters() == r.voters());
    // The fewest processes that are a majority (what the session's confirmation waits for).
    const int size = m.majority_size();
    CHECK(size >= 1 && r.strict_majority(size) == (r.voters() != 2 || r.rule == TwoPlayerRule::PlayOnAlone));
    CHECK(size == 1 || !r.strict_majority(size - 1));
    if (r.voters() == 2 && r.rule == TwoPlayerRule::NoDrop) CHECK(size == 2);  // both, as nobody drops
    int unheard = 0;
    for (int s = 0; s < r.n; ++s) unheard += r.counted(r.local, static_cast<PlayerId>(s)) == Vote::Gone;
    CHECK(m.votes_any_gone() == (unheard > 0));
    CHECK(m.partitioned() == r.partitioned());
}

// One slot: its view, the votes about it as they count, the decision, what the local process
// advertises about it.
NOT_FUZZED void check_slot(const Membership& m, const Record& r, PlayerId s) {
    CHECK(m.state(s) == r.state[s]);
    CHECK(m.epoch(s) == r.epoch[s]);
    CHECK(m.running(s) == r.running(s));
    CHECK(m.host_of(s) == r.host[s]);
    CHECK(m.joining(s) == r.joining[s]);
    CHECK(m.electorate(s) == r.electorate(s));
    const int gone = m.gone_votes(s);
    CHECK(gone == r.gone(s));
    const bool decided = m.decided_gone(s);
    CHECK(decided == r.decided(s));
    if (decided) {
        // Never one voter's word alone with three or more, whatever the record says.
        const int of = m.electorate(s);
        CHECK(of <= 2 || gone >= 2);
        CHECK(2 * gone > of || (of == 2 && m.rule() == TwoPlayerRule::PlayOnAlone && gone >= 1));
        if (of == 2) CHECK(s != r.local && r.counted(r.local, s) == Vote::Gone);  // its own word
    }
    const bool local_gone = r.counted(r.local, s) == Vote::Gone;
    CHECK(m.advertised_state(s) == (local_gone ? SlotState::Disconnected : r.state[s]));
    CHECK(m.advertised_epoch(s) == (local_gone ? r.word[r.local][s].epoch : r.epoch[s]));
}

NOT_FUZZED void check_all(const Membership& m, const Record& r) {
    CHECK(m.players() == r.n);
    CHECK(m.local() == r.local);
    CHECK(m.rule() == r.rule);
    check_summaries(m, r);
    PlayerId first = static_cast<PlayerId>(r.n);
    for (int s = r.n - 1; s >= 0; --s) {
        const auto slot = static_cast<PlayerId>(s);
        check_slot(m, r, slot);
        if (r.decided(slot)) first = slot;
        for (int v = 0; v < r.n; ++v) {
            const auto voter = static_cast<PlayerId>(v);
            CHECK(m.vote_of(voter, slot) == r.counted(voter, slot));
        }
        // Out-of-range voters have no word.
        CHECK(m.vote_of(static_cast<PlayerId>(r.n), slot) == Vote::None);
        CHECK(m.vote_of(0xFFFFFFFFu, slot) == Vote::None);
    }
    CHECK(m.next_gone() == first);
    CHECK(m.vote_of(0, static_cast<PlayerId>(r.n)) == Vote::None);
}

// Every vote cast by s and every vote about s, as it counts.
NOT_FUZZED void check_votes_by_and_about(const Membership& m, const Record& r, PlayerId s) {
    for (int v = 0; v < r.n; ++v) {
        const auto p = static_cast<PlayerId>(v);
        CHECK(m.vote_of(p, s) == r.counted(p, s));
        CHECK(m.vote_of(s, p) == r.counted(s, p));
    }
}

// Between two checks the view moves forward only: unchanged, or (by a tick) dropped into the next
// epoch, or (by a join) handed over in a newer epoch of `joined`.
NOT_FUZZED void check_moves(const Membership& m, const ViewCopy& before, bool tick, PlayerId joined) {
    for (int s = 0; s < m.players(); ++s) {
        const auto slot = static_cast<PlayerId>(s);
        const auto i = static_cast<std::size_t>(s);
        if (m.state(slot) == before.state[i] && m.epoch(slot) == before.epoch[i]) continue;
        if (slot == joined) {
            CHECK(newer_epoch(m.epoch(slot), before.epoch[i]));
            continue;
        }
        CHECK(tick);
        CHECK(before.state[i] == SlotState::Running);
        CHECK(m.state(slot) == SlotState::Disconnected);
        CHECK(m.epoch(slot) == static_cast<std::uint8_t>(before.epoch[i] + 1));
    }
}

// A vote through Membership, with its Tally checked against the record, which then takes it.
void vote(Membership& m, Record& r, PlayerId v, PlayerId s, Vote what, std::uint8_t e) {
    const Record::Expected x = r.expect(v, s, what, e);
    const Tally t = m.vote(v, s, what, e);
    if (!x.taken) {
        CHECK(x.reasons >> static_cast<unsigned>(t) & 1u);
        return;
    }
    const Record::Word next = what == Vote::None ? Record::Word{} : Record::Word{what, e};
    Record::Word& w = r.word[v][s];
    CHECK(t == (w.vote == next.vote && w.epoch == next.epoch ? Tally::Repeated : Tally::Counted));
    w = next;
}

void vote_local(Membership& m, Record& r, PlayerId s, bool gone) {
    if (!r.in_range(s)) {
        CHECK(m.vote_local(s, gone) == Tally::NotRunning);
        return;
    }
    const std::uint8_t e = r.epoch[s];
    const Vote what = gone ? Vote::Gone : Vote::Runs;
    const std::uint8_t at = gone ? static_cast<std::uint8_t>(e + 1) : e;
    const Record::Expected x = r.expect(r.local, s, what, at);
    const Tally t = m.vote_local(s, gone);
    if (!x.taken) {
        CHECK(x.reasons >> static_cast<unsigned>(t) & 1u);
        return;
    }
    Record::Word& w = r.word[r.local][s];
    CHECK(t == (w.vote == what && w.epoch == at ? Tally::Repeated : Tally::Counted));
    w = {what, at};
}

// The session's settle_membership: drop each slot the votes decide, its guests with it, until
// nothing more is decided. A decision about the local slot is the session's Kicked; here the slot
// leaves like any other, as it does in the view of every peer that heard the same votes.
// Returns whether anyone was dropped.
bool settle(Membership& m, Record& r) {
    int round = 0;
    for (;; ++round) {
        const PlayerId s = m.next_gone();
        if (s >= static_cast<PlayerId>(r.n)) break;
        CHECK(round < r.n);          // each round drops a running slot: it ends
        CHECK(r.decided(s));         // a strict majority of distinct voters said so
        for (PlayerId t = 0; t < s; ++t) CHECK(!r.decided(t));  // the first decided one
        const std::uint8_t e = r.epoch[s];
        m.leave(s);
        r.set(s, SlotState::Disconnected, static_cast<std::uint8_t>(e + 1));
        for (int g = static_cast<int>(s) + 1; g < r.n; ++g) {
            const auto guest = static_cast<PlayerId>(g);
            if (r.host[guest] != s || !r.running(guest)) continue;
            const std::uint8_t ge = r.epoch[guest];
            m.leave(guest);
            r.set(guest, SlotState::Disconnected, static_cast<std::uint8_t>(ge + 1));
        }
    }
    // No decision is left untaken.
    for (int s = 0; s < r.n; ++s) CHECK(!r.decided(static_cast<PlayerId>(s)));
    return round > 0;
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
#ifdef MEMBERSHIP_FUZZ_COUNT_ALLOCATIONS
    __sanitizer_install_malloc_and_free_hooks(on_malloc, on_free);
#endif
    return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    if (size < 4) return 0;
    Record r;
    r.n = 1 + data[0] % kMax;
    r.local = static_cast<PlayerId>((data[1] & 0x7f) % r.n);
    r.rule = data[1] & 0x80 ? TwoPlayerRule::NoDrop : TwoPlayerRule::PlayOnAlone;
    const unsigned mask = data[2] | data[3] << 8;
    std::vector<PlayerId> hosts;
    for (int s = 0; s < r.n; ++s) {
        const auto slot = static_cast<PlayerId>(s);
        const bool guest = mask != 0 && s > 0 && (mask >> s & 1u) && slot != r.local;
        r.host[slot] = guest ? r.host[slot - 1] : slot;  // the nearest self-hosted slot below
        r.state[slot] = SlotState::Running;
    }
    if (mask != 0) {
        hosts.assign(r.host, r.host + r.n);
        if (mask & 1u) {
            // A table of the wrong size: Membership must fall back to one process per slot.
            hosts.push_back(0);
            for (int s = 0; s < r.n; ++s) r.host[static_cast<std::size_t>(s)] = static_cast<PlayerId>(s);
        }
    }
    Membership m(r.n, r.local, r.rule, std::move(hosts));
    check_all(m, r);

    armed = true;
    allocations = 0;
    const std::size_t ops = std::min<std::size_t>((size - 4) / 4, fz::kMaxOps);
    for (std::size_t i = 0; i < ops; ++i) {
        const std::uint8_t* op = data + 4 + 4 * i;
        const int kind = op[0] % fz::kOpCount;
        const auto what = static_cast<Vote>(op[0] / fz::kOpCount % 3);
        const std::uint8_t a = op[1], b = op[2], c = op[3];
        const ViewCopy before = copy_view(m);
        bool tick = false;
        PlayerId joined = static_cast<PlayerId>(r.n);
        switch (kind) {
            case fz::kVote:
            case fz::kVoteRaw: {
                const PlayerId v = id(a, r.n), s = id(b, r.n);
                const std::uint8_t slot_epoch = r.in_range(s) ? r.epoch[s] : 0;
                const auto e = kind == fz::kVoteRaw ? c : static_cast<std::uint8_t>(slot_epoch + c - 128);
                vote(m, r, v, s, what, e);
                if (r.in_range(s)) check_slot(m, r, s);
                if (r.in_range(v) && r.in_range(s)) CHECK(m.vote_of(v, s) == r.counted(v, s));
                break;
            }
            case fz::kVoteLocal: {
                const PlayerId s = id(b, r.n);
                vote_local(m, r, s, a & 1);
                if (r.in_range(s)) check_slot(m, r, s);
                break;
            }
            case fz::kSettle:
                // A tick that drops nobody changes nothing, and what it read (next_gone) is
                // checked in settle(); after a drop the whole view is checked.
                if (settle(m, r)) check_all(m, r);
                tick = true;
                break;
            case fz::kSet: {
                const auto s = static_cast<PlayerId>(b % r.n);
                const auto st = static_cast<SlotState>(a % 3);
                const auto e = static_cast<std::uint8_t>(r.epoch[s] + 1 + c % 127);
                if (a & 0x80) {
                    m.hand_over(s, e);
                    r.set(s, SlotState::Running, e);
                    r.joining[s] = true;
                    joined = s;
                } else if (a & 0x40) {
                    m.started(s);  // no change of the view
                    r.joining[s] = false;
                } else {
                    m.set(s, st, e);
                    r.set(s, st, e);
                    joined = s;
                }
                check_slot(m, r, s);
                check_votes_by_and_about(m, r, s);
                break;
            }
            case fz::kChorus: {
                const PlayerId s = id(b, r.n);
                const std::uint8_t slot_epoch = r.in_range(s) ? r.epoch[s] : 0;
                const auto e = what == Vote::Gone ? static_cast<std::uint8_t>(slot_epoch + 1) : slot_epoch;
                const unsigned voters = a | c << 8;
                for (int v = 0; v < r.n; ++v)
                    if (voters >> v & 1u) vote(m, r, static_cast<PlayerId>(v), s, what, e);
                if (r.in_range(s)) {
                    check_slot(m, r, s);
                    check_votes_by_and_about(m, r, s);
                }
                break;
            }
            default: {  // kLocalAll
                const unsigned slots = b | c << 8;
                for (int s = 0; s < r.n; ++s) {
                    if (!(slots >> s & 1u)) continue;
                    vote_local(m, r, static_cast<PlayerId>(s), a & 1);
                    check_slot(m, r, static_cast<PlayerId>(s));
                }
                break;
            }
        }
        check_summaries(m, r);
        check_moves(m, before, tick, joined);
    }
    check_all(m, r);
    armed = false;
#ifdef MEMBERSHIP_FUZZ_COUNT_ALLOCATIONS
    CHECK(allocations == 0);
#endif
    return 0;
}
