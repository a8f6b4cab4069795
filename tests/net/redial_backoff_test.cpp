// RedialBackoff (net/redial_backoff.h): how often the runner dials a peer it is not connected to.
// Virtual microseconds only. Issue 21 (W13): a dropped peer's address was dialed every half
// second for the whole run; it is now dialed at a doubling interval up to a cap, and at once
// again once the peer was heard.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <vector>

#include "net/redial_backoff.h"

namespace lockroll::net {
namespace {

// The times at which the runner, servicing every millisecond from `from` to `until`, dials id 1.
std::vector<std::uint64_t> dials(RedialBackoff& b, std::uint64_t from, std::uint64_t until) {
    std::vector<std::uint64_t> at;
    for (std::uint64_t t = from; t < until; t += 1000)
        if (b.due(1, t)) {
            b.dialed(1, t);
            at.push_back(t);
        }
    return at;
}

constexpr std::uint64_t kSecond = 1000000;

TEST(RedialBackoff, AGoneAddressIsDialedAtADoublingIntervalUpToTheCap) {
    RedialBackoff b(3);
    const auto at = dials(b, 0, 60 * kSecond);
    ASSERT_GE(at.size(), 5u);
    EXPECT_EQ(at[0], 0u);  // the first dial is at once
    EXPECT_EQ(at[1] - at[0], RedialBackoff::kFirstUs);
    EXPECT_EQ(at[2] - at[1], 2 * RedialBackoff::kFirstUs);
    EXPECT_EQ(at[3] - at[2], 4 * RedialBackoff::kFirstUs);
    for (std::size_t i = 1; i < at.size(); ++i) {
        EXPECT_GE(at[i] - at[i - 1], at[i - 1] == 0 ? RedialBackoff::kFirstUs : std::uint64_t{0}) << "dial " << i;
        EXPECT_LE(at[i] - at[i - 1], RedialBackoff::kCapUs) << "dial " << i << ": a healed peer waits at most the cap";
    }
    // The interval never shrinks while nobody is heard.
    for (std::size_t i = 2; i < at.size(); ++i) EXPECT_GE(at[i] - at[i - 1], at[i - 1] - at[i - 2]) << "dial " << i;
    // A minute of a gone address: 0, 0.5, 1.5, 3.5, 7.5 s, then every 4 s -- 18 dials, where the
    // old fixed half-second rate made 120.
    EXPECT_EQ(at.size(), 18u);
    EXPECT_EQ(b.interval_us(1), RedialBackoff::kCapUs);
}

TEST(RedialBackoff, HearingThePeerStartsTheIntervalOverAndMakesItDueAtOnce) {
    RedialBackoff b(3);
    dials(b, 0, 30 * kSecond);
    ASSERT_EQ(b.interval_us(1), RedialBackoff::kCapUs);
    b.heard(1);  // its connection came up; later it is lost again
    EXPECT_EQ(b.interval_us(1), RedialBackoff::kFirstUs);
    const auto at = dials(b, 40 * kSecond, 42 * kSecond);
    ASSERT_EQ(at.size(), 3u);
    EXPECT_EQ(at[0], 40 * kSecond);  // at once after the loss
    EXPECT_EQ(at[1] - at[0], RedialBackoff::kFirstUs);
    EXPECT_EQ(at[2] - at[1], 2 * RedialBackoff::kFirstUs);
}

TEST(RedialBackoff, EachPeerHasItsOwnIntervalAndIdsOutOfRangeAreNeverDue) {
    RedialBackoff b(3);
    dials(b, 0, 20 * kSecond);  // id 1 backs off
    EXPECT_EQ(b.interval_us(2), RedialBackoff::kFirstUs);
    EXPECT_TRUE(b.due(2, 20 * kSecond));
    EXPECT_FALSE(b.due(3, 20 * kSecond));
    b.dialed(3, 0);  // harmless
    b.heard(7);
}

// A transport's connect attempt to a gone address stays pending (refusing further connects)
// for `pending_us`, then fails; one started once the peer is back connects at once.
struct PendingAttempts {
    std::uint64_t back_us = 0;
    std::uint64_t pending_us = 0;
    std::uint64_t pending_until = 0;  // 0: no attempt in flight
    bool connected = false;
    bool connect(std::uint64_t now) {
        if (now < pending_until) return false;  // "a connection for it is pending"
        if (now >= back_us) connected = true;
        else pending_until = now + pending_us;
        return true;
    }
};

TEST(RedialBackoff, ADialRefusedWhileAnAttemptIsPendingIsNoDial) {
    RedialBackoff b(3);
    EXPECT_TRUE(b.try_dial(1, 0, [] { return true; }));
    EXPECT_EQ(b.interval_us(1), 2 * RedialBackoff::kFirstUs);
    EXPECT_FALSE(b.try_dial(1, RedialBackoff::kFirstUs, [] { return false; }));  // refused
    EXPECT_EQ(b.interval_us(1), 2 * RedialBackoff::kFirstUs);                    // not charged
    EXPECT_FALSE(b.due(1, RedialBackoff::kFirstUs + RedialBackoff::kRecheckUs - 1));
    EXPECT_TRUE(b.due(1, RedialBackoff::kFirstUs + RedialBackoff::kRecheckUs));
    bool called = false;
    EXPECT_FALSE(b.try_dial(1, RedialBackoff::kFirstUs + 1, [&] { return called = true; }));  // not due
    EXPECT_FALSE(called);
}

TEST(RedialBackoff, APeerKnownToBeBackIsReachedAsTheDoomedAttemptPendingFails) {
    // Issue 21: attempts to a killed slot's address stay pending ~2 s (ENet's handshake retries)
    // and fail; its successor started while one was pending, and the owner's news that it
    // joined came 0.3 s later. The survivor's dial due then was refused by the pending attempt
    // and charged all the same; the attempt failed, and the next dial, 4 s on, was the first to
    // reach the rejoiner. Now the news makes the id due at once (heard) and a refused dial is
    // not charged: the peer is reached within kRecheckUs of the pending attempt's failure.
    const std::uint64_t pending = 2 * kSecond, news_after = 300000;
    std::uint64_t worst = 0;
    for (std::uint64_t back = 5 * kSecond; back < 25 * kSecond; back += 37 * 1000) {
        RedialBackoff b(3);
        PendingAttempts t{back, pending};
        std::uint64_t at = UINT64_MAX;
        for (std::uint64_t now = 0; now < back + 60 * kSecond && at == UINT64_MAX; now += 1000) {
            if (now == back + news_after) b.heard(1);  // the runner saw the slot's Joined event
            b.try_dial(1, now, [&] { return t.connect(now); });
            if (t.connected) at = now;
        }
        ASSERT_NE(at, UINT64_MAX) << "back at " << back;
        // Reached by then at the latest: at the news, or as the attempt pending then fails.
        const std::uint64_t free_at = std::max(back + news_after, t.pending_until);
        EXPECT_LE(at, free_at + RedialBackoff::kRecheckUs) << "back at " << back << " us, reached at " << at;
        worst = std::max(worst, at - back);
    }
    EXPECT_LE(worst, news_after + pending + RedialBackoff::kRecheckUs);
}

}  // namespace
}  // namespace lockroll::net
