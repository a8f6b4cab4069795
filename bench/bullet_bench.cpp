// lockroll's rigid solver against Bullet (btDiscreteDynamicsWorld), side by side in one run.
//
// Both engines get the same scene, built from the same sim::SceneDesc (harness scene files):
// the same bodies, shapes (sphere, box, capsule along local y), sizes, masses, positions,
// velocities, orientations and angular velocities, gravity, tick rate (one fixed step of
// 1/tick_rate per frame) and solver iteration count. Restitution and friction come from the
// scene's per-pair tables on both sides (Bullet through its contact-added material callback;
// Bullet has one friction coefficient, so it gets the kinetic one). Bullet's deactivation
// (sleeping) is switched off, since lockroll has none: both compute every body every step.
// Players get neutral input (Bullet has no controller), so they just stand.
//
// Measurement: for each scene, `--reps` rounds; each round builds both worlds afresh and steps
// each `--frames` frames, alternating which engine goes first, timed by thread CPU time (the
// machine is shared: wall time would count other jobs). Prints the median CPU time per step of
// each engine and the ratio Bullet / lockroll (> 1: lockroll faster). Not a test: results go to
// docs/performance.md.
#include <btBulletDynamicsCommon.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <memory>
#include <string>
#include <vector>

#include "harness/match/scene_loader.h"
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

bool material_callback(btManifoldPoint& cp, const btCollisionObjectWrapper* a, int, int, const btCollisionObjectWrapper* b,
                       int, int) {
    const int ia = a->getCollisionObject()->getUserIndex(), ib = b->getCollisionObject()->getUserIndex();
    cp.m_combinedRestitution = static_cast<btScalar>(g_materials.restitution(ia, ib));
    cp.m_combinedFriction = static_cast<btScalar>(g_materials.friction(ia, ib));
    return true;
}

// The scene as a Bullet world; owns everything it allocates.
class BulletScene {
public:
    explicit BulletScene(const sim::SceneDesc& scene)
        : dispatcher_(&config_), world_(&dispatcher_, &broadphase_, &solver_, &config_), dt_(1.0 / scene.tick_rate) {
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
            if (mass > 0) {
                body->setLinearVelocity(vec(b.velocity));
                body->setAngularVelocity(vec(b.angular_velocity));
                body->setActivationState(DISABLE_DEACTIVATION);
                const double lin = num(b.linear_damping ? *b.linear_damping : scene.rigid.linear_damping);
                const double ang = num(b.angular_damping ? *b.angular_damping : scene.rigid.angular_damping);
                // lockroll: v /= 1 + c dt per step; Bullet: v *= (1 - d)^dt.
                const auto bullet_damping = [&](double c) { return 1 - std::pow(1 + c * dt_, -1 / dt_); };
                body->setDamping(bullet_damping(lin), bullet_damping(ang));
            }
            world_.addRigidBody(body.get());
            shapes_.push_back(std::move(shape));
            bodies_.push_back(std::move(body));
        }
    }
    ~BulletScene() {
        for (auto& b : bodies_) world_.removeRigidBody(b.get());
    }
    BulletScene(const BulletScene&) = delete;
    BulletScene& operator=(const BulletScene&) = delete;

    void step() { world_.stepSimulation(static_cast<btScalar>(dt_), 0); }

private:
    btDefaultCollisionConfiguration config_;
    btCollisionDispatcher dispatcher_;
    btDbvtBroadphase broadphase_;
    btSequentialImpulseConstraintSolver solver_;
    btDiscreteDynamicsWorld world_;
    double dt_;
    std::vector<std::unique_ptr<btCollisionShape>> shapes_;
    std::vector<std::unique_ptr<btDefaultMotionState>> motion_;
    std::vector<std::unique_ptr<btRigidBody>> bodies_;
};

// CPU seconds per step over `frames` steps of a fresh world.
double time_lockroll(const sim::SceneDesc& scene, int frames) {
    sim::World w(scene);
    const std::vector<sim::PlayerInput> in(static_cast<std::size_t>(w.player_count()));
    const double t0 = thread_seconds();
    for (int f = 0; f < frames; ++f) w.step(in);
    return (thread_seconds() - t0) / frames;
}
double time_bullet(const sim::SceneDesc& scene, int frames) {
    BulletScene w(scene);
    const double t0 = thread_seconds();
    for (int f = 0; f < frames; ++f) w.step();
    return (thread_seconds() - t0) / frames;
}

double median(std::vector<double> v) {
    std::sort(v.begin(), v.end());
    const std::size_t n = v.size();
    return n % 2 ? v[n / 2] : (v[n / 2 - 1] + v[n / 2]) / 2;
}
}  // namespace

int main(int argc, char** argv) {
    CLI::App app{"Steps rigid scenes in lockroll and in Bullet, alternating, and prints medians and ratios"};
    std::vector<std::string> scenes{"paper_rigid", "bodies_10k_rigid"};
    std::vector<int> frames{720, 60};
    int reps = 7;
    app.add_option("--scenes", scenes, "Scene names or files (rigid scenes)");
    app.add_option("--frames", frames, "Frames per round, one per scene (default 720 for paper_rigid, 60 for 10k)");
    app.add_option("--reps", reps, "Rounds per scene (median over them)")->check(CLI::Range(1, 1000));
    CLI11_PARSE(app, argc, argv);
    if (frames.size() != scenes.size()) {
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
        if (frames[s] < 1) {
            std::fprintf(stderr, "bullet_bench: --frames must be >= 1\n");
            return 2;
        }
    }
    gContactAddedCallback = material_callback;
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
