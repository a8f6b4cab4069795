// Narrowphase: does a pair of colliders touch, and along which normal and how deep.
//
// Every collider is a core swept by a radius (see Shape). Capsules are upright, so the closest
// points between two vertical cores, or between a vertical core and a box, separate into an XZ
// part and a Y part; every round-vs-anything test reduces to a sphere test at the right height.
// Hence three routines: round-round, round-box, box-box.
#pragma once

#include "sim/vec3.h"

namespace lockroll::sim {

struct Contact {
    Vec3 normal;  // unit, pointing from body A to body B
    Fixed depth;  // penetration, > 0
};

struct RoundCollider {
    Vec3 center;
    Fixed core_half;  // half-height of the vertical core segment (0 for a sphere)
    Fixed radius;
};

struct BoxCollider {
    Vec3 center;
    Vec3 half;
};

// Each returns true and fills `out` when the colliders overlap by more than zero.
bool collide(const RoundCollider& a, const RoundCollider& b, Contact& out);
bool collide(const RoundCollider& a, const BoxCollider& b, Contact& out);
bool collide(const BoxCollider& a, const BoxCollider& b, Contact& out);

}  // namespace lockroll::sim
