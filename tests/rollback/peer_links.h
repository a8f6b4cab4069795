// Peer links for the tests that drive one part of a session by hand over hand-fed links (the
// handshake, the stream relay, the snapshot fetch): `n` links, each with every per-slot table
// sized for `slots` slots, as a session's links are before anything arrives.
#pragma once

#include <cstddef>
#include <vector>

#include "rollback/peer_link.h"

namespace lockroll::rollback::testing {

inline std::vector<PeerLink> fresh_links(int n, std::size_t slots = 3) {
    std::vector<PeerLink> links;
    for (int p = 0; p < n; ++p) {
        links.emplace_back(10, 8);  // 10 malformed datagrams before the error state, 8 time-sync samples
        links.back().reset_lifecycle(slots);
    }
    return links;
}

}  // namespace lockroll::rollback::testing
