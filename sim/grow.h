// grow(v, n): resize a vector that is refilled every step, keeping geometric growth.
//
// Why: a step's scratch buffers are cleared and sized again each step. libstdc++'s resize() of
// an empty vector past its capacity allocates exactly the new size, with no room to spare, so
// a count that creeps up from step to step (contact points while a pile forms) reallocates
// nearly every step. A buffer of several MB is then unmapped and mapped afresh and every page
// faults in zeroed again: in bodies_10k_rigid's parallel step that was 2,100 page faults a step
// (docs/performance.md, "Page faults in the parallel rigid step").
//
// Contract: afterwards v.size() == n and v.capacity() >= n; when the capacity must rise it at
// least doubles, so a run of steps reallocates O(log(largest n)) times. Elements up to the old
// size keep their values; new ones are what v's allocator's resize() makes of them.
#pragma once

#include <algorithm>
#include <cstddef>

namespace lockroll::sim {

template <class Vector>
void grow(Vector& v, std::size_t n) {
    if (n > v.capacity()) v.reserve(std::max(n, 2 * v.capacity()));
    v.resize(n);
}

}  // namespace lockroll::sim
