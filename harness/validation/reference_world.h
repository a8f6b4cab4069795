// The work-precision reference: the simulation's own step algorithm (sim/step_kernel.h,
// sim/contact.h) instantiated on double instead of Q32.32.
//
// Same scene constants (read exactly from their Q32.32 values), same operations in the same
// order, same candidate pairs (the fixed-point broadphase run on the positions rounded to
// Q32.32: it only proposes candidates, with a 5 cm margin, so rounding cannot lose a contact).
// What differs is only the number type, so comparing the two isolates rounding, and running the
// reference at a fine setting gives the discretisation error of a coarse one.
//
// Only for the harness: sim/ never sees a floating type. Scenes with player bodies are refused
// (the controller is not part of the kernel); the precision sweep does not need them.
#pragma once

#include <cstdint>
#include <vector>

#include "sim/broadphase.h"
#include "sim/step_kernel.h"

namespace lockroll::harness {

struct DVec3 {
    double x = 0, y = 0, z = 0;
};
inline DVec3 operator+(const DVec3& a, const DVec3& b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
inline DVec3 operator-(const DVec3& a, const DVec3& b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline DVec3 operator-(const DVec3& a) { return {-a.x, -a.y, -a.z}; }
inline DVec3 operator*(const DVec3& a, double s) { return {a.x * s, a.y * s, a.z * s}; }
inline DVec3 operator*(double s, const DVec3& a) { return a * s; }
inline DVec3& operator+=(DVec3& a, const DVec3& b) { return a = a + b; }
inline DVec3& operator-=(DVec3& a, const DVec3& b) { return a = a - b; }

}  // namespace lockroll::harness

template <>
struct lockroll::sim::NumberTraits<double> {
    using Vec = harness::DVec3;
    using Wide = double;
    static constexpr double zero() { return 0.0; }
    static constexpr double one() { return 1.0; }
    static double from_fixed(Fixed f);
    static double ratio(std::int64_t a, std::int64_t b) { return static_cast<double>(a) / static_cast<double>(b); }
    static double dot(const Vec& a, const Vec& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
    static double length_sq(const Vec& v) { return dot(v, v); }
    static double square(double x) { return x * x; }
    static double sqrt_wide(double w);
    static double reciprocal(double x) { return 1.0 / x; }
    static double sqrt(double x) { return sqrt_wide(x); }
    static double abs(double x) { return x < 0 ? -x : x; }
    static double min(double a, double b) { return a < b ? a : b; }
    static double max(double a, double b) { return a < b ? b : a; }
    static double clamp(double v, double lo, double hi) { return min(max(v, lo), hi); }
    static double midpoint(double lo, double hi) { return lo + (hi - lo) / 2; }
};

namespace lockroll::harness {

class ReferenceWorld {
public:
    // Throws std::invalid_argument for an invalid scene or one with player bodies.
    explicit ReferenceWorld(const sim::SceneDesc& scene);

    void step();

    std::uint32_t frame() const { return frame_; }
    const DVec3& position(sim::BodyId id) const { return pos_[id]; }
    const DVec3& velocity(sim::BodyId id) const { return vel_[id]; }
    const sim::StepKernel<double>& kernel() const { return kernel_; }
    const sim::SceneDesc& scene() const { return scene_; }

private:
    sim::SceneDesc scene_;
    sim::StepKernel<double> kernel_;
    std::uint32_t frame_ = 0;
    std::vector<DVec3> pos_, vel_;
    sim::Broadphase broadphase_;
    std::vector<sim::Vec3> shadow_, extent_;  // Q32.32 copies for the broadphase
};

}  // namespace lockroll::harness
