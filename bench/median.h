// The median the benchmarks report (of paired runs' times or ratios): the middle value, or the
// mean of the two middle ones; 0 for no values.
#pragma once

#include <algorithm>
#include <vector>

namespace lockroll::bench {

inline double median(std::vector<double> v) {
    if (v.empty()) return 0;
    std::sort(v.begin(), v.end());
    const std::size_t n = v.size();
    return n % 2 ? v[n / 2] : (v[n / 2 - 1] + v[n / 2]) / 2;
}

}  // namespace lockroll::bench
