// Shared machinery of the fixed-point accuracy tests (fixed_test.cpp, vec3_test.cpp).
//
// References are EXACT integer arithmetic, not long double: a Q32.32 operand carries up to 64
// significant bits and a product or quotient needs up to 128, while x86 long double has a 64-bit
// significand, so a long double "reference" would itself round and a 0.5-ulp assertion against
// it would be meaningless. Every result is therefore checked against the exact rational value
// N / D of the operation (N, D integers in units of one ulp, 2^-32), and long double is used only
// to turn an exact error numerator into a printable number.
#pragma once

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <random>
#include <string>

#include "sim/fixed.h"

namespace lockroll::sim::accuracy {

// The references use the compiler's __int128 (so these tests need GCC or Clang), never sim's
// i128: in a LOCKROLL_PORTABLE_MATH build that is the portable implementation under test.
using i128 = __int128;
using u128 = unsigned __int128;

inline constexpr int kRandomCases = 1'000'000;
inline constexpr std::uint64_t kSeed = 20261122;

// A raw value spread over magnitudes: draw the bit length (0..63) uniformly, then the mantissa
// below that leading bit uniformly, then the sign. Uniform raw values would almost all be ~2^62
// and never exercise small results.
inline std::int64_t random_raw(std::mt19937_64& g) {
    const int bits = static_cast<int>(g() % 64);
    std::uint64_t m = 0;
    if (bits > 0) m = (std::uint64_t{1} << (bits - 1)) | (g() & ((std::uint64_t{1} << (bits - 1)) - 1));
    const auto v = static_cast<std::int64_t>(m);
    return (g() & 1) ? -v : v;
}

inline std::string describe(std::int64_t raw) {
    std::string s = "raw ";
    s += std::to_string(raw);
    s += " (";
    s += Fixed::from_raw(raw).to_string();
    s += ')';
    return s;
}

inline std::string u128_string(u128 m) {
    std::string s;
    do { s.insert(s.begin(), static_cast<char>('0' + static_cast<int>(m % 10))); m /= 10; } while (m);
    return s;
}

inline std::string i128_string(i128 v) {
    std::string s = u128_string(v < 0 ? static_cast<u128>(0) - static_cast<u128>(v) : static_cast<u128>(v));
    if (v < 0) s.insert(s.begin(), '-');
    return s;
}

// What a correctly rounded (ties-to-even) result of the exact value N / D must be.
enum class Expect { InRange, SaturateMax, SaturateMin };

// N / D with D > 0, in ulps. Saturation is decided on the ROUNDED value, as the contract says:
// N/D >= INT64_MAX + 1/2 rounds (ties to even) to 2^63 and saturates; N/D == INT64_MIN - 1/2
// rounds to INT64_MIN (even) and does not.
inline Expect expect_for(i128 n, i128 d) {
    i128 t;
    // n - INT64_MAX * d >= d/2  <=>  N/D >= max + 1/2
    if (!__builtin_mul_overflow(static_cast<i128>(INT64_MAX), d, &t) && n - t >= (d + 1) / 2)
        return Expect::SaturateMax;
    // INT64_MIN * d - n > d/2   <=>  N/D < min - 1/2
    if (!__builtin_mul_overflow(static_cast<i128>(INT64_MIN), d, &t) && t - n > d / 2)
        return Expect::SaturateMin;
    return Expect::InRange;
}

// Running error statistics of one operation, in ulps.
struct Stats {
    std::string op;
    long n = 0, saturated = 0, ties = 0;
    long double max_err = 0, sum_err = 0;
    std::string worst = "(none)";

    explicit Stats(std::string name) : op(std::move(name)) {}

    // err_num / err_den is the exact error in ulps; `input` is only evaluated for a new worst.
    template <class Describe>
    void add(i128 err_num, i128 err_den, Describe&& input) {
        if (err_num < 0) err_num = -err_num;
        const long double e = static_cast<long double>(err_num) / static_cast<long double>(err_den);
        ++n;
        sum_err += e;
        if (e > max_err || n == 1) { max_err = e; worst = input(); }
    }

    void report() const {
        const long double mean = n ? sum_err / n : 0;
        std::printf("[accuracy] %-10s in-range=%ld saturated=%ld ties=%ld max=%.12Lf ulp mean=%.6Lf ulp worst: %s\n",
                    op.c_str(), n, saturated, ties, max_err, mean, worst.c_str());
        std::fflush(stdout);
        char buf[64];
        std::snprintf(buf, sizeof buf, "%.12Lf", max_err);
        ::testing::Test::RecordProperty(op + "_max_ulps", buf);
        std::snprintf(buf, sizeof buf, "%.6Lf", mean);
        ::testing::Test::RecordProperty(op + "_mean_ulps", buf);
        ::testing::Test::RecordProperty(op + "_worst_input", worst);
    }
};

// Checks that result r (raw) is N / D (D > 0) correctly rounded, ties to even, including the
// saturation decision and the overflow-counter delta. Returns false (after a gtest failure
// naming `input`) on the first wrong result so the caller can stop a million-case loop.
template <class Describe>
bool check_rounded(Stats& st, i128 n, i128 d, std::int64_t r, std::uint64_t events, Describe&& input) {
    switch (expect_for(n, d)) {
        case Expect::SaturateMax:
            ++st.saturated;
            if (r != INT64_MAX || events != 1) {
                ADD_FAILURE() << st.op << " " << input() << ": expected saturation to max with one overflow event, got raw "
                              << r << " and " << events << " events";
                return false;
            }
            return true;
        case Expect::SaturateMin:
            ++st.saturated;
            if (r != INT64_MIN || events != 1) {
                ADD_FAILURE() << st.op << " " << input() << ": expected saturation to min with one overflow event, got raw "
                              << r << " and " << events << " events";
                return false;
            }
            return true;
        case Expect::InRange: break;
    }
    i128 rd;
    if (__builtin_mul_overflow(static_cast<i128>(r), d, &rd)) {
        ADD_FAILURE() << st.op << " " << input() << ": result raw " << r << " is absurdly far from the exact value";
        return false;
    }
    const i128 err = rd - n;  // error * D, in ulps
    const u128 twice = static_cast<u128>(err < 0 ? -err : err) * 2;
    const bool tie = twice == static_cast<u128>(d);
    if (tie) ++st.ties;
    if (twice > static_cast<u128>(d) || (tie && (r & 1)) || events != 0) {
        ADD_FAILURE() << st.op << " " << input() << ": got raw " << r << ", exact value is " << i128_string(n) << "/"
                      << i128_string(d) << " ulp (error " << static_cast<long double>(err) / static_cast<long double>(d)
                      << " ulp" << (tie ? ", a tie that must go to the even neighbour" : "") << "), overflow events "
                      << events;
        return false;
    }
    st.add(err, d, input);
    return true;
}

// Checks r == sqrt(n) rounded to nearest for an integer radicand n (ties are impossible):
// r^2 - r < n <= r^2 + r. The error |r - sqrt(n)| = |r^2 - n| / (r + sqrt(n)) has an exact
// numerator; long double only supplies the denominator's ~19 significant digits.
template <class Describe>
bool check_sqrt(Stats& st, u128 n, std::uint64_t r, Describe&& input) {
    const u128 r2 = static_cast<u128>(r) * r;
    // r^2 + r and n + r cannot overflow: every caller's n is below 3 * 2^126 and r below 2^64.
    const bool ok = n <= r2 + r && (r == 0 || n + r > r2);
    if (!ok) {
        ADD_FAILURE() << st.op << " " << input() << ": got raw " << r << ", not the rounded square root of " << u128_string(n);
        return false;
    }
    const u128 diff = r2 > n ? r2 - n : n - r2;
    const long double e = diff == 0 ? 0.0L
                                    : static_cast<long double>(diff) /
                                          (static_cast<long double>(r) + sqrtl(static_cast<long double>(n)));
    ++st.n;
    st.sum_err += e;
    if (e > st.max_err || st.n == 1) { st.max_err = e; st.worst = input(); }
    return true;
}

}  // namespace lockroll::sim::accuracy
