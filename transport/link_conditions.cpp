#include "transport/link_conditions.h"

#include <cmath>
#include <utility>

namespace lockroll::transport {

namespace {

std::string check_probability(const char* name, double p) {
    if (std::isnan(p) || p < 0.0 || p > 1.0)
        return std::string(name) + " must be a probability in [0, 1], got " + std::to_string(p);
    return {};
}

}  // namespace

std::string validate(const LinkConditions& link) {
    const std::pair<const char*, double> probabilities[] = {
        {"loss", link.loss},           {"burst_enter", link.burst_enter},
        {"burst_exit", link.burst_exit}, {"burst_loss", link.burst_loss},
        {"duplicate", link.duplicate}, {"reorder", link.reorder},
    };
    for (const auto& [name, p] : probabilities)
        if (std::string err = check_probability(name, p); !err.empty()) return err;
    if (link.burst_enter > 0.0 && link.burst_exit <= 0.0)
        return "burst_exit must be > 0 when burst_enter > 0 (the link would never leave the Bad state)";
    if (link.reorder_min_us > link.reorder_max_us)
        return "reorder_min_us (" + std::to_string(link.reorder_min_us) + ") must not exceed reorder_max_us (" +
               std::to_string(link.reorder_max_us) + ")";
    if (link.jitter_distribution != JitterDistribution::Uniform &&
        link.jitter_distribution != JitterDistribution::Normal)
        return "jitter_distribution must be Uniform or Normal";
    // Keeps every delay sum far from uint64 overflow (about 292,000 years of microseconds).
    constexpr Micros kMaxDelay = Micros{1} << 50;
    if (link.latency_us > kMaxDelay || link.jitter_us > kMaxDelay || link.reorder_max_us > kMaxDelay)
        return "latency_us, jitter_us and reorder_max_us must be at most 2^50 microseconds";
    return {};
}

}  // namespace lockroll::transport
