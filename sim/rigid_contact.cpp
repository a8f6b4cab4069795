#include "sim/rigid_contact.h"

#include <algorithm>
#include <bit>
#include <utility>

namespace lockroll::sim {

namespace {
Vec3 column(const Mat3& r, int k) {
    return k == 0 ? Vec3{r.row[0].x, r.row[1].x, r.row[2].x}
           : k == 1 ? Vec3{r.row[0].y, r.row[1].y, r.row[2].y}
                    : Vec3{r.row[0].z, r.row[1].z, r.row[2].z};
}

Vec3 unit_axis(int k) {
    const Fixed zero = Fixed::zero(), one = Fixed::one();
    return k == 0 ? Vec3{one, zero, zero} : k == 1 ? Vec3{zero, one, zero} : Vec3{zero, zero, one};
}

// The identity rotation exactly (an unturned box: every room wall, and a box that has not turned
// yet). Multiplying by it, either way round, gives v bit for bit (each dot product with a unit
// axis is one exact term rounded once), so the products are skipped.
// Always inline: point_box() is a hot caller too (called out of line, it cost paper_rigid
// ~190 instructions a step).
[[gnu::always_inline]] inline bool identity(const Mat3& m) {
    const Fixed zero = Fixed::zero(), one = Fixed::one();
    return m.row[0] == Vec3{one, zero, zero} && m.row[1] == Vec3{zero, one, zero} && m.row[2] == Vec3{zero, zero, one};
}

void add(Manifold& m, const Vec3& n, const Vec3& p, Fixed depth, std::uint8_t feature) {
    if (m.count >= kMaxManifold) return;
    m.points[m.count++] = {n, p, depth, feature};
}

// Two spheres (centres ca, cb, radii ra, rb): a point when closer than the margin. Coincident
// centres separate along +y, as the particle narrowphase does.
void spheres(const Vec3& ca, Fixed ra, const Vec3& cb, Fixed rb, Fixed margin, Manifold& m) {
    const Vec3 d = cb - ca;
    const Fixed reach = ra + rb + margin;
    const u128 dist_sq = length_sq_wide(d);
    if (dist_sq >= static_cast<u128>(mul_wide(reach.raw, reach.raw))) return;
    const Fixed dist = sqrt_wide(dist_sq);
    Vec3 n{Fixed::zero(), Fixed::one(), Fixed::zero()};
    if (dist.raw != 0) n = {d.x / dist, d.y / dist, d.z / dist};
    const Fixed depth = ra + rb - dist;
    // The point halfway between the two surfaces along the normal.
    add(m, n, ca + n * (ra - Fixed::from_raw(depth.raw / 2)), depth, 0);
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

// Always inline: contact_points() is its one hot caller (out of line, with contact_points_general()
// a second caller, it cost bodies_1k_rigid 6.9 M instructions over 360 steps).
[[gnu::always_inline]] inline void round_round(const OrientedCollider& a, const OrientedCollider& b, Fixed margin, Manifold& m) {
    // Two spheres: closest_segments() of two points gives the centres themselves (every product
    // it takes is of zero vectors), so the centres go straight in.
    if (a.core_half.raw == 0 && b.core_half.raw == 0) {
        spheres(a.center, a.radius, b.center, b.radius, margin, m);
        return;
    }
    Vec3 a0, a1, b0, b1, ca, cb;
    segment(a, a0, a1);
    segment(b, b0, b1);
    closest_segments(a0, a1, b0, b1, ca, cb);
    spheres(ca, a.radius, cb, b.radius, margin, m);
}

// A sphere of radius r at c against the box: normal from sphere to box.
void sphere_box(const Vec3& c, Fixed r, const OrientedCollider& box, Fixed margin, Manifold& m, std::uint8_t feature) {
    Vec3 n, q;
    Fixed dist;
    if (!point_box(c, box, r + margin, n, q, dist)) return;
    const Fixed depth = r - dist;
    // The point on the box's surface (the deepest point of the sphere is q's twin on the sphere).
    add(m, n, q, depth, feature);
}

// axis = x / |x| (len_sq = |x|^2 > 0), turned to point along v; returns v . axis (>= 0).
Fixed unit_toward(const Vec3& x, u128 len_sq, const Vec3& v, Vec3& axis) {
    const Fixed len = sqrt_wide(len_sq);
    axis = {x.x / len, x.y / len, x.z / len};
    Fixed along = dot(v, axis);
    if (along.raw < 0) {
        axis = -axis;
        along = -along;
    }
    return along;
}

// ---- Capsule against an oriented box, exact ----
// In the box's frame the core segment is a + d t, t in [0, 1], and the box is |x_k| <= h_k. The
// capsule touches the box where the segment comes within its radius; the closest point of the
// segment to the box is found exactly: the squared distance is convex and piecewise quadratic
// in t, with breakpoints where a coordinate crosses +-h_k, so its slope is read at the
// breakpoints in order and the root is solved on the one piece where it changes sign.
//  - Closest box point on a face (one coordinate outside the box): the segment is clipped to
//    that face's four side planes, and each end of the clipped part within reach is a point,
//    with the face normal. The deepest end is the exact closest point (the separation from the
//    face plane is linear along the clipped part), and a capsule lying along the face gets two.
//  - On an edge or corner: the exact closest points, normal along their difference; plus, when
//    within reach, the far end of the segment's part over the face the normal leans to most
//    (a capsule lying along a face and over its edge keeps both supports as it tilts).
//  - The segment inside (or within 2^-20 m of) the box: the separating-axis test over the box's
//    three face normals and the three cross products of the segment with the box's edges (the
//    face normals of box + segment, so the least overlap is the exact penetration); a face axis
//    gives the clipped points above, an edge axis (winning by kEdgeBias) one point on that edge.
// Feature ids: face points 8 f + c, f the face (2 k, +1 for the -x_k face), c the clipped end:
// 0 or 1 a segment end, 2 + s the side plane s (2 j' + 1 for the - side of the face's j'-th
// other axis) that cut it; edge and corner points kFeatureEdge + code, code sum over k of
// 3^k * (0 inside, 1 on +h_k, 2 on -h_k): the box feature touched, the same whether found by
// closest points or by the separating axis.

constexpr std::int64_t kEdgeBias = Fixed::kOne / 200;  // 5 mm

// x beyond [-h, h], signed; 0 inside.
Fixed excess(Fixed x, Fixed h) { return x > h ? x - h : x < -h ? x + h : Fixed::zero(); }

// Half the slope of the squared distance from a + d t to the box, in Q64.64 (its sign matters).
i128 box_slope(const Vec3& a, const Vec3& d, const Vec3& h, Fixed t) {
    const Vec3 q = a + d * t;
    return dot_wide(d, {excess(q.x, h.x), excess(q.y, h.y), excess(q.z, h.z)});
}

// num / den for 0 < num < den (Q64.64 both), as a Fixed in [0, 1]: both shifted down to 62 bits.
Fixed unit_ratio(i128 num, i128 den) {
    const auto hi = static_cast<std::uint64_t>(den >> 64), lo = static_cast<std::uint64_t>(den);
    const int width = hi != 0 ? 64 + std::bit_width(hi) : std::bit_width(lo);
    const int shift = width > 62 ? width - 62 : 0;
    return Fixed::ratio(static_cast<std::int64_t>(num >> shift), static_cast<std::int64_t>(den >> shift));
}

// The segment parameter in [0, 1] of a point of the segment closest to the box (a fixed one
// where several are: the middle of a flat piece).
Fixed closest_to_box(const Vec3& a, const Vec3& d, const Vec3& h) {
    const Fixed zero = Fixed::zero(), one = Fixed::one();
    Fixed bp[6];
    int n = 0;
    for (int k = 0; k < 3; ++k) {
        const Fixed dk = component(d, k);
        if (dk.raw == 0) continue;
        for (const Fixed bound : {-component(h, k), component(h, k)}) {
            const Fixed num = bound - component(a, k);
            // Inside (0, 1) only: no division that could saturate.
            const bool in = dk.raw > 0 ? num.raw > 0 && num < dk : num.raw < 0 && num > dk;
            if (!in) continue;
            Fixed t = num / dk;
            int i = n++;
            for (; i > 0 && bp[i - 1] > t; --i) bp[i] = bp[i - 1];
            bp[i] = t;
        }
    }
    if (box_slope(a, d, h, zero) >= i128{0}) return zero;
    Fixed lo = zero, hi = one;
    int i = 0;
    for (; i < n; ++i) {
        if (box_slope(a, d, h, bp[i]) >= i128{0}) break;
        lo = bp[i];
    }
    if (i < n) {
        hi = bp[i];
    } else if (box_slope(a, d, h, one) <= i128{0}) {
        return one;
    }
    // On [lo, hi] the same coordinates are outside: slope = sum over them of d_k (a_k -+ h_k + d_k t).
    const Fixed mid = lo + Fixed::from_raw((hi.raw - lo.raw) / 2);
    const Vec3 q = a + d * mid;
    Vec3 dn, off;
    for (int k = 0; k < 3; ++k) {
        const Fixed qk = component(q, k), hk = component(h, k);
        if (qk > hk || qk < -hk) {
            component(dn, k) = component(d, k);
            component(off, k) = qk > hk ? component(a, k) - hk : component(a, k) + hk;
        }
    }
    const i128 den = dot_wide(dn, dn);
    if (den <= i128{0}) return mid;  // flat: the distance is the same all along the piece
    const i128 num = -dot_wide(dn, off);
    const Fixed t = num <= i128{0} ? zero : num >= den ? one : unit_ratio(num, den);
    return clamp(t, lo, hi);
}

// A capsule in the box's frame: segment a + d t, radius r; writes local normals and points.
// unturned: the box's rotation is the identity (identity()) and the shortcuts are on, so its
// products, r v (to world) and r^T v (to the box's frame), are v itself, bit for bit, and are
// skipped: a player's capsule against a room's wall.
struct LocalCapsule {
    Vec3 a, d;
    Fixed r, reach;
    bool unturned = false;
};

Vec3 to_world(const LocalCapsule& c, const Mat3& r, const Vec3& v) { return c.unturned ? v : r * v; }

// num / d where that is within [-1, 1]; beyond, +-2 (outside the segment either way), so the
// division never saturates.
Fixed slab_param(Fixed num, Fixed d) {
    if (abs(num) <= abs(d)) return num / d;
    const Fixed two = Fixed::from_raw(2 * Fixed::kOne);
    return (num.raw < 0) == (d.raw < 0) ? two : -two;
}

// The part of the segment over face k (between its four side planes): parameters t0 <= t1 and
// what cut each end (0 / 1 the segment's ends, 2 + s side plane s). False when it misses the face.
struct FaceClip {
    Fixed t0, t1;
    int code0 = 0, code1 = 1;
};
bool clip_to_face(const LocalCapsule& c, const Vec3& h, int k, FaceClip& f) {
    f.t0 = Fixed::zero();
    f.t1 = Fixed::one();
    for (int s = 1; s <= 2; ++s) {
        const int j = (k + s) % 3;
        const Fixed dj = component(c.d, j), aj = component(c.a, j), hj = component(h, j);
        const int plus = 2 * s, minus = plus + 1;
        if (dj.raw == 0) {
            if (aj > hj || aj < -hj) return false;
            continue;
        }
        // Entering and leaving parameters of the slab |a_j + d_j t| <= h_j.
        Fixed enter = slab_param(-hj - aj, dj), leave = slab_param(hj - aj, dj);
        int enter_code = minus, leave_code = plus;
        if (dj.raw < 0) {
            std::swap(enter, leave);
            std::swap(enter_code, leave_code);
        }
        if (enter > f.t0) { f.t0 = enter; f.code0 = enter_code; }
        if (leave < f.t1) { f.t1 = leave; f.code1 = leave_code; }
    }
    return f.t0 <= f.t1;
}

// The segment point at t as a contact on face f = 2 k + negative, when within reach: the point on
// the face under it, normal -(outward face normal) (capsule toward box).
void face_point(const LocalCapsule& c, const OrientedCollider& box, int k, bool negative, Fixed t, int code, Manifold& m) {
    const Fixed hk = component(box.half, k);
    Vec3 p = c.a + c.d * t;
    const Fixed sep = (negative ? -component(p, k) : component(p, k)) - hk;
    if (sep >= c.reach) return;
    component(p, k) = negative ? -hk : hk;  // on the face
    const Vec3 ek = column(*box.rot, k);
    const int face = 2 * k + (negative ? 1 : 0);
    add(m, negative ? ek : -ek, box.center + to_world(c, *box.rot, p), c.r - sep, static_cast<std::uint8_t>(8 * face + code));
}

// Face k as the reference: each end of the segment's part over it within reach.
void capsule_face(const LocalCapsule& c, const OrientedCollider& box, int k, bool negative, Manifold& m) {
    FaceClip f;
    if (!clip_to_face(c, box.half, k, f)) {
        // Rounding at a grazing corner (the closest point is over this face): the middle.
        const Fixed t = clamp(f.t0 + Fixed::from_raw((f.t1.raw - f.t0.raw) / 2), Fixed::zero(), Fixed::one());
        face_point(c, box, k, negative, t, f.code0, m);
        return;
    }
    face_point(c, box, k, negative, f.t0, f.code0, m);
    if (f.t1 != f.t0) face_point(c, box, k, negative, f.t1, f.code1, m);
}

std::uint8_t box_feature(const int sign[3]) {
    int code = 0;
    for (int k = 2; k >= 0; --k) code = 3 * code + (sign[k] > 0 ? 1 : sign[k] < 0 ? 2 : 0);
    return static_cast<std::uint8_t>(kFeatureEdge + code);
}

// The segment inside or touching the box: least overlap over the box's face normals and the
// segment-edge cross products.
void capsule_box_sat(const LocalCapsule& c, const OrientedCollider& box, Manifold& m) {
    const Vec3& h = box.half;
    const Vec3 b = c.a + c.d;
    Fixed face_pen = Fixed::max();
    int face_k = 0;
    bool face_neg = false;
    for (int k = 0; k < 3; ++k) {
        const Fixed lo = min(component(c.a, k), component(b, k)), hi = max(component(c.a, k), component(b, k));
        const Fixed up = component(h, k) - lo, down = hi + component(h, k);  // push out through +x_k, -x_k
        if (up < face_pen) { face_pen = up; face_k = k; face_neg = false; }
        if (down < face_pen) { face_pen = down; face_k = k; face_neg = true; }
    }
    Fixed edge_pen = Fixed::max();
    int edge_k = -1;
    Vec3 edge_u{};
    const u128 dd = length_sq_wide(c.d);
    const Vec3 mid = c.a + c.d * Fixed::from_raw(Fixed::kOne / 2);
    for (int k = 0; k < 3; ++k) {
        const Fixed zero = Fixed::zero();
        const Vec3 x = k == 0 ? Vec3{zero, c.d.z, -c.d.y} : k == 1 ? Vec3{-c.d.z, zero, c.d.x} : Vec3{c.d.y, -c.d.x, zero};
        const u128 xx = length_sq_wide(x);
        if (xx == 0 || xx < (dd >> 12)) continue;  // within 2^-6 rad of the edge: a face axis covers it
        Vec3 u;
        const Fixed s = unit_toward(x, xx, mid, u);
        const Fixed pen = h.x * abs(u.x) + h.y * abs(u.y) + h.z * abs(u.z) - s;
        if (pen < edge_pen) { edge_pen = pen; edge_k = k; edge_u = u; }
    }
    if (edge_k < 0 || edge_pen.raw + kEdgeBias >= face_pen.raw) {
        capsule_face(c, box, face_k, face_neg, m);
        return;
    }
    // The box edge along x_k on the side u points to; one point, the closest points of it and the segment.
    int sign[3] = {0, 0, 0};
    Vec3 e0 = {}, e1 = {};
    for (int j = 0; j < 3; ++j) {
        if (j == edge_k) {
            component(e0, j) = -component(h, j);
            component(e1, j) = component(h, j);
            continue;
        }
        sign[j] = component(edge_u, j).raw >= 0 ? 1 : -1;
        component(e0, j) = component(e1, j) = sign[j] > 0 ? component(h, j) : -component(h, j);
    }
    Vec3 cs, ce;
    closest_segments(c.a, b, e0, e1, cs, ce);
    add(m, to_world(c, *box.rot, -edge_u), box.center + to_world(c, *box.rot, ce), edge_pen + c.r, box_feature(sign));
}

// shortcuts: as box_box()'s (off only in tests): an unturned box's products are skipped.
void round_box(const OrientedCollider& a, const OrientedCollider& box, Fixed margin, Manifold& m, bool shortcuts) {
    if (a.core_half.raw == 0) {
        sphere_box(a.center, a.radius, box, margin, m, 0);
        return;
    }
    Vec3 p0, p1;
    segment(a, p0, p1);
    LocalCapsule c;
    c.unturned = shortcuts && identity(*box.rot);
    c.a = c.unturned ? p0 - box.center : transpose_times(*box.rot, p0 - box.center);
    c.d = (c.unturned ? p1 - box.center : transpose_times(*box.rot, p1 - box.center)) - c.a;
    c.r = a.radius;
    c.reach = a.radius + margin;
    const Vec3& h = box.half;
    // Quick reject: the whole segment beyond one face's slab by the reach.
    const Vec3 b = c.a + c.d;
    for (int k = 0; k < 3; ++k) {
        const Fixed lo = min(component(c.a, k), component(b, k)), hi = max(component(c.a, k), component(b, k));
        if (lo - component(h, k) >= c.reach || -hi - component(h, k) >= c.reach) return;
    }
    const Fixed t = closest_to_box(c.a, c.d, h);
    const Vec3 q = c.a + c.d * t;
    Vec3 diff;  // closest box point minus q
    int sign[3], outside = 0, face_k = 0;
    for (int k = 0; k < 3; ++k) {
        const Fixed e = excess(component(q, k), component(h, k));
        component(diff, k) = -e;
        sign[k] = e.raw > 0 ? 1 : e.raw < 0 ? -1 : 0;
        if (sign[k] != 0) {
            ++outside;
            face_k = k;
        }
    }
    const u128 dist_sq = length_sq_wide(diff);
    if (dist_sq >= static_cast<u128>(mul_wide(c.reach.raw, c.reach.raw))) return;
    if (dist_sq < (u128{1} << 24)) {  // within 2^-20 m: the separating axes give the normal
        capsule_box_sat(c, box, m);
        return;
    }
    if (outside == 1) {
        capsule_face(c, box, face_k, sign[face_k] < 0, m);
        return;
    }
    const Fixed dist = sqrt_wide(dist_sq);
    const Vec3 nl{diff.x / dist, diff.y / dist, diff.z / dist};
    add(m, to_world(c, *box.rot, nl), box.center + to_world(c, *box.rot, q + diff), a.radius - dist, box_feature(sign));
    // Over an edge: the far end of the segment's part over the face the normal leans to most is
    // a second point when within reach. A capsule lying along that face and over its edge then
    // keeps two supports whichever way it tilts by a hair (the face case gives the same two).
    int k = 0;
    for (int j = 1; j < 3; ++j)
        if (abs(component(diff, j)) > abs(component(diff, k))) k = j;
    FaceClip f;
    if (!clip_to_face(c, h, k, f) || f.t0 == f.t1) return;
    const bool far_is_t1 = abs(f.t1 - t) > abs(f.t0 - t);
    face_point(c, box, k, sign[k] < 0, far_is_t1 ? f.t1 : f.t0, far_is_t1 ? f.code1 : f.code0, m);
}

// Box-box by the separating-axis test over the 15 axes (3 face normals of each box, 9 edge
// cross products). A face axis with the least penetration gives a face contact: the incident
// box's face most opposed to it, clipped (Sutherland-Hodgman) to the reference face's side
// planes; every clipped vertex within the margin of the reference plane is a point (up to 8).
// An edge axis wins only when it penetrates clearly less (kEdgeBias), which keeps resting
// face contacts from flickering to edge contacts; it gives one point between the two edges.

// A clipped polygon with feature ids, so a point keeps its id from frame to frame (the solver's
// warm starting matches points by it): vertex i is an incident-face corner (id 0..3), an
// incident edge e cut by reference side plane s (4 + 4 s + e), or a corner where side planes
// s1 then s2 cut (20 + 4 s1 + s2). edge[i] says what the edge from v[i] to v[i+1] lies on: an
// incident edge (0..3) or a side plane (4 + s).
// Vertices, ids and edges are written before they are read (face_contact() the first four,
// clip() each one it keeps), so they are not zero-filled: Fixed's default member initialiser
// would have face_contact() write both buffers' 8 vertices each call. The vertices are an
// anonymous union's member so that Poly() leaves them unconstructed; assigning one (Vec3's
// assignment is trivial) begins the array's lifetime ([class.union.general]).
struct Poly {
    Poly() {}
    int n = 0;
    union {
        Vec3 v[8];
    };
    std::uint8_t id[8];
    std::uint8_t edge[8];
};

// Keeps the part of poly where dot(dir, p) <= limit; `plane` (0..3) names the side plane.
// unit: dir is exactly +-e_k (unit = +-(k + 1), else 0): dot(dir, p) is then +-p_k bit for bit
// (one exact term rounded once; -p_k saturates as the rounding does), taken without products.
// Returns the clipped polygon: `in` itself when no vertex lies beyond the plane (every vertex
// is then kept with its id and edge, and no edge crosses, so `out` would be a copy of `in`:
// a face resting well inside the reference face, as on the floor, is not copied four times),
// else `out`.
const Poly& clip(const Poly& in, const Vec3& dir, int unit, Fixed limit, int plane, Poly& out, bool shortcut) {
    // Each vertex's signed distance once: the end of one edge is the start of the next.
    Fixed dist[8];
    bool beyond = false;
    if (unit == 0) {
        for (int i = 0; i < in.n; ++i) {
            dist[i] = dot(dir, in.v[i]) - limit;
            beyond |= dist[i].raw > 0;
        }
    } else {
        const int k = (unit > 0 ? unit : -unit) - 1;
        for (int i = 0; i < in.n; ++i) {
            dist[i] = (unit > 0 ? component(in.v[i], k) : -component(in.v[i], k)) - limit;
            beyond |= dist[i].raw > 0;
        }
    }
    if (!beyond && shortcut) return in;
    out.n = 0;
    const auto push = [&](const Vec3& p, int id, int edge) {
        if (out.n >= 8) return;
        out.v[out.n] = p;
        out.id[out.n] = static_cast<std::uint8_t>(id);
        out.edge[out.n++] = static_cast<std::uint8_t>(edge);
    };
    for (int i = 0; i < in.n; ++i) {
        const int next = i + 1 == in.n ? 0 : i + 1;
        const Vec3& p = in.v[i];
        const Vec3& q = in.v[next];
        const int on = in.edge[i];
        const Fixed dp = dist[i], dq = dist[next];
        if (dp.raw <= 0) push(p, in.id[i], on);
        if ((dp.raw < 0) != (dq.raw < 0) && dp.raw != 0 && dq.raw != 0) {
            const int id = on < 4 ? 4 + 4 * plane + on : 20 + 4 * (on - 4) + plane;
            // Leaving the kept side, the next edge runs along this plane; entering, along `on`.
            push(p + (q - p) * (dp / (dp - dq)), id, dp.raw < 0 ? 4 + plane : on);
        }
    }
    return out;
}

Fixed projected_radius(const OrientedCollider& b, const Vec3& axis) {
    return b.half.x * abs(dot(column(*b.rot, 0), axis)) + b.half.y * abs(dot(column(*b.rot, 1), axis)) +
           b.half.z * abs(dot(column(*b.rot, 2), axis));
}

// Face contact: reference box `ref` (face axis k), incident box `inc`; n points from ref to inc.
// shortcuts: clip() may return an unchanged polygon uncopied (off only in tests).
// cosines: n . (inc's axis i) as box_box() already has them, or null to take them here.
// unturned: identity(*ref.rot), as box_box() found it (n is then +-e_k exactly).
void face_contact(const OrientedCollider& ref, int k, const Vec3& n, const OrientedCollider& inc, Fixed margin,
                  bool flip, Manifold& m, bool shortcuts, const Fixed* cosines, bool unturned) {
    // n is +-e_k exactly when the reference's axis k is a unit axis (an unturned reference: the
    // floor, a wall): then n . v is +-v_k bit for bit (one exact term rounded once; -v_k
    // saturates as the rounding does, as in clip()), so the dot products with n are components.
    const int n_unit = unturned ? (component(n, k).raw > 0 ? k + 1 : -(k + 1))
                       : n == unit_axis(k) ? k + 1 : n == -unit_axis(k) ? -(k + 1) : 0;
    const auto along_n = [&](const Vec3& v) {
        if (n_unit == 0) return dot(n, v);
        return n_unit > 0 ? component(v, n_unit - 1) : -component(v, -n_unit - 1);
    };
    // Incident face: the face of inc whose outward normal is most opposed to n.
    int j = 0;
    Fixed best = Fixed::zero(), along[3];
    for (int i = 0; i < 3; ++i) {
        along[i] = cosines != nullptr ? cosines[i] : along_n(column(*inc.rot, i));
        const Fixed c = abs(along[i]);
        if (c > best) { best = c; j = i; }
    }
    const Vec3 ij = column(*inc.rot, j);
    const Vec3 f = along[j].raw > 0 ? -ij : ij;  // outward normal of the incident face
    const Vec3 fc = inc.center + f * component(inc.half, j);
    const int u = (j + 1) % 3, v = (j + 2) % 3;
    const Vec3 eu = column(*inc.rot, u) * component(inc.half, u), ev = column(*inc.rot, v) * component(inc.half, v);
    Poly a, b;
    a.n = 4;
    a.v[0] = fc + eu + ev;
    a.v[1] = fc - eu + ev;
    a.v[2] = fc - eu - ev;
    a.v[3] = fc + eu - ev;
    for (int i = 0; i < 4; ++i) a.id[i] = a.edge[i] = static_cast<std::uint8_t>(i);
    // Side planes of the reference face (an unturned reference's are unit axes: identity()).
    const Poly* poly = &a;  // the polygon so far; a clip writes into whichever buffer it is not
    for (int s = 1; s <= 2; ++s) {
        const int t = (k + s) % 3;
        const Vec3 axis = column(*ref.rot, t);
        const Fixed c = dot(axis, ref.center), h = component(ref.half, t);
        const int unit = unturned ? t + 1 : 0;
        poly = &clip(*poly, axis, unit, c + h, 2 * s - 2, poly == &a ? b : a, shortcuts);
        poly = &clip(*poly, -axis, -unit, h - c, 2 * s - 1, poly == &a ? b : a, shortcuts);
    }
    const Fixed plane = along_n(ref.center) + component(ref.half, k);
    // Which box is the reference is part of the feature: the other choice gives other points.
    const int base = flip ? kFeatureFlipped : 0;
    for (int i = 0; i < poly->n; ++i) {
        const Fixed sep = along_n(poly->v[i]) - plane;
        if (sep > margin) continue;
        add(m, flip ? -n : n, poly->v[i], -sep, static_cast<std::uint8_t>(base + poly->id[i]));
    }
}

// True when no edge axis can matter: every one of them, computed as box_box's loop does, would
// come out at most `limit` (so none separates beyond the margin and none beats the best face
// axis by kEdgeBias). Decided from what the face axes already computed, r[i][j] = a_i . b_j,
// ta[i] = a_i . d and tb[j] = b_j . d, without a cross product, square root or division. For
// orthonormal right-handed frames the edge axis c = a_i x b_j (i1, i2, j1, j2 the next two axes
// after i, j) is r[i1][j] a_i2 - r[i2][j] a_i1 in A's frame and r[i][j2] b_j1 - r[i][j1] b_j2 in
// B's, so with sep(c / |c|) = N / |c|:
//   d . c     = ta[i2] r[i1][j] - ta[i1] r[i2][j]      = tb[j1] r[i][j2] - tb[j2] r[i][j1]
//   |c|^2     = r[i1][j]^2 + r[i2][j]^2                = r[i][j1]^2 + r[i][j2]^2
//   a_i1 . c  = -r[i2][j],  a_i2 . c = r[i1][j],  b_j1 . c = r[i][j2],  b_j2 . c = -r[i][j1]
// (a_i . c and b_j . c are 0, and leaving them out only raises N). N <= limit |c| is compared
// squared. The frames are rotation() of unit quaternions (|q|^2 within 2^-27 of 1, as
// normalised() and integrated() keep it), so their columns are orthonormal within 2^-24, which
// moves N by at most ~17 * 2^-24 S (S = |d|max + sum h_a + sum h_b) and |c| by a relative
// 2^-10 where |c| >= 2^-6. A frame whose entries are all 0 or +-1 (a room's walls) is exact:
// the formulas are taken in it, and only the other box's error remains (~3 * 2^-24 times its
// half sizes). The slack e (S 2^-16, or the other box's sum h 2^-16, plus 2^-22) covers that at
// least 8 times over, with the rounding of both this bound and box_box's loop (S 2^-24 +
// 2^-28); |limit| 2^-9 covers the error in |c|. Axes the loop skips (|c| < 2^-6) are skipped
// here only where |c|^2 is below 2^-12 by more than its error. Any doubt (large values, an
// axis near the limit) says false and box_box runs its loop; tests/sim/rigid_contact_test.cpp
// compares the two on random pairs.
// Out of line: inlined into box_box() it cost stacks_100x5 10 M instructions more over 240
// frames (docs/performance.md, "Box-box contacts, the same bits").
[[gnu::noinline]] bool edges_cannot_matter(const Fixed r[3][3], const Fixed ta[3], const Fixed tb[3], const Vec3& d, const Vec3& ha,
                         const Vec3& hb, bool exact_a, bool exact_b, std::int64_t limit) {
    constexpr std::int64_t kSmall = std::int64_t{1} << 40;  // 256 m: every product below fits
    const auto mag = [](Fixed f) { return f.raw < 0 ? -static_cast<i128>(f.raw) : static_cast<i128>(f.raw); };
    const i128 sum_a = mag(ha.x) + mag(ha.y) + mag(ha.z), sum_b = mag(hb.x) + mag(hb.y) + mag(hb.z);
    const i128 size = std::max({mag(d.x), mag(d.y), mag(d.z)}) + sum_a + sum_b;
    if (size >= kSmall || limit >= kSmall || limit <= -kSmall) return false;
    // The wide products below stay far inside i128 (and N inside int64) for frames whose
    // entries are at most 2 and distances along the axes below 2^42 raw (1024 m): anything
    // else (never a rotation of a unit quaternion with the sizes above) says false.
    constexpr std::int64_t kEntry = std::int64_t{2} << Fixed::kFracBits, kAlong = std::int64_t{1} << 42;
    std::int64_t ar[3][3];  // |r[i][j]|
    for (int i = 0; i < 3; ++i) {
        if (mag(ta[i]) >= kAlong || mag(tb[i]) >= kAlong) return false;
        for (int j = 0; j < 3; ++j) {
            if (mag(r[i][j]) > kEntry) return false;
            ar[i][j] = r[i][j].raw < 0 ? -r[i][j].raw : r[i][j].raw;
        }
    }
    const bool in_b = !exact_a && exact_b;  // the frame the formulas are taken in
    const i128 err = exact_a ? sum_b : exact_b ? sum_a : size;
    const std::int64_t e = static_cast<std::int64_t>(err >> 16) + 1024;
    const std::int64_t l_abs = limit < 0 ? -limit : limit;
    const std::int64_t bound = limit - e - (l_abs >> 9);
    const std::uint64_t b_abs = static_cast<std::uint64_t>(bound < 0 ? -bound : bound);
    const u128 b_sq = mul_wide_unsigned(b_abs, b_abs);
    // The loop skips |c|^2 < 2^-12 (2^52 in Q64.64); here |c|^2 may be off by 2^-20.
    constexpr u128 kSkipBelow = (u128{1} << 52) - (u128{1} << 45);
    constexpr int kNext[3] = {1, 2, 0}, kAfter[3] = {2, 0, 1};
    // The frame and the bound's sign are fixed for the call: the loop is instantiated for each,
    // so the nine unrolled axes select no operands and test no sign at run time.
    const auto all_pass = [&]<bool InB, bool NonNegative>() {
        for (int i = 0; i < 3; ++i) {
            const int i1 = kNext[i], i2 = kAfter[i];
            for (int j = 0; j < 3; ++j) {
                const int j1 = kNext[j], j2 = kAfter[j];
                // c's two coordinates in the chosen frame, and the distances along those axes.
                const Fixed p = InB ? r[i][j2] : r[i1][j], q = InB ? r[i][j1] : r[i2][j];
                const Fixed tp = InB ? tb[j1] : ta[i2], tq = InB ? tb[j2] : ta[i1];
                // N in Q64.64, exact, then floored once: within 1 unit of the true N (six rounded
                // Fixed products were within 3), so the slack e covers it as before.
                const i128 w = mul_wide(tp.raw, p.raw) - mul_wide(tq.raw, q.raw);
                const i128 h = mul_wide(component(ha, i1).raw, ar[i2][j]) + mul_wide(component(ha, i2).raw, ar[i1][j]) +
                               mul_wide(component(hb, j1).raw, ar[i][j2]) + mul_wide(component(hb, j2).raw, ar[i][j1]);
                const auto n = static_cast<std::int64_t>(((w < 0 ? -w : w) - h) >> Fixed::kFracBits);
                const std::int64_t l = n + e;
                // An axis with N + e <= 0 passes when the bound is not negative, skipped or not, so
                // |c|^2 is taken only after that test (the products above are in range for every
                // axis: the checks at the top bound every entry and distance, skipped axes too).
                if (NonNegative && l <= 0) continue;
                const u128 len_sq = static_cast<u128>(mul_wide(p.raw, p.raw)) + static_cast<u128>(mul_wide(q.raw, q.raw));
                if (len_sq < kSkipBelow) continue;
                // |c|^2 in Q32.32, rounded down: below 2^36 with the entries at most 2 (so a 64-bit
                // factor, which halves the wide products below).
                const auto cc = static_cast<std::uint64_t>(len_sq >> 32);
                if (NonNegative) {
                    if ((mul_wide_unsigned(static_cast<std::uint64_t>(l), static_cast<std::uint64_t>(l)) << 32) > b_sq * u128{cc}) return false;
                } else {
                    if (l >= 0) return false;
                    if ((mul_wide_unsigned(static_cast<std::uint64_t>(-l), static_cast<std::uint64_t>(-l)) << 32) < b_sq * u128{cc + 1}) return false;
                }
            }
        }
        return true;
    };
    if (bound >= 0) return in_b ? all_pass.template operator()<true, true>() : all_pass.template operator()<false, true>();
    return in_b ? all_pass.template operator()<true, false>() : all_pass.template operator()<false, false>();
}

// Every entry 0 or +-1: an exact rotation (a signed permutation), as a room's walls have.
bool axis_aligned(const Mat3& m) {
    for (const Vec3& row : m.row)
        for (const Fixed f : {row.x, row.y, row.z})
            if (f.raw != 0 && f.raw != Fixed::kOne && f.raw != -Fixed::kOne) return false;
    return true;
}

// A face axis's projected radius h.x |c0| + h.y |c1| + h.z |c2| (h the other box's half sizes,
// c its axes' cosines with the face axis), as Fixed arithmetic takes it: each product rounded
// (half to even) once, then summed. small: every h_k in [0, 2^31) raw (below 0.5 m) and every
// |c_j| below 1.5 (kCosineBound; a rotation's entries are within 2^-20 of [-1, 1]): each exact
// product is then below 1.5 * 2^63, so it is taken in one 64-bit word and rounded as round_wide()
// rounds it (the same biased shift, with no high word to carry into and no range to leave: the
// biased product stays below 2^64), and the three rounded terms, each below 1.5 * 2^31, sum
// without overflow: the same integers, without the 128-bit products and the saturation checks.
constexpr std::int64_t kCosineBound = Fixed::kOne + Fixed::kOne / 2;
[[gnu::always_inline]] inline bool small_halves(const Vec3& h) {
    return (static_cast<std::uint64_t>(h.x.raw) | static_cast<std::uint64_t>(h.y.raw) | static_cast<std::uint64_t>(h.z.raw)) <
           (std::uint64_t{1} << 31);
}
[[gnu::always_inline]] inline bool small_cosine(Fixed c) {
    // In unsigned words: c + bound wraps (is not undefined) for c near the top of the range.
    return static_cast<std::uint64_t>(c.raw) + static_cast<std::uint64_t>(kCosineBound) < static_cast<std::uint64_t>(2 * kCosineBound);
}
[[gnu::always_inline]] inline Fixed face_radius(const Vec3& h, Fixed c0, Fixed c1, Fixed c2, bool small) {
    if (!small) return h.x * abs(c0) + h.y * abs(c1) + h.z * abs(c2);
    const auto term = [](Fixed hk, Fixed c) {
        const std::uint64_t p = static_cast<std::uint64_t>(hk.raw) * static_cast<std::uint64_t>(c.raw < 0 ? -c.raw : c.raw);
        return static_cast<std::int64_t>((p + (0x7FFFFFFFu + ((p >> 32) & 1))) >> 32);
    };
    return Fixed::from_raw(term(h.x, c0) + term(h.y, c1) + term(h.z, c2));
}

// shortcuts: edges_cannot_matter() may skip the edge axes' loop, clip() an unchanged polygon's
// copy, and face_radius() take its small case (off only in tests, which check that they change
// nothing).
void box_box(const OrientedCollider& a, const OrientedCollider& b, Fixed margin, Manifold& m, bool shortcuts) {
    const Vec3 d = b.center - a.center;
    const Vec3 ca[3] = {column(*a.rot, 0), column(*a.rot, 1), column(*a.rot, 2)};
    const Vec3 cb[3] = {column(*b.rot, 0), column(*b.rot, 1), column(*b.rot, 2)};
    // c[i][j] = a_i . b_j, filled row by row by A's face axes and reused by B's (the same dot
    // products projected_radius() would take: a dot product is symmetric to the bit).
    Fixed c[3][3];
    Fixed ta[3], tb[3];  // a_k . d, b_k . d
    // Best face axis (largest separation; ties: A before B, x before y before z).
    Fixed face_sep = Fixed::min();
    int face_box = 0, face_k = 0;
    Vec3 face_n{};
    // An unturned box's axes are the unit axes: a dot product with one is the other vector's
    // component, bit for bit (identity()), so the floor's and an unturned box's take no products.
    const bool a_unturned = identity(*a.rot), b_unturned = identity(*b.rot);
    // face_radius()'s small case: A's axes take B's half sizes and a row of c, B's axes A's half
    // sizes and a column (every row checked by then).
    const bool small_a = shortcuts && small_halves(a.half), small_b = shortcuts && small_halves(b.half);
    bool small_c = true;
    for (int box = 0; box < 2; ++box) {
        const Vec3& xh = box == 0 ? a.half : b.half;
        const Vec3& yh = box == 0 ? b.half : a.half;
        const bool unturned = box == 0 ? a_unturned : b_unturned;
        for (int k = 0; k < 3; ++k) {
            const Vec3& axis = box == 0 ? ca[k] : cb[k];
            const Fixed dist = unturned ? component(d, k) : dot(d, axis);
            Fixed radius;
            (box == 0 ? ta : tb)[k] = dist;
            if (box == 0) {
                for (int j = 0; j < 3; ++j)
                    c[k][j] = a_unturned ? component(cb[j], k) : b_unturned ? component(axis, j) : dot(cb[j], axis);
                small_c = small_c && small_cosine(c[k][0]) && small_cosine(c[k][1]) && small_cosine(c[k][2]);
                radius = face_radius(yh, c[k][0], c[k][1], c[k][2], small_b && small_c);
            } else {
                radius = face_radius(yh, c[0][k], c[1][k], c[2][k], small_a && small_c);
            }
            const Fixed sep = abs(dist) - component(xh, k) - radius;
            if (sep > margin) return;
            if (sep > face_sep) {
                face_sep = sep;
                face_box = box;
                face_k = k;
                // From the reference box toward the other: for B as reference, toward A.
                const bool toward_b = dist.raw >= 0;
                face_n = (box == 0) == toward_b ? axis : -axis;
            }
        }
    }
    Fixed edge_sep = Fixed::min();
    int edge_i = 0, edge_j = 0;
    Vec3 edge_n{};
    const i128 limit = std::min<i128>(static_cast<i128>(margin.raw), static_cast<i128>(face_sep.raw) + kEdgeBias);
    // The identity is axis-aligned: the floor's and a wall's nine entries are not read again.
    if (!shortcuts || !edges_cannot_matter(c, ta, tb, d, a.half, b.half, a_unturned || axis_aligned(*a.rot),
                                           b_unturned || axis_aligned(*b.rot), static_cast<std::int64_t>(limit)))
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j) {
                const Vec3 c = cross(ca[i], cb[j]);
                const u128 len_sq = length_sq_wide(c);
                if (len_sq < (u128{1} << 52)) continue;  // |c| < 2^-6: nearly parallel edges, a face axis covers it
                Vec3 axis;
                const Fixed dist = unit_toward(c, len_sq, d, axis);
                const Fixed sep = dist - projected_radius(a, axis) - projected_radius(b, axis);
                if (sep > margin) return;
                if (sep > edge_sep) {
                    edge_sep = sep;
                    edge_i = i;
                    edge_j = j;
                    edge_n = axis;
                }
            }
    if (edge_sep.raw > face_sep.raw + kEdgeBias) {
        // Edge of A furthest along n against the edge of B furthest along -n.
        Vec3 pa = a.center, pb = b.center;
        for (int k = 0; k < 3; ++k) {
            const Vec3 ak = column(*a.rot, k), bk = column(*b.rot, k);
            if (k != edge_i) pa += dot(ak, edge_n).raw >= 0 ? ak * component(a.half, k) : -(ak * component(a.half, k));
            if (k != edge_j) pb += dot(bk, edge_n).raw >= 0 ? -(bk * component(b.half, k)) : bk * component(b.half, k);
        }
        const Vec3 ea = column(*a.rot, edge_i) * component(a.half, edge_i), eb = column(*b.rot, edge_j) * component(b.half, edge_j);
        Vec3 ca, cb;
        closest_segments(pa - ea, pa + ea, pb - eb, pb + eb, ca, cb);
        add(m, edge_n, ca + (cb - ca) * Fixed::from_raw(Fixed::kOne / 2), -edge_sep,
            static_cast<std::uint8_t>(kFeatureEdge + 3 * edge_i + edge_j));
        return;
    }
    // face_contact()'s n . (incident axis i) is +-c, the reference axis's row or column (a dot
    // product is symmetric to the bit, and one with a unit axis is the component, as either side
    // takes it). For n = -axis: dot(-axis, b) = -dot(axis, b) bit for bit when no entry of axis
    // is INT64_MIN raw (-axis exact; the exact sums are negatives, and rounding half to even is
    // symmetric) and small_c (every |c| < 1.5: no saturation either way).
    Fixed cosines[3];
    const Vec3& ref_axis = face_box == 0 ? ca[face_k] : cb[face_k];
    const bool reuse = shortcuts && small_c && ref_axis.x.raw != INT64_MIN && ref_axis.y.raw != INT64_MIN &&
                       ref_axis.z.raw != INT64_MIN;
    if (reuse) {
        const bool negative = !(face_n == ref_axis);
        for (int i = 0; i < 3; ++i) {
            const Fixed v = face_box == 0 ? c[face_k][i] : c[i][face_k];
            cosines[i] = negative ? Fixed::from_raw(-v.raw) : v;
        }
    }
    if (face_box == 0)
        face_contact(a, face_k, face_n, b, margin, false, m, shortcuts, reuse ? cosines : nullptr, a_unturned);
    else
        face_contact(b, face_k, face_n, a, margin, true, m, shortcuts, reuse ? cosines : nullptr, b_unturned);
}
}  // namespace

bool point_box(const Vec3& p, const OrientedCollider& box, Fixed reach, Vec3& normal, Vec3& surface, Fixed& distance) {
    const Mat3& r = *box.rot;
    const bool unturned = identity(r);
    const Vec3& h = box.half;
    Vec3 local;
    if (unturned) {
        local = p - box.center;
        // Quick reject on each axis before any square root.
        for (int k = 0; k < 3; ++k)
            if (abs(component(local, k)) - component(h, k) >= reach) return false;
    } else {
        // transpose_times(r, v) a coordinate at a time, each tested as it comes: a point rejected
        // on x or y skips the other coordinates' dot products (two thirds of a turned box's
        // calls on bodies_1k_rigid are rejects). Skipping one changes nothing unless it would
        // have saturated (its overflow is counted): not with |v_k| <= 2^60 raw and the column's
        // entries within [-2, 2] (each product below 2^93, so the sum rounds below 2^63), else
        // it is taken anyway.
        const Vec3 v = p - box.center;
        const auto within = [](Fixed f, std::uint64_t bound) {
            return static_cast<std::uint64_t>(f.raw) + bound <= 2 * bound;  // |f| <= bound, wrapping
        };
        constexpr std::uint64_t kV = std::uint64_t{1} << 60, kEntry = std::uint64_t{2} << Fixed::kFracBits;
        const auto safe_to_skip = [&](int k) {
            const Vec3 col = column(r, k);
            return within(v.x, kV) && within(v.y, kV) && within(v.z, kV) && within(col.x, kEntry) &&
                   within(col.y, kEntry) && within(col.z, kEntry);
        };
        for (int k = 0; k < 3; ++k) {
            component(local, k) = dot(column(r, k), v);
            if (abs(component(local, k)) - component(h, k) >= reach) {
                for (int j = k + 1; j < 3; ++j)
                    if (!safe_to_skip(j)) (void)dot(column(r, j), v);
                return false;
            }
        }
    }
    Vec3 q = local;
    bool inside = true;
    for (int k = 0; k < 3; ++k) {
        const Fixed c = clamp(component(local, k), -component(h, k), component(h, k));
        if (c != component(local, k)) inside = false;
        component(q, k) = c;
    }
    const Fixed zero = Fixed::zero(), one = Fixed::one();
    Vec3 nl;
    int axis = -1;  // nl = e_axis (-e_axis when axis_neg), or -1 for a general nl
    bool axis_neg = false;
    if (!inside) {
        const Vec3 d = q - local;
        const u128 dsq = length_sq_wide(d);
        if (dsq >= static_cast<u128>(mul_wide(reach.raw, reach.raw))) return false;
        // Off one face only (the common case: a ball on the floor), d has one non-zero
        // component c: |d| = |c| exactly (the square root of a perfect square) and d / |d| is
        // exactly the unit axis with c's sign (0 / |c| = 0, c / |c| = +-1, correctly rounded),
        // so the root and the three divisions give those bits without being computed.
        const int nonzero = (d.x.raw != 0) + (d.y.raw != 0) + (d.z.raw != 0);
        if (nonzero == 1) {
            const int k = d.x.raw != 0 ? 0 : d.y.raw != 0 ? 1 : 2;
            const Fixed c = component(d, k);
            distance = abs(c);
            nl = {zero, zero, zero};
            component(nl, k) = c.raw > 0 ? one : -one;
            axis = k;
            axis_neg = c.raw < 0;
        } else {
            distance = sqrt_wide(dsq);
            if (distance.raw == 0) return false;
            nl = {d.x / distance, d.y / distance, d.z / distance};
        }
    } else {
        // Inside: out through the nearest face (ties: x, then y, then z); the normal points from
        // the point into the box, i.e. opposite to that face's outward direction.
        int best_axis = 0;
        bool best_neg = false;
        Fixed best = h.x - local.x;
        for (int k = 0; k < 3; ++k) {
            const Fixed up = component(h, k) - component(local, k), down = component(local, k) + component(h, k);
            if (up < best) { best = up; best_axis = k; best_neg = false; }
            if (down < best) { best = down; best_axis = k; best_neg = true; }
        }
        nl = {zero, zero, zero};
        component(nl, best_axis) = best_neg ? one : -one;
        component(q, best_axis) = best_neg ? -component(h, best_axis) : component(h, best_axis);
        distance = -best;
        axis = best_axis;
        axis_neg = !best_neg;
    }
    // r e_k is column k bit for bit (each row's dot product has one exact term, rounded once),
    // and r (-e_k) its negation (an entry of Fixed::min() saturates either way, counted once).
    if (unturned) {
        normal = nl;
    } else if (axis >= 0) {
        const Vec3 col = column(r, axis);
        normal = axis_neg ? -col : col;
    } else {
        normal = r * nl;
    }
    surface = box.center + (unturned ? q : r * q);
    return true;
}

namespace {
// shortcuts: on in contact_points(), off in contact_points_general() (tests).
[[gnu::always_inline]] inline void contact_points_with(const OrientedCollider& a, const OrientedCollider& b, Fixed margin,
                                                       Manifold& m, bool shortcuts) {
    m.count = 0;
    const bool a_box = a.shape == Shape::Box, b_box = b.shape == Shape::Box;
    if (!a_box && !b_box) {
        round_round(a, b, margin, m);
    } else if (!a_box) {
        round_box(a, b, margin, m, shortcuts);
    } else if (!b_box) {
        round_box(b, a, margin, m, shortcuts);
        for (int i = 0; i < m.count; ++i) m.points[i].normal = -m.points[i].normal;
    } else {
        box_box(a, b, margin, m, shortcuts);
    }
}
}  // namespace

void contact_points(const OrientedCollider& a, const OrientedCollider& b, Fixed margin, Manifold& m) {
    contact_points_with(a, b, margin, m, true);
}

void contact_points_general(const OrientedCollider& a, const OrientedCollider& b, Fixed margin, Manifold& m) {
    contact_points_with(a, b, margin, m, false);
}

Fixed face_axis_radius(const Vec3& h, Fixed c0, Fixed c1, Fixed c2) {
    return face_radius(h, c0, c1, c2, small_halves(h) && small_cosine(c0) && small_cosine(c1) && small_cosine(c2));
}

void box_box_exhaustive(const OrientedCollider& a, const OrientedCollider& b, Fixed margin, Manifold& m) {
    m.count = 0;
    box_box(a, b, margin, m, false);
}

}  // namespace lockroll::sim
