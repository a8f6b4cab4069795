#include "rollback/sync.h"

#include <algorithm>
#include <limits>
#include <stdexcept>
#include <string>

namespace lockroll::rollback {

namespace {
// Saves the live state as `frame` into the ring: only the bytes the state takes now (a
// variable-size state), allocation-free. A game whose saved_size() exceeds its declared
// capacity is counted (the session then fails) and leaves an empty state rather than writing
// past the buffer.
std::span<const std::uint8_t> save_frame(SnapshotRing& ring, const Simulation& sim, std::uint32_t frame,
                                         SessionStats& stats) {
    const auto saved = sim.save_to(ring.slot_for(frame));
    if (saved.empty() && sim.saved_size() != 0) ++stats.oversized_states;
    ring.set_used(frame, saved.size());
    return saved;
}
}  // namespace

Sync::Sync(const SyncConfig& config, Simulation& sim, Predictor& predictor, SessionObserver* observer,
           SessionStats& stats, CpuClock cpu_clock)
    : config_(config),
      max_window_(config.prediction_window),
      sim_(sim),
      predictor_(predictor),
      observer_(observer),
      stats_(stats),
      cpu_clock_(std::move(cpu_clock)),
      ring_(static_cast<std::size_t>(config.prediction_window) + 1 +
                static_cast<std::size_t>(std::max(config.evidence_frames, 1)),
            sim.state_size()),
      keep_from_(static_cast<std::size_t>(config.players), std::numeric_limits<std::uint32_t>::max()),
      frame_inputs_(static_cast<std::size_t>(config.players) * config.input_size),
      frame_status_(static_cast<std::size_t>(config.players), InputStatus::Confirmed),
      confirm_inputs_(frame_inputs_.size()),
      scratch_input_(config.input_size) {
    if (config.players < 1 || config.players > kMaxPlayers)
        throw std::invalid_argument("players must be 1.." + std::to_string(kMaxPlayers));
    if (config.local_player >= static_cast<PlayerId>(config.players))
        throw std::invalid_argument("local player slot out of range");
    if (config.prediction_window < 0) throw std::invalid_argument("prediction window must be >= 0");
    if (stats_.peers.size() < static_cast<std::size_t>(config.players))
        stats_.peers.resize(static_cast<std::size_t>(config.players));
    queues_.reserve(static_cast<std::size_t>(config.players));
    for (int p = 0; p < config.players; ++p) queues_.emplace_back(config.input_size, config.input_capacity);
    if (config.retain_frames >= config.input_capacity / 2)
        throw std::invalid_argument("retained frames must be below half the input capacity");
    if (static_cast<std::uint32_t>(config.prediction_window) * 2 >= config.input_capacity)
        throw std::invalid_argument("input capacity must exceed twice the prediction window");
    initial_checksum_ = sim_.checksum(save_frame(ring_, sim_, 0, stats_));
    if (!config_.all_streams_remote) keep_from_[config_.local_player] = 0;  // nothing of ours is acknowledged yet
    stats_.rollback_depth_histogram.assign(static_cast<std::size_t>(config.prediction_window) + 1, 0);
}

std::uint32_t Sync::remote_confirmed_inputs() const {
    std::uint32_t m = std::numeric_limits<std::uint32_t>::max();
    for (std::size_t p = 0; p < queues_.size(); ++p)
        if (p != config_.local_player || config_.all_streams_remote) m = std::min(m, queues_[p].confirmed_count());
    return m;
}

std::uint32_t Sync::all_confirmed_inputs() const {
    return std::min(remote_confirmed_inputs(), queues_[config_.local_player].confirmed_count());
}

void Sync::set_keep_from(PlayerId player, std::uint32_t frame) {
    keep_from_[player] = frame;
    // Only this queue's floor can move: another queue's floor depends on the confirmed frame and
    // its own keep_from, and neither changed since update_floors() or set_keep_from() last set
    // it. O(1), because the session calls this for every slot several times a tick.
    queues_[player].discard_before(std::min(retained_floor(), frame));
}

std::uint32_t Sync::retained_floor() const {
    return confirmed_frame_ > config_.retain_frames ? confirmed_frame_ - config_.retain_frames : 0;
}

// Inputs older than the next frame to confirm are never read again (rollback targets are never
// older than that either), except ones a peer still needs from us (resends and relays).
void Sync::update_floors() {
    const std::uint32_t retained = retained_floor();
    for (std::size_t p = 0; p < queues_.size(); ++p) queues_[p].discard_before(std::min(retained, keep_from_[p]));
}

std::string Sync::restart_at(std::uint32_t frame, std::span<const std::uint8_t> state) {
    // A refused state changes nothing, a scheduled rollback included: the caller keeps running
    // on the current frames (and asks again), which still rest on that misprediction.
    if (std::string err = sim_.load(state); !err.empty()) return err;
    pending_.reset();
    for (InputQueue& q : queues_) q.restart_at(frame);
    std::fill(keep_from_.begin(), keep_from_.end(), std::numeric_limits<std::uint32_t>::max());
    if (!config_.all_streams_remote) keep_from_[config_.local_player] = frame;
    frame_ = frame;
    highest_simulated_ = frame;
    confirmed_frame_ = frame;
    save_frame(ring_, sim_, frame, stats_);
    return {};
}

bool Sync::transfer_contents(std::uint32_t frame, bool with_streams, TransferContents& t) const {
    const auto state = saved_state(frame);
    if (!state) return false;
    t.frame = frame;
    t.state.assign(state->begin(), state->end());
    t.streams.assign(static_cast<std::size_t>(config_.players), StreamInputs{});
    if (!with_streams) return true;
    const std::size_t n = config_.input_size;
    for (int s = 0; s < config_.players; ++s) {
        const InputQueue& q = queues_[static_cast<std::size_t>(s)];
        StreamInputs& st = t.streams[static_cast<std::size_t>(s)];
        if (q.floor() > frame) return false;  // queues keep everything from the confirmed frame on
        st.count = q.confirmed_count() > frame ? q.confirmed_count() - frame : 0;
        st.inputs.resize(std::size_t{st.count} * n);
        st.absent.resize(st.count);
        for (std::uint32_t i = 0; i < st.count; ++i) {
            const auto in = q.confirmed(frame + i);
            std::copy(in.begin(), in.end(), st.inputs.begin() + static_cast<std::ptrdiff_t>(std::size_t{i} * n));
            st.absent[i] = q.confirmed_absent(frame + i) ? 1 : 0;
        }
    }
    return true;
}

std::string Sync::load_transfer(const TransferContents& t) {
    // Inputs held beyond what the snapshot brings stay valid (they are confirmed): keep them.
    struct Held {
        std::uint32_t first = 0;
        std::vector<std::uint8_t> inputs, absent;
    };
    const std::size_t n = config_.input_size;
    std::vector<Held> held(static_cast<std::size_t>(config_.players));
    for (int s = 0; s < config_.players; ++s) {
        const InputQueue& q = queues_[static_cast<std::size_t>(s)];
        Held& h = held[static_cast<std::size_t>(s)];
        h.first = std::max(q.floor(), t.frame);
        for (std::uint32_t f = h.first; f < q.confirmed_count(); ++f) {
            const auto in = q.confirmed(f);
            h.inputs.insert(h.inputs.end(), in.begin(), in.end());
            h.absent.push_back(q.confirmed_absent(f) ? 1 : 0);
        }
    }
    if (std::string e = restart_at(t.frame, t.state); !e.empty()) return e;
    for (int s = 0; s < config_.players; ++s) {
        const auto slot = static_cast<PlayerId>(s);
        if (static_cast<std::size_t>(s) < t.streams.size()) {
            const StreamInputs& st = t.streams[static_cast<std::size_t>(s)];
            for (std::uint32_t i = 0; i < st.count; ++i)
                if (add_remote_input(slot, t.frame + i, std::span(st.inputs).subspan(std::size_t{i} * n, n), st.absent[i] != 0) !=
                    InputQueue::Add::Stored)
                    break;
        }
        const Held& h = held[static_cast<std::size_t>(s)];
        for (std::size_t i = 0; i < h.absent.size(); ++i) {
            const std::uint32_t f = h.first + static_cast<std::uint32_t>(i);
            if (f < queues_[slot].confirmed_count()) continue;
            if (add_remote_input(slot, f, std::span(h.inputs).subspan(i * n, n), h.absent[i] != 0) != InputQueue::Add::Stored)
                break;
        }
    }
    return {};
}

bool Sync::add_local_input(std::span<const std::uint8_t> input, int delay, std::uint32_t min_frame) {
    if (input.size() != config_.input_size) throw std::invalid_argument("local input has the wrong size");
    if (config_.all_streams_remote) throw std::logic_error("add_local_input: every stream is remote");
    InputQueue& q = queues_[config_.local_player];
    const std::uint32_t target = std::max(frame_ + static_cast<std::uint32_t>(std::max(delay, 0)), min_frame);
    std::uint32_t next = q.confirmed_count();
    if (target < next) return false;
    const auto last = q.last_confirmed();
    if (last.empty())
        std::fill(scratch_input_.begin(), scratch_input_.end(), std::uint8_t{0});
    else
        std::copy(last.begin(), last.end(), scratch_input_.begin());
    for (; next < target; ++next)
        if (q.add_confirmed(next, scratch_input_) != InputQueue::Add::Stored)
            throw std::logic_error("local input queue full (must_wait() was not checked)");
    if (q.add_confirmed(target, input) != InputQueue::Add::Stored)
        throw std::logic_error("local input queue full (must_wait() was not checked)");
    return true;
}

InputQueue::Add Sync::add_remote_input(PlayerId player, std::uint32_t frame, std::span<const std::uint8_t> input,
                                       bool absent) {
    InputQueue& q = queues_[player];
    const InputQueue::Add result = q.add_confirmed(frame, input, absent);
    if (result != InputQueue::Add::Stored || frame >= frame_) return result;
    // Already simulated: was it simulated with this input?
    const auto used = q.used(frame);
    if (!used || !std::equal(used->begin(), used->end(), input.begin()) || q.used_absent(frame) != absent) {
        ++stats_.peers[player].mispredictions;
        pending_ = pending_ ? std::min(*pending_, frame) : frame;
    }
    return result;
}

bool Sync::replace_remote_input(PlayerId player, std::uint32_t frame, std::span<const std::uint8_t> input) {
    if (player >= queues_.size() || frame < confirmed_frame_) return false;
    InputQueue& q = queues_[player];
    if (!q.replace_confirmed(frame, input)) return false;
    if (frame >= frame_) return true;
    const auto used = q.used(frame);
    if (!used || !std::equal(used->begin(), used->end(), input.begin()) || q.used_absent(frame)) {
        ++stats_.peers[player].mispredictions;
        pending_ = pending_ ? std::min(*pending_, frame) : frame;
    }
    return true;
}

bool Sync::must_wait(int delay) const {
    const std::uint64_t window = static_cast<std::uint64_t>(config_.prediction_window);
    if (std::uint64_t{frame_} >= std::uint64_t{remote_confirmed_inputs()} + window) return true;
    return !config_.all_streams_remote && local_queue_full(delay);
}

bool Sync::local_queue_full(int delay) const {
    const InputQueue& local = queues_[config_.local_player];
    const std::uint64_t target = std::uint64_t{frame_} + static_cast<std::uint64_t>(std::max(delay, 0));
    return target >= std::uint64_t{local.floor()} + local.capacity();
}

int Sync::blocking_player() const {
    int who = -1;
    std::uint32_t least = std::numeric_limits<std::uint32_t>::max();
    for (std::size_t p = 0; p < queues_.size(); ++p)
        if ((p != config_.local_player || config_.all_streams_remote) && queues_[p].confirmed_count() < least) {
            least = queues_[p].confirmed_count();
            who = static_cast<int>(p);
        }
    return who;
}

void Sync::simulate_one(bool resimulation) {
    const std::uint32_t f = frame_;
    const std::size_t n = config_.input_size;
    std::uint64_t predicted = 0;
    for (std::size_t p = 0; p < queues_.size(); ++p) {
        InputQueue& q = queues_[p];
        std::span<std::uint8_t> out(frame_inputs_.data() + p * n, n);
        bool absent = false;
        if (f < q.confirmed_count()) {
            const auto c = q.confirmed(f);
            std::copy(c.begin(), c.end(), out.begin());
            absent = q.confirmed_absent(f);
            frame_status_[p] = absent ? InputStatus::Absent : InputStatus::Confirmed;
        } else if (q.last_absent()) {
            // An absent slot is guessed to stay absent: the neutral input.
            std::fill(out.begin(), out.end(), std::uint8_t{0});
            absent = true;
            frame_status_[p] = InputStatus::Absent;
            predicted |= std::uint64_t{1} << p;
        } else {
            predictor_.predict(static_cast<PlayerId>(p), f, q.last_confirmed(), q.confirmed_count() - 1, out);
            predicted |= std::uint64_t{1} << p;
            frame_status_[p] = InputStatus::Predicted;
        }
        q.set_used(f, out, absent);
    }
    sim_.step(frame_inputs_, frame_status_);
    frame_ = f + 1;
    for (const Fault& fault : faults_)
        if (fault.frame == frame_) sim_.flip_bit(fault.body_id, fault.field, fault.bit);
    save_frame(ring_, sim_, frame_, stats_);
    if (!resimulation) {
        highest_simulated_ = frame_;
        stats_.predicted_inputs += static_cast<std::uint64_t>(__builtin_popcountll(predicted));
    }
    if (observer_) observer_->on_frame_simulated({frame_, resimulation, predicted, frame_inputs_});
}

std::uint32_t Sync::rollback_if_needed() {
    if (!pending_) return 0;
    const std::uint32_t target = *pending_;
    pending_.reset();
    const std::uint32_t displayed = frame_;
    const std::uint64_t t0 = cpu_clock_();
    RollbackInfo info;
    info.from_frame = target;
    info.displayed_frame = displayed;
    info.depth = displayed - target;
    info.displayed_checksum_before = sim_.checksum(*ring_.find(displayed));
    if (observer_) observer_->on_rollback_begin(info);
    const auto saved = ring_.find(target);
    if (!saved) throw std::logic_error("rollback target " + std::to_string(target) + " is no longer saved");
    if (const std::string err = sim_.load(*saved); !err.empty())
        throw std::logic_error("loading saved frame " + std::to_string(target) + ": " + err);
    frame_ = target;
    while (frame_ < displayed) simulate_one(true);
    info.displayed_checksum_after = sim_.checksum(*ring_.find(displayed));
    ++stats_.rollbacks;
    stats_.resimulated_frames += info.depth;
    stats_.max_rollback_depth = std::max(stats_.max_rollback_depth, info.depth);
    auto& hist = stats_.rollback_depth_histogram;
    if (info.depth >= hist.size()) hist.resize(info.depth + 1, 0);
    ++hist[info.depth];
    stats_.resim_ns += cpu_clock_() - t0;
    if (observer_) observer_->on_rollback_end(info);
    return info.depth;
}

void Sync::step_forward() {
    if (pending_) throw std::logic_error("step_forward with a rollback pending");
    const std::uint64_t t0 = cpu_clock_();
    simulate_one(false);
    ++stats_.frames_advanced;
    stats_.forward_ns += cpu_clock_() - t0;
}

std::uint32_t Sync::confirmable_frame() const { return std::min(all_confirmed_inputs(), frame_); }

FrameConfirmed Sync::confirm_next() {
    if (pending_) throw std::logic_error("confirm_next with a rollback pending");
    const std::uint32_t n = confirmed_frame_ + 1;
    if (n > confirmable_frame()) throw std::logic_error("confirm_next beyond the confirmable frame");
    const std::size_t size = config_.input_size;
    for (std::size_t p = 0; p < queues_.size(); ++p) {
        const auto c = queues_[p].confirmed(n - 1);
        std::copy(c.begin(), c.end(), confirm_inputs_.begin() + static_cast<std::ptrdiff_t>(p * size));
    }
    const auto state = ring_.find(n);
    if (!state) throw std::logic_error("confirmed frame " + std::to_string(n) + " is no longer saved");
    confirmed_frame_ = n;
    update_floors();
    return {n, confirm_inputs_, sim_.checksum(*state)};
}

void Sync::set_prediction_window(int frames) {
    if (frames < 0 || frames > max_window_)
        throw std::invalid_argument("prediction window must be 0.." + std::to_string(max_window_) + " (the window built with)");
    config_.prediction_window = frames;
}

std::string Sync::add_fault(std::uint32_t frame, std::uint32_t body_id, int field, int bit) {
    if (frame <= frame_)
        return "frame " + std::to_string(frame) + " is already simulated (now at " + std::to_string(frame_) + ")";
    if (field < 0 || field >= sim_.field_count()) return "field " + std::to_string(field) + " does not exist";
    if (bit < 0 || bit > 63) return "bit must be 0..63";
    bool found = false;
    for (std::uint32_t i = 0; i < sim_.body_count() && !found; ++i) found = sim_.body_id(i) == body_id;
    if (!found) return "body " + std::to_string(body_id) + " is not part of the simulation state (static or unknown)";
    faults_.push_back({frame, body_id, field, bit});
    return {};
}

}  // namespace lockroll::rollback
