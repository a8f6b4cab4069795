// The deterministic physics world: fixed-point bodies in a structure of arrays, stepped at a
// fixed dt. Bit-exact: the same scene and the same inputs give the same bytes on every
// compiler and CPU (see tests/golden/ and scripts/cross-check.sh).
//
// World::step's input, PlayerInput (one per player slot), is defined here too.
//
// Body ids are indices into SceneDesc::bodies, stable for the world's life; they are what
// desync reports, snapshots and the harness name. Static bodies (mass 0) never move and are
// not part of the snapshot.
//
// The step's machinery (kernel, controller factors, broadphase, rigid solver and the impulses it
// carries) lives behind one pointer (Engine, sim/world.cpp), so this installed header names none
// of its types: one indirection per step or per kernel query, no allocation but in construction
// and copying. The state a snapshot stores and a renderer reads (positions, velocities,
// orientations) stays inline here.
//
// Parallel step (opt-in, docs/physics.md "Parallel step"): set_workers() gives the world its
// own pool of threads, set_task_runner() hands it a game's job system instead. Either way the
// step's bits are those of the sequential step, for any worker count and any order the tasks
// run in (docs/determinism.md). The default, one worker, runs the sequential code and nothing
// else. The setting is how the world runs, not state: snapshots and checksums never see it, and
// a copy of a world steps sequentially (a pool's threads are not copied); a move keeps it.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <vector>

#include <lockroll/sim/scene.h>

namespace lockroll::sim {

// One player's input for one frame, what World::step takes per player slot: three signed axes,
// each in [-127, 127] (-128 is clamped to -127 so the range is symmetric). This is all that
// crosses the network per player-frame (rollback/world_simulation.h encodes it as 3 bytes).
struct PlayerInput {
    std::int8_t forward = 0;  // +z
    std::int8_t right = 0;    // +x
    std::int8_t up = 0;       // +y

    friend constexpr bool operator==(const PlayerInput&, const PlayerInput&) = default;
};

// The machinery's types, for the accessors internal code uses (sim/step_kernel.h,
// sim/rigid_solver.h define them).
template <class Number>
class StepKernel;
class RigidSolver;
struct ContactImpulse;

// A game's job system, as the parallel step sees it. Contract: runner(count, task) calls
// task(i) exactly once for every i in [0, count), on any threads, in any order, concurrently or
// not, and returns only after every call has returned. A task never throws (the step's tasks
// do not); the world calls the runner from the thread that steps, a few times per step.
using TaskRunner = std::function<void(std::size_t count, const std::function<void(std::size_t)>& task)>;

class World {
public:
    // The scene must pass validate(); throws std::invalid_argument with validate()'s message
    // otherwise (a programming error: loaders validate and report first).
    explicit World(const SceneDesc& scene);
    World(const World& other);
    World& operator=(const World& other);
    World(World&& other) noexcept;
    World& operator=(World&& other) noexcept;
    ~World();

    // Advances one frame. inputs[p] drives player slot p; slots beyond inputs.size() get a
    // neutral input. Never allocates after the first step.
    void step(std::span<const PlayerInput> inputs);

    // Parallel step. set_workers(n): n - 1 threads of the world's own pool plus the stepping
    // thread; 1 is sequential (the default). set_task_runner(tasks, runner): each parallel phase
    // is cut into `tasks` pieces run by `runner`. Both throw std::invalid_argument for a count
    // below 1 (or an empty runner). workers(): the pool's size or the runner's task count.
    void set_workers(int workers);
    void set_task_runner(int tasks, TaskRunner runner);
    int workers() const;

    std::uint32_t frame() const { return frame_; }
    // Operations that saturated since the world was created (part of state and checksum).
    std::uint64_t overflow_count() const { return overflow_count_; }

    std::size_t body_count() const { return pos_.size(); }
    std::size_t dynamic_count() const;
    int player_count() const { return static_cast<int>(player_body_.size()); }
    BodyId player_body(int slot) const { return player_body_[static_cast<std::size_t>(slot)]; }
    bool is_static(BodyId id) const;
    Shape shape(BodyId id) const;
    const Vec3& position(BodyId id) const { return pos_[id]; }
    const Vec3& velocity(BodyId id) const { return vel_[id]; }
    // Rigid scenes (scene().rigid.enabled) only: orientation and angular velocity (rad/s, world
    // frame) of every body; the particle solver has neither (empty).
    bool rigid() const { return rigid_enabled_; }
    const Quat& orientation(BodyId id) const { return orient_[id]; }
    const Vec3& angular_velocity(BodyId id) const { return angvel_[id]; }
    const RigidSolver& rigid_solver() const;
    // Rigid scenes with rigid.warm_starting: the impulses carried to the next step (state,
    // sorted by key; at most rigid_solver().impulse_capacity()). Empty otherwise.
    const std::vector<ContactImpulse>& contact_impulses() const;
    // Rigid scenes with rigid.sleeping: each body's sleep word (state, by id; 0 for static
    // bodies): how many frames in a row it has been still (saturating at the scene's frames to
    // sleep), or kAsleep. Empty otherwise. asleep(id): false in scenes without sleeping.
    static constexpr std::uint32_t kAsleep = ~std::uint32_t{0};
    const std::vector<std::uint32_t>& sleep_state() const;
    bool asleep(BodyId id) const;
    Fixed inv_mass(BodyId id) const;
    Fixed dt() const;
    const std::vector<BodyId>& dynamic_ids() const;
    // The step algorithm and the per-body constants it uses (sizes, masses, materials).
    const StepKernel<Fixed>& kernel() const;
    const SceneDesc& scene() const { return scene_; }

    // Fault injection for desync tests: flips one bit of one state word of a dynamic body.
    // field: 0..2 position x/y/z, 3..5 velocity x/y/z; rigid scenes also 6..9 orientation
    // w/x/y/z (a bit of the stored 2^-30 grid value, so the world stays on the grid) and 10..12
    // angular velocity x/y/z.
    void flip_bit(BodyId id, int field, int bit);

private:
    friend class SnapshotAccess;
    struct Engine;    // sim/world.cpp
    struct Parallel;  // sim/world.cpp: the pool or runner; not copied

    void apply_controller(std::span<const PlayerInput> inputs);
    std::vector<ContactImpulse>& carried_impulses();  // SnapshotAccess loads them
    std::vector<std::uint32_t>& sleep_words();        // likewise

    SceneDesc scene_;
    std::unique_ptr<Engine> engine_;
    std::unique_ptr<Parallel> parallel_;  // null: sequential

    // Mutable state (exactly what a snapshot stores).
    std::uint32_t frame_ = 0;
    std::uint64_t overflow_count_ = 0;
    std::vector<Vec3> pos_, vel_;
    std::vector<Quat> orient_;  // rigid scenes only
    std::vector<Vec3> angvel_;  // rigid scenes only

    std::vector<BodyId> player_body_;  // by player slot
    bool rigid_enabled_ = false;       // the engine's rigid solver is configured
};

}  // namespace lockroll::sim
