// Consumer of the installed lockroll::sim package: builds a small World in code (a room, one
// player capsule, a spawner of balls), steps it with a scripted input and prints its checksum.
// tests/install runs this against the installed package and the same file built in-tree; the
// two outputs must be identical.
#include <cinttypes>
#include <cstdio>
#include <vector>

#include "sim/snapshot.h"
#include "sim/world.h"

int main() {
    using namespace lockroll::sim;
    SceneDesc scene;
    scene.name = "consumer";
    const Vec3 lo{Fixed::from_int(-5), Fixed::zero(), Fixed::from_int(-5)};
    const Vec3 hi{Fixed::from_int(5), Fixed::from_int(4), Fixed::from_int(5)};
    add_room(scene, lo, hi, Fixed::one());

    BodyDesc player;
    player.shape = Shape::Capsule;
    player.position = {Fixed::zero(), Fixed::one(), Fixed::zero()};
    player.radius = Fixed::ratio(3, 10);
    player.half_height = Fixed::ratio(1, 2);
    player.mass = Fixed::from_int(70);
    player.player = 0;
    scene.bodies.push_back(player);

    SpawnerDesc balls;
    balls.count = 40;
    balls.radius = Fixed::ratio(1, 5);
    balls.region_min = {Fixed::from_int(-4), Fixed::one(), Fixed::from_int(-4)};
    balls.region_max = {Fixed::from_int(4), Fixed::from_int(3), Fixed::from_int(4)};
    balls.max_speed = Fixed::from_int(3);
    balls.seed = 42;
    expand_spawner(scene, balls);

    if (const std::string error = validate(scene); !error.empty()) {
        std::fprintf(stderr, "consumer: invalid scene: %s\n", error.c_str());
        return 1;
    }
    World world(scene);
    std::vector<PlayerInput> inputs(1);
    for (std::uint32_t f = 0; f < 300; ++f) {
        inputs[0].forward = static_cast<std::int8_t>(f % 120 < 60 ? 127 : -127);
        inputs[0].right = static_cast<std::int8_t>(f % 90 < 45 ? 64 : -64);
        world.step(inputs);
    }
    std::printf("lockroll consumer: %zu bodies, frame %" PRIu32 ", overflows %" PRIu64 ", checksum %016" PRIx64 "\n",
                world.body_count(), world.frame(), world.overflow_count(), checksum(world));
    return world.frame() == 300 ? 0 : 1;
}
