#include "harness/match/metrics.h"

#include <algorithm>
#include <cmath>

namespace lockroll::harness {

namespace {
double as_double(sim::Fixed f) { return static_cast<double>(f.raw) / 4294967296.0; }
}  // namespace

void Stat::add(double v) {
    sum += v;
    max = std::max(max, v);
    ++count;
    if (v != 0.0) ++nonzero;
    if (keep_samples) samples.push_back(v);
}

void Stat::merge(const Stat& o) {
    if (keep_samples && o.keep_samples) {
        for (double v : o.samples) add(v);
        return;
    }
    sum += o.sum;
    max = std::max(max, o.max);
    count += o.count;
    nonzero += o.nonzero;
}

double Stat::percentile(double p) const {
    if (samples.empty()) return 0.0;
    std::vector<double> s = samples;
    const auto k = static_cast<std::size_t>(std::ceil(p / 100.0 * static_cast<double>(s.size()))) - 1;
    const std::size_t idx = std::min(k, s.size() - 1);
    std::nth_element(s.begin(), s.begin() + static_cast<std::ptrdiff_t>(idx), s.end());
    return s[idx];
}

double distance_m(const sim::Vec3& a, const sim::Vec3& b) {
    // Exact integer differences first, so equal positions give exactly 0.
    const double dx = as_double(sim::Fixed::from_raw(a.x.raw - b.x.raw));
    const double dy = as_double(sim::Fixed::from_raw(a.y.raw - b.y.raw));
    const double dz = as_double(sim::Fixed::from_raw(a.z.raw - b.z.raw));
    return std::sqrt(dx * dx + dy * dy + dz * dz);
}

PositionErrorTracker::PositionErrorTracker(int clients, std::size_t bodies, bool keep_positions)
    : clients_(clients),
      bodies_(bodies),
      keep_positions_(keep_positions),
      pair_error_(static_cast<std::size_t>(clients * (clients - 1) / 2)),
      body_error_(bodies),
      body_max_(bodies, 0.0) {
    if (keep_positions_) positions_csv_ = "frame,client,body_index,x,y,z\n";
}

void PositionErrorTracker::record(int client, std::uint32_t frame, double time_s,
                                  const std::vector<sim::Vec3>& positions) {
    Pending& p = pending_[frame];
    if (p.by_client.empty()) p.by_client.resize(static_cast<std::size_t>(clients_));
    auto& slot = p.by_client[static_cast<std::size_t>(client)];
    if (!slot.empty()) return;  // first forward simulation only
    slot = positions;
    if (client == 0) p.time_s = time_s;
    if (++p.have == static_cast<std::uint32_t>(clients_)) {
        reduce(frame, p);
        pending_.erase(frame);
    }
}

void PositionErrorTracker::note_rollback(std::uint32_t displayed_frame, std::uint32_t depth) {
    auto& d = rollbacks_[displayed_frame];
    ++d.first;
    d.second = std::max(d.second, depth);
}

void PositionErrorTracker::set_tick_rate(std::uint32_t frame, double tps) { tick_rate_[frame] = tps; }

void PositionErrorTracker::finish() {
    for (auto& [frame, p] : pending_) reduce(frame, p);
    pending_.clear();
}

void PositionErrorTracker::reduce(std::uint32_t frame, Pending& p) {
    FrameRow row;
    row.frame = frame;
    row.time_s = p.time_s;
    double sum = 0;
    std::uint64_t n = 0;
    std::size_t pair = 0;
    for (int a = 0; a < clients_; ++a)
        for (int c = a + 1; c < clients_; ++c, ++pair) {
            const auto& ref = p.by_client[static_cast<std::size_t>(a)];
            const auto& other = p.by_client[static_cast<std::size_t>(c)];
            if (ref.size() < bodies_ || other.size() < bodies_) continue;  // one of them never showed it
            for (std::size_t b = 0; b < bodies_; ++b) {
                const double e = distance_m(ref[b], other[b]);
                error_.add(e);
                pair_error_[pair].add(e);
                body_error_[b].add(e);
                body_max_[b] = std::max(body_max_[b], e);
                sum += e;
                ++n;
                row.max_error = std::max(row.max_error, e);
            }
        }
    row.mean_error = n ? sum / static_cast<double>(n) : 0.0;
    if (auto it = rollbacks_.find(frame); it != rollbacks_.end()) {
        row.rollbacks = it->second.first;
        row.max_rollback_depth = it->second.second;
        rollbacks_.erase(it);
    }
    if (auto it = tick_rate_.find(frame); it != tick_rate_.end()) {
        row.ticks_per_second = it->second;
        tick_rate_.erase(it);
    }
    rows_.push_back(row);
    if (keep_positions_) {
        char line[160];
        for (int c = 0; c < clients_; ++c)
            for (std::size_t b = 0; b < p.by_client[static_cast<std::size_t>(c)].size(); ++b) {
                const sim::Vec3& v = p.by_client[static_cast<std::size_t>(c)][b];
                std::snprintf(line, sizeof line, "%u,%d,%zu,%.9f,%.9f,%.9f\n", frame, c, b, as_double(v.x),
                              as_double(v.y), as_double(v.z));
                positions_csv_ += line;
            }
    }
}

namespace {
// The mean of a client figure over the clients that played from frame 0 (all when none did).
double match_mean(const std::vector<ClientResult>& clients, double ClientResult::*field) {
    const bool any = std::any_of(clients.begin(), clients.end(), [](const ClientResult& c) { return c.from_start; });
    double s = 0;
    std::size_t n = 0;
    for (const auto& c : clients)
        if (c.from_start || !any) s += c.*field, ++n;
    return n ? s / static_cast<double>(n) : 0;
}
}  // namespace

double RunResult::ticks_per_second() const { return match_mean(clients, &ClientResult::ticks_per_second); }
double RunResult::stall_fraction() const { return match_mean(clients, &ClientResult::stall_fraction); }
double RunResult::bytes_sent_per_s() const {
    double s = 0;
    for (const auto& c : clients) s += static_cast<double>(c.bytes_sent);
    return clients.empty() || virtual_seconds <= 0 ? 0 : s / static_cast<double>(clients.size()) / virtual_seconds;
}
double RunResult::bytes_received_per_s() const {
    double s = 0;
    for (const auto& c : clients) s += static_cast<double>(c.bytes_received);
    return clients.empty() || virtual_seconds <= 0 ? 0 : s / static_cast<double>(clients.size()) / virtual_seconds;
}
double RunResult::packets_sent_per_s() const {
    double s = 0;
    for (const auto& c : clients) s += static_cast<double>(c.packets_sent);
    return clients.empty() || virtual_seconds <= 0 ? 0 : s / static_cast<double>(clients.size()) / virtual_seconds;
}
std::uint64_t RunResult::rollbacks() const { return rollback_depth.count; }
std::uint64_t RunResult::resimulated_frames() const {
    std::uint64_t s = 0;
    for (const auto& c : clients) s += c.resimulated_frames;
    return s;
}
double RunResult::resim_frames_per_s() const {
    return clients.empty() || virtual_seconds <= 0
               ? 0
               : static_cast<double>(resimulated_frames()) / static_cast<double>(clients.size()) / virtual_seconds;
}
double RunResult::full_window_rollback_us() const {
    const std::uint64_t frames = resimulated_frames();
    const double per_frame = frames ? resim_us_per_tick.sum / static_cast<double>(frames) : physics_step_us.percentile(50);
    return prediction * per_frame;
}
std::uint64_t RunResult::desync_count() const {
    std::uint64_t s = 0;
    for (const auto& c : clients) s += c.desyncs;
    return s;
}

}  // namespace lockroll::harness
