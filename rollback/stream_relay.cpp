#include "rollback/stream_relay.h"

#include <algorithm>

#include "rollback/input_authority.h"

namespace lockroll::rollback {

namespace {
// The slot table's schedule once every slot simply runs (issue 21: it had ridden every 8th
// message, 22 bytes at 4 players, though it never changed). A change of what we tell a peer
// goes in kTableCopies copies spread over ~1 s (PeerLink::table_due): a vote then survives 30 %
// loss or a short burst. Once it changed, a refresh every kTableRefreshUs (at most half the
// disconnect timeout) repairs a change all of whose copies were lost: the one that matters is
// a withdrawn "gone" vote (a healed partition), which is then back at every peer before another
// voter's silence timer, started when the change was made, could complete a majority with the
// stale one. A table that never changed needs no refresh: it says "runs" in the view's epoch
// about every slot, which counts for no more than saying nothing (only "gone" votes drop), and
// the peer's relays ask for themselves (lags_on_a_stream). Two players need no refresh either:
// there one vote is a majority or nothing (TwoPlayerRule).
constexpr std::uint64_t kTableRefreshUs = 2'000'000;
}  // namespace

StreamRelay::StreamRelay(const StreamView& v) : v_(v) {
    for (int s = 0; s < v_.config.players; ++s) {
        const auto slot = static_cast<PlayerId>(s);
        any_guest_ = any_guest_ || host_of(slot) != slot;
        any_slot_not_running_ = any_slot_not_running_ || !v_.membership.running(slot);
    }
}

bool StreamRelay::extension_needed(PlayerId to, const std::vector<std::uint16_t>& entries, std::uint64_t now_us,
                               bool lagging) const {
    if (v_.config.role != Role::Player || v_.joining || !is_slot(to)) return true;
    // Guest streams travel as blocks, and their hosts learn from the tables what we lack.
    if (any_guest_) return true;
    if (any_slot_not_running_) return true;
    if (v_.membership.votes_any_gone()) return true;  // our votes must reach the voters
    for (const SlotView& v : v_.slots)
        if (v.handed_off_by_me) return true;
    // Every slot simply runs: the table when what we tell this peer changed, and the refresh.
    const PeerLink& link = v_.links[to];
    if (link.table_due(entries, now_us, table_refresh_us())) return true;
    // Three or more players: a peer stuck on a gap gets relays. Our counts go now and then while
    // we lag on some stream (they ask for relays), and the relays to a peer whose counts say it
    // lags.
    if (v_.config.players < 3 || link.messages_sent % static_cast<std::uint64_t>(v_.config.time_sync_every) != 0) return false;
    return lagging || relay_wanted(to, now_us);
}

std::uint64_t StreamRelay::table_refresh_us() const {
    if (v_.config.players < 3) return 0;
    return v_.config.disconnect_us == 0 ? kTableRefreshUs : std::min(kTableRefreshUs, v_.config.disconnect_us / 2);
}

// What our table says about slot s to peer `to`: to a player our vote where we cast one ("gone"
// in the next epoch), else the view; a spectator, which follows our view, gets the view.
SlotEntry StreamRelay::table_entry(PlayerId to, PlayerId s) const {
    const bool vote = is_slot(to);
    const bool voted = vote && v_.membership.running(s) && v_.membership.vote_of(v_.config.local_player, s) == Vote::Gone;
    return {static_cast<std::uint8_t>(s), vote ? v_.membership.advertised_state(s) : v_.membership.state(s),
            vote ? v_.membership.advertised_epoch(s) : v_.membership.epoch(s),
            static_cast<std::uint16_t>(vote && host_of(s) == to ? owner_count(s) : count_of(s)), voted};
}

// Our agreement report goes to a player while a ballot is in play here (every change of it is a
// change of the table, so it goes at once and in copies); with nothing in play it says nothing.
bool StreamRelay::agreement_rides(PlayerId to) const {
    return v_.agreement != nullptr && is_slot(to) && v_.config.role != Role::Spectator && v_.agreement->active();
}

void StreamRelay::table_entries_for(PlayerId to, std::vector<std::uint16_t>& out) const {
    out.clear();
    for (int s = 0; s < v_.config.players; ++s) {
        const SlotEntry e = table_entry(to, static_cast<PlayerId>(s));
        out.push_back(static_cast<std::uint16_t>(static_cast<unsigned>(e.state) << 8 | e.epoch));
    }
    if (v_.agreement != nullptr && v_.agreement->active() && is_slot(to)) {
        const AgreementReport& a = v_.agreement->report();
        out.insert(out.end(), {static_cast<std::uint16_t>(a.instance), static_cast<std::uint16_t>(a.instance >> 16), a.promised,
                               a.accepted, a.accepted_slot, a.proposal, a.proposal_slot});
    }
}

// We lag on a running stream by about as much as lets us predict no further (or half the relay
// lag, if less): our counts should reach the peers, which relay what they hold.
bool StreamRelay::lags_on_a_stream() const {
    if (v_.config.role != Role::Player || v_.config.players < 3) return false;
    const std::uint32_t mine = count_of(v_.config.local_player);
    const auto lag = static_cast<std::uint32_t>(
        std::max(1, std::min(v_.config.relay_lag / 2, v_.config.prediction_window + v_.input_delay)));
    for (int s = 0; s < v_.config.players; ++s) {
        const auto slot = static_cast<PlayerId>(s);
        if (slot == v_.config.local_player || my_guest(slot) || !v_.membership.running(slot)) continue;
        if (count_of(slot) + lag <= mine) return true;
    }
    return false;
}

// Its counts are recent: it sent a table within a time-sync period (and a tick), as often as a
// peer that lags sends one. Counts are read bare, as they always were: a peer stuck on a gap
// shows a lag of the frames since its table on top of its own, which is what lets relays start
// before relay_lag is reached for real -- everyone stalls on the stuck peer's inputs first. But
// counts of seconds ago (the refresh, a lag that ended) would show a lag of seconds.
bool StreamRelay::counts_fresh(const PeerLink& link, std::uint64_t now_us) const {
    const std::uint64_t window = (static_cast<std::uint64_t>(v_.config.time_sync_every) + 1) * 1'000'000 /
                                 static_cast<std::uint64_t>(v_.config.tick_rate);
    return now_us <= link.counts_at_us + window;
}

// A running stream on which `to`'s recent counts say it lags by more than relay_lag (what
// fill_extension relays to a player when every slot simply runs).
bool StreamRelay::relay_wanted(PlayerId to, std::uint64_t now_us) const {
    const PeerLink& link = v_.links[to];
    if (!counts_fresh(link, now_us)) return false;
    for (int s = 0; s < v_.config.players; ++s) {
        const auto slot = static_cast<PlayerId>(s);
        if (slot == v_.config.local_player || slot == to || !link.has_count[slot]) continue;
        if (count_of(slot) > link.counts[slot] + static_cast<std::uint32_t>(v_.config.relay_lag)) return true;
    }
    return false;
}

// The slot table with our counts, and blocks of streams the receiver lacks and will not get
// from anyone else soon: non-running slots (the owner's neutral inputs, or a dropped player's
// last inputs some peers missed), a joiner's stream up to its handoff, everything for a
// spectator, and any stream on which it lags by more than relay_lag.
void StreamRelay::fill_extension(PlayerId to, InputMessage& m, std::size_t budget, std::uint64_t now_us) const {
    m.has_extension = true;
    m.slots.clear();
    m.blocks.clear();
    for (int s = 0; s < v_.config.players; ++s) m.slots.push_back(table_entry(to, static_cast<PlayerId>(s)));
    m.has_agreement = agreement_rides(to);
    if (m.has_agreement) m.agreement = v_.agreement->report();
    const std::size_t table_bytes = 2 + m.slots.size() * 5 + (m.has_agreement ? kAgreementBytes : 0);
    if (budget <= table_bytes) return;
    budget -= table_bytes;
    if (v_.config.role == Role::Spectator) return;  // spectators relay nothing
    const PeerLink& link = v_.links[to];
    const std::size_t n = v_.config.input_size;
    const std::uint8_t max_frames = max_frames_per_message(n);
    for (int s = 0; s < v_.config.players && m.blocks.size() < static_cast<std::size_t>(kMaxStreamBlocks); ++s) {
        const auto slot = static_cast<PlayerId>(s);
        if (slot == v_.config.local_player || (is_slot(to) && slot == to) || !link.has_count[slot]) continue;
        const InputQueue& q = v_.queues[slot];
        const std::uint32_t theirs = link.counts[slot];
        std::uint32_t mine = q.confirmed_count();
        // Only what the owner's own stream delivered is relayed onward, never another's claim.
        if (const auto f = v_.authority.first_unverified_of(slot, theirs)) mine = std::min(mine, *f);
        if (mine <= theirs) continue;
        const SlotView& v = v_.slots[slot];
        // A lag only by counts it sent lately (counts_fresh): by a table of seconds ago (the
        // refresh) every stream would look far behind.
        const bool relay = !is_slot(to) || !v_.membership.running(slot) || my_guest(slot) ||
                           (v.handed_off_by_me && theirs < v.handoff) ||
                           (mine > theirs + static_cast<std::uint32_t>(v_.config.relay_lag) && counts_fresh(link, now_us));
        if (!relay) continue;
        const std::uint32_t from = std::max(theirs, q.floor());
        if (from >= mine) continue;
        StreamBlock b;
        b.slot = static_cast<std::uint8_t>(slot);
        b.absent = q.confirmed_absent(from);
        b.first_frame = static_cast<std::uint16_t>(from);
        std::uint32_t count = 0;
        while (from + count < mine && count < max_frames && q.confirmed_absent(from + count) == b.absent) ++count;
        // Shrink until it fits what is left of the datagram.
        for (;;) {
            b.frame_count = static_cast<std::uint8_t>(count);
            b.inputs.resize(std::size_t{count} * n);
            for (std::uint32_t k = 0; k < count; ++k) {
                const auto in = q.confirmed(from + k);
                std::copy(in.begin(), in.end(), b.inputs.begin() + static_cast<std::ptrdiff_t>(std::size_t{k} * n));
            }
            const std::size_t bytes = encoded_block_bytes(b, n);
            if (bytes <= budget) {
                budget -= bytes;
                m.blocks.push_back(std::move(b));
                break;
            }
            if (count <= 1) return;
            count /= 2;
        }
    }
}

// What we tell slot s's owner we hold of its stream (ack and table count): up to the first
// input a relay filled in that the owner has not verified yet, so it resends from there and its
// own copy settles the relay's -- confirmed or not, up to a quarter of the input ring behind
// confirmation: a relayed input confirmed past the bound (trust, then verify) is still checked,
// and a lie exposed, when the cut heals. Older ones are left to the checksums: the owner keeps
// its inputs from our ack on, and its queue must not fill on a long cut.
std::uint32_t StreamRelay::owner_count(PlayerId s) const {
    const std::uint32_t count = count_of(s);
    const std::uint32_t reach = v_.config.input_capacity / 4;
    const auto f = v_.authority.first_unverified_of(s, v_.confirmed_frame > reach ? v_.confirmed_frame - reach : 0);
    return f ? std::min(count, *f) : count;
}

}  // namespace lockroll::rollback
