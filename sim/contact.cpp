#include "sim/contact.h"

namespace lockroll::sim {

namespace {
// Sphere-sphere on centers; when the centers coincide the normal is +y, a fixed choice so
// every peer separates coincident bodies the same way.
bool spheres(const Vec3& ca, Fixed ra, const Vec3& cb, Fixed rb, Contact& out) {
    const Vec3 d = cb - ca;
    const Fixed reach = ra + rb;
    const u128 dist_sq = length_sq_wide(d);
    const u128 reach_sq = static_cast<u128>(static_cast<i128>(reach.raw) * reach.raw);
    if (dist_sq >= reach_sq) return false;
    const std::uint64_t dist_raw = isqrt_round(dist_sq);
    if (dist_raw == 0) {
        out.normal = {Fixed::zero(), Fixed::one(), Fixed::zero()};
        out.depth = reach;
        return true;
    }
    const Fixed dist = Fixed::from_raw(static_cast<std::int64_t>(dist_raw));
    out.normal = {d.x / dist, d.y / dist, d.z / dist};
    out.depth = reach - dist;
    return out.depth.raw > 0;
}

// The y on segment [lo, hi] closest to interval [olo, ohi]: inside the overlap (its midpoint)
// when the intervals overlap, else the near end.
Fixed closest_y(Fixed lo, Fixed hi, Fixed olo, Fixed ohi) {
    if (hi < olo) return hi;
    if (lo > ohi) return lo;
    const Fixed a = max(lo, olo), b = min(hi, ohi);
    return Fixed::from_raw(a.raw + (b.raw - a.raw) / 2);
}
}  // namespace

bool collide(const RoundCollider& a, const RoundCollider& b, Contact& out) {
    if (a.core_half.raw == 0 && b.core_half.raw == 0) return spheres(a.center, a.radius, b.center, b.radius, out);
    const Fixed ya = closest_y(a.center.y - a.core_half, a.center.y + a.core_half, b.center.y - b.core_half,
                               b.center.y + b.core_half);
    const Fixed yb = closest_y(b.center.y - b.core_half, b.center.y + b.core_half, ya, ya);
    return spheres({a.center.x, ya, a.center.z}, a.radius, {b.center.x, yb, b.center.z}, b.radius, out);
}

bool collide(const RoundCollider& a, const BoxCollider& b, Contact& out) {
    const Vec3 lo = b.center - b.half, hi = b.center + b.half;
    const Vec3 c{a.center.x, closest_y(a.center.y - a.core_half, a.center.y + a.core_half, lo.y, hi.y), a.center.z};
    const Vec3 q{clamp(c.x, lo.x, hi.x), clamp(c.y, lo.y, hi.y), clamp(c.z, lo.z, hi.z)};
    if (q != c) {
        // Center outside the box: contact along the closest-point direction, box to sphere,
        // so the normal from A (sphere) to B (box) points from c to q.
        const Vec3 d = q - c;
        // Face contacts (outside the box on one axis only) are the common case: floors and
        // walls. Their normal is the axis and the distance exact, with no sqrt or division.
        const int off_axes = (d.x.raw != 0) + (d.y.raw != 0) + (d.z.raw != 0);
        if (off_axes == 1) {
            const Fixed dist = abs(d.x) + abs(d.y) + abs(d.z);
            if (dist >= a.radius) return false;
            const Fixed o = Fixed::one(), z = Fixed::zero();
            auto sign = [&](Fixed v) { return v.raw < 0 ? -o : v.raw > 0 ? o : z; };
            out.normal = {sign(d.x), sign(d.y), sign(d.z)};
            out.depth = a.radius - dist;
            return true;
        }
        const u128 dist_sq = length_sq_wide(d);
        const u128 r_sq = static_cast<u128>(static_cast<i128>(a.radius.raw) * a.radius.raw);
        if (dist_sq >= r_sq) return false;
        const Fixed dist = Fixed::from_raw(static_cast<std::int64_t>(isqrt_round(dist_sq)));
        if (dist.raw == 0) return false;  // touching at exactly the surface: no penetration
        out.normal = {d.x / dist, d.y / dist, d.z / dist};
        out.depth = a.radius - dist;
        return out.depth.raw > 0;
    }
    // Center inside the box: push out through the nearest face (ties: x, then y, then z).
    const Fixed dx_lo = c.x - lo.x, dx_hi = hi.x - c.x, dy_lo = c.y - lo.y, dy_hi = hi.y - c.y,
                dz_lo = c.z - lo.z, dz_hi = hi.z - c.z;
    Fixed best = dx_lo;
    Vec3 n{Fixed::one(), Fixed::zero(), Fixed::zero()};  // exit through -x: box pushes sphere to -x
    auto consider = [&](Fixed d, Vec3 normal) {
        if (d < best) { best = d; n = normal; }
    };
    const Fixed o = Fixed::one(), z = Fixed::zero();
    consider(dx_hi, {-o, z, z});
    consider(dy_lo, {z, o, z});
    consider(dy_hi, {z, -o, z});
    consider(dz_lo, {z, z, o});
    consider(dz_hi, {z, z, -o});
    out.normal = n;
    out.depth = best + a.radius;
    return true;
}

bool collide(const BoxCollider& a, const BoxCollider& b, Contact& out) {
    const Vec3 d = b.center - a.center;
    const Fixed ox = a.half.x + b.half.x - abs(d.x);
    if (ox.raw <= 0) return false;
    const Fixed oy = a.half.y + b.half.y - abs(d.y);
    if (oy.raw <= 0) return false;
    const Fixed oz = a.half.z + b.half.z - abs(d.z);
    if (oz.raw <= 0) return false;
    const Fixed o = Fixed::one(), z = Fixed::zero();
    auto sign = [&](Fixed v) { return v.raw < 0 ? -o : o; };
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

}  // namespace lockroll::sim
