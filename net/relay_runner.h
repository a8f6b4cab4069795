// RelayRunner: one RelaySession bound to a transport (ENet through the builder, or the game's
// own: transport/transport.h) and the clock, talking to the relay server (peer id
// rollback::kRelayServerPeer, reached by connect(kRelayServerPeer, server_host, server_port)). The
// relay twin of PeerRunner (peer_runner.h; the config, the loop and its API both share are
// RunnerBase's, net/runner_base.h):
//  - Connection: one, to the server, retried every half second while not connected, for the
//    whole run. A connection ENet dropped is made again and the session says hello again: the
//    server resumes it by its incarnation.
//  - Each tick: drain the transport -> RelaySession::receive -> local input for frame() +
//    input_delay() (input_size bytes per local slot, local_slots() order) -> advance -> catch_up() while behind() (a late start, a joiner, a clock
//    running slow: the session says how far it is behind the room clock) -> events -> poll ->
//    send (reliable for what the session marks so).
//  - The game's loop or the runner's: update() / wait() / run() as PeerRunner's.
//  - Pacing: tick_stretch_ppm lengthens the next tick (at most max_stretch); the schedule is
//    PeerRunner's (late ticks run at once; max_catch_up ticks behind, it restarts from now).
//  - Finishing: target_frame is the last frame simulated (RelaySession::set_last_frame); after
//    showing it it keeps ticking until it has confirmed target_frame
//    and the server holds its inputs up to target_frame (so nobody's frame before the target
//    needs a replacement of its input), then lingers linger_us. A spectator only needs the
//    confirmation. Bounded by finish_timeout_us and run_timeout_us.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "net/peer_runner.h"
#include "net/runner_base.h"
#include "rollback/relay_session.h"
#include "transport/transport.h"

namespace lockroll::net {

// update(), wait(), run(), request_stop() and the stretch and schedule counters: RunnerBase's.
class RelayRunner final : public RunnerBase {
public:
    // config.peers is unused; the server is at server_host:server_port. Throws
    // std::invalid_argument for a bad config (RunnerBase's checks).
    RelayRunner(const RunnerConfig& config, std::string server_host, std::uint16_t server_port,
                rollback::RelaySession& session, transport::Transport& transport, InputSource input,
                RunnerObserver* observer = nullptr);

    std::uint64_t catch_up_frames() const { return caught_up_; }

private:
    // RunnerBase's: the session's hello to the server is the start barrier, so ticking starts at
    // once; done once our confirmation and the server's hold of our inputs reach the target.
    bool service(std::uint64_t now) override;
    std::uint32_t tick(std::uint64_t now, std::uint64_t scheduled) override;
    TickStatus status() override;
    void drain_events();  // the session's events to events_ and the observer

    std::string host_;
    std::uint16_t port_;
    rollback::RelaySession& session_;
    std::vector<std::vector<std::uint8_t>> held_;  // reliable sends before the connection is up
    std::uint64_t last_connect_us_ = 0;
    int connections_ = 0;  // to the server so far (a later one is a reconnect)
    std::uint64_t caught_up_ = 0;
};

}  // namespace lockroll::net
