// Player controller: turns one player's 3-axis input into a velocity change on its body.
// The rule (docs/controller.md): horizontal velocity moves toward stick * max_speed by at most
// acceleration * dt per frame on each axis; "up" adds vertical_acceleration * dt * up/127.
// Pure integer arithmetic on Q32.32; only called when the scene has players.
#pragma once

#include "sim/scene.h"
#include "sim/world.h"  // PlayerInput

namespace lockroll::sim {

struct ControllerFactors {
    Fixed speed_per_unit;        // max_speed / 127
    Fixed accel_dt;              // acceleration * dt
    Fixed vaccel_dt_per_unit;    // vertical_acceleration * dt / 127

    static ControllerFactors from(const ControllerDesc& desc, Fixed dt);
};

// -128 is treated as -127 so the axes are symmetric.
int clamp_axis(std::int8_t v);

void apply_input(const ControllerFactors& f, const PlayerInput& in, Vec3& velocity);

}  // namespace lockroll::sim
