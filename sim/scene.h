// A scene as plain data: what a World is built from. Loaders (JSON in harness/) fill it in;
// sim/ only validates and expands it, so the simulation core never parses text formats.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <lockroll/sim/vec3.h>

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
    // Rigid scenes only (SceneDesc::rigid.enabled): orientation (normalised when the world is
    // built), angular velocity (rad/s, world frame), and per-body overrides of the friction
    // table and the world's damping.
    Quat orientation;
    Vec3 angular_velocity;
    std::optional<Fixed> friction, static_friction;
    std::optional<Fixed> linear_damping, angular_damping;
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
    std::optional<Fixed> friction, static_friction;  // rigid scenes only
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

// How positions follow velocities within a step. Euler (semi-implicit: gravity into velocity,
// then velocity into position) is the seed paper's integrator and the default. Ballistic moves
// by v*dt + g*dt^2/2, which is exact for constant acceleration: free flight and bounce heights
// then carry no integrator error, only rounding.
enum class Integrator : std::uint8_t { Euler, Ballistic };

// Opt-in solver features (docs/stability.md). The defaults are the seed paper's solver exactly,
// and a scene that keeps them runs the original code path, bit for bit and at the same cost;
// any other value switches the world to the extended path.
struct SolverDesc {
    // Physics steps per frame: inputs still arrive once per frame, the solver runs with dt/substeps.
    int substeps = 1;
    Integrator integrator = Integrator::Euler;
    // Fraction of the overlap beyond `slop` removed per iteration (1: all of it, the default).
    Fixed correction = Fixed::one();
    // Overlap left uncorrected, so resting contacts stop fighting over the last micrometres (m).
    Fixed slop = Fixed::zero();
    // Largest speed at which the solver may push a body out of overlaps (m/s): its positional
    // correction in one physics step is capped at max_push_speed * dt. 0 means no cap. Deeply
    // overlapping bodies (a bad spawn) then separate gently instead of being flung apart.
    Fixed max_push_speed = Fixed::zero();
    // Approach speeds below this are treated as inelastic (m/s), so resting bodies do not
    // micro-bounce on e > 0 materials (Box2D's restitution threshold).
    Fixed restitution_threshold = Fixed::zero();
    // Iterations resolve contacts inelastically; restitution is applied once afterwards from the
    // approach speed measured before the iterations (Box2D v3's soft step does the same), so
    // the solver's repeated passes cannot compound it.
    bool restitution_after = false;
    // Position-based velocities (as in XPBD): the iterations only move bodies apart, and each
    // body's velocity then changes by its positional correction / dt, so a correction can never
    // leave a body with velocity that drives it back in (stacks, piles, mass ratios).
    // Restitution is applied afterwards as with restitution_after.
    bool position_based = false;
    // After the iterations, one more pass over the touching contacts from the ground up in which
    // each contact moves only its upper body (shock propagation): stacks and heavy-on-light
    // piles then hold their positions with few iterations, whatever the mass ratio.
    bool shock_propagation = false;
    // Swept motion against static bodies: a dynamic body stops at the exact time it reaches a
    // static one, bounces, and travels on for the rest of the step, so nothing tunnels through
    // walls and bounces conserve energy. Impacts slower than continuous_min_speed (m/s) are left
    // to the contact solver: resting and sliding contacts must not become a stream of tiny
    // bounces, so keep it above gravity * dt (0.16 m/s at 60 Hz). 1 m/s, as Box2D's restitution
    // threshold, by default.
    bool continuous = false;
    Fixed continuous_min_speed = Fixed::one();

    bool is_default() const;
};

// Rigid-body dynamics (opt-in; docs/physics.md): orientation, angular velocity, contact points,
// Coulomb friction and damping. A scene that leaves `enabled` false runs the particle solver
// above exactly as before (same bits, same cost); one that sets it runs sim/rigid_solver.h.
struct RigidDesc {
    bool enabled = false;
    // Kinetic friction coefficient by shape pair (symmetric), and the static one, which a contact
    // must exceed before it starts to slide. A body's own `friction` overrides the table; when
    // both bodies carry one, the pair uses their geometric mean (Box2D's rule).
    Fixed friction[kShapeCount][kShapeCount];
    Fixed static_friction[kShapeCount][kShapeCount];
    // Fraction of velocity lost per second (v *= 1 / (1 + c dt) per step); bodies may override.
    Fixed linear_damping, angular_damping;
    // Positional error fed back per step (Baumgarte factor) beyond `slop` metres of overlap.
    Fixed baumgarte = Fixed::from_raw(Fixed::kOne / 5);
    Fixed slop = Fixed::from_raw(Fixed::kOne / 200);
    // Approach speeds below this (m/s) are resolved without restitution (resting contacts).
    Fixed restitution_threshold = Fixed::from_raw(Fixed::kOne / 2);
    // After the iterations, one pass from the ground up in which each pressing contact moves
    // only its upper body: tall stacks stop sinking whatever the iteration count.
    bool shock_propagation = false;
    // Warm starting: each contact point starts the iterations from the impulses it ended the
    // last step with (matched by the key body a, body b, point index), so tall stacks converge
    // over frames instead of within one. The impulses become state (snapshot layout 2).
    bool warm_starting = false;
    // Split impulses: the overlap beyond `slop` is pushed out by a second, position-only set
    // of velocities (solved after the real ones, used for one step's motion and then dropped),
    // so the Baumgarte push never enters the bodies' velocities and cannot feed a sway.
    bool split_impulse = false;
    // Box-box face manifolds reduced to at most four points, the extremes along the diagonals
    // of the contact plane, each keyed by its diagonal: two nearly equal faces clip to up to
    // eight points whose ids change from step to step, which starves warm starting.
    bool reduce_manifold = false;
    // Each manifold's normal rows solved together, to convergence (repeated sweeps over its
    // points, both ways) before the next manifold: a box's corners then share its load evenly
    // whichever corner comes first, so an unconverged step does not tilt the box.
    bool block_solver = false;
    // Graph-coloured rows: the solver's passes go colour by colour over a greedy colouring of
    // the manifolds (no two in a colour share a dynamic body; sim/graph_colouring.h), each
    // colour's manifolds cut over the workers, instead of manifold by manifold: another
    // Gauss-Seidel order (other bits), the same at any worker count, and a pile's largest
    // island no longer runs on one thread.
    bool graph_colouring = false;
    // Sleeping (docs/physics.md, "Sleeping"): a body whose speed stays below linear_speed
    // (m/s) and whose turn rate stays below angular_speed (rad/s) for `time` seconds
    // (ceil(time * tick_rate) frames), in an island (this step's candidate pairs between awake
    // dynamic bodies) whose every body has, stops being stepped until an awake body comes
    // within reach of its island. Off by default; its state (each body's still-frame count or
    // "asleep") is in the snapshot only when on. Player bodies never sleep.
    struct Sleeping {
        bool enabled = false;
        Fixed linear_speed = Fixed::ratio(1, 20);   // 0.05 m/s (as the JSON "0.05" parses)
        Fixed angular_speed = Fixed::ratio(1, 20);  // 0.05 rad/s
        Fixed time = Fixed::from_raw(Fixed::kOne / 2);            // 0.5 s
    } sleeping;
    // Spinning (torsional) friction and rolling resistance (docs/physics.md, "Spinning and
    // rolling friction"): per contact point, an angular impulse about the normal of at most
    // spinning_friction times the point's normal impulse, and one about the tangent plane of at
    // most rolling_friction times it. Each coefficient is a length (metres: torque per unit of
    // normal force, Bullet's convention), 0 (the default) is off and costs nothing. Scene
    // constants, not state: the rows start from zero each step (no warm start).
    Fixed spinning_friction, rolling_friction;

    RigidDesc();
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
    SolverDesc solver;
    RigidDesc rigid;
    std::vector<BodyDesc> bodies;

    SceneDesc();
};

// Six static boxes of the given wall thickness enclosing [min, max].
void add_room(SceneDesc& scene, const Vec3& min, const Vec3& max, Fixed wall_thickness);

// Appends the spawner's bodies. Positions are drawn uniformly in the region, rejecting spots
// that overlap an earlier spawned body (kSpawnTries tries, then accepted overlapping: the
// solver pushes them apart); velocities uniform in [-max_speed, max_speed] per axis.
//
// Linear time in count, whatever the region: the overlap test looks at 27 grid cells holding
// at most kSpawnCellLimit positions each, and once kSpawnCrowdedLimit bodies found no free
// spot the region counts as full and later bodies take their first draw without a test. Both
// limits sit far above what a region that still has room produces (a cell of edge < 4r holds
// at most ~40 non-overlapping bodies), so they change nothing in a scene that fits; they only
// stop an over-full spawner from costing O(count^2).
inline constexpr int kSpawnTries = 64;
inline constexpr std::size_t kSpawnCellLimit = 64;
inline constexpr std::int64_t kSpawnCrowdedLimit = 256;
void expand_spawner(SceneDesc& scene, const SpawnerDesc& spawner);

// Checks a scene for what would make a World meaningless (non-positive sizes, tick rate or
// iterations out of range, player slots not 0..P-1, static player bodies). Returns an empty
// string when valid, otherwise a message naming the body index and field.
std::string validate(const SceneDesc& scene);

// Number of player slots (max player index + 1).
int player_count(const SceneDesc& scene);

}  // namespace lockroll::sim
