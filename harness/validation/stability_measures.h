// What the stability cases measure in a World: energies, speeds, escapes from the room, overlaps.
// Q32.32 values are read exactly into long double (64-bit mantissa) and never fed back into a
// World. Shared by harness/validation/stability_cases.cpp and
// harness/validation/rigid_stability_cases.cpp.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "harness/match/scene_loader.h"
#include "sim/contact.h"
#include "sim/step_kernel.h"
#include "sim/world.h"

namespace lockroll::harness::stability::measure {

using sim::BodyId;
using sim::Fixed;
using sim::Vec3;
using sim::World;
using LD = long double;


inline LD num(Fixed f) { return static_cast<LD>(f.raw) / 4294967296.0L; }

struct P3 {
    LD x = 0, y = 0, z = 0;
};
inline P3 p3(const Vec3& v) { return {num(v.x), num(v.y), num(v.z)}; }
inline P3 operator-(P3 a, P3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline P3 operator+(P3 a, P3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
inline P3 operator*(P3 a, LD s) { return {a.x * s, a.y * s, a.z * s}; }
inline LD dot(P3 a, P3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline LD norm(P3 a) { return std::sqrt(dot(a, a)); }

inline std::string fmt(LD v, const char* unit = "") {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.4Lg%s%s", v, *unit ? " " : "", unit);
    return buf;
}

inline sim::SceneDesc scene_named(const std::string& name) {
    try {
        return load_scene(name);
    } catch (const SceneError& e) {
        throw std::runtime_error(e.what());  // a shipped scene that does not load is a failure, not usage
    }
}

inline std::vector<sim::PlayerInput> neutral(const World& w) {
    return std::vector<sim::PlayerInput>(static_cast<std::size_t>(w.player_count()));
}

// Kinetic plus potential energy (J) of the dynamic bodies; potential measured from y = 0.
inline LD energy(const World& w) {
    const sim::SceneDesc& s = w.scene();
    const P3 g = p3(s.gravity);
    LD e = 0;
    for (BodyId id : w.dynamic_ids()) {
        const sim::BodyDesc& b = s.bodies[id];
        const LD m = num(b.mass);
        const P3 v = p3(w.velocity(id));
        e += m * dot(v, v) / 2 - m * num(b.gravity_scale) * dot(g, p3(w.position(id)));
    }
    return e;
}

inline LD kinetic(const World& w) {
    LD e = 0;
    for (BodyId id : w.dynamic_ids()) {
        const P3 v = p3(w.velocity(id));
        e += num(w.scene().bodies[id].mass) * dot(v, v) / 2;
    }
    return e;
}

inline LD max_speed(const World& w) {
    LD m = 0;
    for (BodyId id : w.dynamic_ids()) m = std::max(m, norm(p3(w.velocity(id))));
    return m;
}

// The interior of a room built by the scene's "room" key: the six walls are bodies 0..5.
struct Room {
    P3 lo, hi;
};
inline Room room_of(const World& w) {
    auto wall = [&](BodyId id) {
        const sim::BodyDesc& b = w.scene().bodies[id];
        return std::pair<P3, P3>{p3(b.position), p3(b.half_extents)};
    };
    const auto [f, fh] = wall(0);
    const auto [c, ch] = wall(1);
    const auto [xl, xlh] = wall(2);
    const auto [xh, xhh] = wall(3);
    const auto [zl, zlh] = wall(4);
    const auto [zh, zhh] = wall(5);
    return {{xl.x + xlh.x, f.y + fh.y, zl.z + zlh.z}, {xh.x - xhh.x, c.y - ch.y, zh.z - zhh.z}};
}

// How far (m) the body's centre lies outside the room's interior: beyond its bounding radius
// the whole body is in or behind a wall, which is what "escaped" means here.
inline LD outside(const World& w, const Room& r, BodyId id) {
    const P3 p = p3(w.position(id));
    LD d = 0;
    d = std::max({d, r.lo.x - p.x, p.x - r.hi.x, r.lo.y - p.y, p.y - r.hi.y, r.lo.z - p.z, p.z - r.hi.z});
    return d;
}
inline LD bounding_radius(const World& w, BodyId id) {
    const sim::BodyDesc& b = w.scene().bodies[id];
    switch (b.shape) {
        case sim::Shape::Sphere: return num(b.radius);
        case sim::Shape::Capsule: return num(b.radius) + num(b.half_height);
        case sim::Shape::Box: return std::max({num(b.half_extents.x), num(b.half_extents.y), num(b.half_extents.z)});
    }
    return 0;
}
inline int escaped(const World& w, const Room& r) {
    int n = 0;
    for (BodyId id : w.dynamic_ids()) n += outside(w, r, id) > bounding_radius(w, id);
    return n;
}

// Deepest overlap between any two dynamic bodies or a dynamic and a static body (m), from the
// narrowphase itself; O(n^2), for the small scenes that ask for it.
inline LD deepest_overlap(const World& w) {
    const auto& k = w.kernel();
    LD deepest = 0;
    auto collider_pair = [&](BodyId a, BodyId b) -> LD {
        sim::Contact c;
        const bool ra = k.shape(a) != sim::Shape::Box, rb = k.shape(b) != sim::Shape::Box;
        const sim::RoundCollider rca{w.position(a), k.core_half(a), k.radius(a)}, rcb{w.position(b), k.core_half(b), k.radius(b)};
        const sim::BoxCollider bca{w.position(a), k.half_extents(a)}, bcb{w.position(b), k.half_extents(b)};
        bool hit;
        if (ra && rb) hit = sim::collide(rca, rcb, c);
        else if (ra) hit = sim::collide(rca, bcb, c);
        else if (rb) hit = sim::collide(rcb, bca, c);
        else hit = sim::collide(bca, bcb, c);
        return hit ? num(c.depth) : 0;
    };
    const std::size_t n = w.body_count();
    for (std::size_t i = 0; i < n; ++i)
        for (std::size_t j = i + 1; j < n; ++j) {
            const auto a = static_cast<BodyId>(i), b = static_cast<BodyId>(j);
            if (w.is_static(a) && w.is_static(b)) continue;
            deepest = std::max(deepest, collider_pair(a, b));
        }
    return deepest;
}

}  // namespace lockroll::harness::stability::measure
