#include "sim/rigid_contact.h"

namespace lockroll::sim {

namespace {
Vec3 column(const Mat3& r, int k) {
    return k == 0 ? Vec3{r.row[0].x, r.row[1].x, r.row[2].x}
           : k == 1 ? Vec3{r.row[0].y, r.row[1].y, r.row[2].y}
                    : Vec3{r.row[0].z, r.row[1].z, r.row[2].z};
}

Fixed& comp(Vec3& v, int k) { return k == 0 ? v.x : k == 1 ? v.y : v.z; }
Fixed comp(const Vec3& v, int k) { return k == 0 ? v.x : k == 1 ? v.y : v.z; }

void add(Manifold& m, const Vec3& n, const Vec3& p, Fixed depth) {
    if (m.count >= kMaxManifold) return;
    m.points[m.count++] = {n, p, depth};
}

// Two spheres (centres ca, cb, radii ra, rb): a point when closer than the margin. Coincident
// centres separate along +y, as the particle narrowphase does.
void spheres(const Vec3& ca, Fixed ra, const Vec3& cb, Fixed rb, Fixed margin, Manifold& m) {
    const Vec3 d = cb - ca;
    const Fixed reach = ra + rb + margin;
    const u128 dist_sq = length_sq_wide(d);
    if (dist_sq >= static_cast<u128>(mul_wide(reach.raw, reach.raw))) return;
    const Fixed dist = Fixed::from_raw(static_cast<std::int64_t>(isqrt_round(dist_sq)));
    Vec3 n{Fixed::zero(), Fixed::one(), Fixed::zero()};
    if (dist.raw != 0) n = {d.x / dist, d.y / dist, d.z / dist};
    const Fixed depth = ra + rb - dist;
    // The point halfway between the two surfaces along the normal.
    add(m, n, ca + n * (ra - Fixed::from_raw(depth.raw / 2)), depth);
}

// The core segment of a round collider: centre -+ axis * core_half.
void segment(const OrientedCollider& c, Vec3& p0, Vec3& p1) {
    if (c.core_half.raw == 0) {
        p0 = p1 = c.center;
        return;
    }
    const Vec3 e = column(*c.rot, 1) * c.core_half;
    p0 = c.center - e;
    p1 = c.center + e;
}

// Parameter in [0, 1] of the point of segment [p, p + d] closest to q.
Fixed closest_param(const Vec3& p, const Vec3& d, const Vec3& q) {
    const Fixed dd = dot(d, d);
    if (dd.raw == 0) return Fixed::zero();
    return clamp(dot(q - p, d) / dd, Fixed::zero(), Fixed::one());
}

// Closest points of segments [p1, q1] and [p2, q2] (Ericson, Real-Time Collision Detection 5.1.9).
void closest_segments(const Vec3& p1, const Vec3& q1, const Vec3& p2, const Vec3& q2, Vec3& c1, Vec3& c2) {
    const Fixed zero = Fixed::zero(), one = Fixed::one();
    const Vec3 d1 = q1 - p1, d2 = q2 - p2, r = p1 - p2;
    const Fixed a = dot(d1, d1), e = dot(d2, d2), f = dot(d2, r);
    Fixed s, t;
    if (a.raw == 0 && e.raw == 0) {
        s = t = zero;
    } else if (a.raw == 0) {
        s = zero;
        t = clamp(f / e, zero, one);
    } else {
        const Fixed c = dot(d1, r);
        if (e.raw == 0) {
            t = zero;
            s = clamp(-c / a, zero, one);
        } else {
            const Fixed b = dot(d1, d2);
            const Fixed denom = a * e - b * b;
            // Parallel segments (denom 0): any s works; 0 is the fixed choice.
            s = denom.raw > 0 ? clamp((b * f - c * e) / denom, zero, one) : zero;
            t = (b * s + f) / e;
            if (t < zero) {
                t = zero;
                s = clamp(-c / a, zero, one);
            } else if (t > one) {
                t = one;
                s = clamp((b - c) / a, zero, one);
            }
        }
    }
    c1 = p1 + d1 * s;
    c2 = p2 + d2 * t;
}

void round_round(const OrientedCollider& a, const OrientedCollider& b, Fixed margin, Manifold& m) {
    Vec3 a0, a1, b0, b1, ca, cb;
    segment(a, a0, a1);
    segment(b, b0, b1);
    closest_segments(a0, a1, b0, b1, ca, cb);
    spheres(ca, a.radius, cb, b.radius, margin, m);
}

// A sphere of radius r at c against the box: normal from sphere to box.
void sphere_box(const Vec3& c, Fixed r, const OrientedCollider& box, Fixed margin, Manifold& m) {
    Vec3 n, q;
    Fixed dist;
    if (!point_box(c, box, r + margin, n, q, dist)) return;
    const Fixed depth = r - dist;
    // The point on the box's surface (the deepest point of the sphere is q's twin on the sphere).
    add(m, n, q, depth);
}

void round_box(const OrientedCollider& a, const OrientedCollider& box, Fixed margin, Manifold& m) {
    if (a.core_half.raw == 0) {
        sphere_box(a.center, a.radius, box, margin, m);
        return;
    }
    Vec3 p0, p1;
    segment(a, p0, p1);
    sphere_box(p0, a.radius, box, margin, m);
    sphere_box(p1, a.radius, box, margin, m);
    // The core point nearest the box centre, when it is not an end: leaning on an edge.
    const Fixed t = closest_param(p0, p1 - p0, box.center);
    if (t.raw > 0 && t < Fixed::one()) sphere_box(p0 + (p1 - p0) * t, a.radius, box, margin, m);
}

// Corners of `from` within the margin of `to` (normal from `from` toward `to` when flip is
// false; reversed otherwise so that it always points from A to B).
void corners_against(const OrientedCollider& from, const OrientedCollider& to, Fixed margin, bool flip, Manifold& m) {
    const Vec3 ex = column(*from.rot, 0) * from.half.x, ey = column(*from.rot, 1) * from.half.y,
               ez = column(*from.rot, 2) * from.half.z;
    for (int k = 0; k < 8; ++k) {
        const Vec3 p = from.center + ((k & 1) ? ex : -ex) + ((k & 2) ? ey : -ey) + ((k & 4) ? ez : -ez);
        Vec3 n, q;
        Fixed dist;
        if (!point_box(p, to, margin, n, q, dist)) continue;
        add(m, flip ? -n : n, p, -dist);
    }
}
}  // namespace

bool point_box(const Vec3& p, const OrientedCollider& box, Fixed reach, Vec3& normal, Vec3& surface, Fixed& distance) {
    const Mat3& r = *box.rot;
    const Vec3 local = transpose_times(r, p - box.center);
    const Vec3& h = box.half;
    // Quick reject on each axis before any square root.
    for (int k = 0; k < 3; ++k)
        if (abs(comp(local, k)) - comp(h, k) >= reach) return false;
    Vec3 q = local;
    bool inside = true;
    for (int k = 0; k < 3; ++k) {
        const Fixed c = clamp(comp(local, k), -comp(h, k), comp(h, k));
        if (c != comp(local, k)) inside = false;
        comp(q, k) = c;
    }
    const Fixed zero = Fixed::zero(), one = Fixed::one();
    Vec3 nl;
    if (!inside) {
        const Vec3 d = q - local;
        const u128 dsq = length_sq_wide(d);
        if (dsq >= static_cast<u128>(mul_wide(reach.raw, reach.raw))) return false;
        distance = Fixed::from_raw(static_cast<std::int64_t>(isqrt_round(dsq)));
        if (distance.raw == 0) return false;
        nl = {d.x / distance, d.y / distance, d.z / distance};
    } else {
        // Inside: out through the nearest face (ties: x, then y, then z); the normal points from
        // the point into the box, i.e. opposite to that face's outward direction.
        int best_axis = 0;
        bool best_neg = false;
        Fixed best = h.x - local.x;
        for (int k = 0; k < 3; ++k) {
            const Fixed up = comp(h, k) - comp(local, k), down = comp(local, k) + comp(h, k);
            if (up < best) { best = up; best_axis = k; best_neg = false; }
            if (down < best) { best = down; best_axis = k; best_neg = true; }
        }
        nl = {zero, zero, zero};
        comp(nl, best_axis) = best_neg ? one : -one;
        comp(q, best_axis) = best_neg ? -comp(h, best_axis) : comp(h, best_axis);
        distance = -best;
    }
    normal = r * nl;
    surface = box.center + r * q;
    return true;
}

void contact_points(const OrientedCollider& a, const OrientedCollider& b, Fixed margin, Manifold& m) {
    m.count = 0;
    const bool a_box = a.shape == Shape::Box, b_box = b.shape == Shape::Box;
    if (!a_box && !b_box) {
        round_round(a, b, margin, m);
    } else if (!a_box) {
        round_box(a, b, margin, m);
    } else if (!b_box) {
        round_box(b, a, margin, m);
        for (int i = 0; i < m.count; ++i) m.points[i].normal = -m.points[i].normal;
    } else {
        corners_against(a, b, margin, false, m);
        corners_against(b, a, margin, true, m);
    }
}

}  // namespace lockroll::sim
