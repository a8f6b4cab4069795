// SnapshotFetch (rollback/snapshot_fetch.h) on its own, against a TransferSender playing the
// provider (no session, no network): one offer at a time, chunks only from its sender, the
// majority's vetting before a join loads (never a minority's word, the two-player rule),
// rejections that ask again, the silent provider, the provider that stalls mid-transfer and the
// slow one on a lossy link that must not be taken for it.
#include "rollback/snapshot_fetch.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <string>
#include <vector>

#include "tests/rollback/peer_links.h"

namespace lockroll::rollback {
namespace {

constexpr std::size_t kStateSize = 2000;  // two chunks

std::uint64_t sum(std::span<const std::uint8_t> s) {
    std::uint64_t v = 0;
    for (std::uint8_t b : s) v = v * 31 + b;
    return v;
}

// A joiner in the last slot (2 of three unless told); the others run and welcomed it; slot 0
// provides.
struct Fixture {
    SessionConfig config;
    std::vector<PeerLink> links;
    TransferSender sender{60'000'000};
    TransferContents contents;
    std::vector<Datagram> out;
    SnapshotOfferMessage* offer = nullptr;  // the one transfer's, as the provider sends it

    explicit Fixture(TransferReason reason = TransferReason::Join, Role role = Role::Joiner, int players = 3)
        : links(testing::fresh_links(players)) {
        config.players = players;
        config.local_player = static_cast<PlayerId>(players - 1);
        config.role = role;
        config.input_size = 1;
        config.input_capacity = 64;
        for (int s = 0; s + 1 < players; ++s) links[static_cast<std::size_t>(s)].welcomed = true;
        contents.frame = 10;
        contents.state.assign(kStateSize, 7);
        contents.streams.resize(static_cast<std::size_t>(players));
        offer = &sender.offer(0, reason, contents, 1, 0).offer;
        for (std::uint8_t s = 0; s < players; ++s)
            offer->slots.push_back({s, SlotState::Running, static_cast<std::uint8_t>(s == players - 1 ? 1 : 0), 0});
    }
    const TransferSender::Transfer& transfer() const { return sender.transfers().front(); }
    void deliver(SnapshotFetch& f, bool damage_last = false) {
        const auto& t = transfer();
        ASSERT_EQ(f.take_offer(0, t.offer, 1000), SnapshotFetch::OfferTaken::Started);
        for (std::uint32_t i = 0;; ++i) {
            SnapshotChunkMessage c;
            if (!TransferSender::chunk(t, i, c)) break;
            if (damage_last && i == 1) c.bytes.back() ^= 1;
            EXPECT_TRUE(f.take_chunk(0, c));
        }
        ASSERT_TRUE(f.complete());
    }
    SnapshotFetch::Verdict finish(SnapshotFetch& f, std::uint64_t now, SnapshotFetch::Result& r) {
        return f.finish(now, links, sum, r);
    }
    // The whole join transfer delivered, and finished at 2000 before any voter answered: pending.
    void deliver_unvetted(SnapshotFetch& f, SnapshotFetch::Result& r) {
        deliver(f);
        EXPECT_EQ(finish(f, 2000, r), SnapshotFetch::Verdict::Pending);
    }
    static ReplyMessage reply(std::uint64_t value) {
        ReplyMessage r;
        r.what = QueryWhat::FrameChecksums;
        r.available = true;
        r.frame = 10;
        r.count = 1;
        r.values = {value};
        return r;
    }
};

TEST(SnapshotFetch, TakesOneOfferAtATimeWithinTheLimits) {
    Fixture x;
    SnapshotFetch f(x.config, kStateSize);
    SnapshotOfferMessage bad = x.transfer().offer;
    bad.slots.pop_back();
    EXPECT_EQ(f.take_offer(0, bad, 0), SnapshotFetch::OfferTaken::BadSlotTable);
    x.config.max_snapshot_bytes = x.transfer().offer.size - 1;
    EXPECT_EQ(f.take_offer(0, x.transfer().offer, 0), SnapshotFetch::OfferTaken::TooLarge);
    x.config.max_snapshot_bytes = x.transfer().offer.size;
    EXPECT_EQ(f.take_offer(0, x.transfer().offer, 0), SnapshotFetch::OfferTaken::Started);
    EXPECT_EQ(f.take_offer(1, x.transfer().offer, 0), SnapshotFetch::OfferTaken::Busy);
    SnapshotChunkMessage c;
    ASSERT_TRUE(TransferSender::chunk(x.transfer(), 0, c));
    EXPECT_FALSE(f.take_chunk(1, c)) << "a chunk from someone but the offer's sender";
    EXPECT_TRUE(f.take_chunk(0, c));
}

TEST(SnapshotFetch, AsksForOffersAtMostEveryTwoResendPeriods) {
    Fixture x;
    SnapshotFetch f(x.config, kStateSize);
    EXPECT_TRUE(f.may_ask(0));
    const std::vector<PlayerId> peers{0, 1};
    f.ask(peers, TransferReason::Join, 1000, x.out);
    ASSERT_EQ(x.out.size(), 2u);
    EXPECT_TRUE(x.out[0].reliable);
    EXPECT_FALSE(f.may_ask(1000 + 2 * x.config.transfer_resend_us - 1));
    EXPECT_TRUE(f.may_ask(1000 + 2 * x.config.transfer_resend_us));
    f.ask_again();
    EXPECT_TRUE(f.may_ask(1001));
}

TEST(SnapshotFetch, JoinLoadsOnlyOnceTheMajorityConfirmsItsChecksum) {
    Fixture x;
    SnapshotFetch f(x.config, kStateSize);
    SnapshotFetch::Result r;
    x.deliver_unvetted(f, r);
    EXPECT_EQ(f.poll(2000, x.out), SnapshotFetch::Poll::Nothing);
    ASSERT_EQ(x.out.size(), 2u) << "one checksum query to each voter";
    f.take_reply(0, Fixture::reply(sum(x.contents.state)));
    EXPECT_EQ(f.poll(3000, x.out), SnapshotFetch::Poll::Nothing) << "one of two voters is no majority";
    f.take_reply(1, Fixture::reply(sum(x.contents.state)));
    EXPECT_EQ(f.poll(4000, x.out), SnapshotFetch::Poll::Decided);
    ASSERT_EQ(x.finish(f, 4000, r), SnapshotFetch::Verdict::Ready);
    EXPECT_EQ(r.contents.frame, 10u);
    EXPECT_EQ(r.contents.state, x.contents.state);
    EXPECT_EQ(r.from, 0);
    EXPECT_EQ(f.incoming(), nullptr);
}

// The vetting's deadline: min(2 s, disconnect_us / 3) after the transfer completed (at 2000).
std::uint64_t vetting_deadline(const SessionConfig& c) {
    return 2000 + (c.disconnect_us == 0 ? 2'000'000 : std::min<std::uint64_t>(2'000'000, c.disconnect_us / 3));
}

// The transfer delivered, only the provider (slot 0) answers, and the vetting's deadline comes:
// the verdict.
SnapshotFetch::Verdict provider_alone_until(Fixture& x, SnapshotFetch& f, std::uint64_t deadline,
                                            SnapshotFetch::Result& r) {
    x.deliver_unvetted(f, r);
    f.take_reply(0, Fixture::reply(sum(x.contents.state)));
    EXPECT_EQ(f.poll(deadline - 1, x.out), SnapshotFetch::Poll::Nothing);
    EXPECT_EQ(f.poll(deadline, x.out), SnapshotFetch::Poll::Decided);
    return x.finish(f, deadline, r);
}

// Before, the provider's own answer with slot 1 silent was loaded at the deadline.
TEST(SnapshotFetch, TheProvidersWordAloneIsRejectedAtTheDeadlineAndAskedAgain) {
    Fixture x;
    SnapshotFetch f(x.config, kStateSize);
    SnapshotFetch::Result r;
    const std::uint64_t deadline = vetting_deadline(x.config);
    EXPECT_EQ(provider_alone_until(x, f, deadline, r), SnapshotFetch::Verdict::Rejected);
    EXPECT_NE(r.why.find("snapshot rejected"), std::string::npos) << r.why;
    EXPECT_NE(r.why.find("cut off from a majority of the view: no answer in time from peer 1"), std::string::npos)
        << r.why;
    EXPECT_TRUE(f.may_ask(deadline)) << "a rejection asks again at once";
    EXPECT_FALSE(f.vetting());
}

// A spectator (SessionBuilder: it knows only its host's address) takes its host's uncontested
// word at the deadline.
TEST(SnapshotFetch, ASpectatorLoadsOnItsHostsUncontestedWordAtTheDeadline) {
    Fixture x(TransferReason::Spectate, Role::Spectator);
    x.config.local_player = 3;  // a spectator id: no slot
    x.config.max_spectators = 1;
    SnapshotFetch f(x.config, kStateSize);
    SnapshotFetch::Result r;
    ASSERT_EQ(provider_alone_until(x, f, vetting_deadline(x.config), r), SnapshotFetch::Verdict::Ready);
    EXPECT_NE(r.why.find("a spectator: accepted uncontested"), std::string::npos) << r.why;
}

// The offer's table is the provider's word: one that says slot 1 left cannot shrink the view
// to itself and the joiner (a view of two, where its word alone would decide) while slot 1 has
// welcomed the joiner.
TEST(SnapshotFetch, AnOfferThatHidesAWelcomedPeerDoesNotShrinkTheView) {
    Fixture x;
    x.offer->slots[1].state = SlotState::Disconnected;
    SnapshotFetch f(x.config, kStateSize);
    SnapshotFetch::Result r;
    x.deliver_unvetted(f, r);
    f.take_reply(0, Fixture::reply(sum(x.contents.state)));
    EXPECT_EQ(f.poll(3000, x.out), SnapshotFetch::Poll::Nothing) << "slot 1's answer is still needed";
    f.take_reply(1, Fixture::reply(sum(x.contents.state)));
    EXPECT_EQ(f.poll(4000, x.out), SnapshotFetch::Poll::Decided);
    EXPECT_EQ(x.finish(f, 4000, r), SnapshotFetch::Verdict::Ready);
}

// Issue 21: slot 1 welcomed the joiner, then was killed and dropped before the joiner loaded.
// Counted whatever the table said, it kept the joiner from a majority of a view that had dropped
// it, for good. A welcomed peer the table says left, and that the joiner itself has not heard for
// disconnect_us (the silence a player votes on), is not counted; one heard within it still is.
TEST(SnapshotFetch, AWelcomedPeerTheTableDropsAndWeHaveNotHeardForTheTimeoutIsNotCounted) {
    for (const bool silent : {true, false}) {
        Fixture x;
        x.config.disconnect_us = 1'000'000;
        x.offer->slots[1].state = SlotState::Disconnected;
        x.offer->slots[1].epoch = 1;
        x.links[1].heard = true;
        x.links[1].last_heard_us = silent ? 400'000 : 900'000;
        SnapshotFetch f(x.config, kStateSize);
        SnapshotFetch::Result r;
        x.deliver(f);
        const std::uint64_t now = 1'400'000;
        ASSERT_EQ(x.finish(f, now, r), SnapshotFetch::Verdict::Pending);
        f.take_reply(0, Fixture::reply(sum(x.contents.state)));
        if (!silent) {
            EXPECT_EQ(f.poll(now + 1, x.out), SnapshotFetch::Poll::Nothing) << "heard 0.5 s ago: slot 1 still counts";
            continue;
        }
        ASSERT_EQ(f.poll(now + 1, x.out), SnapshotFetch::Poll::Decided);
        ASSERT_EQ(x.finish(f, now + 1, r), SnapshotFetch::Verdict::Ready) << r.why;
        EXPECT_NE(r.why.find("the two-player rule play_on_alone lets the provider's word decide"), std::string::npos)
            << r.why;
    }
}

// Two players: the joiner's slot and the provider are the view; the two-player rule decides.
TEST(SnapshotFetch, AViewOfTwoLoadsOnTheProvidersWordUnderPlayOnAloneAndSaysSo) {
    Fixture x(TransferReason::Join, Role::Joiner, 2);
    SnapshotFetch f(x.config, kStateSize);
    SnapshotFetch::Result r;
    x.deliver_unvetted(f, r);
    f.take_reply(0, Fixture::reply(sum(x.contents.state)));
    EXPECT_EQ(f.poll(3000, x.out), SnapshotFetch::Poll::Decided);
    ASSERT_EQ(x.finish(f, 3000, r), SnapshotFetch::Verdict::Ready);
    EXPECT_NE(r.why.find("the two-player rule play_on_alone lets the provider's word decide"), std::string::npos)
        << r.why;
}

TEST(SnapshotFetch, MajorityAgainstRejectsAndAsksThatProviderLast) {
    Fixture x;
    SnapshotFetch f(x.config, kStateSize);
    SnapshotFetch::Result r;
    x.deliver_unvetted(f, r);
    f.take_reply(0, Fixture::reply(1));
    f.take_reply(1, Fixture::reply(2));
    EXPECT_EQ(f.poll(3000, x.out), SnapshotFetch::Poll::Decided);
    EXPECT_EQ(x.finish(f, 3000, r), SnapshotFetch::Verdict::Rejected);
    EXPECT_NE(r.why.find("snapshot rejected"), std::string::npos) << r.why;
    EXPECT_EQ(f.rejected_provider(), PlayerId{0});
    EXPECT_TRUE(f.may_ask(3000)) << "a rejection asks again at once";
    // A spectator asks one host: not the one whose snapshot was rejected.
    for (auto& l : x.links) {
        l.has_remote_frame = true;
        l.roundtrips = x.config.sync_roundtrips;
    }
    x.config.role = Role::Spectator;
    std::vector<PlayerId> ask;
    f.newcomer_providers(x.links, 1, 1 + 3 * x.config.hello_resend_us, ask);
    EXPECT_EQ(ask, std::vector<PlayerId>{1});
}

TEST(SnapshotFetch, CorruptedTransferIsRejectedWithoutVetting) {
    Fixture x;
    SnapshotFetch f(x.config, kStateSize);
    x.deliver(f, true);
    SnapshotFetch::Result r;
    EXPECT_EQ(x.finish(f, 2000, r), SnapshotFetch::Verdict::Rejected);
    EXPECT_NE(r.why.find("hash mismatch"), std::string::npos) << r.why;
    EXPECT_FALSE(f.vetting());
    EXPECT_TRUE(f.may_ask(2000));
}

TEST(SnapshotFetch, RecoveryLoadsWithoutVetting) {
    Fixture x(TransferReason::Recover, Role::Player);
    SnapshotFetch f(x.config, kStateSize);
    x.deliver(f);
    SnapshotFetch::Result r;
    EXPECT_EQ(x.finish(f, 2000, r), SnapshotFetch::Verdict::Ready);
    EXPECT_TRUE(r.why.empty());
}

TEST(SnapshotFetch, RequestsMissingChunksAndDropsASilentProvider) {
    Fixture x;
    SnapshotFetch f(x.config, kStateSize);
    ASSERT_EQ(f.take_offer(0, x.transfer().offer, 1000), SnapshotFetch::OfferTaken::Started);
    EXPECT_EQ(f.poll(1000, x.out), SnapshotFetch::Poll::Nothing);
    ASSERT_EQ(x.out.size(), 2u) << "both chunks asked for";
    EXPECT_EQ(x.out[0].peer, 0);
    EXPECT_TRUE(x.out[0].reliable);
    // No chunk at all since the offer: dropped once that lasted kStallResends resend periods.
    const std::uint64_t stall = SnapshotFetch::kStallResends * x.config.transfer_resend_us;
    EXPECT_EQ(f.poll(1000 + stall, x.out), SnapshotFetch::Poll::Nothing);
    EXPECT_EQ(f.poll(1001 + stall, x.out), SnapshotFetch::Poll::TimedOut);
    EXPECT_NE(f.why().find("transfer stalled: no new chunk for 2000 ms (0 of 2 chunks from peer 0)"), std::string::npos)
        << f.why();
    f.restart();
    EXPECT_TRUE(f.may_ask(1001 + stall));
    EXPECT_EQ(f.rejected_provider(), PlayerId{0}) << "the silent provider is asked last";
}

// A transfer of `chunks` chunks of state, offered by slot 0 with x's slot table.
TransferSender::Transfer& big_transfer(Fixture& x, TransferSender& sender, std::size_t chunks, TransferReason reason) {
    TransferContents big = x.contents;
    big.state.resize(chunks * kSnapshotChunkBytes);
    for (std::size_t i = 0; i < big.state.size(); ++i) big.state[i] = static_cast<std::uint8_t>(i * 7);
    TransferSender::Transfer& t = sender.offer(0, reason, big, 1, 0);
    t.offer.slots = x.offer->slots;
    return t;
}

// A provider that sends one chunk now and then, never quite stalling, is still dropped
// kTimeoutUs after its offer.
TEST(SnapshotFetch, AProviderThatTricklesChunksIsDroppedAtTheOverallBound) {
    Fixture x;
    TransferSender sender(60'000'000);
    const TransferSender::Transfer& t = big_transfer(x, sender, 100, TransferReason::Join);
    SnapshotFetch f(x.config, t.offer.size);
    ASSERT_EQ(f.take_offer(0, t.offer, 0), SnapshotFetch::OfferTaken::Started);
    const std::uint64_t every = SnapshotFetch::kStallResends * x.config.transfer_resend_us - 1;
    std::uint32_t next = 0;
    std::uint64_t now = 0;
    SnapshotFetch::Poll p = SnapshotFetch::Poll::Nothing;
    for (; p == SnapshotFetch::Poll::Nothing && now < 2 * SnapshotFetch::kTimeoutUs; now += every) {
        SnapshotChunkMessage c;
        ASSERT_TRUE(TransferSender::chunk(t, next++, c));
        ASSERT_TRUE(f.take_chunk(0, c));
        p = f.poll(now, x.out);
    }
    EXPECT_EQ(p, SnapshotFetch::Poll::TimedOut);
    EXPECT_GT(now, SnapshotFetch::kTimeoutUs);
    EXPECT_LE(now, SnapshotFetch::kTimeoutUs + 2 * every);
    EXPECT_NE(f.why().find("transfer timed out"), std::string::npos) << f.why();
    EXPECT_FALSE(f.complete());
}

// Issue 21: a provider that dies (or is cut off) in the middle of a transfer. Before, the
// newcomer waited kTimeoutUs (20 s) from the offer before it asked anyone else; now a transfer
// that brought no new chunk for kStallResends resend periods is dropped (TimedOut, its provider
// asked last) -- a few resend periods, well under kTimeoutUs.
TEST(SnapshotFetch, ATransferWhoseProviderStopsMidwayIsDroppedWithinAFewResendPeriods) {
    Fixture x(TransferReason::Spectate, Role::Spectator, 4);
    x.config.local_player = 4;  // a spectator id: no slot
    x.config.max_spectators = 1;
    x.links = testing::fresh_links(5, 4);
    for (int s = 0; s < 4; ++s) {
        auto& l = x.links[static_cast<std::size_t>(s)];
        l.welcomed = true;
        l.has_remote_frame = true;
        l.roundtrips = x.config.sync_roundtrips;
    }
    SnapshotFetch f(x.config, kStateSize);
    ASSERT_EQ(f.take_offer(0, x.transfer().offer, 1000), SnapshotFetch::OfferTaken::Started);
    EXPECT_EQ(f.poll(1000, x.out), SnapshotFetch::Poll::Nothing);
    SnapshotChunkMessage c;
    ASSERT_TRUE(TransferSender::chunk(x.transfer(), 0, c));
    const std::uint64_t last_chunk = 60'000;  // the first chunk came; the provider died after it
    ASSERT_TRUE(f.take_chunk(0, c));
    const std::uint64_t resend = x.config.transfer_resend_us;
    std::uint64_t now = last_chunk;
    SnapshotFetch::Poll p = SnapshotFetch::Poll::Nothing;
    for (; now < last_chunk + SnapshotFetch::kTimeoutUs && p == SnapshotFetch::Poll::Nothing; now += 10'000)
        p = f.poll(now, x.out);
    ASSERT_EQ(p, SnapshotFetch::Poll::TimedOut) << "never dropped before kTimeoutUs";
    EXPECT_LE(now, last_chunk + 2 * SnapshotFetch::kStallResends * resend) << "dropped only after " << now << " us";
    EXPECT_GE(now, last_chunk + 4 * resend) << "a few resend periods of silence, not one lost round trip";
    EXPECT_NE(f.why().find("no new chunk"), std::string::npos) << f.why();
    f.restart();
    EXPECT_TRUE(f.may_ask(now)) << "asked again at once";
    EXPECT_EQ(f.rejected_provider(), PlayerId{0});
    std::vector<PlayerId> ask;
    f.newcomer_providers(x.links, 1, now, ask);
    EXPECT_EQ(ask, std::vector<PlayerId>{1}) << "the next host, not the one that went silent";
}

// The other side of the stall rule: a live provider behind a lossy link (20 % of datagrams lost
// each way, so a chunk request is answered only 64 % of the time, 60 ms round trip) keeps
// bringing chunks, however slowly towards the end, and is never dropped: a 200-chunk transfer
// completes in one go (one offer, no TimedOut) for every seed.
TEST(SnapshotFetch, ASlowProviderOnALossyLinkIsNotDropped) {
    Fixture x(TransferReason::Recover, Role::Player);
    TransferSender sender(60'000'000);
    const TransferSender::Transfer& t = big_transfer(x, sender, 200, TransferReason::Recover);
    constexpr std::uint64_t kOneWay = 30'000, kTick = 16'667;
    for (std::uint64_t seed = 1; seed <= 40; ++seed) {
        SCOPED_TRACE("seed " + std::to_string(seed));
        std::uint64_t rng = seed * 0x9E3779B97F4A7C15ull;
        const auto lost = [&rng] {  // 20 %
            rng = rng * 6364136223846793005ull + 1442695040888963407ull;
            return (rng >> 33) % 100 < 20;
        };
        SnapshotFetch f(x.config, t.offer.size);
        ASSERT_EQ(f.take_offer(0, t.offer, 0), SnapshotFetch::OfferTaken::Started);
        std::multimap<std::uint64_t, std::uint32_t> chunks_in_flight;  // arrival -> index
        std::uint64_t now = 0;
        for (; now < 60'000'000 && !f.complete(); now += kTick) {
            for (auto it = chunks_in_flight.begin(); it != chunks_in_flight.end() && it->first <= now;
                 it = chunks_in_flight.erase(it)) {
                SnapshotChunkMessage c;
                ASSERT_TRUE(TransferSender::chunk(t, it->second, c));
                f.take_chunk(0, c);
            }
            x.out.clear();
            if (f.poll(now, x.out) != SnapshotFetch::Poll::Nothing) {
                ADD_FAILURE() << "dropped at " << now << " us: " << f.why();
                break;
            }
            for (const Datagram& d : x.out) {
                SnapshotRequestMessage r;
                ASSERT_EQ(decode(d.bytes, r), nullptr);
                if (!lost() && !lost()) chunks_in_flight.emplace(now + 2 * kOneWay, r.chunk);  // asked and answered
            }
        }
        EXPECT_TRUE(f.complete()) << "after " << now << " us";
    }
}

// Issue 21: a spectator's host killed between its welcome and its offer stays welcomed in the
// spectator's links; asked first every time, it kept the spectator out for good. An ask that
// went unanswered moves on to the next host, round the welcomed ones.
TEST(SnapshotFetch, ASpectatorWhoseHostNeverAnswersAsksTheNext) {
    Fixture x(TransferReason::Spectate, Role::Spectator, 4);
    for (auto& l : x.links) {
        l.has_remote_frame = true;
        l.roundtrips = x.config.sync_roundtrips;
    }
    SnapshotFetch f(x.config, kStateSize);
    const std::uint64_t period = 2 * x.config.transfer_resend_us;
    std::uint64_t now = 1 + 3 * x.config.hello_resend_us;
    std::vector<PlayerId> asked;
    for (int i = 0; i < 4; ++i, now += period) {
        ASSERT_TRUE(f.may_ask(now));
        std::vector<PlayerId> ask;
        f.newcomer_providers(x.links, 1, now, ask);
        ASSERT_EQ(ask.size(), 1u);
        asked.push_back(ask.front());
        f.ask(ask, TransferReason::Spectate, now, x.out);
    }
    EXPECT_EQ(asked, (std::vector<PlayerId>{0, 1, 2, 0}));
    // Answered: the next ask (after a rejection) starts from the first again.
    ASSERT_EQ(f.take_offer(1, x.transfer().offer, now), SnapshotFetch::OfferTaken::Started);
    f.restart();
    std::vector<PlayerId> ask;
    f.newcomer_providers(x.links, 1, now, ask);
    EXPECT_EQ(ask, std::vector<PlayerId>{0});
}

}  // namespace
}  // namespace lockroll::rollback
