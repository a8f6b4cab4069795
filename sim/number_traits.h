// What the step algorithm (sim/step_kernel.h, sim/contact.h) needs of its number type.
//
// The physics is written once, as templates over a number type N, so that exactly the same
// algorithm can run on Q32.32 (the simulation: this header's Fixed specialization, the only one
// sim/ ever instantiates) and on a wide floating type in the harness, which uses it as the
// reference for the work-precision sweep (harness/validation/reference_world.h). sim/ never names a
// floating type; the harness supplies that specialization itself.
//
// Besides + - * / unary minus and comparisons on N, a specialization provides:
//   Vec             three-component vector of N with + - unary minus, Vec * N, N * Vec, +=, -=
//   Wide            a type that holds squared lengths without overflow, ordered by <
//   zero(), one()
//   from_fixed(f)   the scene's Q32.32 value f in N (exact for Fixed and for binary floating types)
//   ratio(a, b)     a / b for integers, correctly rounded in N
//   dot(a, b)       a . b
//   length_sq(v)    |v|^2 as Wide;  square(x): x^2 as Wide
//   sqrt_wide(w)    sqrt(w) rounded to N
//   reciprocal(x), sqrt(x), abs(x), min, max, clamp
//   midpoint(lo, hi)  a point of [lo, hi] halfway between them (lo <= hi)
#pragma once

#include <cstdint>

#include "sim/vec3.h"

namespace lockroll::sim {

template <class N>
struct NumberTraits;

template <>
struct NumberTraits<Fixed> {
    using Vec = Vec3;
    using Wide = u128;

    static constexpr Fixed zero() { return Fixed::zero(); }
    static constexpr Fixed one() { return Fixed::one(); }
    static Fixed from_fixed(Fixed f) { return f; }
    static Fixed ratio(std::int64_t a, std::int64_t b) { return Fixed::ratio(a, b); }
    static Fixed dot(const Vec3& a, const Vec3& b) { return sim::dot(a, b); }
    static u128 length_sq(const Vec3& v) { return length_sq_wide(v); }
    static u128 square(Fixed x) { return static_cast<u128>(mul_wide(x.raw, x.raw)); }
    // Same cast as everywhere in sim/: a root above INT64_MAX cannot come from a squared Fixed
    // distance that mattered (it would be beyond any reach compared against it).
    static Fixed sqrt_wide(u128 w) { return lockroll::sim::sqrt_wide(w); }
    static Fixed reciprocal(Fixed x) { return sim::reciprocal(x); }
    static Fixed sqrt(Fixed x) { return sim::sqrt(x); }
    static Fixed abs(Fixed x) { return sim::abs(x); }
    static Fixed min(Fixed a, Fixed b) { return sim::min(a, b); }
    static Fixed max(Fixed a, Fixed b) { return sim::max(a, b); }
    static Fixed clamp(Fixed v, Fixed lo, Fixed hi) { return sim::clamp(v, lo, hi); }
    // lo + floor((hi - lo) / 2): the integer midpoint, exact and the same on every machine.
    static Fixed midpoint(Fixed lo, Fixed hi) { return Fixed::from_raw(lo.raw + (hi.raw - lo.raw) / 2); }
};

}  // namespace lockroll::sim
