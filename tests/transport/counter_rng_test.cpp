#include "transport/counter_rng.h"

#include <gtest/gtest.h>

namespace lockroll::transport {
namespace {

// SplitMix64 reference outputs for seed 0 (Vigna's splitmix64.c): pins the generator to the bit.
TEST(CounterRng, MatchesSplitMix64Reference) {
    const CounterRng rng(0);
    EXPECT_EQ(rng.at(0), 0xE220A8397B1DCDAFull);
    EXPECT_EQ(rng.at(1), 0x6E789E6AA1B965F4ull);
    EXPECT_EQ(rng.at(2), 0x06C45D188009454Full);
}

TEST(CounterRng, PositionsAreRandomAccess) {
    const CounterRng rng = CounterRng::derive(42, 1, 2);
    const std::uint64_t a = rng.at(1000);
    EXPECT_EQ(rng.at(1000), a);
    EXPECT_NE(rng.at(1001), a);
}

TEST(CounterRng, DerivedStreamsDifferByLabelAndOrder) {
    EXPECT_NE(CounterRng::derive(1, 0, 1).at(0), CounterRng::derive(1, 1, 0).at(0));
    EXPECT_NE(CounterRng::derive(1, 0, 1).at(0), CounterRng::derive(2, 0, 1).at(0));
}

TEST(CounterRng, BelowStaysInRange) {
    const CounterRng rng(7);
    for (std::uint64_t i = 0; i < 10000; ++i) {
        EXPECT_LT(CounterRng::below(rng.at(i), 21), 21u);
    }
    EXPECT_EQ(CounterRng::below(~std::uint64_t{0}, 10), 9u);
    EXPECT_EQ(CounterRng::below(0, 10), 0u);
    EXPECT_EQ(CounterRng::below(12345, 0), 0u);
}

TEST(Chance, QuantisesProbabilities) {
    EXPECT_EQ(Chance::from_probability(0.0).threshold, 0u);
    EXPECT_EQ(Chance::from_probability(1.0).threshold, std::uint64_t{1} << 32);
    EXPECT_EQ(Chance::from_probability(0.5).threshold, std::uint64_t{1} << 31);
    EXPECT_EQ(Chance::from_probability(0.25).threshold, std::uint64_t{1} << 30);
    EXPECT_FALSE(Chance::from_probability(0.0).hit(0));
    EXPECT_TRUE(Chance::from_probability(1.0).hit(~std::uint64_t{0}));
    EXPECT_TRUE(Chance::from_probability(0.5).hit(0x7FFFFFFFFFFFFFFFull));
    EXPECT_FALSE(Chance::from_probability(0.5).hit(0x8000000000000000ull));
}

}  // namespace
}  // namespace lockroll::transport
