// libFuzzer target: arbitrary bytes into the decoders and into a live session as datagrams from
// its peers. Must never crash, hang or trip a sanitizer. Built only with clang
// (cmake -DCMAKE_CXX_COMPILER=clang++ ..., then `cmake --build DIR --target rollback_protocol_fuzz`
// and run ./rollback_protocol_fuzz -max_total_time=60).
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
    std::span<const std::uint8_t> in(data, size);
    InputMessage im;
    QueryMessage qm;
    ReplyMessage rm;
    (void)decode(in, 3, im);
    (void)decode(in, qm);
    (void)decode(in, rm);

    // The input as a sequence of datagrams: [u8 sender][u8 length][bytes]..., with a tick of the
    // session after each, so state built by earlier datagrams is exercised by later ones.
    WorldSimulation sim(scene, 3);
    SessionConfig cfg;
    cfg.players = 3;
    cfg.max_bad_packets = 1 << 30;
    Session session(cfg, sim);
    std::vector<Datagram> out;
    std::uint64_t now = 0;
    std::size_t at = 0;
    const std::uint8_t local[3] = {1, 2, 3};
    while (at + 2 <= size) {
        const PlayerId from = data[at] % 4;
        const std::size_t len = data[at + 1];
        at += 2;
        const std::size_t n = len < size - at ? len : size - at;
        session.receive(from, in.subspan(at, n), now);
        at += n;
        now += 16667;
        session.advance(local, now);
        out.clear();
        session.poll(now, out);
    }
    return 0;
}
