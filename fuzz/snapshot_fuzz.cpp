// libFuzzer target: arbitrary bytes as a world snapshot (sim/snapshot.h load, through
// rollback::WorldSimulation::load as a session does). Property: a rejected snapshot leaves the
// world untouched; an accepted one saves back to the same bytes; and the world then steps, is
// checksummed and described without a crash or undefined behaviour, whatever numbers it holds
// (a peer's snapshot is untrusted input once late joiners receive one).
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <span>
#include <vector>

#include "rollback/world_simulation.h"
#include "sim/snapshot.h"
#include "tests/rollback/test_support.h"

using namespace lockroll;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    // Two player boxes and six balls in the test room: 8 dynamic bodies, 408-byte snapshots.
    static const sim::SceneDesc scene = rollback::testing::make_scene(2, 6);
    rollback::WorldSimulation sim(scene, 2);
    std::vector<std::uint8_t> before(sim.state_size()), after(sim.state_size());
    sim.save(before);
    const std::span<const std::uint8_t> in(data, size);
    if (!sim.load(in).empty()) {
        sim.save(after);
        if (after != before) std::abort();  // a rejected load changed the world
        return 0;
    }
    sim.save(after);
    if (!std::equal(after.begin(), after.end(), in.begin(), in.end())) std::abort();
    (void)sim.describe_state(after);
    for (std::uint32_t i = 0; i < sim.body_count(); ++i) (void)sim.body_hash(after, i);
    const std::uint8_t inputs[6] = {127, 129, 1, 0, 0, 127};
    for (int f = 0; f < 3; ++f) sim.step(inputs);
    sim.save(after);
    (void)sim.checksum(after);
    return 0;
}
