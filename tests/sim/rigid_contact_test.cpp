// sim/rigid_contact.h: manifolds with points for oriented shapes.
#include <gtest/gtest.h>

#include <cmath>

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

TEST(RigidContact, CapsuleLyingOnFloorHasTwoPoints) {
    // Local y axis turned onto world x: a quarter turn about z.
    const double h = std::sqrt(0.5);
    const Mat3 r = rotation(normalised({fx(h), Fixed::zero(), Fixed::zero(), fx(h)}));
    OrientedCollider c;
    c.shape = Shape::Capsule;
    c.center = v3(0, 0.29, 0);
    c.rot = &r;
    c.radius = fx(0.3);
    c.core_half = fx(0.5);
    Manifold m;
    contact_points(c, floor_box(), fx(0.05), m);
    ASSERT_EQ(m.count, 3);  // both ends and the core point over the floor's centre
    for (int i = 0; i < m.count; ++i) EXPECT_NEAR(d(m.points[i].depth), 0.01, 1e-8);
    EXPECT_NEAR(std::fabs(d(m.points[0].point.x)), 0.5, 1e-8);
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

}  // namespace
}  // namespace lockroll::sim
