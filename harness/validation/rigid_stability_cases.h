// The rigid-body cases of the stability suite (docs/stability.md, cases 15-21): a sliding ball
// that ends rolling, backspin, a torque-free box, a box on a ramp, a box tipped on an edge, a
// pyramid and a stack with friction. all_cases() (harness/validation/stability_cases.cpp) lists
// them with the others.
#pragma once

#include "harness/validation/stability_cases.h"

namespace lockroll::harness::stability {

Outcome rigid_roll();
Outcome rigid_backspin();
Outcome rigid_spin();
Outcome rigid_ramp();
Outcome rigid_tip();
Outcome rigid_pyramid();
Outcome rigid_stack();

}  // namespace lockroll::harness::stability
