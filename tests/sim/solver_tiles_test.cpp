// The particle solver's iterations interleaved over a window of the pairs
// (StepKernel::solve_tiled) against the plain whole sweeps: every position and velocity
// bit-identical after every step, in a dense mixed pile (spheres, capsules, dynamic boxes, a
// static sphere, static walls), so every pair kind, every resolution branch and the moving of
// static pairs up to their body are exercised. An operation run before an earlier one on the
// same body (a window one pair too far ahead, a static pair placed before its body's last
// dynamic pair) shows as a differing bit.
#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

#include "sim/broadphase.h"
#include "sim/rng.h"
#include "sim/step_kernel.h"

namespace lockroll::sim {
namespace {

Fixed mm(std::int64_t v) { return Fixed::from_int(v) / Fixed::from_int(1000); }

Fixed random_mm(SplitMix64& rng, std::int64_t lo, std::int64_t hi) {
    return mm(lo + static_cast<std::int64_t>(rng.below(static_cast<std::uint64_t>(hi - lo))));
}

BodyDesc static_box(Vec3 pos, Vec3 half) {
    BodyDesc b;
    b.shape = Shape::Box;
    b.position = pos;
    b.half_extents = half;
    b.mass = Fixed::zero();
    return b;
}

SceneDesc pile() {
    SceneDesc s;
    const Fixed one = Fixed::one(), three = Fixed::from_int(3);
    s.bodies.push_back(static_box({Fixed::zero(), -one, Fixed::zero()}, {three, one, three}));  // floor
    for (int side = -1; side <= 1; side += 2) {
        s.bodies.push_back(static_box({Fixed::from_int(2 * side), three, Fixed::zero()}, {mm(100), three, three}));
        s.bodies.push_back(static_box({Fixed::zero(), three, Fixed::from_int(2 * side)}, {three, three, mm(100)}));
    }
    BodyDesc post;  // a static round body: the solver's mirrored (static a, dynamic box b) case
    post.shape = Shape::Sphere;
    post.position = {Fixed::zero(), mm(300), Fixed::zero()};
    post.radius = mm(300);
    post.mass = Fixed::zero();
    s.bodies.push_back(post);
    SplitMix64 rng(19);
    for (int i = 0; i < 300; ++i) {
        BodyDesc b;
        b.shape = i % 10 == 3 ? Shape::Box : i % 10 == 7 ? Shape::Capsule : Shape::Sphere;
        b.position = {random_mm(rng, -1800, 1800), random_mm(rng, 200, 2500), random_mm(rng, -1800, 1800)};
        b.velocity = {random_mm(rng, -3000, 3000), random_mm(rng, -3000, 3000), random_mm(rng, -3000, 3000)};
        b.radius = mm(120);
        b.half_height = mm(100);
        b.half_extents = {mm(130), mm(110), mm(150)};
        b.mass = Fixed::from_int(1 + i % 3);
        if (i % 13 == 0) b.restitution = mm(900);
        s.bodies.push_back(b);
    }
    s.broadphase = BroadphaseKind::Grid;
    return s;
}

struct KernelRun {
    StepKernel<Fixed> kernel;
    Broadphase broadphase;
    std::vector<Vec3> pos, vel;

    KernelRun(const SceneDesc& scene, std::size_t gather_bodies) : kernel(scene) {
        kernel.set_tile_bodies(gather_bodies);
        kernel.initial_state(scene, pos, vel);
        broadphase.configure(scene.broadphase, kernel.dynamic_ids(), kernel.static_ids(), pos, kernel.extent(),
                             scene.contact_margin);
    }
    void step() {
        kernel.step(
            pos, vel,
            [this](const std::vector<Vec3>& p, std::vector<BodyPair>& out) {
                broadphase.find_pairs(p, kernel.extent(), out);
            },
            [](std::vector<Vec3>&) {});
    }
};

bool same(const Vec3& a, const Vec3& b) { return a.x.raw == b.x.raw && a.y.raw == b.y.raw && a.z.raw == b.z.raw; }

TEST(SolverTiles, WindowedIterationsAreBitIdenticalToWholeSweeps) {
    const SceneDesc scene = pile();
    KernelRun gathered(scene, 0), by_id(scene, SIZE_MAX);
    ASSERT_FALSE(gathered.kernel.extended());
    for (int frame = 0; frame < 240; ++frame) {
        gathered.step();
        by_id.step();
        for (std::size_t i = 0; i < scene.bodies.size(); ++i) {
            ASSERT_TRUE(same(gathered.pos[i], by_id.pos[i])) << "position of body " << i << " at frame " << frame;
            ASSERT_TRUE(same(gathered.vel[i], by_id.vel[i])) << "velocity of body " << i << " at frame " << frame;
        }
    }
    // The pile did collide (else the comparison would prove little): nothing fell through the floor.
    for (BodyId id : by_id.kernel.dynamic_ids()) EXPECT_GT(by_id.pos[id].y.raw, 0) << "body " << id;
    EXPECT_TRUE(same(gathered.pos[5], scene.bodies[5].position)) << "the static sphere never moves";
}

}  // namespace
}  // namespace lockroll::sim
