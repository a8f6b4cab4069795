// Inertia tensors of the three shapes, about the body's centre in its own frame, where each is
// diagonal: a sphere (2/5 m r^2), a box (m (b^2 + c^2) / 3 from half extents), and a capsule
// along its local y axis (a cylinder of height 2h plus two hemispheres, mass split by volume).
//
// The solver needs the inverses: inverse_inertia() returns the diagonal of I^-1 in the body
// frame (zero for a static body), computed once per body in Q32.32. The world-space inverse
// R diag R^T is computed from it once per step (sim/vec3.h rotate_diagonal).
#pragma once

#include "sim/scene.h"

namespace lockroll::sim {

// Principal moments (kg m^2) of a body of the given shape, size and mass.
Vec3 inertia(Shape shape, Fixed radius, const Vec3& half_extents, Fixed half_height, Fixed mass);

// Reciprocals of inertia(...) for a dynamic body; zero for mass 0 (static).
Vec3 inverse_inertia(const BodyDesc& body);

}  // namespace lockroll::sim
