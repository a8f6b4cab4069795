#include "transport/sim_network.h"
#include "transport/partition_schedule.h"

#include <gtest/gtest.h>

#define XXH_INLINE_ALL
#include <xxhash.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <stdexcept>
#include <vector>

namespace lockroll::transport {
namespace {

struct Delivery {
    PeerId to = 0;
    PeerId from = 0;
    Micros at = 0;
    std::vector<std::uint8_t> bytes;
    friend bool operator==(const Delivery&, const Delivery&) = default;
};

std::vector<std::uint8_t> payload(std::uint32_t id, std::size_t size = 8) {
    std::vector<std::uint8_t> b(std::max<std::size_t>(size, 4), 0xAB);
    for (int i = 0; i < 4; ++i) b[static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(id >> (8 * i));
    return b;
}

std::uint32_t id_of(const std::vector<std::uint8_t>& b) {
    return std::uint32_t{b[0]} | std::uint32_t{b[1]} << 8 | std::uint32_t{b[2]} << 16 | std::uint32_t{b[3]} << 24;
}

// Discrete-event drain: jumps to each delivery time up to `until`, peers in id order.
void drain(SimNetwork& net, Micros until, std::vector<Delivery>& out) {
    Datagram d;
    while (const auto t = net.next_delivery_time()) {
        if (*t > until) break;
        for (PeerId p = 0; p < static_cast<PeerId>(net.peer_count()); ++p)
            while (net.endpoint(p).receive(d, *t)) out.push_back({p, d.from, d.time_us, d.bytes});
    }
}

// Sends `count` packets 0 -> 1, one every interval_us, and returns every arrival in order.
std::vector<Delivery> stream(SimNetwork& net, std::uint32_t count, Micros interval_us, std::size_t size = 8) {
    for (std::uint32_t i = 0; i < count; ++i)
        EXPECT_TRUE(net.endpoint(0).send(1, payload(i, size), Micros{i} * interval_us));
    std::vector<Delivery> out;
    drain(net, ~Micros{0}, out);
    return out;
}

LinkConditions rough_link() {
    LinkConditions c;
    c.latency_us = 57'000;
    c.jitter_us = 10'000;
    c.loss = 0.1;
    c.duplicate = 0.05;
    c.reorder = 0.1;
    c.burst_enter = 0.02;
    c.burst_exit = 0.3;
    return c;
}

// Up to four peers (three by default), 60 Hz, everyone sends to everyone each tick with varying
// sizes, interleaved with receiving: the shape of the harness's traffic. Datagram ids are
// tick * 16 + from * 4 + to (see mesh_send_time, mesh_from, mesh_to).
constexpr Micros kMeshTickUs = 16'667;
std::vector<Delivery> scripted_run(const SimNetworkConfig& config) {
    SimNetwork net(config);
    const auto peers = static_cast<PeerId>(config.peers);
    std::vector<Delivery> out;
    for (std::uint32_t tick = 0; tick < 600; ++tick) {
        const Micros now = Micros{tick} * kMeshTickUs;
        drain(net, now, out);
        for (PeerId from = 0; from < peers; ++from)
            for (PeerId to = 0; to < peers; ++to)
                if (from != to) net.endpoint(from).send(to, payload(tick * 16 + from * 4 + to, 4 + (tick + from) % 40), now);
    }
    drain(net, ~Micros{0}, out);
    return out;
}
std::vector<Delivery> scripted_run(std::uint64_t seed, const LinkConditions& link) {
    return scripted_run({.peers = 3, .seed = seed, .link = link});
}
Micros mesh_send_time(std::uint32_t id) { return Micros{id / 16} * kMeshTickUs; }
PeerId mesh_from(std::uint32_t id) { return id / 4 % 4; }
PeerId mesh_to(std::uint32_t id) { return id % 4; }

std::uint64_t trace_hash(const std::vector<Delivery>& trace) {
    // Field by field, little-endian, so the hash means the same thing on every machine.
    std::vector<std::uint8_t> buf;
    auto put = [&](std::uint64_t v, int bytes) {
        for (int i = 0; i < bytes; ++i) buf.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
    };
    for (const Delivery& d : trace) {
        put(d.to, 4);
        put(d.from, 4);
        put(d.at, 8);
        put(d.bytes.size(), 4);
        buf.insert(buf.end(), d.bytes.begin(), d.bytes.end());
    }
    return XXH3_64bits(buf.data(), buf.size());
}

// ---------------------------------------------------------------------------------------------

TEST(SimNetwork, ZeroConditionLinkDeliversEverythingInOrderAfterExactlyTheLatency) {
    LinkConditions c;
    c.latency_us = 25'000;
    SimNetwork net({.peers = 2, .seed = 9, .link = c});
    std::vector<Micros> sent_at;
    for (std::uint32_t i = 0; i < 1000; ++i) {
        const Micros t = Micros{i / 3} * 7'919;  // three sends share each instant
        sent_at.push_back(t);
        ASSERT_TRUE(net.endpoint(0).send(1, payload(i), t));
    }
    Datagram d;
    EXPECT_FALSE(net.endpoint(1).receive(d, 24'999));  // nothing early
    ASSERT_EQ(net.next_delivery_time(), Micros{25'000});
    std::vector<Delivery> out;
    drain(net, ~Micros{0}, out);
    ASSERT_EQ(out.size(), 1000u);
    for (std::uint32_t i = 0; i < 1000; ++i) {
        EXPECT_EQ(id_of(out[i].bytes), i);
        EXPECT_EQ(out[i].at, sent_at[i] + 25'000);
        EXPECT_EQ(out[i].from, 0u);
        EXPECT_EQ(out[i].to, 1u);
    }
    EXPECT_EQ(net.in_flight(), 0u);
    EXPECT_FALSE(net.next_delivery_time().has_value());
}

TEST(SimNetwork, SameSeedGivesIdenticalTrace) {
    const auto a = scripted_run(1234, rough_link());
    const auto b = scripted_run(1234, rough_link());
    ASSERT_GT(a.size(), 1000u);
    EXPECT_EQ(a, b);
}

TEST(SimNetwork, DifferentSeedGivesDifferentTrace) {
    EXPECT_NE(scripted_run(1234, rough_link()), scripted_run(1235, rough_link()));
}

// Pins the model to the bit: any change to the generator, the draw layout or the delay
// arithmetic changes this hash (update it deliberately, and say so in docs/network-model.md).
TEST(SimNetwork, GoldenTrace) {
    EXPECT_EQ(trace_hash(scripted_run(2024, rough_link())), 0x7bb9050ebbe15b25ull);
}

TEST(SimNetwork, LinkFateDoesNotDependOnOtherLinksTraffic) {
    SimNetwork quiet({.peers = 3, .seed = 5, .link = rough_link()});
    SimNetwork busy({.peers = 3, .seed = 5, .link = rough_link()});
    for (std::uint32_t i = 0; i < 500; ++i) {
        const Micros t = Micros{i} * 10'000;
        quiet.endpoint(0).send(1, payload(i), t);
        busy.endpoint(2).send(1, payload(100000 + i), t);
        busy.endpoint(0).send(1, payload(i), t);
        busy.endpoint(1).send(0, payload(200000 + i), t);
    }
    std::vector<Delivery> q, b;
    drain(quiet, ~Micros{0}, q);
    drain(busy, ~Micros{0}, b);
    std::erase_if(b, [](const Delivery& d) { return d.from != 0 || d.to != 1; });
    EXPECT_EQ(q, b);
}

TEST(SimNetwork, LossRateWithinStatisticalBounds) {
    LinkConditions c;
    c.latency_us = 1'000;
    c.loss = 0.1;
    SimNetwork net({.peers = 2, .seed = 77, .link = c});
    constexpr std::uint32_t n = 100'000;
    const auto out = stream(net, n, 1'000);
    const double expected = n * c.loss;
    const double sd = std::sqrt(n * c.loss * (1 - c.loss));
    const double lost = n - static_cast<double>(out.size());
    EXPECT_NEAR(lost, expected, 5 * sd);
    EXPECT_EQ(net.link_stats(0, 1).lost_random, static_cast<std::uint64_t>(lost));
    EXPECT_EQ(net.endpoint(0).counters().dropped, static_cast<std::uint64_t>(lost));
    EXPECT_EQ(net.endpoint(0).counters().datagrams_sent, n);
    EXPECT_EQ(net.endpoint(1).counters().datagrams_received, out.size());
    // Loss alone keeps order.
    for (std::size_t i = 1; i < out.size(); ++i) EXPECT_LT(id_of(out[i - 1].bytes), id_of(out[i].bytes));
}

TEST(SimNetwork, DuplicationHappensAtRoughlyTheSetRate) {
    LinkConditions c;
    c.latency_us = 5'000;
    c.jitter_us = 2'000;
    c.duplicate = 0.05;
    SimNetwork net({.peers = 2, .seed = 3, .link = c});
    constexpr std::uint32_t n = 50'000;
    const auto out = stream(net, n, 10'000);
    std::map<std::uint32_t, int> copies;
    for (const auto& d : out) ++copies[id_of(d.bytes)];
    ASSERT_EQ(copies.size(), n);  // no loss: everything arrives at least once
    std::uint32_t twice = 0;
    for (const auto& [id, k] : copies) {
        EXPECT_LE(k, 2);
        twice += (k == 2);
    }
    const double sd = std::sqrt(n * c.duplicate * (1 - c.duplicate));
    EXPECT_NEAR(twice, n * c.duplicate, 5 * sd);
    EXPECT_EQ(net.link_stats(0, 1).duplicated, twice);
    EXPECT_EQ(net.endpoint(0).counters().duplicated, twice);
    EXPECT_EQ(out.size(), n + twice);
}

TEST(SimNetwork, ReorderingHappensAtRoughlyTheSetRate) {
    LinkConditions c;
    c.latency_us = 20'000;
    c.reorder = 0.1;
    c.reorder_min_us = 10'000;
    c.reorder_max_us = 30'000;
    SimNetwork net({.peers = 2, .seed = 11, .link = c});
    constexpr std::uint32_t n = 50'000;
    // Sent every 1 ms, shorter than the minimum hold: every held packet gets overtaken.
    const auto out = stream(net, n, 1'000);
    ASSERT_EQ(out.size(), n);
    std::uint32_t late = 0, highest = 0;
    for (std::size_t i = 0; i < out.size(); ++i) {
        const std::uint32_t id = id_of(out[i].bytes);
        if (i > 0 && id < highest) ++late;
        highest = std::max(highest, id);
    }
    const double sd = std::sqrt(n * c.reorder * (1 - c.reorder));
    EXPECT_NEAR(late, n * c.reorder, 5 * sd);
    EXPECT_EQ(net.link_stats(0, 1).reordered, late);
    // Held packets arrive within latency + [min, max].
    for (const auto& d : out) {
        const Micros sent = Micros{id_of(d.bytes)} * 1'000;
        EXPECT_GE(d.at, sent + c.latency_us);
        EXPECT_LE(d.at, sent + c.latency_us + c.reorder_max_us);
    }
}

TEST(SimNetwork, JitterAloneKeepsOrder) {
    LinkConditions c;
    c.latency_us = 50'000;
    c.jitter_us = 20'000;  // far more than the 1 ms spacing
    SimNetwork net({.peers = 2, .seed = 4, .link = c});
    const auto out = stream(net, 20'000, 1'000);
    ASSERT_EQ(out.size(), 20'000u);
    for (std::size_t i = 1; i < out.size(); ++i) {
        EXPECT_LT(id_of(out[i - 1].bytes), id_of(out[i].bytes));
        EXPECT_LE(out[i - 1].at, out[i].at);
    }
    for (const auto& d : out) {
        const Micros sent = Micros{id_of(d.bytes)} * 1'000;
        EXPECT_GE(d.at, sent + c.latency_us - c.jitter_us);
        EXPECT_LE(d.at, sent + c.latency_us + c.jitter_us);
    }
}

TEST(SimNetwork, UniformJitterStaysWithinBoundsAndCoversThem) {
    LinkConditions c;
    c.latency_us = 57'000;
    c.jitter_us = 10'000;
    SimNetwork net({.peers = 2, .seed = 21, .link = c});
    constexpr std::uint32_t n = 100'000;
    // Spacing 25 ms > 2 * jitter: the in-order queue never holds a packet back.
    const auto out = stream(net, n, 25'000);
    ASSERT_EQ(out.size(), n);
    double sum = 0;
    std::int64_t lo = INT64_MAX, hi = INT64_MIN;
    for (const auto& d : out) {
        const auto delay = static_cast<std::int64_t>(d.at - Micros{id_of(d.bytes)} * 25'000);
        sum += static_cast<double>(delay);
        lo = std::min(lo, delay);
        hi = std::max(hi, delay);
    }
    EXPECT_GE(lo, 47'000);
    EXPECT_LE(hi, 67'000);
    EXPECT_LT(lo, 47'100);  // both ends are reached
    EXPECT_GT(hi, 66'900);
    const double sd_of_mean = 10'000 / std::sqrt(3.0) / std::sqrt(double{n});
    EXPECT_NEAR(sum / n, 57'000.0, 6 * sd_of_mean);
}

TEST(SimNetwork, NormalJitterHasTheSetMeanAndDeviation) {
    LinkConditions c;
    c.latency_us = 50'000;
    c.jitter_us = 5'000;
    c.jitter_distribution = JitterDistribution::Normal;
    SimNetwork net({.peers = 2, .seed = 8, .link = c});
    constexpr std::uint32_t n = 50'000;
    const auto out = stream(net, n, 100'000);
    ASSERT_EQ(out.size(), n);
    double sum = 0, sum_sq = 0;
    for (const auto& d : out) {
        const double off = static_cast<double>(d.at - Micros{id_of(d.bytes)} * 100'000) - 50'000.0;
        EXPECT_LE(std::abs(off), 6 * 5'000.0 + 1);
        sum += off;
        sum_sq += off * off;
    }
    const double mean = sum / n;
    const double sd = std::sqrt(sum_sq / n - mean * mean);
    EXPECT_NEAR(mean, 0.0, 6 * 5'000 / std::sqrt(double{n}));
    EXPECT_NEAR(sd, 5'000.0, 150.0);
}

namespace {
double mean_loss_run(const std::vector<Delivery>& out, std::uint32_t n, std::uint32_t* lost_total) {
    std::vector<bool> arrived(n, false);
    for (const auto& d : out) arrived[id_of(d.bytes)] = true;
    std::uint32_t runs = 0, lost = 0;
    for (std::uint32_t i = 0; i < n; ++i) {
        if (arrived[i]) continue;
        ++lost;
        if (i == 0 || arrived[i - 1]) ++runs;
    }
    *lost_total = lost;
    return runs == 0 ? 0.0 : static_cast<double>(lost) / runs;
}
}  // namespace

TEST(SimNetwork, BurstLossProducesRuns) {
    LinkConditions burst;
    burst.latency_us = 1'000;
    burst.burst_enter = 0.01;
    burst.burst_exit = 0.25;  // mean burst 4 packets
    burst.burst_loss = 1.0;
    constexpr std::uint32_t n = 200'000;
    SimNetwork net({.peers = 2, .seed = 99, .link = burst});
    std::uint32_t lost = 0;
    const double run = mean_loss_run(stream(net, n, 1'000), n, &lost);
    EXPECT_NEAR(run, 4.0, 0.4);
    const double bad_fraction = 0.01 / (0.01 + 0.25);
    EXPECT_NEAR(static_cast<double>(lost) / n, bad_fraction, 0.15 * bad_fraction);
    EXPECT_EQ(net.link_stats(0, 1).lost_burst, lost);
    EXPECT_EQ(net.link_stats(0, 1).burst_packets, lost);

    // The same average loss, independent: runs are about one packet long.
    LinkConditions iid;
    iid.latency_us = 1'000;
    iid.loss = bad_fraction;
    SimNetwork net2({.peers = 2, .seed = 99, .link = iid});
    std::uint32_t lost2 = 0;
    EXPECT_LT(mean_loss_run(stream(net2, n, 1'000), n, &lost2), 1.2);
    EXPECT_NEAR(static_cast<double>(lost2) / n, bad_fraction, 0.1 * bad_fraction);
}

TEST(SimNetwork, BandwidthCapSerialisesAndQueueLimitDropsTail) {
    LinkConditions c;
    c.latency_us = 1'000;
    c.bandwidth_bytes_per_s = 12'800;  // 100 + 28 bytes take exactly 10 ms
    SimNetwork net({.peers = 2, .seed = 1, .link = c});
    for (std::uint32_t i = 0; i < 5; ++i) net.endpoint(0).send(1, payload(i, 100), 0);
    std::vector<Delivery> out;
    drain(net, ~Micros{0}, out);
    ASSERT_EQ(out.size(), 5u);
    for (std::uint32_t i = 0; i < 5; ++i) EXPECT_EQ(out[i].at, 1'000 + 10'000 * Micros{i + 1});

    c.queue_limit_bytes = 300;  // room for two 128-byte packets
    SimNetwork capped({.peers = 2, .seed = 1, .link = c});
    for (std::uint32_t i = 0; i < 5; ++i) capped.endpoint(0).send(1, payload(i, 100), 0);
    out.clear();
    drain(capped, ~Micros{0}, out);
    ASSERT_EQ(out.size(), 2u);
    EXPECT_EQ(capped.link_stats(0, 1).lost_queue, 3u);
    // Once the queue drains, packets pass again.
    capped.endpoint(0).send(1, payload(9, 100), 20'000);
    out.clear();
    drain(capped, ~Micros{0}, out);
    ASSERT_EQ(out.size(), 1u);
    EXPECT_EQ(out[0].at, 20'000 + 10'000 + 1'000u);
}

TEST(SimNetwork, EqualDeliveryTimesFollowSendOrder) {
    SimNetwork net({.peers = 4, .seed = 1, .link = {}});
    net.endpoint(3).send(0, payload(3), 5);
    net.endpoint(1).send(0, payload(1), 5);
    net.endpoint(2).send(0, payload(2), 5);
    net.endpoint(1).send(0, payload(4), 5);
    std::vector<Delivery> out;
    drain(net, 5, out);
    ASSERT_EQ(out.size(), 4u);
    EXPECT_EQ(id_of(out[0].bytes), 3u);
    EXPECT_EQ(id_of(out[1].bytes), 1u);
    EXPECT_EQ(id_of(out[2].bytes), 2u);
    EXPECT_EQ(id_of(out[3].bytes), 4u);
    for (const auto& d : out) EXPECT_EQ(d.at, 5u);
}

TEST(SimNetwork, NextDeliveryTimePerPeer) {
    LinkConditions c;
    c.latency_us = 100;
    SimNetwork net({.peers = 3, .seed = 1, .link = c});
    EXPECT_FALSE(net.next_delivery_time().has_value());
    net.endpoint(0).send(2, payload(0), 50);
    net.endpoint(0).send(1, payload(1), 10);
    EXPECT_EQ(net.next_delivery_time(), Micros{110});
    EXPECT_EQ(net.next_delivery_time(2), Micros{150});
    EXPECT_EQ(net.next_delivery_time(1), Micros{110});
    EXPECT_FALSE(net.next_delivery_time(0).has_value());
    EXPECT_EQ(net.in_flight(), 2u);
}

TEST(SimNetwork, ConditionChangesApplyToLaterSendsOnly) {
    LinkConditions c;
    c.latency_us = 10'000;
    SimNetwork net({.peers = 2, .seed = 1, .link = c});
    net.endpoint(0).send(1, payload(0), 0);
    c.latency_us = 50'000;
    net.set_link(0, 1, c);
    net.endpoint(0).send(1, payload(1), 1);
    net.endpoint(1).send(0, payload(2), 1);  // the other direction is unchanged
    std::vector<Delivery> out;
    drain(net, ~Micros{0}, out);
    ASSERT_EQ(out.size(), 3u);
    EXPECT_EQ(out[0].at, 10'000u);
    EXPECT_EQ(out[1].at, 10'001u);
    EXPECT_EQ(id_of(out[1].bytes), 2u);
    EXPECT_EQ(out[2].at, 50'001u);
    EXPECT_EQ(net.link(0, 1).latency_us, 50'000u);
    EXPECT_EQ(net.link(1, 0).latency_us, 10'000u);
}

TEST(SimNetwork, RejectsBadSendsWithoutThrowing) {
    SimNetwork net({.peers = 2, .seed = 1, .link = {}});
    Transport& ep = net.endpoint(0);
    EXPECT_FALSE(ep.send(0, payload(0), 0));  // self
    EXPECT_FALSE(ep.send(7, payload(0), 0));  // unknown
    EXPECT_FALSE(ep.send(1, std::vector<std::uint8_t>(kMaxDatagramBytes + 1), 0));
    EXPECT_TRUE(ep.send(1, std::vector<std::uint8_t>(kMaxDatagramBytes), 0));
    EXPECT_TRUE(ep.send(1, {}, 0));  // empty datagrams are datagrams too
    EXPECT_EQ(ep.counters().rejected, 3u);
    EXPECT_EQ(ep.counters().datagrams_sent, 2u);
    EXPECT_EQ(ep.counters().bytes_sent, kMaxDatagramBytes);
    EXPECT_EQ(ep.local_id(), 0u);
}

TEST(SimNetwork, InvalidConfigurationThrowsNamingTheField) {
    LinkConditions bad;
    bad.loss = 1.5;
    EXPECT_NE(validate(bad).find("loss"), std::string::npos);
    EXPECT_THROW(SimNetwork({.peers = 2, .seed = 1, .link = bad}), std::invalid_argument);
    EXPECT_THROW(SimNetwork({.peers = 0, .seed = 1, .link = {}}), std::invalid_argument);
    LinkConditions nan;
    nan.reorder = std::nan("");
    EXPECT_NE(validate(nan).find("reorder"), std::string::npos);
    LinkConditions stuck;
    stuck.burst_enter = 0.1;
    stuck.burst_exit = 0.0;
    EXPECT_NE(validate(stuck).find("burst_exit"), std::string::npos);
    LinkConditions inverted;
    inverted.reorder_min_us = 5;
    inverted.reorder_max_us = 4;
    EXPECT_NE(validate(inverted).find("reorder_min_us"), std::string::npos);
    EXPECT_TRUE(validate(rough_link()).empty());
    SimNetwork net({.peers = 2, .seed = 1, .link = {}});
    EXPECT_THROW(net.endpoint(2), std::out_of_range);
    EXPECT_THROW(net.set_link(0, 1, bad), std::invalid_argument);
}

// ---------------------------------------------------------------------------------------------
// Partitions

// {0,1} / {2} cut from 3 s to 6 s; slot 3 is named in neither set. Against the same run without
// the partition: links that do not cross the cut are identical to the bit; on the four directed
// links that cross it, exactly the datagrams sent inside the window are missing, and every other
// datagram has the same fate (lost or delivered, duplicated or not) as without the cut, since a
// cut datagram keeps its draws and burst step (LinkModel::cut).
TEST(SimNetwork, PartitionDropsExactlyTheCutLinksInsideTheWindowAndNothingElse) {
    constexpr Micros kFrom = 3'000'000, kUntil = 6'000'000;
    PartitionSchedule schedule;
    schedule.add({{{0, 1}, {2}}, kFrom, kUntil});
    const SimNetworkConfig plain{.peers = 4, .seed = 77, .link = rough_link()};
    SimNetworkConfig cut = plain;
    cut.partitions = schedule;
    const auto without = scripted_run(plain);
    const auto with = scripted_run(cut);

    const auto crosses = [](PeerId a, PeerId b) { return (a < 2 && b == 2) || (a == 2 && b < 2); };
    std::map<std::uint32_t, int> want_on_cut_links, got_on_cut_links;  // id -> copies delivered
    std::vector<Delivery> want_elsewhere, got_elsewhere;
    std::size_t removed = 0;
    for (const Delivery& d : without) {
        const std::uint32_t id = id_of(d.bytes);
        if (!crosses(d.from, d.to)) {
            want_elsewhere.push_back(d);
        } else if (mesh_send_time(id) >= kFrom && mesh_send_time(id) < kUntil) {
            ++removed;
        } else {
            ++want_on_cut_links[id];
        }
    }
    for (const Delivery& d : with) {
        const std::uint32_t id = id_of(d.bytes);
        ASSERT_EQ(mesh_from(id), d.from);
        ASSERT_EQ(mesh_to(id), d.to);
        if (crosses(d.from, d.to)) {
            const Micros sent = mesh_send_time(id);
            EXPECT_FALSE(sent >= kFrom && sent < kUntil) << "datagram " << id << " crossed the cut at " << sent;
            ++got_on_cut_links[id];
        } else {
            got_elsewhere.push_back(d);
        }
    }
    EXPECT_GT(removed, 300u);  // ~180 sends per cut link in the window, less random loss
    EXPECT_EQ(got_elsewhere, want_elsewhere);
    EXPECT_EQ(got_on_cut_links, want_on_cut_links);

    // Counted as partition losses on the cut links only: 180 ticks of the window on each of the
    // four directed links (ticks 180..359 are sent at 3.00 s .. 5.98 s).
    SimNetwork net(cut);
    for (std::uint32_t tick = 0; tick < 600; ++tick)
        for (PeerId from = 0; from < 4; ++from)
            for (PeerId to = 0; to < 4; ++to)
                if (from != to) net.endpoint(from).send(to, payload(tick), Micros{tick} * kMeshTickUs);
    for (PeerId from = 0; from < 4; ++from)
        for (PeerId to = 0; to < 4; ++to) {
            if (from == to) continue;
            const LinkStats& ls = net.link_stats(from, to);
            EXPECT_EQ(ls.lost_partition, crosses(from, to) ? 180u : 0u) << from << "->" << to;
            EXPECT_EQ(ls.sent, 600u);
            EXPECT_EQ(ls.sent, ls.delivered - ls.duplicated + ls.lost_random + ls.lost_burst + ls.lost_queue +
                                   ls.lost_partition);
        }
    EXPECT_GE(net.endpoint(2).counters().dropped, 2 * 180u);  // cut ones, plus random loss
}

// No schedule, an empty one, or one whose window comes after every send: the golden trace, bit
// for bit (the same hash as SimNetwork.GoldenTrace).
TEST(SimNetwork, APartitionThatNeverAppliesLeavesTheGoldenTrace) {
    PartitionSchedule later;
    later.add({{{0}, {1, 2}}, 600 * kMeshTickUs + 10'000'000, 600 * kMeshTickUs + 20'000'000});
    for (const PartitionSchedule& s : {PartitionSchedule{}, later}) {
        SimNetworkConfig c{.peers = 3, .seed = 2024, .link = rough_link()};
        c.partitions = s;
        EXPECT_EQ(trace_hash(scripted_run(c)), 0x7bb9050ebbe15b25ull);
    }
}

TEST(SimNetwork, PartitionsCanBeReplacedAndRefuseUnknownSlots) {
    SimNetwork net({.peers = 2, .seed = 1, .link = {}});
    PartitionSchedule s;
    s.add({{{0}, {1}}, 100, 200});
    net.set_partitions(s);
    EXPECT_TRUE(net.endpoint(0).send(1, payload(0), 150));  // accepted, then cut
    EXPECT_EQ(net.endpoint(0).counters().dropped, 1u);
    EXPECT_EQ(net.link_stats(0, 1).lost_partition, 1u);
    EXPECT_EQ(net.in_flight(), 0u);
    net.set_partitions({});
    EXPECT_TRUE(net.endpoint(0).send(1, payload(1), 150));
    EXPECT_EQ(net.in_flight(), 1u);
    PartitionSchedule bad;
    bad.add({{{0}, {5}}, 0, 10});
    try {
        net.set_partitions(bad);
        ADD_FAILURE() << "slot 5 accepted on a 2-peer network";
    } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::string(e.what()).find("slot 5"), std::string::npos) << e.what();
    }
    EXPECT_THROW(SimNetwork({.peers = 2, .seed = 1, .link = {}, .partitions = bad}), std::invalid_argument);
}

}  // namespace
}  // namespace lockroll::transport
