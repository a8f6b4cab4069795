// A scene as plain data: what a World is built from. Loaders (JSON in harness/) fill it in;
// sim/ only validates and expands it, so the simulation core never parses text formats.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "sim/vec3.h"

namespace lockroll::sim {

// Every collider is a "core" swept by a radius: a sphere is a point, an upright capsule a
// vertical segment, an axis-aligned box a box with radius 0. Narrowphase needs three routines.
enum class Shape : std::uint8_t { Sphere = 0, Box = 1, Capsule = 2 };
inline constexpr int kShapeCount = 3;
const char* shape_name(Shape s);

struct BodyDesc {
    Shape shape = Shape::Sphere;
    Vec3 position;
    Vec3 velocity;
    Fixed radius;           // sphere, capsule
    Vec3 half_extents;      // box
    Fixed half_height;      // capsule: half the length of its vertical core segment
    Fixed mass;             // 0 means static (infinite mass, never moves)
    Fixed gravity_scale = Fixed::one();
    std::optional<Fixed> restitution;  // overrides the shape-pair table (pairs combine by max)
    int player = -1;        // player slot that steers this body, or -1
};

// "count bodies of this shape in region [min, max], random velocities up to max_speed per
// axis, from seed": expanded into BodyDescs by expand_spawner, bit-exactly on every platform.
struct SpawnerDesc {
    int count = 0;
    Shape shape = Shape::Sphere;
    Fixed radius;
    Vec3 half_extents;
    Fixed half_height;
    Fixed mass = Fixed::one();
    Fixed gravity_scale = Fixed::one();
    std::optional<Fixed> restitution;
    Vec3 region_min, region_max;
    Fixed max_speed;
    std::uint64_t seed = 1;
};

// Player controller tuning (rule in docs/controller.md).
struct ControllerDesc {
    Fixed max_speed = Fixed::from_raw(6 * Fixed::kOne);        // m/s at full stick, horizontal
    Fixed acceleration = Fixed::from_raw(40 * Fixed::kOne);    // m/s^2 toward the target velocity
    Fixed vertical_acceleration = Fixed::from_raw(20 * Fixed::kOne);  // m/s^2 at full "up"
};

// Auto picks sweep-and-prune for small scenes and a uniform grid for large ones.
enum class BroadphaseKind : std::uint8_t { Auto, SweepAndPrune, Grid };

using BodyId = std::uint32_t;

struct SceneDesc {
    std::string name;
    Vec3 gravity{Fixed::zero(), Fixed::from_raw(-981 * Fixed::kOne / 100), Fixed::zero()};
    int tick_rate = 60;
    int iterations = 4;
    // restitution[a][b] by Shape; symmetric. Defaults are the seed paper's rules.
    Fixed restitution[kShapeCount][kShapeCount];
    // Fattening of the per-step candidate AABBs: pairs that come within this distance during
    // the solver iterations of a step are still found.
    Fixed contact_margin = Fixed::from_raw(Fixed::kOne / 20);
    BroadphaseKind broadphase = BroadphaseKind::Auto;
    ControllerDesc controller;
    std::vector<BodyDesc> bodies;

    SceneDesc();
};

// Six static boxes of the given wall thickness enclosing [min, max].
void add_room(SceneDesc& scene, const Vec3& min, const Vec3& max, Fixed wall_thickness);

// Appends the spawner's bodies. Positions are drawn uniformly in the region, rejecting spots
// that overlap an earlier spawned body (bounded tries, then accepted overlapping: the solver
// pushes them apart); velocities uniform in [-max_speed, max_speed] per axis.
void expand_spawner(SceneDesc& scene, const SpawnerDesc& spawner);

// Checks a scene for what would make a World meaningless (non-positive sizes, tick rate or
// iterations out of range, player slots not 0..P-1, static player bodies). Returns an empty
// string when valid, otherwise a message naming the body index and field.
std::string validate(const SceneDesc& scene);

// Number of player slots (max player index + 1).
int player_count(const SceneDesc& scene);

}  // namespace lockroll::sim
