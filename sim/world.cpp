#include "sim/world.h"

#include <stdexcept>
#include <string>

#include "sim/broadphase.h"
#include "sim/controller.h"
#include "sim/parallel_tasks.h"
#include "sim/rigid_solver.h"
#include "sim/step_kernel.h"
#include "sim/task_pool.h"

namespace lockroll::sim {

// What steps the world, apart from its state: built once from the scene, copied with the world.
struct World::Engine {
    explicit Engine(const SceneDesc& scene) : kernel(scene) {}
    StepKernel<Fixed> kernel;
    ControllerFactors controller;  // used only when the scene has players
    Broadphase broadphase;
    RigidSolver rigid;                      // configured only for rigid scenes
    std::vector<ContactImpulse> impulses;   // state: rigid scenes with warm starting only
    std::vector<std::uint32_t> sleep;       // state: rigid scenes with sleeping only (by id)
};

// How this world runs its parallel phases (World::set_workers, set_task_runner).
struct World::Parallel {
    std::unique_ptr<TaskPool> pool;  // set_workers only
    ParallelTasks tasks;
};

namespace {
const ParallelTasks kSequential;

const SceneDesc& validated(const SceneDesc& scene) {
    if (const std::string err = validate(scene); !err.empty()) throw std::invalid_argument(err);
    return scene;
}
}  // namespace

World::World(const SceneDesc& scene)
    : scene_(validated(scene)), engine_(std::make_unique<Engine>(scene_)) {
    auto& kernel_ = engine_->kernel;
    auto& rigid_ = engine_->rigid;
    kernel_.initial_state(scene_, pos_, vel_);
    player_body_.resize(static_cast<std::size_t>(sim::player_count(scene_)));
    for (std::size_t i = 0; i < scene_.bodies.size(); ++i)
        if (scene_.bodies[i].player >= 0)
            player_body_[static_cast<std::size_t>(scene_.bodies[i].player)] = static_cast<BodyId>(i);
    engine_->controller = ControllerFactors::from(scene_.controller, kernel_.dt());
    rigid_.configure(scene_, kernel_);
    rigid_enabled_ = rigid_.enabled();
    if (rigid_.enabled()) rigid_.initial_state(scene_, orient_, angvel_);
    engine_->impulses.reserve(rigid_.impulse_capacity());  // steps and loads never allocate for it
    if (rigid_.sleeping()) engine_->sleep.assign(scene_.bodies.size(), 0);
    engine_->broadphase.configure(scene_.broadphase, kernel_.dynamic_ids(), kernel_.static_ids(), pos_,
                          rigid_.enabled() ? rigid_.extent() : kernel_.extent(), scene_.contact_margin);
    // Whatever scene construction saturated is part of the initial state.
    overflow_count_ = 0;
}

World::World(const World& other)
    : scene_(other.scene_),
      engine_(std::make_unique<Engine>(*other.engine_)),
      frame_(other.frame_),
      overflow_count_(other.overflow_count_),
      pos_(other.pos_),
      vel_(other.vel_),
      orient_(other.orient_),
      angvel_(other.angvel_),
      player_body_(other.player_body_),
      rigid_enabled_(other.rigid_enabled_) {}

World& World::operator=(const World& other) {
    if (this != &other) *this = World(other);
    return *this;
}

void World::set_workers(int workers) {
    if (workers < 1)
        throw std::invalid_argument("World::set_workers: workers must be at least 1 (got " + std::to_string(workers) + ")");
    if (workers == 1) {
        parallel_.reset();
        return;
    }
    auto p = std::make_unique<Parallel>();
    p->pool = std::make_unique<TaskPool>(workers);
    TaskPool* pool = p->pool.get();
    p->tasks = ParallelTasks(workers, [pool](std::size_t count, const std::function<void(std::size_t)>& task) {
        pool->run(count, task);
    });
    parallel_ = std::move(p);
}

void World::set_task_runner(int tasks, TaskRunner runner) {
    auto p = std::make_unique<Parallel>();
    p->tasks = ParallelTasks(tasks, std::move(runner));  // throws for tasks < 1 or an empty runner
    parallel_ = std::move(p);
}

int World::workers() const { return parallel_ ? parallel_->tasks.chunks() : 1; }

World::World(World&&) noexcept = default;
World& World::operator=(World&&) noexcept = default;
World::~World() = default;

std::size_t World::dynamic_count() const { return engine_->kernel.dynamic_ids().size(); }
bool World::is_static(BodyId id) const { return engine_->kernel.inv_mass(id).raw == 0; }
Shape World::shape(BodyId id) const { return engine_->kernel.shape(id); }
const RigidSolver& World::rigid_solver() const { return engine_->rigid; }
const std::vector<ContactImpulse>& World::contact_impulses() const { return engine_->impulses; }
std::vector<ContactImpulse>& World::carried_impulses() { return engine_->impulses; }
const std::vector<std::uint32_t>& World::sleep_state() const { return engine_->sleep; }
std::vector<std::uint32_t>& World::sleep_words() { return engine_->sleep; }
bool World::asleep(BodyId id) const { return !engine_->sleep.empty() && engine_->sleep[id] == kAsleep; }
Fixed World::inv_mass(BodyId id) const { return engine_->kernel.inv_mass(id); }
Fixed World::dt() const { return engine_->kernel.dt(); }
const std::vector<BodyId>& World::dynamic_ids() const { return engine_->kernel.dynamic_ids(); }
const StepKernel<Fixed>& World::kernel() const { return engine_->kernel; }

void World::step(std::span<const PlayerInput> inputs) {
    auto& kernel_ = engine_->kernel;
    auto& rigid_ = engine_->rigid;
    auto& broadphase_ = engine_->broadphase;
    const ParallelTasks& tasks = parallel_ ? parallel_->tasks : kSequential;
    const std::uint64_t overflow_before = overflow_events();
    const auto control = [this, inputs](std::vector<Vec3>&) {
        if (!player_body_.empty()) apply_controller(inputs);
    };
    if (rigid_.enabled())
        rigid_.step(
            pos_, vel_, orient_, angvel_, engine_->impulses, engine_->sleep,
            [&broadphase_, &rigid_, &tasks](const std::vector<Vec3>& pos, std::vector<BodyPair>& out) {
                broadphase_.find_pairs(pos, rigid_.extent(), out, tasks);
            },
            control, tasks);
    else
        kernel_.step(
            pos_, vel_,
            [&broadphase_, &kernel_, &tasks](const std::vector<Vec3>& pos, std::vector<BodyPair>& out) {
                broadphase_.find_pairs(pos, kernel_.extent(), out, tasks);
            },
            control, tasks);
    ++frame_;
    overflow_count_ += overflow_events() - overflow_before;
}

void World::apply_controller(std::span<const PlayerInput> inputs) {
    for (std::size_t slot = 0; slot < player_body_.size(); ++slot) {
        const PlayerInput in = slot < inputs.size() ? inputs[slot] : PlayerInput{};
        apply_input(engine_->controller, in, vel_[player_body_[slot]]);
    }
}

void World::flip_bit(BodyId id, int field, int bit) {
    if (field >= 6 && field < 10) {
        Quat& q = orient_[id];
        Fixed& f = field == 6 ? q.w : field == 7 ? q.x : field == 8 ? q.y : q.z;
        // Bit b of the stored int32 (raw / 4): the flipped value stays on the 2^-30 grid.
        const auto stored = static_cast<std::uint32_t>(static_cast<std::int32_t>(f.raw / 4)) ^ (std::uint32_t{1} << (bit & 31));
        f.raw = static_cast<std::int64_t>(static_cast<std::int32_t>(stored)) * 4;
        return;
    }
    Vec3& v = field < 3 ? pos_[id] : field < 6 ? vel_[id] : angvel_[id];
    const int k = field < 6 ? field % 3 : field - 10;
    Fixed& f = k == 0 ? v.x : k == 1 ? v.y : v.z;
    f.raw = static_cast<std::int64_t>(static_cast<std::uint64_t>(f.raw) ^ (std::uint64_t{1} << (bit & 63)));
}

}  // namespace lockroll::sim
