// sim/grow.h: a per-step buffer, cleared and sized again each step, reallocates only when its
// capacity must at least double.
#include "sim/grow.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

#include "sim/uninitialized_allocator.h"

namespace lockroll::sim {
namespace {

// A count that rises by one each step (contact points while a pile forms), the buffer cleared
// before each: plain resize() after clear() reallocated at every step in libstdc++.
template <class Vector>
int reallocations_over_rising_counts(int steps) {
    Vector v;
    int reallocations = 0;
    for (int n = 1; n <= steps; ++n) {
        v.clear();
        const auto* before = v.data();
        const std::size_t capacity = v.capacity();
        grow(v, static_cast<std::size_t>(n));
        EXPECT_EQ(v.size(), static_cast<std::size_t>(n));
        if (v.capacity() != capacity || (capacity > 0 && v.data() != before)) ++reallocations;
    }
    return reallocations;
}

TEST(Grow, RisingCountsReallocateLogarithmically) {
    // 4,096 steps: at most 13 doublings from 1, where resize() after clear() made 4,096.
    EXPECT_LE(reallocations_over_rising_counts<std::vector<std::uint64_t>>(4096), 13);
    EXPECT_LE((reallocations_over_rising_counts<std::vector<std::uint64_t, UninitializedAllocator<std::uint64_t>>>(4096)), 13);
}

TEST(Grow, KeepsValuesAndShrinksWithoutReallocating) {
    std::vector<int> v{1, 2, 3};
    grow(v, 5);
    ASSERT_EQ(v.size(), 5u);
    EXPECT_EQ(v[0], 1);
    EXPECT_EQ(v[2], 3);
    EXPECT_EQ(v[4], 0);  // value-initialised by std::allocator
    const std::size_t capacity = v.capacity();
    const int* data = v.data();
    grow(v, 2);
    EXPECT_EQ(v.size(), 2u);
    EXPECT_EQ(v.capacity(), capacity);
    EXPECT_EQ(v.data(), data);
}

}  // namespace
}  // namespace lockroll::sim
