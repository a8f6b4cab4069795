#include "net/relay_runner.h"

#include <algorithm>

#include "net/clock.h"
#include "net/tick_schedule.h"

namespace lockroll::net {

namespace {
constexpr std::uint64_t kReconnectEveryUs = 500000;
constexpr std::size_t kMaxHeld = 256;
}  // namespace

RelayRunner::RelayRunner(const RunnerConfig& config, std::string server_host, std::uint16_t server_port,
                         rollback::RelaySession& session, transport::Transport& transport, InputSource input,
                         RunnerObserver* observer)
    : RunnerBase(config, transport, std::move(input), observer), host_(std::move(server_host)), port_(server_port),
      session_(session) {
    // input_size bytes per local slot, in slot order (RelaySession::local_slots()).
    input_bytes_.assign(session_.local_input_size(), 0);
    session_.set_last_frame(config_.target_frame);  // a run of target_frame frames ends on it
}

bool RelayRunner::service(std::uint64_t now) {
    transport_.poll(now);
    for (transport::TransportEvent e; transport_.next_event(e);) {
        if (e.type == transport::TransportEvent::Type::Connected && e.peer == rollback::kRelayServerPeer) {
            if (connections_++ > 0) session_.transport_reconnected(now);  // a new connection: hello again
            for (const auto& bytes : held_) transport_.send_reliable(e.peer, bytes, now);
            held_.clear();
        }
        if (observer_) observer_->on_transport_event(e, now);
    }
    if (now - last_connect_us_ >= kReconnectEveryUs) {
        last_connect_us_ = now;
        if (!transport_.is_connected(rollback::kRelayServerPeer)) transport_.connect(rollback::kRelayServerPeer, host_, port_);
    }
    return true;  // the session's hello to the server is the start barrier
}

std::uint32_t RelayRunner::tick(std::uint64_t now, std::uint64_t scheduled) {
    while (transport_.receive(in_, now))
        if (in_.from == rollback::kRelayServerPeer) session_.receive(in_.bytes, in_.time_us);
    input_(session_.frame() + static_cast<std::uint32_t>(session_.input_delay()), input_bytes_);
    TickReport report;
    report.tick = ticks_;
    report.now_us = now;
    report.scheduled_us = scheduled;
    report.advance = session_.advance(input_bytes_, now);
    if (config_.catch_up_frames > 0 && session_.running() && session_.behind(now) > 0)
        caught_up_ += static_cast<std::uint64_t>(session_.catch_up(now, config_.catch_up_frames));
    drain_events();
    const auto max_extra = static_cast<std::uint64_t>(static_cast<double>(period_us_) * config_.max_stretch);
    const std::uint64_t extra =
        std::min(max_extra, period_us_ * static_cast<std::uint64_t>(std::max(0, report.advance.tick_stretch_ppm)) / 1000000u);
    stretch_.record(extra);
    out_.clear();
    session_.poll(now, out_);
    send_polled(now, [this](const rollback::Datagram& d) {
        if (held_.size() >= kMaxHeld) held_.erase(held_.begin());
        held_.push_back(d.bytes);
    });
    drain_events();  // poll's too: the server's silence is found there, and ends the run at once
    return report_tick(report, extra);
}

void RelayRunner::drain_events() {
    for (rollback::SessionEvent e; session_.next_event(e);) {
        events_.push_back(e);
        if (observer_) observer_->on_session_event(e);
    }
}

TickStatus RelayRunner::status() {
    // Everyone's confirmation is the server's business; ours, and the server holding our inputs
    // up to the target, is what this process waits for.
    const bool spectator = session_.config().role == rollback::RelayRole::Spectator;
    const std::uint32_t target = config_.target_frame;
    return TickStatus{.failed = session_.phase() == rollback::SessionPhase::Failed,
                      .running = session_.running(),
                      .shown_target = session_.frame() >= target,
                      .confirmed = session_.confirmed_frame() >= target &&
                                   (spectator || session_.server_input_ack() >= target),
                      .server_lost = session_.server_lost()};
}

}  // namespace lockroll::net
