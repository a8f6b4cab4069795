// Helpers shared by the lifecycle tests (tests/rollback/lifecycle_*_test.cpp): events of one
// kind, "everyone confirmed the same checksum", a dropped client that rejoins, a partition.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <functional>
#include <initializer_list>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "rollback/playing_alone.h"
#include "rollback/session.h"
#include "rollback/session_impl.h"
#include "tests/rollback/test_support.h"

namespace lockroll::rollback {

// The names every lifecycle test uses.
using testing::Client;
using testing::Cluster;
using testing::make_scene;
using testing::NetParams;
using testing::real_config;
using testing::start_newcomer;
using Kind = SessionEvent::Kind;

inline std::vector<const SessionEvent*> events_of(const testing::Client& c, SessionEvent::Kind k) {
    std::vector<const SessionEvent*> out;
    for (const SessionEvent& e : c.events)
        if (e.kind == k) out.push_back(&e);
    return out;
}


// Every client that takes part confirmed `frame` with the same checksum.
inline void expect_equal_at(const testing::Cluster& cluster, std::uint32_t frame) {
    std::optional<std::uint64_t> first;
    int compared = 0;
    for (std::size_t i = 0; i < cluster.clients.size(); ++i) {
        if (!cluster.counts(i)) continue;
        const auto& c = *cluster.clients[i];
        const auto it = c.confirmed.find(frame);
        ASSERT_NE(it, c.confirmed.end()) << "client " << i << " never confirmed frame " << frame;
        if (!first) first = it->second;
        EXPECT_EQ(it->second, *first) << "client " << i << " differs at confirmed frame " << frame;
        ++compared;
    }
    EXPECT_GE(compared, 2);
}

// A client whose session the others dropped starts again as a joiner of its slot, as
// net::PeerRunner and the in-process match do (Session::restart_as_joiner), and catches up.
inline void rejoin_when_dropped(testing::Cluster& cluster) {
    cluster.before_tick = [](PlayerId, testing::Client& c) {
        if (c.session->phase() != SessionPhase::Failed || !c.session->can_rejoin()) return;
        for (SessionEvent e; c.session->next_event(e);) c.events.push_back(e);  // the kick, first
        ASSERT_TRUE(c.session->restart_as_joiner());
        c.catches_up = true;
    };
}

// The setup of a joiner into an absent slot: a match of four (real_config(4, 8)) of `balls`
// whose slot 3 is absent (SessionConfig::absent_slots) and run by nobody yet (its client killed),
// `tweak` applied to the config first, over `net` with `seed`. The test starts the joiner
// (start_newcomer(cluster, scene, cfg, Role::Joiner, 3, ...)); `auto& [scene, cfg, cluster] = m`
// names the parts.
struct JoinerIntoAbsentSlot {
    sim::SceneDesc scene;
    SessionConfig cfg;
    testing::Cluster cluster;
    JoinerIntoAbsentSlot(int balls, void (*tweak)(SessionConfig&), testing::NetParams net, std::uint64_t seed)
        : scene(make_scene(4, balls)), cfg(config(tweak)), cluster(scene, cfg, net, seed) {
        cluster.kill(3);
    }

private:
    static SessionConfig config(void (*tweak)(SessionConfig&)) {
        SessionConfig c = real_config(4, 8);
        c.absent_slots = 1u << 3;
        tweak(c);
        return c;
    }
};

// Every datagram between `side` and the rest is lost while `cut` is set.
inline void split(testing::Cluster& cluster, std::set<PlayerId> side, const bool& cut) {
    cluster.filter = [side = std::move(side), &cut](PlayerId from, PlayerId to, const std::vector<std::uint8_t>&) {
        return !cut || side.count(from) == side.count(to);
    };
}

// A joiner cut off: a match of three (`cfg`) whose slot 2 is killed at frame 200 and dropped by
// the two others; a new process of slot 2 then joins while every datagram between it and the
// slots in `unreachable` is lost as long as `cut` is set. Dropped again meanwhile (its handoff
// lapsed), it starts again as a joiner, as a runner does. Returns the joiner's client.
inline testing::Client& start_cut_off_joiner(testing::Cluster& cluster, const sim::SceneDesc& scene,
                                             const SessionConfig& cfg, std::set<PlayerId> unreachable, const bool& cut) {
    rejoin_when_dropped(cluster);
    cluster.run_frames(200);
    cluster.kill(2);
    cluster.run_frames(400, 60'000'000);
    EXPECT_EQ(cluster.clients[0]->session->slot_state(2), SlotState::Disconnected);
    cluster.filter = [unreachable = std::move(unreachable), &cut](PlayerId from, PlayerId to, const std::vector<std::uint8_t>&) {
        return !(cut && ((from == 2 && unreachable.count(to)) || (to == 2 && unreachable.count(from))));
    };
    SessionConfig again = cfg;
    again.local_player = 2;
    again.role = Role::Joiner;
    return cluster.start(2, scene, again, 999);
}

}  // namespace lockroll::rollback
