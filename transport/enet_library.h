// ENet's process-wide state: enet_initialize once per process (whichever ENet host is made
// first), enet_deinitialize at exit. Throws std::runtime_error when ENet cannot initialise.
#pragma once

namespace lockroll::transport {

void ensure_enet_initialized();

}  // namespace lockroll::transport
