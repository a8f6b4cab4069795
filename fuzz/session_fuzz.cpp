// libFuzzer target: a live session fed datagrams from fuzzed peers (rollback/session.h).
// Session 0 of a 3-player game is the target; sessions 1 and 2 are real peers. The input is a
// script of operations, so the fuzzer reaches deep states (rollbacks, confirmations, desync
// narrowing) and then corrupts the traffic that drives them:
//   op % 4 == 0  [from][len][len bytes]  a raw datagram to session 0 (from 3 is out of range)
//   op % 4 == 1                          one tick of everyone, traffic delivered intact
//   op % 4 == 2  [at][xor]               one tick; every datagram to session 0 has byte
//                                        `at % size` xored with `xor`
//   op % 4 == 3                          one tick; peer 1's datagrams to session 0 are lost
// When the first byte is odd, peer 1 flips a bit of a ball at frame 5, so the sessions desync
// and narrow it with queries and replies, which the fuzzer then corrupts.
// Property: no crash, hang or sanitizer report; session 0 keeps a bounded amount of state.
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "rollback/protocol.h"
#include "rollback/session.h"
#include "rollback/world_simulation.h"
#include "tests/rollback/test_support.h"

using namespace lockroll::rollback;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    static const lockroll::sim::SceneDesc scene = testing::make_scene(3, 6);
    constexpr int kPlayers = 3;
    std::vector<std::unique_ptr<WorldSimulation>> sims;
    std::vector<std::unique_ptr<Session>> sessions;
    for (int p = 0; p < kPlayers; ++p) {
        SessionConfig cfg;
        cfg.players = kPlayers;
        cfg.local_player = static_cast<PlayerId>(p);
        cfg.max_bad_packets = p == 0 ? 1 << 30 : 8;  // the target never stops listening
        sims.push_back(std::make_unique<WorldSimulation>(scene, kPlayers));
        sessions.push_back(std::make_unique<Session>(cfg, *sims.back()));
    }
    if (size > 0 && (data[0] & 1)) (void)sessions[1]->inject_fault(5, 9, 0, 40);

    std::uint64_t now = 0;
    std::vector<Datagram> out;
    std::size_t at = size > 0 ? 1 : 0;
    auto next = [&]() -> std::uint8_t { return at < size ? data[at++] : 0; };
    int ticks = 0;
    while (at < size && ticks < 600) {
        const std::uint8_t op = next();
        if (op % 4 == 0) {
            const PlayerId from = next() % (kPlayers + 1);
            const std::size_t len = next();
            const std::size_t n = len < size - at ? len : size - at;
            sessions[0]->receive(from, std::span<const std::uint8_t>(data + at, n), now);
            at += n;
            continue;
        }
        const std::uint8_t flip_at = op % 4 == 2 ? next() : 0, flip = op % 4 == 2 ? next() : 0;
        ++ticks;
        now += 16667;
        for (int p = 0; p < kPlayers; ++p) {
            const std::uint8_t input[3] = {static_cast<std::uint8_t>(ticks * (p + 1)), static_cast<std::uint8_t>(p), 0};
            (void)sessions[p]->advance(input, now);
        }
        for (int p = 0; p < kPlayers; ++p) {
            out.clear();
            sessions[p]->poll(now, out);
            for (Datagram& d : out) {
                if (d.peer >= kPlayers) continue;
                if (d.peer == 0) {
                    if (op % 4 == 3 && p == 1) continue;
                    if (op % 4 == 2 && !d.bytes.empty()) d.bytes[flip_at % d.bytes.size()] ^= flip;
                }
                sessions[d.peer]->receive(static_cast<PlayerId>(p), d.bytes, now);
            }
        }
    }
    return 0;
}
