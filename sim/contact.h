// Narrowphase: does a pair of colliders touch, and along which normal and how deep; and, for
// continuous collision, how far apart two colliders are.
//
// Every collider is a core swept by a radius (see Shape). Capsules are upright, so the closest
// points between two vertical cores, or between a vertical core and a box, separate into an XZ
// part and a Y part; every round-vs-anything test reduces to a sphere test at the right height.
// Hence three routines: round-round, round-box, box-box.
//
// Templates over the number type (sim/number_traits.h) so the float reference in the harness
// runs these very routines; sim/ uses them only with Fixed (the aliases below).
#pragma once

#include "sim/number_traits.h"

namespace lockroll::sim {

template <class N>
struct BasicContact {
    typename NumberTraits<N>::Vec normal;  // unit, pointing from body A to body B
    N depth;                               // penetration, > 0
};

template <class N>
struct BasicRoundCollider {
    typename NumberTraits<N>::Vec center;
    N core_half;  // half-height of the vertical core segment (0 for a sphere)
    N radius;
};

template <class N>
struct BasicBoxCollider {
    typename NumberTraits<N>::Vec center;
    typename NumberTraits<N>::Vec half;
};

using Contact = BasicContact<Fixed>;
using RoundCollider = BasicRoundCollider<Fixed>;
using BoxCollider = BasicBoxCollider<Fixed>;

namespace contact_detail {
// Sphere-sphere on centers; when the centers coincide the normal is +y, a fixed choice so
// every peer separates coincident bodies the same way.
template <class N, class V>
bool spheres(const V& ca, N ra, const V& cb, N rb, BasicContact<N>& out) {
    using T = NumberTraits<N>;
    const V d = cb - ca;
    const N reach = ra + rb;
    const typename T::Wide dist_sq = T::length_sq(d);
    const typename T::Wide reach_sq = T::square(reach);
    if (dist_sq >= reach_sq) return false;
    const N dist = T::sqrt_wide(dist_sq);
    if (dist == T::zero()) {
        out.normal = {T::zero(), T::one(), T::zero()};
        out.depth = reach;
        return true;
    }
    out.normal = {d.x / dist, d.y / dist, d.z / dist};
    out.depth = reach - dist;
    return out.depth > T::zero();
}

// The y on segment [lo, hi] closest to interval [olo, ohi]: inside the overlap (its midpoint)
// when the intervals overlap, else the near end.
template <class N>
N closest_y(N lo, N hi, N olo, N ohi) {
    using T = NumberTraits<N>;
    if (hi < olo) return hi;
    if (lo > ohi) return lo;
    return T::midpoint(T::max(lo, olo), T::min(hi, ohi));
}

template <class N>
N sign_of(N v) {
    using T = NumberTraits<N>;
    return v < T::zero() ? -T::one() : v > T::zero() ? T::one() : T::zero();
}

// The two closest core points of two upright round colliders.
template <class N, class V = typename NumberTraits<N>::Vec>
void round_cores(const BasicRoundCollider<N>& a, const BasicRoundCollider<N>& b, V& pa, V& pb) {
    const N ya = closest_y(a.center.y - a.core_half, a.center.y + a.core_half, b.center.y - b.core_half,
                           b.center.y + b.core_half);
    const N yb = closest_y(b.center.y - b.core_half, b.center.y + b.core_half, ya, ya);
    pa = {a.center.x, ya, a.center.z};
    pb = {b.center.x, yb, b.center.z};
}
}  // namespace contact_detail

// Each collide() returns true and fills `out` when the colliders overlap by more than zero.

template <class N>
bool collide(const BasicRoundCollider<N>& a, const BasicRoundCollider<N>& b, BasicContact<N>& out) {
    using T = NumberTraits<N>;
    if (a.core_half == T::zero() && b.core_half == T::zero())
        return contact_detail::spheres(a.center, a.radius, b.center, b.radius, out);
    typename T::Vec pa, pb;
    contact_detail::round_cores(a, b, pa, pb);
    return contact_detail::spheres(pa, a.radius, pb, b.radius, out);
}

// collide(round, box) for a box given by its bounds lo = center - half, hi = center + half:
// static boxes never move, so the solver computes their bounds once.
template <class N>
bool collide_with_bounds(const BasicRoundCollider<N>& a, const typename NumberTraits<N>::Vec& lo,
                         const typename NumberTraits<N>::Vec& hi, BasicContact<N>& out) {
    using T = NumberTraits<N>;
    using V = typename T::Vec;
    // A sphere's core is its centre (closest_y of a zero-length segment is its y, exactly).
    const N cy = a.core_half == T::zero()
                     ? a.center.y
                     : contact_detail::closest_y(a.center.y - a.core_half, a.center.y + a.core_half, lo.y, hi.y);
    const V c{a.center.x, cy, a.center.z};
    const V q{T::clamp(c.x, lo.x, hi.x), T::clamp(c.y, lo.y, hi.y), T::clamp(c.z, lo.z, hi.z)};
    const N z = T::zero(), o = T::one();
    if (!(q.x == c.x && q.y == c.y && q.z == c.z)) {
        // Center outside the box: contact along the closest-point direction, box to sphere,
        // so the normal from A (sphere) to B (box) points from c to q.
        const V d = q - c;
        // Face contacts (outside the box on one axis only) are the common case: floors and
        // walls. Their normal is the axis and the distance exact, with no sqrt or division.
        const int off_axes = (d.x != z) + (d.y != z) + (d.z != z);
        if (off_axes == 1) {
            const N dist = T::abs(d.x) + T::abs(d.y) + T::abs(d.z);
            if (dist >= a.radius) return false;
            out.normal = {contact_detail::sign_of(d.x), contact_detail::sign_of(d.y), contact_detail::sign_of(d.z)};
            out.depth = a.radius - dist;
            return true;
        }
        const typename T::Wide dist_sq = T::length_sq(d);
        if (dist_sq >= T::square(a.radius)) return false;
        const N dist = T::sqrt_wide(dist_sq);
        if (dist == z) return false;  // touching at exactly the surface: no penetration
        out.normal = {d.x / dist, d.y / dist, d.z / dist};
        out.depth = a.radius - dist;
        return out.depth > z;
    }
    // Center inside the box: push out through the nearest face (ties: x, then y, then z).
    const N dx_lo = c.x - lo.x, dx_hi = hi.x - c.x, dy_lo = c.y - lo.y, dy_hi = hi.y - c.y, dz_lo = c.z - lo.z,
            dz_hi = hi.z - c.z;
    N best = dx_lo;
    V n{o, z, z};  // exit through -x: box pushes sphere to -x
    auto consider = [&](N d, V normal) {
        if (d < best) {
            best = d;
            n = normal;
        }
    };
    consider(dx_hi, {-o, z, z});
    consider(dy_lo, {z, o, z});
    consider(dy_hi, {z, -o, z});
    consider(dz_lo, {z, z, o});
    consider(dz_hi, {z, z, -o});
    out.normal = n;
    out.depth = best + a.radius;
    return true;
}

template <class N>
bool collide(const BasicRoundCollider<N>& a, const BasicBoxCollider<N>& b, BasicContact<N>& out) {
    return collide_with_bounds(a, b.center - b.half, b.center + b.half, out);
}

template <class N>
bool collide(const BasicBoxCollider<N>& a, const BasicBoxCollider<N>& b, BasicContact<N>& out) {
    using T = NumberTraits<N>;
    const typename T::Vec d = b.center - a.center;
    const N z = T::zero(), o = T::one();
    const N ox = a.half.x + b.half.x - T::abs(d.x);
    if (ox <= z) return false;
    const N oy = a.half.y + b.half.y - T::abs(d.y);
    if (oy <= z) return false;
    const N oz = a.half.z + b.half.z - T::abs(d.z);
    if (oz <= z) return false;
    auto sign = [&](N v) { return v < z ? -o : o; };
    // Least-penetration axis; ties go to x, then y, then z.
    if (ox <= oy && ox <= oz) {
        out.normal = {sign(d.x), z, z};
        out.depth = ox;
    } else if (oy <= oz) {
        out.normal = {z, sign(d.y), z};
        out.depth = oy;
    } else {
        out.normal = {z, z, sign(d.z)};
        out.depth = oz;
    }
    return true;
}

// Signed separation for continuous collision: the distance between the colliders' surfaces
// when they are apart, minus the penetration depth when they overlap; `normal` is the unit
// direction from A toward B along which it is measured (collide()'s normal when overlapping).
// Exact distances, so a sweep that advances by separation / speed never steps past a contact.

template <class N>
N separation(const BasicRoundCollider<N>& a, const BasicRoundCollider<N>& b, typename NumberTraits<N>::Vec& normal) {
    using T = NumberTraits<N>;
    BasicContact<N> c;
    if (collide(a, b, c)) {
        normal = c.normal;
        return -c.depth;
    }
    typename T::Vec pa, pb;
    contact_detail::round_cores(a, b, pa, pb);
    const typename T::Vec d = pb - pa;
    const N dist = T::sqrt_wide(T::length_sq(d));  // > 0: coincident cores would overlap
    normal = {d.x / dist, d.y / dist, d.z / dist};
    return dist - (a.radius + b.radius);
}

template <class N>
N separation(const BasicRoundCollider<N>& a, const BasicBoxCollider<N>& b, typename NumberTraits<N>::Vec& normal) {
    using T = NumberTraits<N>;
    using V = typename T::Vec;
    BasicContact<N> c;
    if (collide(a, b, c)) {
        normal = c.normal;
        return -c.depth;
    }
    const V lo = b.center - b.half, hi = b.center + b.half;
    const V p{a.center.x, contact_detail::closest_y(a.center.y - a.core_half, a.center.y + a.core_half, lo.y, hi.y),
              a.center.z};
    const V d = V{T::clamp(p.x, lo.x, hi.x), T::clamp(p.y, lo.y, hi.y), T::clamp(p.z, lo.z, hi.z)} - p;
    const N dist = T::sqrt_wide(T::length_sq(d));  // > 0: a core point inside the box would overlap
    normal = {d.x / dist, d.y / dist, d.z / dist};
    return dist - a.radius;
}

template <class N>
N separation(const BasicBoxCollider<N>& a, const BasicBoxCollider<N>& b, typename NumberTraits<N>::Vec& normal) {
    using T = NumberTraits<N>;
    BasicContact<N> c;
    if (collide(a, b, c)) {
        normal = c.normal;
        return -c.depth;
    }
    const N z = T::zero(), o = T::one();
    const typename T::Vec d = b.center - a.center;
    const N gx = T::abs(d.x) - (a.half.x + b.half.x), gy = T::abs(d.y) - (a.half.y + b.half.y),
            gz = T::abs(d.z) - (a.half.z + b.half.z);
    auto sign = [&](N v) { return v < z ? -o : o; };
    if (gx <= z && gy <= z && gz <= z) {
        // Touching exactly (a zero gap on some axis): distance 0 along that axis, chosen as
        // collide() chooses its axis (ties x, then y, then z).
        if (gx >= gy && gx >= gz) normal = {sign(d.x), z, z};
        else if (gy >= gz) normal = {z, sign(d.y), z};
        else normal = {z, z, sign(d.z)};
        return z;
    }
    const typename T::Vec g{T::max(gx, z) * contact_detail::sign_of(d.x), T::max(gy, z) * contact_detail::sign_of(d.y),
                            T::max(gz, z) * contact_detail::sign_of(d.z)};
    const N dist = T::sqrt_wide(T::length_sq(g));  // > 0: some gap is positive
    normal = {g.x / dist, g.y / dist, g.z / dist};
    return dist;
}

template <class N>
N separation(const BasicBoxCollider<N>& a, const BasicRoundCollider<N>& b, typename NumberTraits<N>::Vec& normal) {
    const N s = separation(b, a, normal);
    normal = -normal;
    return s;
}

// Fixed instantiations are compiled once, in contact.cpp (out of line, as the solver has
// always called them: inlining them into the solver loop measured slower).
extern template bool collide<Fixed>(const RoundCollider&, const RoundCollider&, Contact&);
extern template bool collide<Fixed>(const RoundCollider&, const BoxCollider&, Contact&);
extern template bool collide<Fixed>(const BoxCollider&, const BoxCollider&, Contact&);
extern template Fixed separation<Fixed>(const RoundCollider&, const RoundCollider&, Vec3&);
extern template Fixed separation<Fixed>(const RoundCollider&, const BoxCollider&, Vec3&);
extern template Fixed separation<Fixed>(const BoxCollider&, const BoxCollider&, Vec3&);
extern template Fixed separation<Fixed>(const BoxCollider&, const RoundCollider&, Vec3&);

}  // namespace lockroll::sim
