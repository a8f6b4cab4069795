// libFuzzer target: arbitrary text as a scene file (harness/match/scene_loader.h). Property: the
// loader either returns a scene or throws SceneError (anything else escaping is a bug), within
// the body limit; an accepted scene builds a World that steps without a crash or undefined
// behaviour. Run with -dict=fuzz/scene.dict.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "harness/match/scene_loader.h"
#include "sim/world.h"

using namespace lockroll;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    // Small scenes only: the limit itself is tested (cli_test); here time goes to the parser.
    harness::set_max_scene_bodies(300);
    const std::string text(reinterpret_cast<const char*>(data), size);
    sim::SceneDesc scene;
    try {
        scene = harness::parse_scene(text, "fuzz");
    } catch (const harness::SceneError&) {
        return 0;
    }
    sim::World world(scene);
    const std::vector<sim::PlayerInput> in(static_cast<std::size_t>(world.player_count()), sim::PlayerInput{100, -100, 50});
    for (int f = 0; f < 2; ++f) world.step(in);
    return 0;
}
