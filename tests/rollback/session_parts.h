// The parts of a P2P session that a concept test borrows instead of a whole session: three
// players (this session is slot 0) and one spectator peer (3), a Sync over the test scene with
// its stats, the view, one slot view per slot and one link per peer.
#pragma once

#include <vector>

#include "rollback/membership.h"
#include "rollback/peer_link.h"
#include "rollback/predictor.h"
#include "rollback/slot_view.h"
#include "rollback/sync.h"
#include "rollback/world_simulation.h"
#include "tests/rollback/test_support.h"

namespace lockroll::rollback::testing {

struct SessionParts {
    static SyncConfig sync_config() {
        SyncConfig s;
        s.players = 3;
        s.input_size = kWorldInputSize;
        s.input_capacity = 64;
        return s;
    }
    SessionParts() : sync(sync_config(), sim, predictor, nullptr, stats, [] { return 0ull; }) {
        config.players = 3;
        config.max_spectators = 1;
        config.input_size = kWorldInputSize;
        stats.peers.resize(4);
        for (int p = 0; p < 4; ++p) {
            links.emplace_back(10, 8);
            links.back().reset_lifecycle(3);
        }
    }

    SessionConfig config;
    WorldSimulation sim{make_scene(3, 0), 3};
    RepeatLastPredictor predictor;
    SessionStats stats;
    Sync sync;
    Membership membership{3, 0, TwoPlayerRule::PlayOnAlone};
    std::vector<SlotView> slots{3};
    std::vector<PeerLink> links;
};

}  // namespace lockroll::rollback::testing
