// A relay match in virtual time: one RelayServer and N RelaySessions in this process, each
// client with its own link to the server (latency, jitter, loss, duplication, reordering; the
// in-test network of tests/rollback/test_support.h), every tick of every client and every
// millisecond of the server simulated in order. The same code runs between real processes in
// tests/net and tests/harness.
#pragma once

#include <map>
#include <memory>
#include <optional>
#include <vector>

#include "rollback/relay_session.h"
#include "server/relay_server.h"
#include "tests/rollback/test_support.h"

namespace lockroll::server::testing {

using rollback::testing::NetParams;
using rollback::testing::TestNet;
using rollback::testing::WalkBot;

struct RelayClient : rollback::SessionObserver {
    RelayClient(const sim::SceneDesc& scene, const rollback::RelaySessionConfig& cfg, ConnectionId conn,
                NetParams up, NetParams down, std::uint64_t seed)
        : sim(scene, cfg.players), session(std::make_unique<rollback::RelaySession>(cfg, sim, this)),
          connection(conn), up_net(up, seed * 2 + 1), down_net(down, seed * 2 + 2), bot(seed + 77) {
        // One bot per further local slot (several local players on one connection).
        for (std::size_t k = 1; k < session->local_slots().size(); ++k) also_bots.emplace_back(seed + 77 + 1000 * k);
    }

    void on_frame_confirmed(const rollback::FrameConfirmed& f) override { confirmed[f.frame] = f.checksum; }

    rollback::WorldSimulation sim;
    std::unique_ptr<rollback::RelaySession> session;
    ConnectionId connection;
    TestNet up_net, down_net;   // client -> server, server -> client
    WalkBot bot;
    std::vector<WalkBot> also_bots;  // the further local slots', in slot order
    std::map<std::uint32_t, std::uint64_t> confirmed;
    std::vector<rollback::SessionEvent> events;
    std::uint64_t next_tick_us = 0;
    std::uint64_t period_ppm = 1000000;  // clock rate of this client (1 % fast: 990000)
    std::uint64_t longest_stall_us = 0, last_advance_us = 0;
    bool alive = true;
    bool frozen = false;  // sends nothing, ticks nothing (a hung process)
    bool lies = false;    // a modified client: every checksum it reports is flipped on the way out
    bool deaf_to_forwards = false;  // gets no snapshot messages: a joiner whose load never starts
    int catch_ups = 0;
};

class RelayCluster {
public:
    RelayCluster(sim::SceneDesc scene, ServerConfig sc = {}) : scene_(std::move(scene)), server_(std::make_unique<RelayServer>(sc)) {}

    // Adds a client; returns its index. Connects at the current time.
    int add(rollback::RelaySessionConfig cfg, NetParams link, std::uint64_t seed) {
        cfg.room_id = cfg.room_id ? cfg.room_id : 42;
        const ConnectionId conn = next_conn_++;
        clients_.push_back(std::make_unique<RelayClient>(scene_, cfg, conn, link, link, seed));
        clients_.back()->next_tick_us = now_;
        server_->on_connect(conn, now_);
        return static_cast<int>(clients_.size()) - 1;
    }
    // The process dies: nothing more is sent or received; the server notices the silence.
    void kill(int i) { clients_[static_cast<std::size_t>(i)]->alive = false; }
    // The server process dies and nothing takes its place: it receives, sends and ticks no more.
    void kill_server() { server_alive_ = false; }
    // The server process dies and a new one starts at once with no rooms: every client's
    // transport reconnects (a new connection, datagrams in flight lost).
    void restart_server(ServerConfig sc = {}) {
        server_ = std::make_unique<RelayServer>(sc);
        kicked_.clear();
        for (auto& c : clients_) {
            const auto lost = [](rollback::PlayerId, rollback::PlayerId, const std::vector<std::uint8_t>&, std::uint64_t) {};
            c->up_net.deliver(UINT64_MAX, lost);
            c->down_net.deliver(UINT64_MAX, lost);
            c->connection = next_conn_++;
            server_->on_connect(c->connection, now_);
            if (c->alive) c->session->transport_reconnected(now_);
        }
    }

    RelayClient& client(int i) { return *clients_[static_cast<std::size_t>(i)]; }
    RelayServer& server() { return *server_; }
    std::uint64_t now() const { return now_; }

    void run_for(std::uint64_t us) {
        const std::uint64_t end = now_ + us;
        while (now_ < end) step_ms();
    }
    // Until every live client shows `frame` (bounded by limit_us of virtual time).
    bool run_until_frame(std::uint32_t frame, std::uint64_t limit_us = 120'000'000) {
        const std::uint64_t end = now_ + limit_us;
        while (now_ < end) {
            bool all = true;
            for (auto& c : clients_) {
                if (!c->alive || c->frozen) continue;
                if (c->session->phase() == rollback::SessionPhase::Failed) return false;
                if (c->session->frame() < frame) all = false;
            }
            if (all) return true;
            step_ms();
        }
        return false;
    }

    std::uint64_t kicked(ConnectionId c) const { return kicked_.count(c); }
    std::vector<ServerEvent> server_events;

private:
    void step_ms() {
        now_ += 1000;
        // Deliveries due now, both ways.
        for (auto& c : clients_) {
            RelayClient& cl = *c;
            cl.up_net.deliver(now_, [&](rollback::PlayerId, rollback::PlayerId, const std::vector<std::uint8_t>& b, std::uint64_t at) {
                if (cl.alive && server_alive_ && !kicked_.count(cl.connection)) server_->receive(cl.connection, b, at);
            });
            cl.down_net.deliver(now_, [&](rollback::PlayerId, rollback::PlayerId, const std::vector<std::uint8_t>& b, std::uint64_t at) {
                if (!cl.alive || cl.frozen) return;
                if (cl.deaf_to_forwards && rollback::peek_relay_kind(b) == rollback::RelayKind::Forward) return;
                cl.session->receive(b, at);
            });
        }
        if (server_alive_) {
            server_->tick(now_);
            flush_server();
        }
        for (auto& c : clients_) {
            RelayClient& cl = *c;
            if (!cl.alive || cl.frozen || now_ < cl.next_tick_us) continue;
            const auto first = cl.bot.next();
            in_.assign(first.begin(), first.end());
            for (auto& b : cl.also_bots) {
                const auto more = b.next();
                in_.insert(in_.end(), more.begin(), more.end());
            }
            const rollback::AdvanceResult r = cl.session->advance(in_, now_);
            if (cl.session->running()) {
                if (r.advanced) {
                    if (cl.last_advance_us) cl.longest_stall_us = std::max(cl.longest_stall_us, now_ - cl.last_advance_us);
                    cl.last_advance_us = now_;
                }
                if (cl.session->behind(now_) > 0) cl.catch_ups += cl.session->catch_up(now_, 8);
            }
            for (rollback::SessionEvent e; cl.session->next_event(e);) cl.events.push_back(e);
            out_.clear();
            cl.session->poll(now_, out_);
            for (auto& d : out_) {
                if (cl.lies) lie(cl, d.bytes);
                cl.up_net.send(0, 1, std::move(d.bytes), now_);
            }
            const std::uint64_t period = 1000000 / static_cast<std::uint64_t>(cl.session->config().tick_rate);
            const std::uint64_t stretched = period + period * static_cast<std::uint64_t>(r.tick_stretch_ppm) / 1000000;
            cl.next_tick_us += stretched * cl.period_ppm / 1000000;
            if (cl.next_tick_us <= now_) cl.next_tick_us = now_ + 1;
        }
    }
    // Rewrites an Input datagram with every checksum it reports flipped (its state stays honest).
    void lie(RelayClient& cl, std::vector<std::uint8_t>& bytes) {
        if (rollback::peek_relay_kind(bytes) != rollback::RelayKind::Input) return;
        const std::size_t input_size = cl.session->config().input_size;
        if (rollback::decode(bytes, input_size, lie_) != nullptr || lie_.checksum_count == 0) return;
        for (int i = 0; i < lie_.checksum_count; ++i) lie_.checksums[i] = ~lie_.checksums[i];
        bytes.clear();
        rollback::encode(lie_, input_size, bytes);
    }
    void flush_server() {
        sent_.clear();
        server_->take_outgoing(sent_);
        for (auto& o : sent_)
            for (auto& c : clients_)
                if (c->connection == o.to) c->down_net.send(1, 0, std::move(o.bytes), now_);
        for (ConnectionId k; server_->next_kick(k);) {
            kicked_[k] = now_;
            server_->on_disconnect(k, now_);
        }
        for (ServerEvent e; server_->next_event(e);) server_events.push_back(e);
    }

    sim::SceneDesc scene_;
    std::unique_ptr<RelayServer> server_;
    bool server_alive_ = true;
    std::vector<std::unique_ptr<RelayClient>> clients_;
    std::uint64_t now_ = 1'000'000;
    ConnectionId next_conn_ = 1;
    std::vector<rollback::Datagram> out_;
    std::vector<std::uint8_t> in_;  // a client's local input: 3 bytes per local slot
    std::vector<Outgoing> sent_;
    rollback::RelayInput lie_;
    std::map<ConnectionId, std::uint64_t> kicked_;
};

}  // namespace lockroll::server::testing
