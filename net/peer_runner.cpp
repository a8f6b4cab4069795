#include "net/peer_runner.h"

#include <algorithm>
#include <chrono>
#include <stdexcept>
#include <thread>

#include "net/clock.h"

namespace lockroll::net {

namespace {
// How often a lower slot re-tries connecting to a higher slot it is not connected to.
constexpr std::uint64_t kReconnectEveryUs = 500000;
}  // namespace

const char* outcome_name(RunOutcome o) {
    switch (o) {
        case RunOutcome::Completed: return "completed";
        case RunOutcome::ConnectTimeout: return "connect_timeout";
        case RunOutcome::FinishTimeout: return "finish_timeout";
        case RunOutcome::RunTimeout: return "run_timeout";
        case RunOutcome::Stopped: return "stopped";
    }
    return "?";
}

PeerRunner::PeerRunner(const RunnerConfig& config, rollback::Session& session, transport::EnetTransport& transport,
                       InputSource input, RunnerObserver* observer)
    : config_(config), session_(session), transport_(transport), input_(std::move(input)), observer_(observer) {
    const auto& sc = session_.config();
    if (config_.tick_rate < 1 || config_.tick_rate > 1000) throw std::invalid_argument("RunnerConfig: tick_rate must be 1..1000");
    if (!(config_.max_stretch >= 0 && config_.max_stretch <= 0.5))
        throw std::invalid_argument("RunnerConfig: max_stretch must be 0..0.5");
    if (config_.max_catch_up < 1) throw std::invalid_argument("RunnerConfig: max_catch_up must be >= 1");
    if (config_.service_interval_us < 100) throw std::invalid_argument("RunnerConfig: service_interval_us must be >= 100");
    if (!input_) throw std::invalid_argument("RunnerConfig: no input source");
    for (const auto& p : config_.peers)
        if (p.slot >= static_cast<rollback::PlayerId>(sc.players) || p.slot == sc.local_player)
            throw std::invalid_argument("RunnerConfig: peer slot " + std::to_string(p.slot) + " is out of range or local");
    const auto players = static_cast<std::size_t>(sc.players);
    connected_.assign(players, false);
    ever_connected_.assign(players, false);
    input_bytes_.assign(sc.input_size, 0);
    period_us_ = 1000000u / static_cast<unsigned>(config_.tick_rate);
}

void PeerRunner::track_connections(std::uint64_t now) {
    const auto local = session_.config().local_player;
    for (std::size_t p = 0; p < connected_.size(); ++p) {
        if (p == local) continue;
        const bool c = transport_.is_connected(static_cast<transport::PeerId>(p));
        if (c == connected_[p]) continue;
        connected_[p] = c;
        if (c) ever_connected_[p] = true;
        if (observer_) {
            if (c) observer_->on_connected(static_cast<rollback::PlayerId>(p), now);
            else observer_->on_disconnected(static_cast<rollback::PlayerId>(p), now);
        }
    }
}

void PeerRunner::service_until(std::uint64_t deadline_us) {
    for (;;) {
        const std::uint64_t now = now_us();
        transport_.poll(now);
        track_connections(now);
        if (now - last_reconnect_us_ >= kReconnectEveryUs) {
            last_reconnect_us_ = now;
            // Lower slot connects; connect() refuses harmlessly while one is already pending.
            for (const auto& p : config_.peers)
                if (p.slot > session_.config().local_player && !connected_[p.slot])
                    transport_.connect(p.slot, p.host, p.port);
        }
        if (now >= deadline_us || stop_.load(std::memory_order_relaxed)) return;
        std::this_thread::sleep_for(std::chrono::microseconds(std::min(deadline_us - now, config_.service_interval_us)));
    }
}

bool PeerRunner::connect_phase() {
    const std::uint64_t begin = now_us();
    const auto local = session_.config().local_player;
    for (;;) {
        service_until(now_us() + 5 * config_.service_interval_us);
        bool all = true;
        for (std::size_t p = 0; p < connected_.size(); ++p)
            if (p != local && !connected_[p]) all = false;
        if (all) return true;
        if (stop_.load(std::memory_order_relaxed) || now_us() - begin > config_.connect_timeout_us) return false;
    }
}

bool PeerRunner::everyone_confirmed() const {
    const std::uint32_t target = config_.target_frame;
    if (session_.confirmed_frame() < target) return false;
    const auto local = session_.config().local_player;
    for (std::size_t p = 0; p < connected_.size(); ++p) {
        if (p == local) continue;
        const bool gone = ever_connected_[p] && !connected_[p];
        if (!gone && session_.peer_ack(static_cast<rollback::PlayerId>(p)) < target) return false;
    }
    return true;
}

void PeerRunner::tick(std::uint64_t now, std::uint64_t scheduled) {
    while (transport_.receive(in_, now)) {
        if (in_.from >= connected_.size()) continue;
        session_.receive(static_cast<rollback::PlayerId>(in_.from), in_.bytes, in_.time_us);
    }
    const std::uint32_t input_frame = session_.frame() + static_cast<std::uint32_t>(session_.input_delay());
    input_(input_frame, input_bytes_);
    TickReport report;
    report.tick = ticks_;
    report.now_us = now;
    report.scheduled_us = scheduled;
    report.advance = session_.advance(input_bytes_, now);
    // A recommendation measures the whole gap as it stands, so it replaces the unpaid rest.
    if (report.advance.wait_frames > 0) debt_us_ = static_cast<std::uint64_t>(report.advance.wait_frames) * period_us_;
    const auto max_extra = static_cast<std::uint64_t>(static_cast<double>(period_us_) * config_.max_stretch);
    const std::uint64_t extra = std::min(debt_us_, max_extra);
    debt_us_ -= extra;
    if (extra > 0) {
        ++stretched_ticks_;
        stretch_total_us_ += extra;
    }
    last_extra_us_ = extra;
    out_.clear();
    session_.poll(now, out_);
    for (const auto& d : out_) transport_.send(d.peer, d.bytes, now);
    report.length_us = period_us_ + extra;
    if (observer_) observer_->on_tick(report);
    ++ticks_;
}

RunOutcome PeerRunner::run() {
    if (!connect_phase()) return stop_.load() ? RunOutcome::Stopped : RunOutcome::ConnectTimeout;
    started_us_ = now_us();
    if (observer_) observer_->on_synchronized(started_us_);
    // Tick k is due at start + k / tick_rate seconds (exact integers) + all stretches so far.
    std::uint64_t offset = 0, k = 0, reached = 0, all_confirmed = 0;
    const auto rate = static_cast<std::uint64_t>(config_.tick_rate);
    for (;;) {
        std::uint64_t due = started_us_ + k * 1000000u / rate + offset;
        service_until(due);
        if (stop_.load(std::memory_order_relaxed)) return RunOutcome::Stopped;
        const std::uint64_t now = now_us();
        if (now > due + static_cast<std::uint64_t>(config_.max_catch_up) * period_us_) {
            offset += now - due;
            due = now;
            ++schedule_resets_;
        }
        tick(now, due);
        offset += last_extra_us_;
        ++k;
        if (!reached && session_.frame() >= config_.target_frame) reached = now;
        if (reached && !all_confirmed && everyone_confirmed()) {
            all_confirmed = now;
            if (observer_) observer_->on_all_confirmed(now);
        }
        if (all_confirmed && now - all_confirmed >= config_.linger_us) return RunOutcome::Completed;
        if (reached && !all_confirmed && now - reached > config_.finish_timeout_us) return RunOutcome::FinishTimeout;
        if (!reached && config_.run_timeout_us && now - started_us_ > config_.run_timeout_us) return RunOutcome::RunTimeout;
    }
}

}  // namespace lockroll::net
