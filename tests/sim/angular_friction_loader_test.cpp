// The scene loader's rigid.spinning_friction and rigid.rolling_friction: read as metres,
// absent = 0 (off), and a bad value refused with an error naming the field.
#include <gtest/gtest.h>

#include <string>

#include "harness/match/scene_loader.h"

namespace lockroll::harness {
namespace {

std::string error_of(const std::string& text) {
    try {
        parse_scene(text, "test.json");
    } catch (const SceneError& e) {
        return e.what();
    }
    return "";
}

TEST(AngularFrictionLoader, ReadsTheCoefficientsAndRejectsBadOnes) {
    const sim::SceneDesc off = parse_scene(R"({"rigid": true})", "t.json");
    EXPECT_EQ(off.rigid.spinning_friction, sim::Fixed::zero());
    EXPECT_EQ(off.rigid.rolling_friction, sim::Fixed::zero());
    const sim::SceneDesc on = parse_scene(R"({"rigid": {"spinning_friction": 0.02, "rolling_friction": 0.005}})", "t.json");
    EXPECT_EQ(on.rigid.spinning_friction, *sim::Fixed::parse("0.02"));
    EXPECT_EQ(on.rigid.rolling_friction, *sim::Fixed::parse("0.005"));
    EXPECT_EQ(error_of(R"({"rigid": {"spinning_friction": -1}})"),
              "test.json: /rigid/spinning_friction: must be within [0, 1], got -1");
    EXPECT_EQ(error_of(R"({"rigid": {"rolling_friction": 2}})"),
              "test.json: /rigid/rolling_friction: must be within [0, 1], got 2");
    EXPECT_EQ(error_of(R"({"rigid": {"rolling_friction": "x"}})"), "test.json: /rigid/rolling_friction: expected a number");
}

}  // namespace
}  // namespace lockroll::harness
