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
    const Fixed dist = Fixed::from_raw(static_cast<std::int64_t>(isqrt_round(dist_sq)));
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
void sphere_box(const Vec3& c, Fixed r, const OrientedCollider& box, Fixed margin, Manifold& m, std::uint8_t feature) {
    Vec3 n, q;
    Fixed dist;
    if (!point_box(c, box, r + margin, n, q, dist)) return;
    const Fixed depth = r - dist;
    // The point on the box's surface (the deepest point of the sphere is q's twin on the sphere).
    add(m, n, q, depth, feature);
}

void round_box(const OrientedCollider& a, const OrientedCollider& box, Fixed margin, Manifold& m) {
    if (a.core_half.raw == 0) {
        sphere_box(a.center, a.radius, box, margin, m, 0);
        return;
    }
    Vec3 p0, p1;
    segment(a, p0, p1);
    sphere_box(p0, a.radius, box, margin, m, 0);
    sphere_box(p1, a.radius, box, margin, m, 1);
    // The core point nearest the box centre, when it is not an end: leaning on an edge.
    const Fixed t = closest_param(p0, p1 - p0, box.center);
    if (t.raw > 0 && t < Fixed::one()) sphere_box(p0 + (p1 - p0) * t, a.radius, box, margin, m, 2);
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
struct Poly {
    int n = 0;
    Vec3 v[8];
    std::uint8_t id[8] = {};
    std::uint8_t edge[8] = {};
};

// Keeps the part of poly where dot(dir, p) <= limit; `plane` (0..3) names the side plane.
void clip(const Poly& in, const Vec3& dir, Fixed limit, int plane, Poly& out) {
    out.n = 0;
    const auto push = [&](const Vec3& p, int id, int edge) {
        if (out.n >= 8) return;
        out.v[out.n] = p;
        out.id[out.n] = static_cast<std::uint8_t>(id);
        out.edge[out.n++] = static_cast<std::uint8_t>(edge);
    };
    for (int i = 0; i < in.n; ++i) {
        const Vec3& p = in.v[i];
        const Vec3& q = in.v[(i + 1) % in.n];
        const int on = in.edge[i];
        const Fixed dp = dot(dir, p) - limit, dq = dot(dir, q) - limit;
        if (dp.raw <= 0) push(p, in.id[i], on);
        if ((dp.raw < 0) != (dq.raw < 0) && dp.raw != 0 && dq.raw != 0) {
            const int id = on < 4 ? 4 + 4 * plane + on : 20 + 4 * (on - 4) + plane;
            // Leaving the kept side, the next edge runs along this plane; entering, along `on`.
            push(p + (q - p) * (dp / (dp - dq)), id, dp.raw < 0 ? 4 + plane : on);
        }
    }
}

Fixed projected_radius(const OrientedCollider& b, const Vec3& axis) {
    return b.half.x * abs(dot(column(*b.rot, 0), axis)) + b.half.y * abs(dot(column(*b.rot, 1), axis)) +
           b.half.z * abs(dot(column(*b.rot, 2), axis));
}

// Face contact: reference box `ref` (face axis k), incident box `inc`; n points from ref to inc.
void face_contact(const OrientedCollider& ref, int k, const Vec3& n, const OrientedCollider& inc, Fixed margin,
                  bool flip, Manifold& m) {
    // Incident face: the face of inc whose outward normal is most opposed to n.
    int j = 0;
    Fixed best = Fixed::zero();
    for (int i = 0; i < 3; ++i) {
        const Fixed c = abs(dot(n, column(*inc.rot, i)));
        if (c > best) { best = c; j = i; }
    }
    const Vec3 ij = column(*inc.rot, j);
    const Vec3 f = dot(n, ij).raw > 0 ? -ij : ij;  // outward normal of the incident face
    const Vec3 fc = inc.center + f * comp(inc.half, j);
    const int u = (j + 1) % 3, v = (j + 2) % 3;
    const Vec3 eu = column(*inc.rot, u) * comp(inc.half, u), ev = column(*inc.rot, v) * comp(inc.half, v);
    Poly a, b;
    a.n = 4;
    a.v[0] = fc + eu + ev;
    a.v[1] = fc - eu + ev;
    a.v[2] = fc - eu - ev;
    a.v[3] = fc + eu - ev;
    for (int i = 0; i < 4; ++i) a.id[i] = a.edge[i] = static_cast<std::uint8_t>(i);
    // Side planes of the reference face.
    for (int s = 1; s <= 2; ++s) {
        const int t = (k + s) % 3;
        const Vec3 axis = column(*ref.rot, t);
        const Fixed c = dot(axis, ref.center), h = comp(ref.half, t);
        clip(a, axis, c + h, 2 * s - 2, b);
        clip(b, -axis, h - c, 2 * s - 1, a);
    }
    const Fixed plane = dot(n, ref.center) + comp(ref.half, k);
    // Which box is the reference is part of the feature: the other choice gives other points.
    const int base = flip ? kFeatureFlipped : 0;
    for (int i = 0; i < a.n; ++i) {
        const Fixed sep = dot(n, a.v[i]) - plane;
        if (sep > margin) continue;
        add(m, flip ? -n : n, a.v[i], -sep, static_cast<std::uint8_t>(base + a.id[i]));
    }
}

constexpr std::int64_t kEdgeBias = Fixed::kOne / 200;  // 5 mm

void box_box(const OrientedCollider& a, const OrientedCollider& b, Fixed margin, Manifold& m) {
    const Vec3 d = b.center - a.center;
    // Best face axis (largest separation; ties: A before B, x before y before z).
    Fixed face_sep = Fixed::min();
    int face_box = 0, face_k = 0;
    Vec3 face_n{};
    for (int box = 0; box < 2; ++box) {
        const OrientedCollider& x = box == 0 ? a : b;
        const OrientedCollider& y = box == 0 ? b : a;
        for (int k = 0; k < 3; ++k) {
            const Vec3 axis = column(*x.rot, k);
            const Fixed dist = dot(d, axis);
            const Fixed sep = abs(dist) - comp(x.half, k) - projected_radius(y, axis);
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
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) {
            const Vec3 c = cross(column(*a.rot, i), column(*b.rot, j));
            const u128 len_sq = length_sq_wide(c);
            if (len_sq < (u128{1} << 52)) continue;  // |c| < 2^-6: nearly parallel edges, a face axis covers it
            const Fixed len = Fixed::from_raw(static_cast<std::int64_t>(isqrt_round(len_sq)));
            Vec3 axis{c.x / len, c.y / len, c.z / len};
            Fixed dist = dot(d, axis);
            if (dist.raw < 0) {
                axis = -axis;
                dist = -dist;
            }
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
            if (k != edge_i) pa += dot(ak, edge_n).raw >= 0 ? ak * comp(a.half, k) : -(ak * comp(a.half, k));
            if (k != edge_j) pb += dot(bk, edge_n).raw >= 0 ? -(bk * comp(b.half, k)) : bk * comp(b.half, k);
        }
        const Vec3 ea = column(*a.rot, edge_i) * comp(a.half, edge_i), eb = column(*b.rot, edge_j) * comp(b.half, edge_j);
        Vec3 ca, cb;
        closest_segments(pa - ea, pa + ea, pb - eb, pb + eb, ca, cb);
        add(m, edge_n, ca + (cb - ca) * Fixed::from_raw(Fixed::kOne / 2), -edge_sep,
            static_cast<std::uint8_t>(kFeatureEdge + 3 * edge_i + edge_j));
        return;
    }
    if (face_box == 0)
        face_contact(a, face_k, face_n, b, margin, false, m);
    else
        face_contact(b, face_k, face_n, a, margin, true, m);
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
        box_box(a, b, margin, m);
    }
}

}  // namespace lockroll::sim
