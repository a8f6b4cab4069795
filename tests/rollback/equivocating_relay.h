// An equivocating relay for the in-test network (test_support.h's Cluster): `liar` flips every
// byte of `owner`'s inputs it relays to `victim`; nothing else of its messages changes (its own
// stream, table and checksums stay honest). Shared by relay_authority_test.cpp (a cut within the
// bound confirmation waits) and relay_equivocation_test.cpp (past it).
#pragma once

#include <cstdint>
#include <vector>

#include "rollback/protocol.h"
#include "tests/rollback/test_support.h"

namespace lockroll::rollback::testing {

// `altered` counts the relayed inputs the liar altered; it must outlive the cluster's rewrite.
inline void equivocate(Cluster& cluster, PlayerId liar, PlayerId victim, PlayerId owner, std::uint64_t& altered) {
    const std::size_t n = cluster.clients[victim]->session->config().input_size;
    cluster.rewrite = [=, &altered](PlayerId from, PlayerId to, std::vector<std::uint8_t>& bytes) {
        if (from != liar || to != victim || peek_kind(bytes) != MessageKind::Input) return;
        InputMessage m;
        if (decode(bytes, n, m) != nullptr || !m.has_extension) return;
        bool changed = false;
        for (StreamBlock& b : m.blocks) {
            if (b.slot != owner || b.absent) continue;
            for (auto& v : b.inputs) v = static_cast<std::uint8_t>(v ^ 0x5A);
            altered += b.frame_count;
            changed = true;
        }
        if (!changed) return;
        bytes.clear();
        encode(m, n, bytes);
    };
}

}  // namespace lockroll::rollback::testing
