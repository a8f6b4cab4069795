#include "rollback/session.h"

#include <algorithm>
#include <chrono>
#include <limits>
#include <stdexcept>

namespace lockroll::rollback {

namespace {
std::uint64_t steady_ns() {
    return static_cast<std::uint64_t>(
        std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
            .count());
}

void require(bool ok, const std::string& what) {
    if (!ok) throw std::invalid_argument("session config: " + what);
}

std::uint32_t next_pow2(std::uint64_t v) {
    std::uint32_t p = 1;
    while (p < v) p <<= 1;
    return p;
}

std::int8_t clamp_i8(std::int64_t v) { return static_cast<std::int8_t>(std::clamp<std::int64_t>(v, -127, 127)); }
}  // namespace

void validate(const SessionConfig& c) {
    require(c.players >= 1 && c.players <= kMaxPlayers, "players must be 1.." + std::to_string(kMaxPlayers));
    require(c.local_player < static_cast<PlayerId>(c.players), "local_player must be a player slot");
    require(c.input_size >= 1 && c.input_size <= kMaxInputSize,
            "input_size must be 1.." + std::to_string(kMaxInputSize));
    require(c.tick_rate >= 1 && c.tick_rate <= 10000, "tick_rate must be 1..10000");
    require(c.prediction_window >= 0 && c.prediction_window <= 120, "prediction_window must be 0..120");
    require(c.input_capacity >= 64 && (c.input_capacity & (c.input_capacity - 1)) == 0,
            "input_capacity must be a power of two >= 64");
    const int max_delay = static_cast<int>(c.input_capacity / 4);
    require(c.input_delay >= 0 && c.input_delay <= max_delay, "input_delay must be 0.." + std::to_string(max_delay));
    require(static_cast<std::uint32_t>(c.prediction_window) < c.input_capacity / 4,
            "prediction_window must be below input_capacity / 4");
    require(c.checksum_interval >= 1 && c.checksum_interval <= 65535, "checksum_interval must be 1..65535");
    require(c.checksum_repeats >= 1, "checksum_repeats must be >= 1");
    require(c.evidence_frames >= 1 && c.evidence_frames <= 100000, "evidence_frames must be 1..100000");
    require(c.max_bad_packets >= 1, "max_bad_packets must be >= 1");
    require(c.time_sync_window >= 1 && c.time_sync_window <= 100000, "time_sync_window must be >= 1");
    require(c.time_sync_min_frames >= 1, "time_sync_min_frames must be >= 1");
    require(c.time_sync_every >= 1, "time_sync_every must be >= 1");
    require(c.max_replies_per_poll >= 1, "max_replies_per_poll must be >= 1");
}

Session::Session(const SessionConfig& config, Simulation& simulation, SessionObserver* observer,
                 Predictor* predictor)
    : config_(config), sim_(simulation), observer_(observer), input_delay_(config.input_delay) {
    validate(config_);
    if (!config_.cpu_clock) config_.cpu_clock = steady_ns;
    if (!predictor) {
        default_predictor_ = std::make_unique<RepeatLastPredictor>();
        predictor = default_predictor_.get();
    }
    const auto players = static_cast<std::size_t>(config_.players);
    stats_.peers.resize(players);
    SyncConfig sc;
    sc.players = config_.players;
    sc.local_player = config_.local_player;
    sc.input_size = config_.input_size;
    sc.prediction_window = config_.prediction_window;
    sc.evidence_frames = config_.evidence_frames;
    sc.input_capacity = config_.input_capacity;
    sync_ = std::make_unique<Sync>(sc, sim_, *predictor, observer_, stats_, config_.cpu_clock);
    DesyncConfig dc;
    dc.history = next_pow2(std::max<std::uint64_t>(
        1024, 2 * static_cast<std::uint64_t>(config_.checksum_interval) +
                  static_cast<std::uint64_t>(config_.evidence_frames + config_.prediction_window)));
    dc.max_pinned_frames = std::clamp(2 * config_.checksum_interval + 8, 10, 64);
    dc.resend_us = config_.query_resend_us;
    detector_ = std::make_unique<DesyncDetector>(dc, config_.players, config_.local_player, sim_, sync_->ring(),
                                                 observer_, stats_);
    detector_->add_local(0, sync_->initial_checksum());
    links_.reserve(players);
    for (std::size_t p = 0; p < players; ++p) links_.emplace_back(config_.max_bad_packets, config_.time_sync_window);
    local_advantage_.assign(players, 0);
    replies_this_poll_.assign(players, 0);
    first_sent_us_.assign(config_.input_capacity, 0);
    first_sent_tag_.assign(config_.input_capacity, 0);
}

Session::~Session() = default;

void Session::malformed(PlayerId from, const char* why) {
    ++stats_.malformed_packets;
    ++stats_.peers[from].malformed_packets;
    if (links_[from].note_malformed(why)) {
        stats_.peers[from].error = true;
        detector_->peer_failed(from);
        refresh_resend_floor();
        if (observer_) observer_->on_peer_error(from, why);
    }
}

void Session::receive(PlayerId from, std::span<const std::uint8_t> datagram, std::uint64_t now_us) {
    ++stats_.packets_received;
    stats_.bytes_received += datagram.size();
    if (from >= static_cast<PlayerId>(config_.players) || from == config_.local_player) {
        ++stats_.unknown_peer_packets;
        return;
    }
    PeerStats& ps = stats_.peers[from];
    ++ps.packets_received;
    ps.bytes_received += datagram.size();
    if (links_[from].error()) {
        ++ps.ignored_packets;
        return;
    }
    const auto kind = peek_kind(datagram);
    if (!kind) return malformed(from, "unknown message kind");
    switch (*kind) {
        case MessageKind::Input:
            if (const char* e = decode(datagram, config_.input_size, in_msg_)) return malformed(from, e);
            return handle_input(from, now_us);
        case MessageKind::Query: {
            if (const char* e = decode(datagram, query_msg_)) return malformed(from, e);
            if (replies_this_poll_[from] >= config_.max_replies_per_poll) {
                ++ps.ignored_packets;
                return;
            }
            ++replies_this_poll_[from];
            Datagram d{from, {}};
            encode(detector_->answer(query_msg_), d.bytes);
            pending_out_.push_back(std::move(d));
            return;
        }
        case MessageKind::Reply:
            if (const char* e = decode(datagram, reply_msg_)) return malformed(from, e);
            detector_->on_reply(from, reply_msg_);
            return;
    }
}

void Session::handle_input(PlayerId from, std::uint64_t now_us) {
    const InputMessage& m = in_msg_;
    PeerLink& link = links_[from];
    const InputQueue& local = sync_->queue(config_.local_player);
    const InputQueue& remote = sync_->queue(from);
    // Unwrap every frame before applying anything, so a bad packet changes nothing.
    const auto ack = unwrap_frame(m.ack, local.confirmed_count());
    if (!ack) return malformed(from, "input message: ack frame out of range");
    if (*ack > local.confirmed_count()) return malformed(from, "input message: acknowledges inputs never sent");
    std::optional<std::uint32_t> first;
    if (m.frame_count > 0) {
        first = unwrap_frame(m.first_frame, remote.confirmed_count());
        if (!first) return malformed(from, "input message: first frame out of range");
    }
    std::optional<std::uint32_t> sender_frame;
    if (m.has_time_sync) {
        sender_frame = unwrap_frame(m.sender_frame, sync_->frame());
        if (!sender_frame) return malformed(from, "input message: sender frame out of range");
    }
    std::uint32_t checksum_frames[kMaxChecksumsPerMessage];
    for (int i = 0; i < m.checksum_count; ++i) {
        const auto f = unwrap_frame(m.checksum_frames[i], detector_->newest_local());
        if (!f) return malformed(from, "input message: checksum frame out of range");
        checksum_frames[i] = *f;
    }

    if (*ack > link.remote_ack) {
        const std::uint32_t newest = *ack - 1;
        const std::size_t i = newest & (config_.input_capacity - 1);
        if (first_sent_tag_[i] == newest + 1 && now_us >= first_sent_us_[i])
            link.add_rtt_sample(now_us - first_sent_us_[i]);
        link.remote_ack = *ack;
        refresh_resend_floor();
    }
    if (first) {
        const std::size_t n = config_.input_size;
        for (std::uint32_t k = 0; k < m.frame_count; ++k) {
            const std::uint32_t f = *first + k;
            const auto r = sync_->add_remote_input(from, f, std::span(m.inputs).subspan(k * n, n));
            if (r == InputQueue::Add::Conflict) return malformed(from, "input message: rewrites a confirmed input");
            if (r == InputQueue::Add::Gap || r == InputQueue::Add::TooFarAhead) break;  // resent later
        }
    }
    if (sender_frame) {
        link.has_remote_frame = true;
        link.remote_frame = *sender_frame;
        link.remote_frame_time_us = now_us;
        link.remote_advantage = m.advantage;
    }
    for (int i = 0; i < m.checksum_count; ++i) detector_->add_remote(from, checksum_frames[i], m.checksums[i]);
}

void Session::refresh_resend_floor() {
    std::uint32_t floor = std::numeric_limits<std::uint32_t>::max();
    for (std::size_t p = 0; p < links_.size(); ++p)
        if (p != config_.local_player && !links_[p].error()) floor = std::min(floor, links_[p].remote_ack);
    if (floor == std::numeric_limits<std::uint32_t>::max()) floor = sync_->queue(config_.local_player).confirmed_count();
    sync_->set_local_resend_floor(floor);
}

void Session::confirm_frames() {
    while (sync_->confirmed_frame() < sync_->confirmable_frame()) {
        const FrameConfirmed fc = sync_->confirm_next();
        detector_->add_local(fc.frame, fc.checksum);
        if (observer_) observer_->on_frame_confirmed(fc);
    }
}

// Local advantage against each peer: (its frame now, estimated) - our frame. Its frame now is
// what it last reported plus the time since then and half a round trip, in frames.
void Session::sample_time_sync(std::uint64_t now_us) {
    for (std::size_t p = 0; p < links_.size(); ++p) {
        PeerLink& link = links_[p];
        if (p == config_.local_player || link.error() || !link.has_remote_frame) continue;
        const std::uint64_t elapsed = (now_us >= link.remote_frame_time_us ? now_us - link.remote_frame_time_us : 0) +
                                      link.rtt_us() / 2;
        const std::int64_t estimate =
            std::int64_t{link.remote_frame} + static_cast<std::int64_t>(elapsed * static_cast<std::uint64_t>(config_.tick_rate) / 1000000);
        const std::int64_t adv = estimate - std::int64_t{sync_->frame()};
        local_advantage_[p] = static_cast<std::int32_t>(std::clamp<std::int64_t>(adv, -100000, 100000));
        link.time_sync().add_sample(local_advantage_[p], link.remote_advantage);
        stats_.peers[p].frame_advantage_x100 = link.time_sync().local_advantage_x100();
        stats_.peers[p].rtt_us = link.rtt_us();
    }
}

std::int32_t Session::frames_ahead_x100() const {
    std::int32_t ahead = 0;
    for (std::size_t p = 0; p < links_.size(); ++p)
        if (p != config_.local_player && !links_[p].error())
            ahead = std::max(ahead, links_[p].time_sync().frames_ahead_x100());
    return ahead;
}

AdvanceResult Session::advance(std::span<const std::uint8_t> local_input, std::uint64_t now_us) {
    if (local_input.size() != config_.input_size)
        throw std::invalid_argument("advance: local input must be input_size bytes");
    AdvanceResult result;
    ++stats_.ticks;
    const std::uint64_t resim_before = stats_.resim_ns;
    result.rollback_depth = sync_->rollback_if_needed();
    result.resim_ns = stats_.resim_ns - resim_before;
    confirm_frames();
    sample_time_sync(now_us);
    // The local input goes to frame() + delay whether or not this tick can step: in lockstep
    // both sides wait for each other's input of the same frame, so it must be sent while
    // waiting. While stalled that frame already has its input and later ones are not used.
    bool input_taken = false;
    if (!sync_->local_queue_full(input_delay_)) input_taken = sync_->add_local_input(local_input, input_delay_);
    if (sync_->must_wait(input_delay_)) {
        ++stats_.stall_ticks;
        if (!stalled_since_) stalled_since_ = now_us;
        result.blocking_player = sync_->blocking_player();
    } else {
        if (stalled_since_) {
            stats_.stall_time_us += now_us >= *stalled_since_ ? now_us - *stalled_since_ : 0;
            stalled_since_.reset();
        } else if (!input_taken) {
            ++stats_.dropped_local_inputs;  // the delay just shrank
        }
        const std::uint64_t forward_before = stats_.forward_ns;
        sync_->step_forward();
        result.forward_ns = stats_.forward_ns - forward_before;
        result.advanced = true;
        confirm_frames();
    }
    result.frame = sync_->frame();
    // Time sync: at most one recommendation per window, from fresh samples only.
    if (result.frame >= next_time_sync_frame_) {
        int wait = 0;
        for (std::size_t p = 0; p < links_.size(); ++p)
            if (p != config_.local_player && !links_[p].error())
                wait = std::max(wait, links_[p].time_sync().recommended_wait(config_.time_sync_min_frames));
        if (wait > 0) {
            result.wait_frames = wait;
            ++stats_.time_sync_waits;
            stats_.time_sync_wait_frames += static_cast<std::uint64_t>(wait);
            for (auto& link : links_) link.time_sync().clear();
            next_time_sync_frame_ = result.frame + static_cast<std::uint32_t>(config_.time_sync_window);
        }
    }
    return result;
}

std::uint32_t Session::checkpoint() const {
    const std::uint32_t newest = detector_->newest_local();
    return newest - newest % static_cast<std::uint32_t>(config_.checksum_interval);
}

void Session::poll(std::uint64_t now_us, std::vector<Datagram>& out) {
    const auto account = [&](const Datagram& d) {
        ++stats_.packets_sent;
        stats_.bytes_sent += d.bytes.size();
        ++stats_.peers[d.peer].packets_sent;
        stats_.peers[d.peer].bytes_sent += d.bytes.size();
    };
    for (Datagram& d : pending_out_) {
        account(d);
        out.push_back(std::move(d));
    }
    pending_out_.clear();
    std::fill(replies_this_poll_.begin(), replies_this_poll_.end(), 0);

    queries_.clear();
    detector_->collect_queries(now_us, queries_);
    for (const auto& [peer, q] : queries_) {
        if (links_[peer].error()) continue;
        Datagram d{peer, {}};
        encode(q, d.bytes);
        account(d);
        out.push_back(std::move(d));
    }

    const InputQueue& local = sync_->queue(config_.local_player);
    const std::size_t n = config_.input_size;
    const std::uint32_t cp = checkpoint();
    for (std::size_t p = 0; p < links_.size(); ++p) {
        PeerLink& link = links_[p];
        if (p == config_.local_player || link.error()) continue;
        InputMessage& m = out_msg_;
        m.ack = static_cast<std::uint16_t>(sync_->queue(static_cast<PlayerId>(p)).confirmed_count());
        const std::uint32_t from = std::max(link.remote_ack, local.floor());
        const std::uint32_t to = local.confirmed_count();
        const std::uint32_t count = std::min<std::uint32_t>(to > from ? to - from : 0, max_frames_per_message(n));
        m.first_frame = static_cast<std::uint16_t>(from);
        m.frame_count = static_cast<std::uint8_t>(count);
        m.inputs.resize(std::size_t{count} * n);
        for (std::uint32_t k = 0; k < count; ++k) {
            const std::uint32_t f = from + k;
            const auto in = local.confirmed(f);
            std::copy(in.begin(), in.end(), m.inputs.begin() + static_cast<std::ptrdiff_t>(k * n));
            const std::size_t i = f & (config_.input_capacity - 1);
            if (first_sent_tag_[i] != f + 1) {
                first_sent_tag_[i] = f + 1;
                first_sent_us_[i] = now_us;
            }
        }
        m.has_time_sync = link.messages_sent % static_cast<std::uint64_t>(config_.time_sync_every) == 0;
        m.sender_frame = static_cast<std::uint16_t>(sync_->frame());
        m.advantage = clamp_i8(local_advantage_[p]);
        // Every checkpoint confirmed since the last message (newest three at most), else the
        // newest again until it has ridden checksum_repeats messages.
        m.checksum_count = 0;
        if (!link.any_checksum_sent || cp > link.checksum_frame_sent) {
            const std::uint32_t k = static_cast<std::uint32_t>(config_.checksum_interval);
            std::uint32_t oldest = cp;
            while (oldest >= k && cp - (oldest - k) < k * kMaxChecksumsPerMessage &&
                   (!link.any_checksum_sent || oldest - k > link.checksum_frame_sent))
                oldest -= k;
            for (std::uint32_t f = oldest; f <= cp; f += k) {
                m.checksum_frames[m.checksum_count] = static_cast<std::uint16_t>(f);
                m.checksums[m.checksum_count] = *detector_->local_checksum(f);
                ++m.checksum_count;
            }
            link.any_checksum_sent = true;
            link.checksum_frame_sent = cp;
            link.checksum_sends = 1;
        } else if (link.checksum_sends < config_.checksum_repeats) {
            ++link.checksum_sends;
            m.checksum_frames[0] = static_cast<std::uint16_t>(cp);
            m.checksums[0] = *detector_->local_checksum(cp);
            m.checksum_count = 1;
        }
        ++link.messages_sent;
        Datagram d{static_cast<PlayerId>(p), {}};
        encode(m, n, d.bytes);
        account(d);
        out.push_back(std::move(d));
    }
}

void Session::set_input_delay(int frames) {
    const int max_delay = static_cast<int>(config_.input_capacity / 4);
    if (frames < 0 || frames > max_delay)
        throw std::invalid_argument("input delay must be 0.." + std::to_string(max_delay));
    input_delay_ = frames;
}

std::string Session::inject_fault(std::uint32_t frame, std::uint32_t body_id, int field, int bit) {
    if (frame <= sync_->frame())
        return "frame " + std::to_string(frame) + " is already simulated (now at " + std::to_string(sync_->frame()) + ")";
    if (field < 0 || field >= sim_.field_count()) return "field " + std::to_string(field) + " does not exist";
    if (bit < 0 || bit > 63) return "bit must be 0..63";
    bool found = false;
    for (std::uint32_t i = 0; i < sim_.body_count() && !found; ++i) found = sim_.body_id(i) == body_id;
    if (!found) return "body " + std::to_string(body_id) + " is not part of the simulation state (static or unknown)";
    sync_->add_fault(frame, body_id, field, bit);
    return {};
}

}  // namespace lockroll::rollback
