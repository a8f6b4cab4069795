// Free UDP ports on 127.0.0.1 for the processes `lockroll live` starts (and the test scripts'
// tests/net/free_ports.py, which follows the same rule).
//
// Contract: returns n distinct ports that were all bound at once on 127.0.0.1 and then
// released, chosen *below* the kernel's ephemeral range (/proc/sys/net/ipv4/ip_local_port_range,
// 32768 when unreadable) from a random starting point. Why below: a port taken from the
// ephemeral range (bind to port 0) can be handed by the kernel to any other process's
// unbound socket (an ENet client, a DNS lookup) between our release and the child's bind, and the
// child then fails "cannot create a host bound to ...". The kernel never hands out ports below
// that range on its own, so only another process choosing the same port by the same rule can
// collide, and the random start makes that unlikely. Throws std::runtime_error when n ports
// cannot be found.
#pragma once

#include <cstdint>
#include <vector>

namespace lockroll::harness {

std::vector<std::uint16_t> free_loopback_ports(int n);

// The low end of the kernel's ephemeral port range (32768 when it cannot be read).
std::uint16_t ephemeral_port_floor();

}  // namespace lockroll::harness
