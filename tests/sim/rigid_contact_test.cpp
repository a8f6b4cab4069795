// sim/rigid_contact.h: manifolds with points for oriented shapes.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>

#include "sim/rigid_contact.h"

namespace lockroll::sim {
namespace {

double d(Fixed f) { return static_cast<double>(f.raw) / 4294967296.0; }
Fixed fx(double v) { return Fixed::from_raw(static_cast<std::int64_t>(std::llround(v * 4294967296.0))); }
Vec3 v3(double x, double y, double z) { return {fx(x), fx(y), fx(z)}; }

const Mat3 kIdentity = rotation(Quat{});

OrientedCollider floor_box() {
    OrientedCollider c;
    c.shape = Shape::Box;
    c.center = v3(0, -0.5, 0);
    c.rot = &kIdentity;
    c.half = v3(10, 0.5, 10);
    return c;
}

TEST(RigidContact, SphereOnFloorTouchesAtItsLowestPoint) {
    OrientedCollider s;
    s.center = v3(1, 0.49, 2);
    s.rot = &kIdentity;
    s.radius = fx(0.5);
    Manifold m;
    contact_points(s, floor_box(), fx(0.05), m);
    ASSERT_EQ(m.count, 1);
    EXPECT_EQ(m.points[0].normal, v3(0, -1, 0));  // sphere (A) toward floor (B)
    EXPECT_NEAR(d(m.points[0].depth), 0.01, 1e-9);
    EXPECT_NEAR(d(m.points[0].point.x), 1, 1e-9);
    EXPECT_NEAR(d(m.points[0].point.y), 0, 1e-9);
}

// point_box's general arithmetic, written out: what its shortcuts for an unturned box (no
// matrix products), for a point off one face only (no root, no divisions) and for a normal
// along a box axis (a column of the rotation, no product) must reproduce.
bool point_box_general(const Vec3& p, const OrientedCollider& box, Fixed reach, Vec3& normal, Vec3& surface,
                       Fixed& distance) {
    const Mat3& r = *box.rot;
    const Vec3 local = transpose_times(r, p - box.center);
    const Vec3& h = box.half;
    const Fixed lc[3] = {local.x, local.y, local.z}, hc[3] = {h.x, h.y, h.z};
    Fixed q[3];
    bool inside = true;
    for (int k = 0; k < 3; ++k) {
        if (abs(lc[k]) - hc[k] >= reach) return false;
        q[k] = clamp(lc[k], -hc[k], hc[k]);
        inside = inside && q[k] == lc[k];
    }
    if (inside) {  // out through the nearest face (ties: x, y, z), normal into the box
        int best_axis = 0;
        bool best_neg = false;
        Fixed best = hc[0] - lc[0];
        for (int k = 0; k < 3; ++k) {
            const Fixed up = hc[k] - lc[k], down = lc[k] + hc[k];
            if (up < best) { best = up; best_axis = k; best_neg = false; }
            if (down < best) { best = down; best_axis = k; best_neg = true; }
        }
        Fixed nl[3] = {Fixed::zero(), Fixed::zero(), Fixed::zero()};
        nl[best_axis] = best_neg ? Fixed::one() : -Fixed::one();
        q[best_axis] = best_neg ? -hc[best_axis] : hc[best_axis];
        distance = -best;
        normal = r * Vec3{nl[0], nl[1], nl[2]};
        surface = box.center + r * Vec3{q[0], q[1], q[2]};
        return true;
    }
    const Vec3 dl{q[0] - lc[0], q[1] - lc[1], q[2] - lc[2]};
    const u128 dsq = length_sq_wide(dl);
    if (dsq >= static_cast<u128>(mul_wide(reach.raw, reach.raw))) return false;
    distance = Fixed::from_raw(static_cast<std::int64_t>(isqrt_round(dsq)));
    if (distance.raw == 0) return false;
    normal = r * Vec3{dl.x / distance, dl.y / distance, dl.z / distance};
    surface = box.center + r * Vec3{q[0], q[1], q[2]};
    return true;
}

TEST(RigidContact, PointBoxShortcutsGiveTheGeneralBits) {
    std::mt19937_64 rng(19);
    std::uniform_real_distribution<double> u(-2.5, 2.5);
    OrientedCollider box;
    box.shape = Shape::Box;
    box.rot = &kIdentity;
    box.half = v3(1.5, 0.5, 0.75);
    int off_one_face = 0, off_an_edge = 0, inside = 0, turned = 0;
    for (int i = 0; i < 200000; ++i) {
        // Every other box turned (any unit quaternion): its normals along an axis are columns.
        const Mat3 rot = rotation(normalised({fx(u(rng)), fx(u(rng)), fx(u(rng)), fx(u(rng))}));
        box.rot = i % 2 == 0 ? &kIdentity : &rot;
        box.center = v3(u(rng) * 100, u(rng), u(rng) * 100);
        const Vec3 p = box.center + v3(u(rng), u(rng), u(rng));
        const Fixed reach = fx(0.2 + (u(rng) + 2.5) / 5);
        Vec3 n1, s1, n2, s2;
        Fixed d1, d2;
        const bool hit1 = point_box(p, box, reach, n1, s1, d1), hit2 = point_box_general(p, box, reach, n2, s2, d2);
        ASSERT_EQ(hit1, hit2) << i;
        if (!hit1) continue;
        ASSERT_EQ(n1, n2) << i;
        ASSERT_EQ(s1, s2) << i;
        ASSERT_EQ(d1, d2) << i;
        const Vec3 nl = transpose_times(*box.rot, n1);  // within rounding of the local normal
        const auto big = [](Fixed f) { return abs(f) > Fixed::ratio(1, 2); };
        const bool axis = big(nl.x) + big(nl.y) + big(nl.z) == 1 && abs(nl.x) + abs(nl.y) + abs(nl.z) < Fixed::ratio(101, 100);
        if (d1.raw <= 0) ++inside;
        else (axis ? off_one_face : off_an_edge) += 1;
        turned += i % 2 == 1 && axis;
    }
    EXPECT_GT(off_one_face, 1000);  // every case is exercised
    EXPECT_GT(off_an_edge, 1000);
    EXPECT_GT(inside, 1000);
    EXPECT_GT(turned, 1000);
}

// point_box() takes a turned box's local coordinates one at a time and rejects on x or y
// before the later dot products; where a skipped one would have saturated (an overflow event, which
// a World folds into its state) it must still be taken. Matrices and offsets at every scale, from
// rotations and metres to entries of 2^29 and offsets at Fixed's limits: the answer and the
// overflow count must be point_box_general()'s.
TEST(RigidContact, PointBoxEarlyRejectCountsTheGeneralOverflows) {
    std::mt19937_64 rng(2023);
    std::uniform_real_distribution<double> u(-1, 1);
    std::uniform_int_distribution<int> scale(0, 62);
    OrientedCollider box;
    box.shape = Shape::Box;
    box.half = v3(0.3, 0.2, 0.4);
    int rejected = 0, overflowed = 0, hits = 0;
    for (int i = 0; i < 100000; ++i) {
        // A rotation, or one with a column (or all) scaled up; the point near, far, or at the limits.
        const Mat3 rot = rotation(normalised({fx(u(rng)), fx(u(rng)), fx(u(rng)), fx(u(rng))}));
        Mat3 m = rot;
        const int mode = i % 4;
        const auto big = [&] { return Fixed::from_raw(static_cast<std::int64_t>(u(rng) * std::ldexp(1.0, scale(rng)))); };
        if (mode == 1) m.row[0].y = big(), m.row[1].y = big(), m.row[2].z = big();
        if (mode == 2)
            for (Vec3& row : m.row) row = {big(), big(), big()};
        box.rot = &m;
        box.center = v3(u(rng) * 10, u(rng), u(rng) * 10);
        Vec3 off = mode == 0 ? v3(u(rng), u(rng), u(rng)) : Vec3{big(), big(), big()};
        if (mode == 3) off = {Fixed::from_raw(INT64_MAX), big(), Fixed::from_raw(INT64_MIN)};
        const Vec3 p = box.center + off;
        const Fixed reach = fx(0.2);
        Vec3 n1, s1, n2, s2;
        Fixed d1, d2;
        const auto before = overflow_events();
        const bool hit1 = point_box(p, box, reach, n1, s1, d1);
        const auto mid = overflow_events();
        const bool hit2 = point_box_general(p, box, reach, n2, s2, d2);
        const auto events = overflow_events() - mid;
        ASSERT_EQ(hit1, hit2) << i;
        ASSERT_EQ(mid - before, events) << i;
        overflowed += events > 0;
        if (!hit1) {
            ++rejected;
            continue;
        }
        ++hits;
        ASSERT_EQ(n1, n2) << i;
        ASSERT_EQ(s1, s2) << i;
        ASSERT_EQ(d1, d2) << i;
    }
    EXPECT_GT(rejected, 50000) << hits;  // rejects with and without saturation are compared
    EXPECT_GT(overflowed, 10000);
}

TEST(RigidContact, SpeculativeWithinTheMarginOnly) {
    OrientedCollider s;
    s.center = v3(0, 0.53, 0);
    s.rot = &kIdentity;
    s.radius = fx(0.5);
    Manifold m;
    contact_points(s, floor_box(), fx(0.05), m);
    ASSERT_EQ(m.count, 1);
    EXPECT_NEAR(d(m.points[0].depth), -0.03, 1e-9);
    s.center = v3(0, 0.56, 0);
    contact_points(s, floor_box(), fx(0.05), m);
    EXPECT_EQ(m.count, 0);
}

TEST(RigidContact, SphereAgainstARotatedBoxUsesItsFace) {
    // A box turned 45 degrees about z: its +x face normal is (1, 1, 0)/sqrt 2.
    const double h = std::sqrt(0.5);
    const Mat3 r = rotation(normalised({fx(std::cos(M_PI / 8)), Fixed::zero(), Fixed::zero(), fx(std::sin(M_PI / 8))}));
    OrientedCollider box;
    box.shape = Shape::Box;
    box.rot = &r;
    box.half = v3(1, 1, 1);
    OrientedCollider s;
    s.rot = &kIdentity;
    s.radius = fx(0.5);
    s.center = v3(1.4 * h, 1.4 * h, 0);  // 1.4 m out along the face normal: 0.1 m deep
    Manifold m;
    contact_points(s, box, fx(0.05), m);
    ASSERT_EQ(m.count, 1);
    EXPECT_NEAR(d(m.points[0].normal.x), -h, 1e-8);
    EXPECT_NEAR(d(m.points[0].normal.y), -h, 1e-8);
    EXPECT_NEAR(d(m.points[0].depth), 0.1, 1e-8);
}

TEST(RigidContact, BoxOnFloorHasFourCornerPoints) {
    OrientedCollider b;
    b.shape = Shape::Box;
    b.center = v3(0, 0.49, 0);
    b.rot = &kIdentity;
    b.half = v3(0.5, 0.5, 0.5);
    Manifold m;
    contact_points(b, floor_box(), fx(0.05), m);
    ASSERT_EQ(m.count, 4);
    for (int i = 0; i < 4; ++i) {
        EXPECT_EQ(m.points[i].normal, v3(0, -1, 0));
        EXPECT_NEAR(d(m.points[i].depth), 0.01, 1e-9);
        EXPECT_NEAR(d(m.points[i].point.y), 0, 0.0100001);  // on one of the two touching faces
        EXPECT_NEAR(std::fabs(d(m.points[i].point.x)), 0.5, 1e-8);
    }
}

TEST(RigidContact, TurnedBoxOnFloorRestsOnAnEdge) {
    // A cube turned 45 degrees about z with its lowest edge 1 cm into the floor: two points, the
    // ends of that edge.
    const Mat3 r = rotation(normalised({fx(std::cos(M_PI / 8)), Fixed::zero(), Fixed::zero(), fx(std::sin(M_PI / 8))}));
    OrientedCollider b;
    b.shape = Shape::Box;
    b.center = v3(0, std::sqrt(0.5) - 0.01, 0);
    b.rot = &r;
    b.half = v3(0.5, 0.5, 0.5);
    Manifold m;
    contact_points(b, floor_box(), fx(0.005), m);
    ASSERT_EQ(m.count, 2);
    for (int i = 0; i < 2; ++i) {
        EXPECT_EQ(m.points[i].normal, v3(0, -1, 0));
        EXPECT_NEAR(d(m.points[i].depth), 0.01, 1e-7);
        EXPECT_NEAR(d(m.points[i].point.x), 0, 1e-7);
        EXPECT_NEAR(std::fabs(d(m.points[i].point.z)), 0.5, 1e-7);
    }
}

TEST(RigidContact, CrossedBoxEdgesMeetEdgeOnEdge) {
    // Two long bars turned 45 degrees about their long axes (x and z), one above the other: their
    // edges cross; no corner of either is near the other.
    const Mat3 ra = rotation(normalised({fx(std::cos(M_PI / 8)), fx(std::sin(M_PI / 8)), Fixed::zero(), Fixed::zero()}));
    const Mat3 rb = rotation(normalised({fx(std::cos(M_PI / 8)), Fixed::zero(), Fixed::zero(), fx(std::sin(M_PI / 8))}));
    OrientedCollider a, b;
    a.shape = b.shape = Shape::Box;
    a.rot = &ra;
    b.rot = &rb;
    a.half = v3(2, 0.5, 0.5);
    b.half = v3(0.5, 0.5, 2);
    a.center = v3(0, 0, 0);
    b.center = v3(0, 2 * std::sqrt(0.5) - 0.02, 0);
    Manifold m;
    contact_points(a, b, fx(0.005), m);
    ASSERT_EQ(m.count, 1);
    EXPECT_NEAR(d(m.points[0].normal.y), 1, 1e-7);
    EXPECT_NEAR(d(m.points[0].depth), 0.02, 1e-7);
    EXPECT_NEAR(d(m.points[0].point.x), 0, 1e-7);
    EXPECT_NEAR(d(m.points[0].point.z), 0, 1e-7);
}

// ---- Capsule-box, exact ----

Quat quat(double w, double x, double y, double z) {
    const double n = std::sqrt(w * w + x * x + y * y + z * z);
    return normalised({fx(w / n), fx(x / n), fx(y / n), fx(z / n)});
}

struct D3 {
    double x, y, z;
};
D3 dd(const Vec3& v) { return {d(v.x), d(v.y), d(v.z)}; }
D3 operator+(D3 a, D3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
D3 operator-(D3 a, D3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
D3 operator*(D3 a, double s) { return {a.x * s, a.y * s, a.z * s}; }
double dotd(D3 a, D3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
D3 col(const Mat3& r, int k) {
    return k == 0 ? D3{d(r.row[0].x), d(r.row[1].x), d(r.row[2].x)}
           : k == 1 ? D3{d(r.row[0].y), d(r.row[1].y), d(r.row[2].y)}
                    : D3{d(r.row[0].z), d(r.row[1].z), d(r.row[2].z)};
}
Vec3 v3(D3 v) { return v3(v.x, v.y, v.z); }

OrientedCollider capsule(const Mat3& r, D3 center, double radius, double core_half) {
    OrientedCollider c;
    c.shape = Shape::Capsule;
    c.rot = &r;
    c.center = v3(center);
    c.radius = fx(radius);
    c.core_half = fx(core_half);
    return c;
}

OrientedCollider box(const Mat3& r, D3 center, D3 half) {
    OrientedCollider c;
    c.shape = Shape::Box;
    c.rot = &r;
    c.center = v3(center);
    c.half = v3(half);
    return c;
}

// The same points, in the same order, bit for bit: what a shortcut must give against the
// general path (contact_points_general, box_box_exhaustive).
bool same_manifold(const Manifold& fast, const Manifold& full) {
    if (fast.count != full.count) return false;
    for (int i = 0; i < fast.count; ++i) {
        const ContactPoint &p = fast.points[i], &q = full.points[i];
        if (!(p.normal == q.normal && p.point == q.point && p.depth == q.depth && p.feature == q.feature)) return false;
    }
    return true;
}

// Two boxes through contact_points() and box_box_exhaustive(), x first unless swapped, margin
// 0.02: true when the manifolds are the same bit for bit; full gets the exhaustive one.
bool exhaustive_agrees(const OrientedCollider& x, const OrientedCollider& y, bool swapped, Manifold& full) {
    const OrientedCollider& a = swapped ? y : x;
    const OrientedCollider& b = swapped ? x : y;
    Manifold fast;
    contact_points(a, b, fx(0.02), fast);
    box_box_exhaustive(a, b, fx(0.02), full);
    return same_manifold(fast, full);
}

// The edge-axis shortcut (edges_cannot_matter) must never change a manifold: random pairs of
// boxes at every orientation and distance, from apart to deep, compared bit for bit with the
// exhaustive test of all 15 axes. A quarter of the pairs have an exact axis-aligned box (a
// wall or floor, up to 20 m long) as A, a quarter as B: the shortcut takes its formulas in an
// exact frame with less slack.
TEST(RigidContact, BoxBoxEdgeShortcutChangesNoManifold) {
    std::mt19937_64 rng(12);
    std::uniform_real_distribution<double> u(-1, 1), size(0.05, 0.6), tilt(-0.05, 0.05), unit(0, 1);
    const Fixed one = Fixed::one(), zero = Fixed::zero();
    // The identity and a quarter turn about y, both exact.
    const Mat3 exact[2] = {rotation(Quat{}), {{{zero, zero, one}, {zero, one, zero}, {-one, zero, zero}}}};
    int touching = 0, edge = 0, differ = 0;
    for (int n = 0; n < 80000; ++n) {
        const int mode = n % 4;  // 0 nearly axis-aligned (a pile), 1 any, 2 A exact, 3 B exact
        const auto random_quat = [&] {
            return mode == 0 ? quat(1, tilt(rng), tilt(rng), tilt(rng)) : quat(u(rng), u(rng), u(rng), u(rng));
        };
        const Mat3 qa = rotation(random_quat()), qb = rotation(random_quat());
        const Mat3& ra = mode == 2 ? exact[n / 4 % 2] : qa;
        const Mat3& rb = mode == 3 ? exact[n / 4 % 2] : qb;
        const auto half = [&](bool wall) {
            return wall && n / 8 % 2 == 0 ? D3{20 * unit(rng) + 0.1, size(rng), 20 * unit(rng) + 0.1}
                                          : D3{size(rng), size(rng), size(rng)};
        };
        const D3 ha = half(mode == 2), hb = half(mode == 3);
        // B's centre: along a random direction from A's, from 0.3 to 1.05 times the distance at
        // which the boxes' bounding boxes (in A's frame for a wall) would just touch.
        D3 dir{u(rng), u(rng), u(rng)};
        const double len = std::sqrt(dotd(dir, dir)) + 1e-9;
        dir = dir * (1 / len);
        const double rb_r = std::sqrt(dotd(hb, hb)), ra_r = std::sqrt(dotd(ha, ha));
        double reach = ra_r + rb_r;
        if (mode == 2 && ha.x > 1) reach = std::abs(dir.y) * ha.y + rb_r;  // lean on the wall's face
        if (mode == 3 && hb.x > 1) reach = std::abs(dir.y) * hb.y + ra_r;
        const double dist = reach * (0.3 + 0.75 * unit(rng));
        const OrientedCollider a = box(ra, {0, 0, 0}, ha), b = box(rb, dir * dist, hb);
        Manifold fast, full;
        contact_points(a, b, fx(0.02), fast);
        box_box_exhaustive(a, b, fx(0.02), full);
        if (!same_manifold(fast, full)) ++differ;
        if (full.count > 0) ++touching;
        if (full.count > 0 && full.points[0].feature >= kFeatureEdge) ++edge;
    }
    EXPECT_EQ(differ, 0);
    // The sample reaches both kinds of contact, so the comparison means something.
    EXPECT_GT(touching, 20000);
    EXPECT_GT(edge, 500);
}

// face_contact() takes n . v as a component when the reference face's normal n is exactly a
// unit axis (an unturned reference: the floor, a wall); every face point's depth must be the
// general plane distance -(n . p - (n . c + h_k)) with dot products, bit for bit, whichever
// box is the reference and whichever way n points.
TEST(RigidContact, UnturnedReferenceFaceDepthsAreTheDotProducts) {
    std::mt19937_64 rng(1919);
    std::uniform_real_distribution<double> u(-1, 1), size(0.1, 0.6), tilt(-0.3, 0.3);
    int points = 0, flipped = 0, negative = 0;
    for (int n = 0; n < 40000; ++n) {
        // An unturned box and a tilted one, either first; the tilted one is placed just
        // touching along a random unit axis of the unturned box (pile contacts).
        const Mat3 turned = rotation(quat(1, tilt(rng), tilt(rng), tilt(rng)));
        const D3 hu{size(rng) * 4, size(rng), size(rng) * 4}, ht{size(rng), size(rng), size(rng)};
        const int axis = n % 3;
        const double sign = n / 3 % 2 == 0 ? 1 : -1;
        const double hu_k = axis == 0 ? hu.x : axis == 1 ? hu.y : hu.z;
        const double reach = hu_k + std::sqrt(dotd(ht, ht)) * (0.55 + 0.4 * (u(rng) + 1) / 2);
        D3 c{u(rng) * 0.3, u(rng) * 0.3, u(rng) * 0.3};
        (axis == 0 ? c.x : axis == 1 ? c.y : c.z) = sign * reach;
        const bool unturned_first = n / 6 % 2 == 0;
        const OrientedCollider fixed_box = box(kIdentity, {0, 0, 0}, hu), tilted = box(turned, c, ht);
        const OrientedCollider& a = unturned_first ? fixed_box : tilted;
        const OrientedCollider& b = unturned_first ? tilted : fixed_box;
        Manifold m;
        contact_points(a, b, fx(0.02), m);
        for (int i = 0; i < m.count; ++i) {
            const ContactPoint& p = m.points[i];
            if (p.feature >= kFeatureEdge) continue;
            const bool flip = p.feature >= kFeatureFlipped;
            const OrientedCollider& ref = flip ? b : a;
            if (ref.rot != &kIdentity) continue;  // a tilted reference: the general path
            const Vec3 nr = flip ? -p.normal : p.normal;  // from the reference toward the other
            const int k = nr.x.raw != 0 ? 0 : nr.y.raw != 0 ? 1 : 2;
            const Fixed h = k == 0 ? ref.half.x : k == 1 ? ref.half.y : ref.half.z;
            ASSERT_EQ(p.depth, -(dot(nr, p.point) - (dot(nr, ref.center) + h))) << n << " " << i;
            ++points;
            flipped += flip;
            negative += (k == 0 ? nr.x : k == 1 ? nr.y : nr.z).raw < 0;
        }
    }
    EXPECT_GT(points, 20000);  // both references, both directions
    EXPECT_GT(flipped, 5000);
    EXPECT_GT(negative, 5000);
}

// clip() returns the incident face uncopied when no vertex lies beyond a side plane; the
// manifold must be the one the full clipping gives, bit for bit. Face contacts of every kind:
// a face well inside the reference face (every clip unchanged: a box on the floor), one
// overhanging an edge or a corner of it (some clips cut), equal unturned boxes stacked exactly
// (vertices on the side planes, at distance 0), against unturned references (a component for
// the distance) and turned ones (a dot product), either box the reference.
TEST(RigidContact, UnchangedClipShortcutChangesNoManifold) {
    std::mt19937_64 rng(2020);
    std::uniform_real_distribution<double> u(-1, 1), size(0.1, 0.6), tilt(-0.08, 0.08), unit(0, 1);
    int faces = 0, inside = 0, cut = 0, differ = 0;
    for (int n = 0; n < 40000; ++n) {
        const int mode = n % 4;  // 0 on a big unturned box, 1 overhanging, 2 stacked exactly, 3 both turned
        const Mat3 upper = mode == 2 && n / 4 % 2 == 0 ? kIdentity : rotation(quat(1, tilt(rng), tilt(rng), tilt(rng)));
        const Mat3 lower = mode == 3 ? rotation(quat(1, tilt(rng), tilt(rng), tilt(rng))) : kIdentity;
        const D3 hu{size(rng), size(rng), size(rng)};
        const D3 hl = mode == 0 ? D3{5, 0.5, 5} : mode == 2 ? hu : D3{size(rng), size(rng), size(rng)};
        // Upper box's centre: over the lower one's top face, offset sideways (within it, or over
        // its edges), resting at a small gap or overlap.
        const double spread = mode == 0 ? 3 : mode == 2 ? (n / 8 % 2 == 0 ? 0 : 0.1) : 1;
        const double dx = mode == 2 && spread == 0 ? 0 : spread * u(rng) * (hl.x + hu.x);
        const double dz = mode == 2 && spread == 0 ? 0 : spread * u(rng) * (hl.z + hu.z);
        const D3 c{dx, hl.y + hu.y + 0.01 * u(rng), dz};
        const OrientedCollider lo = box(lower, {0, 0, 0}, hl), up = box(upper, c, hu);
        Manifold full;
        if (!exhaustive_agrees(lo, up, n / 16 % 2 != 0, full)) ++differ;
        if (full.count == 0 || full.points[0].feature >= kFeatureEdge) continue;
        ++faces;
        // Ids 0..3 (mod the flip) are the incident face's own corners: all four kept and no
        // other is an unchanged face; any id 4 or more is a cut.
        bool any_cut = false;
        for (int i = 0; i < full.count; ++i) any_cut |= (full.points[i].feature % kFeatureFlipped) >= 4;
        (any_cut ? cut : inside) += 1;
    }
    EXPECT_EQ(differ, 0);
    // Both kinds of face contact are reached, so the comparison means something.
    EXPECT_GT(faces, 20000) << inside << " " << cut;
    EXPECT_GT(inside, 4000);
    EXPECT_GT(cut, 5000);
}

// A capsule against an unturned box (a player against a room's wall) skips the rotation's
// products; the manifold must be the general one (contact_points_general), bit for bit, for
// capsules touching a face (one or two points), an edge or a corner, or deep inside, either
// collider first, and far boxes (the products of a centre far from the origin).
TEST(RigidContact, CapsuleUnturnedBoxShortcutGivesTheGeneralBits) {
    std::mt19937_64 rng(2021);
    std::uniform_real_distribution<double> u(-1, 1), unit(0, 1);
    int face = 0, two = 0, edge = 0, deep = 0, differ = 0;
    for (int n = 0; n < 60000; ++n) {
        const Mat3 rc = rotation(quat(u(rng), u(rng), u(rng), u(rng)));
        // Every fourth capsule lies along a face (its axis along the box's x or z).
        const Mat3 lying = rotation(quat(1, 0, 0, n % 8 < 4 ? 1 : 0));
        const bool flat = n % 4 == 0;
        const D3 hb{0.2 + 3 * unit(rng), 0.2 + unit(rng), 0.2 + 3 * unit(rng)};
        const D3 far{n % 3 == 0 ? 0 : 100 * u(rng), 0, n % 3 == 0 ? 0 : 100 * u(rng)};
        const double radius = 0.05 + 0.4 * unit(rng), core = 0.05 + 0.8 * unit(rng);
        // The capsule's centre: around the box's surface, from inside to just beyond the reach.
        D3 c{u(rng) * (hb.x + core), u(rng) * (hb.y + core), u(rng) * (hb.z + core)};
        if (flat) c.y = (hb.y + radius + 0.02 * u(rng)) * (n % 16 < 8 ? 1 : -1);
        const OrientedCollider b = box(kIdentity, far, hb), a = capsule(flat ? lying : rc, far + c, radius, core);
        const bool capsule_first = n % 2 == 0;
        Manifold fast, full;
        contact_points(capsule_first ? a : b, capsule_first ? b : a, fx(0.02), fast);
        contact_points_general(capsule_first ? a : b, capsule_first ? b : a, fx(0.02), full);
        if (!same_manifold(fast, full)) ++differ;
        if (full.count == 0) continue;
        if (full.points[0].feature >= kFeatureEdge) ++edge;
        else ++face;
        two += full.count == 2;
        deep += full.points[0].depth > fx(radius);
    }
    EXPECT_EQ(differ, 0);
    EXPECT_GT(face, 3000) << edge << " " << two << " " << deep;  // every case is exercised
    EXPECT_GT(edge, 3000);
    EXPECT_GT(two, 1000);
    EXPECT_GT(deep, 1000);
}

// Reference distance from the capsule's core segment to the box, in double: the distance is
// convex along the segment, so a golden-section search finds its minimum.
double segment_box_distance(const OrientedCollider& c, const OrientedCollider& b) {
    const D3 axis = col(*c.rot, 1) * d(c.core_half);
    const D3 p0 = dd(c.center) - axis, p1 = dd(c.center) + axis;
    const auto dist = [&](double t) {
        const D3 p = p0 + (p1 - p0) * t - dd(b.center);
        double s = 0;
        const double h[3] = {d(b.half.x), d(b.half.y), d(b.half.z)};
        for (int k = 0; k < 3; ++k) {
            const double x = dotd(p, col(*b.rot, k));
            const double e = x > h[k] ? x - h[k] : x < -h[k] ? x + h[k] : 0;
            s += e * e;
        }
        return std::sqrt(s);
    };
    double lo = 0, hi = 1;
    for (int i = 0; i < 200; ++i) {
        const double m1 = lo + (hi - lo) * 0.382, m2 = lo + (hi - lo) * 0.618;
        if (dist(m1) < dist(m2)) hi = m2; else lo = m1;
    }
    return dist((lo + hi) / 2);
}

double max_depth(const Manifold& m) {
    double best = -1e9;
    for (int i = 0; i < m.count; ++i) best = std::max(best, d(m.points[i].depth));
    return best;
}

TEST(RigidContact, CapsuleLyingOnFloorHasTwoPointsAtItsEnds) {
    // Local y axis turned onto world x: a quarter turn about z.
    const Mat3 r = rotation(quat(1, 0, 0, 1));
    Manifold m;
    contact_points(capsule(r, {0, 0.29, 0}, 0.3, 0.5), floor_box(), fx(0.05), m);
    ASSERT_EQ(m.count, 2);
    EXPECT_NE(m.points[0].feature, m.points[1].feature);
    for (int i = 0; i < 2; ++i) {
        EXPECT_EQ(m.points[i].normal, v3(0, -1, 0));
        EXPECT_NEAR(d(m.points[i].depth), 0.01, 1e-8);
        EXPECT_NEAR(d(m.points[i].point.y), 0, 1e-8);
        EXPECT_NEAR(std::fabs(d(m.points[i].point.x)), 0.5, 1e-8);
    }
    EXPECT_NEAR(d(m.points[0].point.x) + d(m.points[1].point.x), 0, 1e-8);
}

TEST(RigidContact, CapsuleLyingOnATurnedBoxFaceHasTwoPoints) {
    // A box at a skew orientation; the capsule lies along a skew direction in the plane of its
    // +z face, 2 cm deep, with one end hanging over the face's +x side: the points are at the
    // inner end and where the segment leaves the face.
    const Mat3 rb = rotation(quat(0.9, 0.2, -0.3, 0.25));
    const OrientedCollider b = box(rb, {1, 2, -1}, {0.6, 0.4, 0.5});
    const D3 ex = col(rb, 0), ey = col(rb, 1), ez = col(rb, 2);
    // Capsule axis (its local y) along 0.8 ex + 0.6 ey: a rotation taking y to that direction.
    const D3 w = ex * 0.8 + ey * 0.6;
    const D3 yw{0, 1, 0};
    const D3 axis{yw.y * w.z - yw.z * w.y, yw.z * w.x - yw.x * w.z, yw.x * w.y - yw.y * w.x};
    const double c = dotd(yw, w), s = std::sqrt(dotd(axis, axis));
    const double half_angle = std::atan2(s, c) / 2;
    const Mat3 rc = rotation(quat(std::cos(half_angle), axis.x / s * std::sin(half_angle), axis.y / s * std::sin(half_angle),
                                  axis.z / s * std::sin(half_angle)));
    const double r = 0.2, depth = 0.02;
    // Centre over the face at local (0.3, 0.1): the segment runs from (-0.1, -0.2) to (0.7, 0.4),
    // beyond the face's x = 0.6, so the clip ends at (0.6, 0.325).
    const D3 center = dd(b.center) + ex * 0.3 + ey * 0.1 + ez * (0.5 + r - depth);
    Manifold m;
    contact_points(capsule(rc, center, r, 0.5), b, fx(0.01), m);
    ASSERT_EQ(m.count, 2);
    // The segment is parallel to the face up to rounding, so whether the point at the face's
    // edge comes out as a face or an edge contact is rounding's choice; either way the same two.
    const D3 expect[2] = {dd(b.center) + ex * -0.1 + ey * -0.2 + ez * 0.5, dd(b.center) + ex * 0.6 + ey * 0.325 + ez * 0.5};
    for (int i = 0; i < 2; ++i) {
        EXPECT_NEAR(d(m.points[i].depth), depth, 1e-7);
        EXPECT_NEAR(d(m.points[i].normal.x), -ez.x, 1e-7);
        EXPECT_NEAR(d(m.points[i].normal.y), -ez.y, 1e-7);
        EXPECT_NEAR(d(m.points[i].normal.z), -ez.z, 1e-7);
        const D3 p = dd(m.points[i].point);
        const D3 e = std::fabs(p.x - expect[0].x) < 1e-3 ? expect[0] : expect[1];
        EXPECT_NEAR(p.x, e.x, 1e-6);
        EXPECT_NEAR(p.y, e.y, 1e-6);
        EXPECT_NEAR(p.z, e.z, 1e-6);
    }
    EXPECT_GT(std::fabs(d(m.points[0].point.x) - d(m.points[1].point.x)), 0.1);
    // Swapping the bodies flips the normals only.
    Manifold f;
    contact_points(b, capsule(rc, center, r, 0.5), fx(0.01), f);
    ASSERT_EQ(f.count, 2);
    for (int i = 0; i < 2; ++i) EXPECT_EQ(f.points[i].normal, -m.points[i].normal);
}

TEST(RigidContact, CapsuleOverhangingABoxEdgeKeepsTwoSupportsAsItTilts) {
    // A capsule lying along x on a box's top face, its +x end hanging 0.4 m over the edge at
    // x = 0.5, tilted by a hair or a degree either way: always two points, one at the inner end
    // and one at the edge (a face clip when the inner end dips, the exact edge point when the
    // overhang dips), and the deepest is r minus the exact distance.
    const Mat3 rb = rotation(Quat{});
    const OrientedCollider b = box(rb, {0, 0, 0}, {0.5, 0.5, 0.5});
    for (const double deg : {-1.0, -0.01, 0.0, 0.01, 1.0}) {
        const double th = (90 + deg) * M_PI / 180;  // local y to (-cos phi, -sin phi, 0)
        const Mat3 rc = rotation(quat(std::cos(th / 2), 0, 0, std::sin(th / 2)));
        const D3 center{0.4, 0.5 + 0.2 - 0.01 + 0.1 * std::sin(deg * M_PI / 180), 0};  // 1 cm deep at the edge
        const OrientedCollider c = capsule(rc, center, 0.2, 0.5);
        Manifold m;
        contact_points(c, b, fx(0.05), m);
        ASSERT_EQ(m.count, 2) << deg;
        EXPECT_NEAR(max_depth(m), 0.2 - segment_box_distance(c, b), 1e-7) << deg;
        const double x0 = d(m.points[0].point.x), x1 = d(m.points[1].point.x);
        EXPECT_NEAR(std::min(x0, x1), 0.4 - 0.5 * std::cos(deg * M_PI / 180), 1e-6) << deg;
        EXPECT_NEAR(std::max(x0, x1), 0.5, 1e-6) << deg;
    }
}

TEST(RigidContact, TiltedCapsuleTouchesByOneEnd) {
    // Tilted 30 degrees from upright about z: the lower end sphere is 2 cm into the floor, the
    // upper one far above it: one point under the lower end.
    const double a = M_PI / 6;
    const Mat3 r = rotation(quat(std::cos(a / 2), 0, 0, std::sin(a / 2)));
    const double core = 0.5, rad = 0.3;
    // Local y turned by +30 degrees about z points to (-sin a, cos a, 0).
    const D3 low{core * std::sin(a), rad - 0.02, 0};
    const D3 center = low + D3{-std::sin(a), std::cos(a), 0} * core;
    Manifold m;
    contact_points(capsule(r, center, rad, core), floor_box(), fx(0.05), m);
    ASSERT_EQ(m.count, 1);
    EXPECT_EQ(m.points[0].normal, v3(0, -1, 0));
    EXPECT_NEAR(d(m.points[0].depth), 0.02, 1e-8);
    EXPECT_NEAR(d(m.points[0].point.x), low.x, 1e-8);
    EXPECT_NEAR(d(m.points[0].point.y), 0, 1e-8);
}

TEST(RigidContact, CapsuleCrossingABoxEdgeTouchesTheEdge) {
    // A long box whose +y/+z edge runs along x at y = z = 0.5 (its centre is off the capsule's
    // plane, so the core point nearest the centre is not the touching one). The capsule lies
    // across the edge, perpendicular to it, touching 1.5 cm deep 0.3 m off its own centre.
    const Mat3 rb = rotation(Quat{});
    const OrientedCollider b = box(rb, {0, 0, -1}, {2, 0.5, 1.5});
    const double h = std::sqrt(0.5);
    const D3 u{0, h, h}, w{0, h, -h};  // out of the edge; the capsule's axis
    // A turn of -45 degrees about x takes the capsule's local y to w.
    const Mat3 rw = rotation(quat(std::cos(-M_PI / 8), std::sin(-M_PI / 8), 0, 0));
    ASSERT_NEAR(col(rw, 1).y, w.y, 1e-8);
    ASSERT_NEAR(col(rw, 1).z, w.z, 1e-8);
    const double rad = 0.25, depth = 0.015;
    const D3 edge{0.7, 0.5, 0.5};
    const D3 center = edge + u * (rad - depth) + w * 0.3;
    Manifold m;
    contact_points(capsule(rw, center, rad, 0.5), b, fx(0.01), m);
    ASSERT_EQ(m.count, 1);
    EXPECT_GE(m.points[0].feature, kFeatureEdge);
    EXPECT_NEAR(d(m.points[0].depth), depth, 1e-8);
    EXPECT_NEAR(d(m.points[0].normal.x), 0, 1e-8);
    EXPECT_NEAR(d(m.points[0].normal.y), -h, 1e-8);
    EXPECT_NEAR(d(m.points[0].normal.z), -h, 1e-8);
    EXPECT_NEAR(d(m.points[0].point.x), 0.7, 1e-8);
    EXPECT_NEAR(d(m.points[0].point.y), 0.5, 1e-8);
    EXPECT_NEAR(d(m.points[0].point.z), 0.5, 1e-8);
}

TEST(RigidContact, DeepCapsuleLeavesThroughTheNearestFace) {
    // The core segment itself 0.1 m inside the box below its top face: two points over the
    // segment's ends, each 0.1 + r deep, pushed out through the top.
    const Mat3 rb = rotation(Quat{});
    const Mat3 rc = rotation(quat(1, 0, 0, 1));  // along x
    Manifold m;
    contact_points(capsule(rc, {0.2, 0.4, 0.1}, 0.25, 0.3), box(rb, {0, 0, 0}, {1, 0.5, 1}), fx(0.01), m);
    ASSERT_EQ(m.count, 2);
    for (int i = 0; i < 2; ++i) {
        EXPECT_EQ(m.points[i].normal, v3(0, -1, 0));
        EXPECT_NEAR(d(m.points[i].depth), 0.35, 1e-8);
        EXPECT_NEAR(d(m.points[i].point.y), 0.5, 1e-8);
        EXPECT_NEAR(std::fabs(d(m.points[i].point.x) - 0.2), 0.3, 1e-8);
    }
    // Upright, its lower core end 0.3 m under the top face: one point (the upper end is far
    // above), 0.3 + r deep, out through the top.
    const Mat3 up = rotation(Quat{});
    contact_points(capsule(up, {0.1, 0.6, -0.2}, 0.25, 0.4), box(rb, {0, 0, 0}, {1, 0.5, 1}), fx(0.01), m);
    ASSERT_EQ(m.count, 1);
    EXPECT_EQ(m.points[0].normal, v3(0, -1, 0));
    EXPECT_NEAR(d(m.points[0].depth), 0.5 - 0.2 + 0.25, 1e-8);
}

TEST(RigidContact, ZeroLengthCapsuleIsASphere) {
    const Mat3 rb = rotation(quat(0.9, 0.2, -0.3, 0.25));
    const Mat3 rc = rotation(quat(0.7, -0.1, 0.5, 0.3));
    const OrientedCollider b = box(rb, {1, 2, -1}, {0.6, 0.4, 0.5});
    for (const D3 c : {D3{1.5, 2.6, -0.8}, D3{1.1, 2.1, -0.2}, D3{1.9, 2.5, -1.5}, D3{1.2, 2.0, -1.1}}) {
        OrientedCollider s = capsule(rc, c, 0.35, 0);
        s.shape = Shape::Sphere;
        Manifold ms, mc, mt;
        contact_points(s, b, fx(0.05), ms);
        contact_points(capsule(rc, c, 0.35, 0), b, fx(0.05), mc);
        ASSERT_EQ(mc.count, ms.count);
        for (int i = 0; i < ms.count; ++i) {
            EXPECT_EQ(mc.points[i].normal, ms.points[i].normal);
            EXPECT_EQ(mc.points[i].point, ms.points[i].point);
            EXPECT_EQ(mc.points[i].depth, ms.points[i].depth);
        }
        // Nearly zero length (2^-30 m): the capsule routine itself, within rounding.
        OrientedCollider t = capsule(rc, c, 0.35, 0);
        t.core_half = Fixed::from_raw(4);
        contact_points(t, b, fx(0.05), mt);
        ASSERT_GE(mt.count, ms.count > 0 ? 1 : 0);
        if (ms.count == 0) continue;
        EXPECT_NEAR(max_depth(mt), d(ms.points[0].depth), 1e-8);
        EXPECT_NEAR(d(mt.points[0].normal.x), d(ms.points[0].normal.x), 1e-7);
        EXPECT_NEAR(d(mt.points[0].normal.y), d(ms.points[0].normal.y), 1e-7);
        EXPECT_NEAR(d(mt.points[0].normal.z), d(ms.points[0].normal.z), 1e-7);
    }
}

TEST(RigidContact, CapsuleBoxDepthIsExactAtAnyOrientation) {
    // Random boxes and capsules near each other: the deepest point's depth is r minus the exact
    // segment-box distance (a golden-section search in double), every normal is unit, and the
    // points come and go with that distance against the margin.
    std::uint64_t state = 12345;
    const auto rnd = [&]() {
        state = state * 6364136223846793005ULL + 1442695040888963407ULL;
        return static_cast<double>(state >> 11) / 9007199254740992.0;
    };
    int touching = 0;
    for (int trial = 0; trial < 2000; ++trial) {
        const Mat3 rb = rotation(quat(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5, rnd() - 0.5));
        const Mat3 rc = rotation(quat(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5, rnd() - 0.5));
        const OrientedCollider b = box(rb, {rnd() - 0.5, rnd() - 0.5, rnd() - 0.5}, {0.1 + rnd(), 0.1 + rnd(), 0.1 + rnd()});
        const double rad = 0.05 + 0.5 * rnd();
        const OrientedCollider c = capsule(rc, {3 * rnd() - 1.5, 3 * rnd() - 1.5, 3 * rnd() - 1.5}, rad, 0.05 + rnd());
        const double dist = segment_box_distance(c, b);
        if (dist < 1e-3) continue;  // the core inside: the separating-axis path (tested above)
        const double margin = 0.05;
        Manifold m;
        contact_points(c, b, fx(margin), m);
        if (dist > rad + margin + 1e-6) {
            EXPECT_EQ(m.count, 0) << "trial " << trial;
            continue;
        }
        if (dist > rad + margin - 1e-6) continue;  // at the margin: either
        ASSERT_GE(m.count, 1) << "trial " << trial;
        ++touching;
        EXPECT_NEAR(max_depth(m), rad - dist, 1e-6) << "trial " << trial;
        for (int i = 0; i < m.count; ++i) {
            const D3 n = dd(m.points[i].normal);
            EXPECT_NEAR(dotd(n, n), 1, 1e-7);
            EXPECT_GE(d(m.points[i].depth), -margin - 1e-9);
        }
    }
    EXPECT_GT(touching, 50);  // the sample really exercises contacts
}

TEST(RigidContact, CrossedCapsulesMeetAtTheCrossing) {
    const double h = std::sqrt(0.5);
    const Mat3 along_x = rotation(normalised({fx(h), Fixed::zero(), Fixed::zero(), fx(h)}));
    const Mat3 along_z = rotation(normalised({fx(h), fx(h), Fixed::zero(), Fixed::zero()}));
    OrientedCollider a, b;
    a.shape = b.shape = Shape::Capsule;
    a.radius = b.radius = fx(0.25);
    a.core_half = b.core_half = fx(1);
    a.rot = &along_x;
    b.rot = &along_z;
    a.center = v3(0.3, 0, 0.2);
    b.center = v3(0, 0.4, 0);
    Manifold m;
    contact_points(a, b, fx(0.05), m);
    ASSERT_EQ(m.count, 1);
    EXPECT_NEAR(d(m.points[0].normal.y), 1, 1e-8);
    EXPECT_NEAR(d(m.points[0].depth), 0.1, 1e-8);
    EXPECT_NEAR(d(m.points[0].point.x), 0, 1e-8);
    EXPECT_NEAR(d(m.points[0].point.z), 0.2, 1e-8);
}

// box_box()'s face axes take each projected radius h.x |c0| + h.y |c1| + h.z |c2| in 64-bit words
// when the half sizes are below 2^31 raw and the cosines below 1.5; it must be Fixed arithmetic's
// sum of rounded products, bit for bit: random sizes and cosines on both sides of both bounds,
// the extremes of the small case, and products on an exact tie (half an ulp, rounded to even).
TEST(RigidContact, FaceRadiusShortcutGivesTheFixedProducts) {
    std::mt19937_64 rng(2022);
    const std::int64_t one = Fixed::kOne, h_top = std::int64_t{1} << 31, c_top = one + one / 2;
    std::uniform_int_distribution<std::int64_t> h_any(0, 16 * h_top), c_any(-c_top - c_top / 8, c_top + c_top / 8),
        c_near(c_top - 4096, c_top + 4096), c_wide(0, 9 * one / 2), h_near(h_top - 4096, h_top + 4096), odd(0, std::int64_t{1} << 20);
    const auto general = [](const Vec3& h, Fixed c0, Fixed c1, Fixed c2) {
        return h.x * abs(c0) + h.y * abs(c1) + h.z * abs(c2);
    };
    int differ = 0, small = 0, ties = 0;
    const auto check = [&](const Vec3& h, Fixed c0, Fixed c1, Fixed c2) {
        if (face_axis_radius(h, c0, c1, c2) != general(h, c0, c1, c2)) ++differ;
        const auto in = [&](std::int64_t hk, Fixed c) { return hk >= 0 && hk < h_top && c.raw > -c_top && c.raw < c_top; };
        small += in(h.x.raw, c0) && in(h.y.raw, c1) && in(h.z.raw, c2);
    };
    const auto f = [](std::int64_t raw) { return Fixed::from_raw(raw); };
    const auto sign = [&](std::int64_t v) { return rng() % 2 == 0 ? v : -v; };
    for (int n = 0; n < 200000; ++n) {
        const int mode = n % 4;
        if (mode == 0) {  // sizes up to 16 m, cosines either side of their bound
            check({f(h_any(rng)), f(h_any(rng)), f(h_any(rng))}, f(c_any(rng)), f(c_any(rng)), f(c_any(rng)));
        } else if (mode == 1) {  // at the size bound, cosines at theirs or up to 4.5
            auto& c = n % 8 == 1 ? c_near : c_wide;
            check({f(h_near(rng)), f(h_near(rng)), f(h_near(rng))}, f(sign(c(rng))), f(sign(c(rng))), f(sign(c(rng))));
        } else {  // exact ties: h = 2^(30 - s), c = 2^(s + 1) (2 m + 1), so h c = 2^31 (2 m + 1)
            Fixed c[3];
            Vec3 h;
            for (int k = 0; k < 3; ++k) {
                const int s = static_cast<int>(rng() % 8);
                component(h, k) = f(std::int64_t{1} << (30 - s));
                c[k] = f(sign((std::int64_t{1} << (s + 1)) * (2 * (odd(rng) + (mode == 3 ? c_top >> 21 : 0)) + 1) % c_top));
            }
            ties += 3;
            check(h, c[0], c[1], c[2]);
        }
    }
    for (const std::int64_t hk : {std::int64_t{0}, std::int64_t{1}, h_top - 1, h_top, -one})
        for (const std::int64_t ck : {std::int64_t{0}, std::int64_t{1}, one, c_top - 1, c_top, 2 * one, -(c_top - 1), INT64_MIN, INT64_MAX})
            check({f(hk), f(hk), f(hk)}, f(ck), f(-(ck / 2)), f(ck));
    EXPECT_EQ(differ, 0);
    EXPECT_GT(small, 90000) << ties;  // the small case is what is compared, ties and bounds included
}

// box_box() hands face_contact() the incident axes' cosines n . b_i from its own products; they
// only choose the incident face, so an error shows where two faces tie. A box turned exactly 45
// degrees about x (two columns with equal |n . b_i| against a floor's normal) resting on its edge,
// on or under an unturned or turned box, either first: the exhaustive path's manifold, bit for bit.
TEST(RigidContact, IncidentFaceTieGivesTheExhaustiveManifold) {
    std::mt19937_64 rng(2024);
    std::uniform_real_distribution<double> u(-1, 1), size(0.1, 0.5);
    const Fixed zero = Fixed::zero(), one = Fixed::one(), c = fx(std::sqrt(0.5));
    const Mat3 tie{{{one, zero, zero}, {zero, c, -c}, {zero, c, c}}};
    int touching = 0, differ = 0;
    for (int n = 0; n < 20000; ++n) {
        const Mat3 base = n % 4 < 2 ? kIdentity : rotation(quat(1, 0, 0.02 * u(rng), 0));
        const D3 hb{size(rng) * 4, size(rng), size(rng) * 4}, ht{size(rng), size(rng), size(rng)};
        const double side = n % 2 == 0 ? 1 : -1;  // on top of the base, or under it
        const double reach = hb.y + (ht.y + ht.z) * std::sqrt(0.5) - 0.01 * (u(rng) + 1);
        const OrientedCollider lo = box(base, {0, 0, 0}, hb), up = box(tie, {0.3 * u(rng), side * reach, 0.3 * u(rng)}, ht);
        Manifold full;
        if (!exhaustive_agrees(lo, up, n / 4 % 2 != 0, full)) ++differ;
        touching += full.count > 0;
    }
    EXPECT_EQ(differ, 0);
    EXPECT_GT(touching, 10000);
}

}  // namespace
}  // namespace lockroll::sim
