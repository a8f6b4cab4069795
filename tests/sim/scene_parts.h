// Pieces of scenes that the sim tests share: a static floor, a ball, a box, a scene that bounces
// nothing. A test builds its scene from these so that a floor reads the same in every file and a
// new BodyDesc or SceneDesc field is set in one place.
//
// Contract: numbers are decimal text parsed exactly (Fixed::parse aborts the test binary on a
// typo via the optional's dereference), so a test states the values it means; every part is a
// plain value the test may change before use. d() is for assertions only: no double ever reaches
// the simulation.
#pragma once

#include "sim/scene.h"

namespace lockroll::sim::test {

inline Fixed fx(const char* text) { return *Fixed::parse(text); }
inline Vec3 v3(const char* x, const char* y, const char* z) { return {fx(x), fx(y), fx(z)}; }
inline double d(Fixed f) { return static_cast<double>(f.raw) / 4294967296.0; }

// A static box whose top face is y = 0: `half` metres from the origin each way in x and z, and
// `half_height` metres half deep (its centre at y = -half_height).
inline BodyDesc floor_box(const char* half, const char* half_height) {
    BodyDesc floor;
    floor.shape = Shape::Box;
    floor.position = {Fixed::zero(), -fx(half_height), Fixed::zero()};
    floor.half_extents = v3(half, half_height, half);
    floor.mass = Fixed::zero();
    return floor;
}

// A dynamic ball at `position`, at rest unless the test says otherwise.
inline BodyDesc ball(Vec3 position, const char* radius = "0.5", const char* mass = "1") {
    BodyDesc b;
    b.shape = Shape::Sphere;
    b.radius = fx(radius);
    b.mass = fx(mass);
    b.position = position;
    return b;
}

// A dynamic box at `position`, at rest and unturned.
inline BodyDesc box(Vec3 position, Vec3 half_extents, const char* mass = "1") {
    BodyDesc b;
    b.shape = Shape::Box;
    b.half_extents = half_extents;
    b.mass = fx(mass);
    b.position = position;
    return b;
}

// Every entry of the restitution table zero, so no pair bounces (per-body overrides aside).
inline void no_bounce(SceneDesc& s) {
    for (auto& row : s.restitution)
        for (auto& e : row) e = Fixed::zero();
}

// A rigid scene (turning bodies, the default friction) whose body 0 is floor_box(half, "0.5").
inline SceneDesc rigid_floor(const char* half) {
    SceneDesc s;
    s.rigid.enabled = true;
    s.bodies.push_back(floor_box(half, "0.5"));
    return s;
}

}  // namespace lockroll::sim::test
