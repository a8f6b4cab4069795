// PartEffects (rollback/part_effects.h): the hooks MembershipEffects and AuthoringEffects share
// are declared once, so a class that implements both (SessionImpl::Effects, the tests'
// FakeEffects) has one of each: whichever part calls emit, live_peer or stream reaches the same
// definition, and the class is a PartEffects once.
#include "rollback/part_effects.h"

#include <gtest/gtest.h>

#include <type_traits>

#include "tests/rollback/fake_effects.h"

namespace lockroll::rollback {
namespace {

using testing::EffectsFixture;
using testing::FakeEffects;

// One PartEffects in a class that implements both interfaces (a virtual base): were it two, the
// conversion would be ambiguous.
static_assert(std::is_convertible_v<FakeEffects*, PartEffects*>);
static_assert(std::is_base_of_v<PartEffects, MembershipEffects> && std::is_base_of_v<PartEffects, AuthoringEffects>);

TEST(PartEffects, BothPartsReachTheSameHooks) {
    EffectsFixture f(3, 0, {}, TwoPlayerRule::PlayOnAlone, 1);
    MembershipEffects& membership = f.fake;
    AuthoringEffects& authoring = f.fake;
    PartEffects& membership_part = membership;
    PartEffects& authoring_part = authoring;
    EXPECT_EQ(&membership_part, &authoring_part) << "one base, not one per interface";

    membership.emit(SessionEvent::Kind::Disconnected, SessionEvent::Reason::TimedOut, 2, 5, 100, "by membership");
    authoring.emit(SessionEvent::Kind::NeutralFrom, SessionEvent::Reason::WritesNeutral, 2, 6, 100, "by authoring");
    ASSERT_EQ(f.fake.events.size(), 2u);
    EXPECT_EQ(f.fake.events[0].detail, "by membership");
    EXPECT_EQ(f.fake.events[1].detail, "by authoring");

    EXPECT_EQ(&membership.stream(1), &authoring.stream(1));
    EXPECT_EQ(membership.live_peer(1), authoring.live_peer(1));
    EXPECT_TRUE(authoring.live_peer(3)) << "the spectator, welcomed";
    EXPECT_FALSE(membership.live_peer(0)) << "never this session's own slot";
}

}  // namespace
}  // namespace lockroll::rollback
