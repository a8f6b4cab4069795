#include "sim/controller.h"

namespace lockroll::sim {

ControllerFactors ControllerFactors::from(const ControllerDesc& d, Fixed dt) {
    ControllerFactors f;
    f.speed_per_unit = d.max_speed / Fixed::from_int(127);
    f.accel_dt = d.acceleration * dt;
    f.vaccel_dt_per_unit = d.vertical_acceleration * dt / Fixed::from_int(127);
    return f;
}

int clamp_axis(std::int8_t v) { return v < -127 ? -127 : v; }

void apply_input(const ControllerFactors& f, const PlayerInput& in, Vec3& v) {
    const Fixed target_x = f.speed_per_unit * clamp_axis(in.right);
    const Fixed target_z = f.speed_per_unit * clamp_axis(in.forward);
    v.x += clamp(target_x - v.x, -f.accel_dt, f.accel_dt);
    v.z += clamp(target_z - v.z, -f.accel_dt, f.accel_dt);
    v.y += f.vaccel_dt_per_unit * clamp_axis(in.up);
}

}  // namespace lockroll::sim
