// sim/inertia.h against the textbook formulas.
#include <gtest/gtest.h>

#include <cmath>

#include "sim/inertia.h"

namespace lockroll::sim {
namespace {

double d(Fixed f) { return static_cast<double>(f.raw) / 4294967296.0; }
Fixed fx(const char* t) { return *Fixed::parse(t); }

TEST(Inertia, SphereIsTwoFifthsMR2) {
    const Vec3 i = inertia(Shape::Sphere, fx("0.5"), {}, {}, fx("2"));
    EXPECT_NEAR(d(i.x), 0.4 * 2 * 0.25, 1e-9);
    EXPECT_EQ(i.x, i.y);
    EXPECT_EQ(i.y, i.z);
}

TEST(Inertia, BoxFromHalfExtents) {
    // Edges 2 x 4 x 6 m, 3 kg: I_x = m (4^2 + 6^2) / 12 = 13.
    const Vec3 i = inertia(Shape::Box, {}, {fx("1"), fx("2"), fx("3")}, {}, fx("3"));
    EXPECT_NEAR(d(i.x), 3 * (16 + 36) / 12.0, 1e-8);
    EXPECT_NEAR(d(i.y), 3 * (4 + 36) / 12.0, 1e-8);
    EXPECT_NEAR(d(i.z), 3 * (4 + 16) / 12.0, 1e-8);
}

TEST(Inertia, CapsuleMatchesCylinderPlusHemispheres) {
    const double r = 0.3, h = 0.6, m = 5;
    const double vc = M_PI * r * r * 2 * h, vs = 4.0 / 3.0 * M_PI * r * r * r;
    const double mc = m * vc / (vc + vs), ms = m - mc;
    const double axial = mc * r * r / 2 + ms * 2 * r * r / 5;
    const double across = mc * (r * r / 4 + (2 * h) * (2 * h) / 12) + ms * (2 * r * r / 5 + h * h + 3 * h * r / 4);
    const Vec3 i = inertia(Shape::Capsule, fx("0.3"), {}, fx("0.6"), fx("5"));
    EXPECT_NEAR(d(i.y), axial, 1e-8);
    EXPECT_NEAR(d(i.x), across, 1e-8);
    EXPECT_EQ(i.x, i.z);
    // No core: a sphere.
    const Vec3 s = inertia(Shape::Capsule, fx("0.3"), {}, Fixed::zero(), fx("5"));
    EXPECT_NEAR(d(s.x), 0.4 * 5 * 0.09, 1e-8);
}

TEST(Inertia, StaticBodyHasZeroInverse) {
    BodyDesc b;
    b.shape = Shape::Box;
    b.half_extents = {fx("1"), fx("1"), fx("1")};
    EXPECT_EQ(inverse_inertia(b), Vec3{});
    b.mass = fx("6");
    EXPECT_NEAR(d(inverse_inertia(b).x), 1 / (6 * 2 / 3.0), 1e-8);
}

}  // namespace
}  // namespace lockroll::sim
