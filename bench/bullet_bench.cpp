// lockroll's rigid solver against Bullet (btDiscreteDynamicsWorld), side by side in one run.
//
// Both engines get the same scene, built from the same sim::SceneDesc (harness scene files):
// the same bodies, shapes (sphere, box, capsule along local y), sizes, masses, positions,
// velocities, orientations and angular velocities, gravity, tick rate (one fixed step of
// 1/tick_rate per frame) and solver iteration count. Restitution and friction come from the
// scene's per-pair tables on both sides (Bullet through its contact-added material callback;
// Bullet has one friction coefficient, so it gets the kinetic one). Bullet's deactivation
// (sleeping) is switched off by default: both compute every body every step. `--sleep` turns
// on rigid.sleeping (its thresholds as the scene gives them, the defaults otherwise: 0.05 m/s,
// 0.05 rad/s, 0.5 s) in every lockroll scene, and Bullet's deactivation for every dynamic body
// with the same rule (setSleepingThresholds(linear, angular), gDeactivationTime = time), so
// both engines sleep alike; with --settle it also prints how many bodies each has asleep.
// `--spin MU` and `--roll MU` set rigid.spinning_friction and rigid.rolling_friction (metres)
// in every lockroll scene and the same coefficients in Bullet: setSpinningFriction and
// setRollingFriction on every body, and each contact point's combined values set to MU in the
// material callback (Bullet would otherwise combine them as spin_a mu_b + mu_a spin_b). Bullet
// builds its torsional rows only when the combined rolling friction is > 0: with --spin alone
// its rolling coefficient is 1e-9 (no measurable resistance) so the spin row exists.
// Players are driven as in the paper scene's matches: each slot's input is the random bot's
// (harness/match/bots.h, seed 1, 4 changes a second, as `lockroll compare` runs them), a pure
// function of slot and frame, and both engines apply it by lockroll's controller rule
// (sim/controller.h; Bullet: to the body's velocity before each step, which lockroll applies
// after the step's gravity: the same horizontal velocities, the rule does not look at v.y).
// `--neutral` gives every player neutral input instead (the bench before issue 19).
//
// Measurement: for each scene, `--reps` rounds; each round builds both worlds afresh and steps
// each `--frames` frames, alternating which engine goes first, timed by thread CPU time (the
// machine is shared: wall time would count other jobs). Prints the median CPU time per step of
// each engine and the ratio Bullet / lockroll (> 1: lockroll faster). Not a test: results go to
// docs/performance.md.
//
// Bullet keeps its own solver defaults (btContactSolverInfo): warm starting (factor 0.85),
// Baumgarte erp 0.2, split impulses for overlaps deeper than 4 cm, restitution only above a
// 0.2 m/s approach, measured from the velocity before this step's gravity.
//
// `--settle N` instead steps each scene N frames in both engines (no timing) and prints, every
// `--every` frames, per engine: the kinetic energy of the dynamic bodies (translational +
// rotational, J), the spheres' share of it, the rotational part, the vertical part (m vy^2 / 2:
// hopping), the mean height of the centres (m), how many spheres sit above 1.5 radii (on other
// bodies), the deepest sphere into the floor (mm, floor at y = 0 as in the shipped rooms) and,
// the contact points of the last step (what a step's solver work scales with; Bullet's: the
// points held in its persistent manifolds, at most 4 a pair):
// whether a pile comes to rest, and how it compares with Bullet's on the same scene
// (docs/physics.md). `--lockroll-only` leaves Bullet out, for quick what-ifs on scene files.
#include <btBulletDynamicsCommon.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <memory>
#include <string>
#include <vector>

#include "bench/median.h"
#include "harness/match/bots.h"
#include "harness/match/scene_loader.h"
#include "sim/controller.h"
#include "sim/inertia.h"
#include "sim/rigid_solver.h"
#include "sim/world.h"

namespace {
using namespace lockroll;

double num(sim::Fixed f) { return static_cast<double>(f.raw) / static_cast<double>(sim::Fixed::kOne); }
btVector3 vec(const sim::Vec3& v) {
    return {static_cast<btScalar>(num(v.x)), static_cast<btScalar>(num(v.y)), static_cast<btScalar>(num(v.z))};
}

double thread_seconds() {
    timespec ts{};
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return static_cast<double>(ts.tv_sec) + static_cast<double>(ts.tv_nsec) * 1e-9;
}

// Pair restitution and friction exactly as sim/rigid_solver.cpp combines them (per-body
// overrides: max for restitution, geometric mean for friction; else the shape-pair table).
struct Materials {
    const sim::SceneDesc* scene = nullptr;
    double restitution(int a, int b) const {
        const sim::BodyDesc &x = scene->bodies[static_cast<std::size_t>(a)], &y = scene->bodies[static_cast<std::size_t>(b)];
        if (x.restitution || y.restitution)
            return std::max(x.restitution ? num(*x.restitution) : -1.0, y.restitution ? num(*y.restitution) : -1.0);
        return num(scene->restitution[static_cast<int>(x.shape)][static_cast<int>(y.shape)]);
    }
    double friction(int a, int b) const {
        const sim::BodyDesc &x = scene->bodies[static_cast<std::size_t>(a)], &y = scene->bodies[static_cast<std::size_t>(b)];
        if (x.friction && y.friction) return std::sqrt(num(*x.friction) * num(*y.friction));
        if (x.friction) return num(*x.friction);
        if (y.friction) return num(*y.friction);
        return num(scene->rigid.friction[static_cast<int>(x.shape)][static_cast<int>(y.shape)]);
    }
};
Materials g_materials;
double g_spin = 0, g_roll = 0;  // --spin, --roll (metres)
// Bullet's combined rolling friction: > 0 whenever either is on (see the header).
double bullet_roll() { return g_roll > 0 ? g_roll : g_spin > 0 ? 1e-9 : 0; }

bool material_callback(btManifoldPoint& cp, const btCollisionObjectWrapper* a, int, int, const btCollisionObjectWrapper* b,
                       int, int) {
    const int ia = a->getCollisionObject()->getUserIndex(), ib = b->getCollisionObject()->getUserIndex();
    cp.m_combinedRestitution = static_cast<btScalar>(g_materials.restitution(ia, ib));
    cp.m_combinedFriction = static_cast<btScalar>(g_materials.friction(ia, ib));
    cp.m_combinedSpinningFriction = static_cast<btScalar>(g_spin);
    cp.m_combinedRollingFriction = static_cast<btScalar>(bullet_roll());
    return true;
}

// The players' inputs of one frame, the same for both engines.
class Drivers {
public:
    Drivers(const sim::SceneDesc& scene, bool neutral) : inputs_(static_cast<std::size_t>(sim::player_count(scene))) {
        if (neutral) return;
        for (int slot = 0; slot < sim::player_count(scene); ++slot)
            bots_.emplace_back(harness::BotConfig{harness::BotKind::Random, 1, scene.tick_rate, 4.0}, slot);
    }
    const std::vector<sim::PlayerInput>& at(std::uint32_t frame) {
        for (std::size_t slot = 0; slot < bots_.size(); ++slot) inputs_[slot] = bots_[slot].random_walk(frame);
        return inputs_;
    }

private:
    std::vector<harness::Bot> bots_;
    std::vector<sim::PlayerInput> inputs_;
};
bool g_neutral = false;
bool g_sleep = false;

// The scene as a Bullet world; owns everything it allocates.
class BulletScene {
public:
    explicit BulletScene(const sim::SceneDesc& scene)
        : dispatcher_(&config_), world_(&dispatcher_, &broadphase_, &solver_, &config_), dt_(1.0 / scene.tick_rate),
          controller_(scene.controller) {
        world_.setGravity(vec(scene.gravity));
        world_.getSolverInfo().m_numIterations = scene.iterations;
        for (std::size_t i = 0; i < scene.bodies.size(); ++i) {
            const sim::BodyDesc& b = scene.bodies[i];
            std::unique_ptr<btCollisionShape> shape;
            if (b.shape == sim::Shape::Sphere) shape = std::make_unique<btSphereShape>(num(b.radius));
            else if (b.shape == sim::Shape::Box) shape = std::make_unique<btBoxShape>(vec(b.half_extents));
            else shape = std::make_unique<btCapsuleShape>(num(b.radius), 2 * num(b.half_height));  // along y
            const double mass = num(b.mass);
            btVector3 inertia(0, 0, 0);
            if (mass > 0) shape->calculateLocalInertia(mass, inertia);
            const sim::Quat& q = b.orientation;
            btTransform t(btQuaternion(num(q.x), num(q.y), num(q.z), num(q.w)).normalized(), vec(b.position));
            motion_.push_back(std::make_unique<btDefaultMotionState>(t));
            btRigidBody::btRigidBodyConstructionInfo info(mass, motion_.back().get(), shape.get(), inertia);
            auto body = std::make_unique<btRigidBody>(info);
            body->setUserIndex(static_cast<int>(i));
            body->setCollisionFlags(body->getCollisionFlags() | btCollisionObject::CF_CUSTOM_MATERIAL_CALLBACK);
            body->setSpinningFriction(static_cast<btScalar>(g_spin));
            body->setRollingFriction(static_cast<btScalar>(bullet_roll()));
            if (mass > 0) {
                body->setLinearVelocity(vec(b.velocity));
                body->setAngularVelocity(vec(b.angular_velocity));
                if (g_sleep && b.player < 0) {  // players never sleep in lockroll either
                    const sim::RigidDesc::Sleeping& sl = scene.rigid.sleeping;
                    body->setSleepingThresholds(static_cast<btScalar>(num(sl.linear_speed)),
                                                static_cast<btScalar>(num(sl.angular_speed)));
                } else {
                    body->setActivationState(DISABLE_DEACTIVATION);
                }
                const double lin = num(b.linear_damping ? *b.linear_damping : scene.rigid.linear_damping);
                const double ang = num(b.angular_damping ? *b.angular_damping : scene.rigid.angular_damping);
                // lockroll: v /= 1 + c dt per step; Bullet: v *= (1 - d)^dt.
                const auto bullet_damping = [&](double c) { return 1 - std::pow(1 + c * dt_, -1 / dt_); };
                body->setDamping(bullet_damping(lin), bullet_damping(ang));
            }
            world_.addRigidBody(body.get());
            if (b.player >= 0) {
                if (players_.size() <= static_cast<std::size_t>(b.player)) players_.resize(static_cast<std::size_t>(b.player) + 1);
                players_[static_cast<std::size_t>(b.player)] = body.get();
            }
            shapes_.push_back(std::move(shape));
            bodies_.push_back(std::move(body));
        }
    }
    ~BulletScene() {
        for (auto& b : bodies_) world_.removeRigidBody(b.get());
    }
    BulletScene(const BulletScene&) = delete;
    BulletScene& operator=(const BulletScene&) = delete;

    // lockroll's controller rule (sim/controller.cpp) on each player body, then one step.
    void step(const std::vector<sim::PlayerInput>& in) {
        const double per_unit = num(controller_.max_speed) / 127, accel_dt = num(controller_.acceleration) * dt_;
        const double vaccel_dt = num(controller_.vertical_acceleration) * dt_ / 127;
        for (std::size_t slot = 0; slot < players_.size() && slot < in.size(); ++slot) {
            if (players_[slot] == nullptr) continue;
            btVector3 v = players_[slot]->getLinearVelocity();
            const auto axis = [](std::int8_t a) { return static_cast<double>(sim::clamp_axis(a)); };
            const auto toward = [&](double target, double now) { return std::clamp(target - now, -accel_dt, accel_dt); };
            v.setX(v.x() + static_cast<btScalar>(toward(per_unit * axis(in[slot].right), v.x())));
            v.setZ(v.z() + static_cast<btScalar>(toward(per_unit * axis(in[slot].forward), v.z())));
            v.setY(v.y() + static_cast<btScalar>(vaccel_dt * axis(in[slot].up)));
            players_[slot]->setLinearVelocity(v);
        }
        world_.stepSimulation(static_cast<btScalar>(dt_), 0);
    }
    const std::vector<std::unique_ptr<btRigidBody>>& bodies() const { return bodies_; }
    // Contact points in Bullet's persistent manifolds after the last step (at most 4 a pair),
    // the counterpart of lockroll's contact_count().
    std::size_t asleep() const {
        std::size_t n = 0;
        for (const auto& b : bodies_) n += b->getInvMass() != 0 && b->getActivationState() == ISLAND_SLEEPING;
        return n;
    }
    std::size_t contact_points() {
        std::size_t n = 0;
        for (int i = 0; i < dispatcher_.getNumManifolds(); ++i)
            n += static_cast<std::size_t>(dispatcher_.getManifoldByIndexInternal(i)->getNumContacts());
        return n;
    }

private:
    btDefaultCollisionConfiguration config_;
    btCollisionDispatcher dispatcher_;
    btDbvtBroadphase broadphase_;
    btSequentialImpulseConstraintSolver solver_;
    btDiscreteDynamicsWorld world_;
    double dt_;
    sim::ControllerDesc controller_;
    std::vector<btRigidBody*> players_;  // by slot
    std::vector<std::unique_ptr<btCollisionShape>> shapes_;
    std::vector<std::unique_ptr<btDefaultMotionState>> motion_;
    std::vector<std::unique_ptr<btRigidBody>> bodies_;
};

// CPU seconds per step over `frames` steps of a fresh world.
// The inputs are made before the clock starts (a bot's draw is not the engine's work).
std::vector<std::vector<sim::PlayerInput>> inputs_for(const sim::SceneDesc& scene, int frames) {
    Drivers d(scene, g_neutral);
    std::vector<std::vector<sim::PlayerInput>> all;
    for (int f = 0; f < frames; ++f) all.push_back(d.at(static_cast<std::uint32_t>(f)));
    return all;
}
double time_lockroll(const sim::SceneDesc& scene, int frames) {
    sim::World w(scene);
    const auto in = inputs_for(scene, frames);
    const double t0 = thread_seconds();
    for (int f = 0; f < frames; ++f) w.step(in[static_cast<std::size_t>(f)]);
    return (thread_seconds() - t0) / frames;
}
double time_bullet(const sim::SceneDesc& scene, int frames) {
    BulletScene w(scene);
    const auto in = inputs_for(scene, frames);
    const double t0 = thread_seconds();
    for (int f = 0; f < frames; ++f) w.step(in[static_cast<std::size_t>(f)]);
    return (thread_seconds() - t0) / frames;
}

// What --settle reports of one world at one frame.
struct Rest {
    double ke_spheres = 0, ke_others = 0, ke_rot = 0, ke_vertical = 0, height_sum = 0;
    std::size_t count = 0, lifted = 0;  // lifted: spheres whose centre is above 1.5 radii (on others)
    double sink = 0;  // deepest sphere into the floor (radius - height; the shipped rooms' floor is y = 0)
    double ke() const { return ke_spheres + ke_others; }
    double mean_height() const { return count ? height_sum / static_cast<double>(count) : 0; }
    void add(bool sphere, double mass, double radius, const double v[3], const double w_body[3], const double inertia[3],
             double y) {
        ke_vertical += 0.5 * mass * v[1] * v[1];
        if (sphere && y > 1.5 * radius) ++lifted;
        if (sphere) sink = std::max(sink, radius - y);
        const double lin = 0.5 * mass * (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
        const double rot = 0.5 * (inertia[0] * w_body[0] * w_body[0] + inertia[1] * w_body[1] * w_body[1] +
                                  inertia[2] * w_body[2] * w_body[2]);
        (sphere ? ke_spheres : ke_others) += lin + rot;
        ke_rot += rot;
        height_sum += y;
        ++count;
    }
};

Rest rest_of(const sim::World& w) {
    Rest r;
    const sim::SceneDesc& scene = w.scene();
    for (sim::BodyId id : w.dynamic_ids()) {
        const sim::BodyDesc& b = scene.bodies[id];
        const sim::Vec3 vi = w.velocity(id), wi = w.angular_velocity(id);
        const double v[3] = {num(vi.x), num(vi.y), num(vi.z)};
        // Angular velocity into the body frame: R^T w, R from the unit quaternion.
        const sim::Quat& q = w.orientation(id);
        const btMatrix3x3 rot(btQuaternion(num(q.x), num(q.y), num(q.z), num(q.w)));
        const btVector3 wb = rot.transpose() * btVector3(num(wi.x), num(wi.y), num(wi.z));
        const double w_body[3] = {wb.x(), wb.y(), wb.z()};
        const sim::Vec3 in = sim::inertia(b.shape, b.radius, b.half_extents, b.half_height, b.mass);
        const double inertia[3] = {num(in.x), num(in.y), num(in.z)};
        r.add(b.shape == sim::Shape::Sphere, num(b.mass), num(b.radius), v, w_body, inertia, num(w.position(id).y));
    }
    return r;
}
Rest rest_of(const BulletScene& w, const sim::SceneDesc& scene) {
    Rest r;
    for (const auto& body : w.bodies()) {
        if (body->getInvMass() == 0) continue;
        const sim::BodyDesc& b = scene.bodies[static_cast<std::size_t>(body->getUserIndex())];
        const btVector3 vi = body->getLinearVelocity();
        const btVector3 wb = body->getWorldTransform().getBasis().transpose() * body->getAngularVelocity();
        const btVector3 in = body->getLocalInertia();
        const double v[3] = {vi.x(), vi.y(), vi.z()}, w_body[3] = {wb.x(), wb.y(), wb.z()};
        const double inertia[3] = {in.x(), in.y(), in.z()};
        r.add(b.shape == sim::Shape::Sphere, 1 / body->getInvMass(), num(b.radius), v, w_body, inertia,
              body->getWorldTransform().getOrigin().y());
    }
    return r;
}

// --settle: both engines side by side, every `every` frames up to `frames`.
void settle(const sim::SceneDesc& scene, int frames, int every, bool with_bullet) {
    sim::World ours(scene);
    std::unique_ptr<BulletScene> theirs;
    if (with_bullet) theirs = std::make_unique<BulletScene>(scene);
    Drivers drivers(scene, g_neutral);
    std::printf("%-18s %6s | %10s %10s %10s %10s %8s %6s %7s %6s | %10s %10s %10s %10s %8s %6s %7s %6s\n", "scene",
                "frame", "lockroll J", "spheres", "rotation", "vertical", "height m", "lifted", "sink mm", "points",
                "bullet J", "spheres", "rotation", "vertical", "height m", "lifted", "sink mm", "points");
    for (int f = 1; f <= frames; ++f) {
        const std::vector<sim::PlayerInput>& in = drivers.at(static_cast<std::uint32_t>(f - 1));
        ours.step(in);
        if (theirs) theirs->step(in);
        if (f % every != 0 && f != frames) continue;
        const Rest a = rest_of(ours), b = theirs ? rest_of(*theirs, scene) : Rest{};
        std::printf(
            "%-18s %6d | %10.2f %10.2f %10.2f %10.2f %8.4f %6zu %7.2f %6zu | %10.2f %10.2f %10.2f %10.2f %8.4f %6zu "
            "%7.2f %6zu\n",
            scene.name.c_str(), f, a.ke(), a.ke_spheres, a.ke_rot, a.ke_vertical, a.mean_height(), a.lifted, a.sink * 1e3,
            ours.rigid_solver().contact_count(), b.ke(), b.ke_spheres, b.ke_rot, b.ke_vertical, b.mean_height(), b.lifted,
            b.sink * 1e3, theirs ? theirs->contact_points() : std::size_t{0});
        if (g_sleep) {
            std::size_t ours_asleep = 0;
            for (sim::BodyId id : ours.dynamic_ids()) ours_asleep += ours.asleep(id);
            std::printf("%-18s %6d | asleep: lockroll %zu of %zu, bullet %zu\n", scene.name.c_str(), f, ours_asleep,
                        ours.dynamic_count(), theirs ? theirs->asleep() : std::size_t{0});
        }
        std::fflush(stdout);
    }
}

using lockroll::bench::median;
}  // namespace

int main(int argc, char** argv) {
    CLI::App app{"Steps rigid scenes in lockroll and in Bullet, alternating, and prints medians and ratios"};
    std::vector<std::string> scenes{"paper_rigid", "bodies_1k_rigid", "bodies_10k_rigid"};
    std::vector<int> frames{720, 720, 720};
    int reps = 7;
    int settle_frames = 0, every = 60;
    bool lockroll_only = false;
    app.add_option("--scenes", scenes, "Scene names or files (rigid scenes)");
    app.add_option("--frames", frames, "Frames per round, one per scene (default 720 each: a scene's whole life)");
    app.add_option("--reps", reps, "Rounds per scene (median over them)")->check(CLI::Range(1, 1000));
    app.add_option("--settle", settle_frames,
                   "Instead of timing: step each scene this many frames in both engines and print kinetic "
                   "energy and mean height")
        ->check(CLI::Range(1, 1000000));
    app.add_option("--every", every, "With --settle: print every this many frames")->check(CLI::Range(1, 1000000));
    app.add_flag("--neutral", g_neutral, "Players get neutral input (they stand) instead of the random bot's");
    app.add_flag("--sleep", g_sleep,
                 "Both engines sleep: rigid.sleeping on in every scene, Bullet's deactivation with the same "
                 "thresholds and time (else both step every body)");
    app.add_option("--spin", g_spin, "Spinning friction (metres) in both engines: rigid.spinning_friction")
        ->check(CLI::Range(0.0, 1.0));
    app.add_option("--roll", g_roll, "Rolling resistance (metres) in both engines: rigid.rolling_friction")
        ->check(CLI::Range(0.0, 1.0));
    app.add_flag("--lockroll-only", lockroll_only, "With --settle: leave Bullet out (quick what-ifs on scene files)");
    try {
        app.parse(argc, argv);
    } catch (const CLI::CallForHelp& e) {
        return app.exit(e);
    } catch (const CLI::ParseError& e) {
        // Bad flags: CLI11's message names the flag and value; exit 2 before any work.
        std::fprintf(stderr, "bullet_bench: %s\n", e.what());
        return 2;
    }
    if (settle_frames == 0 && frames.size() != scenes.size()) {
        std::fprintf(stderr, "bullet_bench: --frames needs one value per scene (%zu scenes, %zu values)\n",
                     scenes.size(), frames.size());
        return 2;
    }
    std::vector<sim::SceneDesc> loaded;
    for (std::size_t s = 0; s < scenes.size(); ++s) {
        loaded.push_back(harness::load_scene(scenes[s]));
        if (!loaded.back().rigid.enabled) {
            std::fprintf(stderr, "bullet_bench: scene %s is not rigid (no \"rigid\")\n", scenes[s].c_str());
            return 2;
        }
        if (settle_frames == 0 && frames[s] < 1) {
            std::fprintf(stderr, "bullet_bench: --frames must be >= 1\n");
            return 2;
        }
    }
    gContactAddedCallback = material_callback;
    if (g_sleep) {
        for (sim::SceneDesc& scene : loaded) scene.rigid.sleeping.enabled = true;
        // One time for every scene (Bullet's is a global): the first scene's.
        gDeactivationTime = static_cast<btScalar>(num(loaded.front().rigid.sleeping.time));
    }
    for (sim::SceneDesc& scene : loaded) {
        // The bench's doubles to Fixed by the loader's own parser (the same bits as in JSON).
        const auto fixed = [](double v) { return *sim::Fixed::parse(std::to_string(v)); };
        if (g_spin > 0) scene.rigid.spinning_friction = fixed(g_spin);
        if (g_roll > 0) scene.rigid.rolling_friction = fixed(g_roll);
    }
    if (settle_frames > 0) {
        for (const sim::SceneDesc& scene : loaded) {
            g_materials.scene = &scene;
            settle(scene, settle_frames, every, !lockroll_only);
        }
        return 0;
    }
    std::printf("%-18s %7s %6s %4s %16s %16s %8s\n", "scene", "bodies", "frames", "reps", "lockroll us/step",
                "bullet us/step", "ratio");
    for (std::size_t s = 0; s < loaded.size(); ++s) {
        const sim::SceneDesc& scene = loaded[s];
        g_materials.scene = &scene;
        std::vector<double> ours, theirs;
        for (int r = 0; r < reps; ++r) {
            if (r % 2 == 0) {
                ours.push_back(time_lockroll(scene, frames[s]));
                theirs.push_back(time_bullet(scene, frames[s]));
            } else {
                theirs.push_back(time_bullet(scene, frames[s]));
                ours.push_back(time_lockroll(scene, frames[s]));
            }
        }
        const double a = median(ours), b = median(theirs);
        std::printf("%-18s %7zu %6d %4d %16.1f %16.1f %8.2f\n", scene.name.c_str(), scene.bodies.size(), frames[s], reps,
                    a * 1e6, b * 1e6, b / a);
        std::fflush(stdout);
    }
    return 0;
}
