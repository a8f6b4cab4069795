#include "sim/inertia.h"

namespace lockroll::sim {

Vec3 inertia(Shape shape, Fixed r, const Vec3& he, Fixed h, Fixed m) {
    switch (shape) {
        case Shape::Sphere: {
            const Fixed i = m * (r * r) * Fixed::ratio(2, 5);
            return {i, i, i};
        }
        case Shape::Box: {
            // A solid box of full edges 2a, 2b, 2c: I_x = m ((2b)^2 + (2c)^2) / 12 = m (b^2 + c^2) / 3.
            const Fixed third = Fixed::ratio(1, 3);
            const Fixed xx = he.x * he.x, yy = he.y * he.y, zz = he.z * he.z;
            return {m * (yy + zz) * third, m * (xx + zz) * third, m * (xx + yy) * third};
        }
        case Shape::Capsule: {
            // Mass by volume: cylinder pi r^2 2h, two hemispheres 4/3 pi r^3, so the cylinder holds
            // 3h / (3h + 2r) of it.
            const Fixed three_h = h * std::int64_t{3};
            const Fixed mc = m * three_h / (three_h + r * std::int64_t{2});
            const Fixed ms = m - mc;
            const Fixed rr = r * r;
            // About the axis: cylinder m r^2 / 2, hemispheres 2/5 m r^2.
            const Fixed axial = mc * rr * Fixed::ratio(1, 2) + ms * rr * Fixed::ratio(2, 5);
            // Across: cylinder m (r^2/4 + (2h)^2/12); the hemisphere pair, each (83/320) m r^2 about
            // its own centre of mass 3r/8 from the flat face, moved out to h + 3r/8 by parallel axes:
            // ms (2/5 r^2 + h^2 + 3 h r / 4).
            const Fixed across = mc * (rr * Fixed::ratio(1, 4) + h * h * Fixed::ratio(1, 3)) +
                                 ms * (rr * Fixed::ratio(2, 5) + h * h + h * r * Fixed::ratio(3, 4));
            return {across, axial, across};
        }
    }
    return {};
}

Vec3 inverse_inertia(const BodyDesc& b) {
    if (b.mass.raw == 0) return {};
    const Vec3 i = inertia(b.shape, b.radius, b.half_extents, b.half_height, b.mass);
    return {reciprocal(i.x), reciprocal(i.y), reciprocal(i.z)};
}

}  // namespace lockroll::sim
