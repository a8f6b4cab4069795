#include "harness/match/match_recorder.h"

#include <algorithm>
#include <cmath>

#include "harness/match/hex.h"
#include "rollback/world_simulation.h"

namespace lockroll::harness {

using nlohmann::json;

TickFigures tick_figures(const ShownTimes& shown, int tick_rate) {
    TickFigures t;
    if (shown.size() < 2 || tick_rate <= 0) return t;
    const double period = 1e6 / tick_rate;
    for (std::size_t i = 1; i < shown.size(); ++i) {
        const double gap = static_cast<double>(shown[i].second - shown[i - 1].second);
        // Late by (gap - period); every whole period of lateness is a tick that showed nothing.
        // The small tolerance keeps an exact two-period gap (one stalled tick in virtual time)
        // at one, whatever the rounding of the period.
        t.stalled_periods += static_cast<std::uint64_t>(std::max(0.0, std::floor((gap - period) / period + 1e-6)));
    }
    t.intervals = shown.back().first - shown.front().first;
    const double seconds = static_cast<double>(shown.back().second - shown.front().second) / 1e6;
    t.ticks_per_second = seconds > 0 ? static_cast<double>(t.intervals) / seconds : 0;
    const double all = static_cast<double>(t.stalled_periods + t.intervals);
    t.stall_fraction = all > 0 ? static_cast<double>(t.stalled_periods) / all : 0;
    t.measured = seconds > 0;
    return t;
}

namespace {

json samples_of(const Stat& s) { return s.samples; }

void read_samples(const json& j, Stat& into) {
    for (const auto& v : j) into.add(v.get<double>());
}

json bytes_json(const std::array<std::uint8_t, 3>& b) { return json::array({b[0], b[1], b[2]}); }
std::array<std::uint8_t, 3> bytes_of(const json& j) {
    return {j.at(0).get<std::uint8_t>(), j.at(1).get<std::uint8_t>(), j.at(2).get<std::uint8_t>()};
}

}  // namespace

json RecordedSamples::to_json() const {
    json shown_j = json::array(), confirmed_j = json::array(), rtt_j = json::object(), made = json::array(), seen = json::array();
    for (const auto& [f, t] : shown) shown_j.push_back({f, t});
    for (const auto& [f, c] : confirmed) confirmed_j.push_back({f, hex16(c)});
    for (const auto& [peer, s] : rtt_ms) rtt_j[std::to_string(peer)] = samples_of(s);
    for (const auto& i : inputs_made) made.push_back({i.frame, bytes_json(i.bytes), i.made_us});
    for (const auto& [key, values] : inputs_seen)
        for (const auto& [bytes, t] : values) seen.push_back({key.first, key.second, bytes_json(bytes), t});
    const Stat& d = displayed_vs_confirmed;
    return {{"slot", slot},
            {"shown_us", shown_j},
            {"confirmed_checksums", confirmed_j},
            {"input_latency_local_ms", samples_of(input_latency_local)},
            {"cpu_us_per_tick", samples_of(cpu_us_per_tick)},
            {"resim_us_per_tick", samples_of(resim_us_per_tick)},
            {"physics_step_us", samples_of(physics_step_us)},
            {"rollback_depths", samples_of(rollback_depth)},
            {"correction_jumps_m", samples_of(correction_jump)},
            // One sample per body per frame: kept as its sums (a 10k-body scene has millions).
            {"displayed_vs_confirmed_m", {{"sum", d.sum}, {"max", d.max}, {"count", d.count}, {"nonzero", d.nonzero}}},
            {"rtt_ms", rtt_j},
            {"inputs_made", made},
            {"inputs_seen", seen}};
}

RecordedSamples RecordedSamples::from_json(const json& j) {
    RecordedSamples s;
    s.slot = j.at("slot").get<int>();
    for (const auto& e : j.at("shown_us")) s.shown.emplace_back(e.at(0).get<std::uint32_t>(), e.at(1).get<std::uint64_t>());
    for (const auto& e : j.at("confirmed_checksums"))
        s.confirmed.emplace_back(e.at(0).get<std::uint32_t>(), parse_hex16(e.at(1).get<std::string>()).value_or(0));
    read_samples(j.at("input_latency_local_ms"), s.input_latency_local);
    read_samples(j.at("cpu_us_per_tick"), s.cpu_us_per_tick);
    read_samples(j.at("resim_us_per_tick"), s.resim_us_per_tick);
    read_samples(j.at("physics_step_us"), s.physics_step_us);
    read_samples(j.at("rollback_depths"), s.rollback_depth);
    for (const auto& d : s.rollback_depth.samples) {
        const auto k = static_cast<std::size_t>(d);
        if (s.rollback_depth_histogram.size() <= k) s.rollback_depth_histogram.resize(k + 1, 0);
        ++s.rollback_depth_histogram[k];
    }
    read_samples(j.at("correction_jumps_m"), s.correction_jump);
    const json& d = j.at("displayed_vs_confirmed_m");
    s.displayed_vs_confirmed.sum = d.at("sum").get<double>();
    s.displayed_vs_confirmed.max = d.at("max").get<double>();
    s.displayed_vs_confirmed.count = d.at("count").get<std::uint64_t>();
    s.displayed_vs_confirmed.nonzero = d.at("nonzero").get<std::uint64_t>();
    for (const auto& [peer, v] : j.at("rtt_ms").items()) {
        Stat& st = s.rtt_ms.emplace(std::stoi(peer), Stat::keeping_samples()).first->second;
        read_samples(v, st);
    }
    for (const auto& e : j.at("inputs_made"))
        s.inputs_made.push_back({e.at(0).get<std::uint32_t>(), bytes_of(e.at(1)), e.at(2).get<std::uint64_t>()});
    for (const auto& e : j.at("inputs_seen"))
        s.inputs_seen[{e.at(0).get<int>(), e.at(1).get<std::uint32_t>()}].emplace_back(bytes_of(e.at(2)), e.at(3).get<std::uint64_t>());
    return s;
}

Stat remote_input_latency(const std::vector<const RecordedSamples*>& clients) {
    Stat out = Stat::keeping_samples();
    for (const RecordedSamples* maker : clients)
        for (const auto& in : maker->inputs_made)
            for (const RecordedSamples* other : clients) {
                if (other == maker || other->slot == maker->slot) continue;
                const auto it = other->inputs_seen.find({maker->slot, in.frame});
                if (it == other->inputs_seen.end()) continue;
                for (const auto& [bytes, t] : it->second)
                    if (bytes == in.bytes && t >= in.made_us) {
                        out.add(static_cast<double>(t - in.made_us) / 1000.0);
                        break;
                    }
            }
    return out;
}

std::pair<std::uint64_t, std::uint64_t> confirmed_agreement(const std::vector<const RecordedSamples*>& clients) {
    std::map<std::uint32_t, std::uint64_t> first;
    std::uint64_t compared = 0, mismatches = 0;
    for (const RecordedSamples* m : clients)
        for (const auto& [f, c] : m->confirmed)
            if (const auto [it, fresh] = first.emplace(f, c); !fresh) {
                ++compared;
                if (it->second != c) ++mismatches;
            }
    return {compared, mismatches};
}

void add_client_samples(RunResult& r, const RecordedSamples& m) {
    r.input_latency_local.merge(m.input_latency_local);
    r.cpu_us_per_tick.merge(m.cpu_us_per_tick);
    r.resim_us_per_tick.merge(m.resim_us_per_tick);
    r.physics_step_us.merge(m.physics_step_us);
    r.rollback_depth.merge(m.rollback_depth);
    if (r.rollback_depth_histogram.size() < m.rollback_depth_histogram.size())
        r.rollback_depth_histogram.resize(m.rollback_depth_histogram.size(), 0);
    for (std::size_t d = 0; d < m.rollback_depth_histogram.size(); ++d) r.rollback_depth_histogram[d] += m.rollback_depth_histogram[d];
    r.correction_jump.merge(m.correction_jump);
    r.displayed_vs_confirmed.push_back(m.displayed_vs_confirmed);
}

MatchRecorder::MatchRecorder(int slot, int players, std::uint32_t target, const rollback::WorldSimulation& sim,
                             bool record_remote_inputs, bool keep_positions)
    : sim_(sim), players_(players), target_(target), remote_(record_remote_inputs), keep_positions_(keep_positions) {
    s_.slot = slot;
    s_.shown.reserve(target + 1);
    if (keep_positions_) shown_positions_.reserve(target + 1);
}

std::vector<sim::Vec3> MatchRecorder::positions() const {
    std::vector<sim::Vec3> out;
    const sim::World& w = sim_.world();
    out.reserve(w.dynamic_count());
    for (sim::BodyId id : w.dynamic_ids()) out.push_back(w.position(id));
    return out;
}

void MatchRecorder::input_offered(std::uint64_t now_us, std::uint32_t input_frame, const std::array<std::uint8_t, 3>& bytes) {
    const bool taken = !have_last_ || input_frame > last_frame_;
    if (!taken) return;
    if (!have_last_ || bytes != last_bytes_) {
        pending_local_[input_frame] = {now_us, bytes};
        s_.inputs_made.push_back({input_frame, bytes, now_us});
    }
    last_bytes_ = bytes;
    last_frame_ = input_frame;
    have_last_ = true;
    while (pending_local_.size() > 256) pending_local_.erase(pending_local_.begin());
}

const std::vector<sim::Vec3>* MatchRecorder::frame_simulated(std::uint64_t now_us, const rollback::FrameSimulated& f) {
    if (f.frame > target_) return nullptr;
    // Frame f consumed the inputs of frame f - 1.
    const std::uint32_t input_frame = f.frame - 1;
    constexpr std::size_t kSize = rollback::kWorldInputSize;
    if (remote_)
        for (int p = 0; p < players_; ++p) {
            const auto off = static_cast<std::size_t>(p) * kSize;
            if (p == s_.slot || off + kSize > f.inputs.size()) continue;
            std::array<std::uint8_t, 3> b{};
            std::copy_n(f.inputs.begin() + static_cast<std::ptrdiff_t>(off), kSize, b.begin());
            auto& seen = s_.inputs_seen[{p, input_frame}];
            if (std::none_of(seen.begin(), seen.end(), [&](const auto& e) { return e.first == b; })) seen.emplace_back(b, now_us);
        }
    // Local input latency. A spectator's id is past the players' inputs: no local input to time.
    const auto off = static_cast<std::size_t>(s_.slot) * kSize;
    if (const auto it = pending_local_.find(input_frame); it != pending_local_.end() && off + kSize <= f.inputs.size()) {
        if (std::equal(it->second.second.begin(), it->second.second.end(), f.inputs.begin() + static_cast<std::ptrdiff_t>(off))) {
            s_.input_latency_local.add(static_cast<double>(now_us - it->second.first) / 1000.0);
            pending_local_.erase(it);
        }
    }
    if (f.resimulation) return nullptr;
    s_.shown.emplace_back(f.frame, now_us);
    const auto [it, fresh] = awaiting_confirmation_.insert_or_assign(f.frame, positions());
    (void)fresh;
    if (keep_positions_) shown_positions_.emplace_back(f.frame, it->second);
    return &it->second;
}

void MatchRecorder::frame0_shown(std::uint64_t now_us) { s_.shown.insert(s_.shown.begin(), {0, now_us}); }

double MatchRecorder::recent_tick_rate(int tick_rate) const {
    if (s_.shown.empty() || tick_rate <= 0) return 0;
    const bool has_frame0 = s_.shown.front().first == 0;
    const auto frames = s_.shown.begin() + (has_frame0 ? 1 : 0);  // frame 0 is the origin, not a frame shown
    if (frames == s_.shown.end()) return 0;
    const std::uint64_t now = s_.shown.back().second;
    const double origin = static_cast<double>(s_.shown.front().second) - (has_frame0 ? 0.0 : 1e6 / tick_rate);
    // The frames shown in the last second, over the time from the frame before them (or the
    // origin) to the latest: whole intervals, so a steady rate reads itself exactly.
    const auto first = std::upper_bound(frames, s_.shown.end(), now >= 1000000 ? now - 1000000 : 0,
                                        [](std::uint64_t t, const auto& e) { return t < e.second; });
    const double before = first == frames ? origin : static_cast<double>(std::prev(first)->second);
    const double span = static_cast<double>(now) - before;
    return span > 0 ? static_cast<double>(s_.shown.end() - first) / span * 1e6 : 0.0;
}

void MatchRecorder::rollback_begin() { before_rollback_ = positions(); }

std::optional<double> MatchRecorder::rollback_end(const rollback::RollbackInfo& r) {
    if (r.displayed_frame > target_) return std::nullopt;
    s_.rollback_depth.add(r.depth);
    if (s_.rollback_depth_histogram.size() <= r.depth) s_.rollback_depth_histogram.resize(r.depth + 1, 0);
    ++s_.rollback_depth_histogram[r.depth];
    if (!r.displayed_changed()) return std::nullopt;
    const auto after = positions();
    double jump = 0;
    for (std::size_t b = 0; b < after.size() && b < before_rollback_.size(); ++b)
        jump = std::max(jump, distance_m(before_rollback_[b], after[b]));
    s_.correction_jump.add(jump);
    return jump;
}

void MatchRecorder::frame_confirmed(const rollback::FrameConfirmed& f, std::optional<std::span<const std::uint8_t>> state) {
    if (f.frame > target_) return;
    s_.confirmed.emplace_back(f.frame, f.checksum);
    if (f.frame == target_) final_ = f.checksum;
    // What this client showed for the frame against the state it now knows to be final.
    const auto shown = awaiting_confirmation_.find(f.frame);
    if (shown == awaiting_confirmation_.end()) return;
    if (state) {
        const auto& bodies = shown->second;
        for (std::uint32_t b = 0; b < bodies.size() && b < sim_.body_count(); ++b) {
            sim::Vec3 confirmed;
            confirmed.x = sim::Fixed::from_raw(sim_.field_value(*state, b, 0));
            confirmed.y = sim::Fixed::from_raw(sim_.field_value(*state, b, 1));
            confirmed.z = sim::Fixed::from_raw(sim_.field_value(*state, b, 2));
            s_.displayed_vs_confirmed.add(distance_m(bodies[b], confirmed));
        }
    }
    awaiting_confirmation_.erase(awaiting_confirmation_.begin(), std::next(shown));
}

void MatchRecorder::tick(double cpu_us, double resim_us) {
    s_.cpu_us_per_tick.add(cpu_us);
    s_.resim_us_per_tick.add(resim_us);
}

void MatchRecorder::rtt(int peer, double ms) {
    s_.rtt_ms.emplace(peer, Stat::keeping_samples()).first->second.add(ms);
}

}  // namespace lockroll::harness
