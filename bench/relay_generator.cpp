#include "bench/relay_generator.h"

#include <enet/enet.h>
#include <sys/epoll.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <span>
#include <stdexcept>
#include <vector>

#include "rollback/relay_messages.h"

namespace lockroll::bench {

namespace {

using namespace lockroll::rollback;

constexpr std::uint32_t kRing = 1024;           // frames of send times kept per room
constexpr std::uint32_t kMaxResend = 8;         // unacknowledged own inputs carried per message
// A replaced input is the generator's own doing when it left 100 ms or more behind its tick (of
// the ~167 ms a bot's input has before the server's deadline: input delay 2 + deadline 8 ticks),
// or had not left at all when its frame was confirmed.
constexpr std::uint64_t kGeneratorLateUs = 100'000;

struct Client {
    ENetPeer* peer = nullptr;
    int room = 0;
    int slot = 0;
    bool welcomed = false;
    std::uint32_t input_ack = 0;        // the server's: next own input it needs
    std::uint32_t confirmed_next = 0;   // frames [0, this) received
    bool has_clock = false;
    bool connected = false;
    double clock_frame = 0;             // server_frame + subframe at clock_at_us
    std::uint64_t clock_at_us = 0;
};

struct Room {
    std::uint64_t id = 0;
    int host = 0;
    Client* c[kPlayers] = {};
    bool live = false;
    std::uint32_t first_frame = 0;      // first frame this room sent inputs for
    std::uint32_t next_frame = 0;       // next frame to send
    std::array<std::uint64_t, kRing> sent_us{};
    std::array<std::uint32_t, kRing> sent_frame{};  // frame + 1 held in each entry
    std::array<std::uint32_t, kRing> sent_late_us{};  // how far behind its tick the frame's first send fired
};

double percentile(std::vector<std::uint32_t>& v, double p) {
    if (v.empty()) return 0;
    const auto k = static_cast<std::size_t>(std::min<double>(static_cast<double>(v.size() - 1), std::floor(p * static_cast<double>(v.size()))));
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
    return v[k];
}

class Generator {
public:
    Generator(const Options& o, int rooms, const std::string& host, std::uint16_t port, std::uint64_t run_id, ReplacedLog& log,
              DelayLog& delay_log)
        : o_(o), log_(log), delay_log_(delay_log), rooms_(static_cast<std::size_t>(rooms)), clients_(static_cast<std::size_t>(rooms) * kPlayers) {
        const int hosts = std::max(1, std::min(o.hosts, rooms));
        std::vector<int> per_host(static_cast<std::size_t>(hosts), 0);
        for (int r = 0; r < rooms; ++r) per_host[static_cast<std::size_t>(r % hosts)] += kPlayers;
        for (int h = 0; h < hosts; ++h) {
            ENetHost* e = enet_host_create(nullptr, static_cast<std::size_t>(per_host[static_cast<std::size_t>(h)]), 2, 0, 0);
            if (!e) throw std::runtime_error("enet_host_create failed");
            e->duplicatePeers = ENET_PROTOCOL_MAXIMUM_PEER_ID;
            enet_socket_set_option(e->socket, ENET_SOCKOPT_RCVBUF, 1 << 20);
            hosts_.push_back(e);
        }
        if (enet_address_set_host(&address_, host.c_str()) != 0) throw std::runtime_error("cannot resolve " + host);
        address_.port = port;
        for (int r = 0; r < rooms; ++r) {
            Room& room = rooms_[static_cast<std::size_t>(r)];
            room.id = (run_id << 24) | static_cast<std::uint64_t>(r);
            room.host = r % hosts;
            for (int s = 0; s < kPlayers; ++s) {
                Client& c = clients_[static_cast<std::size_t>(r * kPlayers + s)];
                c.room = r;
                c.slot = s;
                room.c[s] = &c;
            }
        }
    }

    // Rooms connect at a bounded rate (a real fleet's matches do not all begin in one
    // millisecond, and a burst of thousands of handshakes measures the burst, not the relay).
    void connect_more(std::uint64_t now, std::uint64_t start) {
        const auto due = std::min<std::size_t>(rooms_.size(), static_cast<std::size_t>(static_cast<double>(now - start) / 1e6 * o_.ramp_rooms_per_s) + 1);
        for (; connected_rooms_ < due; ++connected_rooms_) {
            Room& room = rooms_[connected_rooms_];
            for (auto* c : room.c) {
                c->peer = enet_host_connect(hosts_[static_cast<std::size_t>(room.host)], &address_, 2, 0);
                if (!c->peer) throw std::runtime_error("enet_host_connect failed");
                c->peer->data = c;
            }
        }
    }
    ~Generator() {
        for (auto& c : clients_)
            if (c.peer) enet_peer_disconnect_now(c.peer, 0);
        for (auto* h : hosts_) {
            enet_host_flush(h);
            enet_host_destroy(h);
        }
    }

    // Runs until every room is live and warm, then measures for o.seconds.
    RunResult run(const ServerChild& server) {
        RunResult res;
        res.rooms = static_cast<int>(rooms_.size());
        const std::uint64_t start = now_us();
        const std::uint64_t ramp_limit = start + 30'000'000;
        const int hosts = static_cast<int>(hosts_.size());
        std::vector<std::uint64_t> next_fire(static_cast<std::size_t>(hosts));
        for (int h = 0; h < hosts; ++h) next_fire[static_cast<std::size_t>(h)] = start + kPeriodUs * static_cast<std::uint64_t>(h) / static_cast<std::uint64_t>(hosts);
        last_service_.assign(static_cast<std::size_t>(hosts), 0);
        // One epoll set over every host's socket: a wait costs what is ready, not what is
        // watched (ppoll over 64 sockets was a quarter of the generator's CPU at 500 rooms).
        const int ep = epoll_create1(EPOLL_CLOEXEC);
        if (ep < 0) throw std::runtime_error("epoll_create1 failed");
        struct EpollFd {
            int fd;
            ~EpollFd() { close(fd); }
        } ep_guard{ep};
        for (int h = 0; h < hosts; ++h) {
            epoll_event ev{};
            ev.events = EPOLLIN;
            ev.data.u32 = static_cast<std::uint32_t>(h);
            if (epoll_ctl(ep, EPOLL_CTL_ADD, static_cast<int>(hosts_[static_cast<std::size_t>(h)]->socket), &ev) != 0)
                throw std::runtime_error("epoll_ctl failed");
        }
        std::vector<epoll_event> ready_events(static_cast<std::size_t>(hosts));
        std::vector<char> readable(static_cast<std::size_t>(hosts), 0);
        std::uint64_t window_start = 0, window_end = 0;
        double cpu0 = 0, sys0 = 0, gen_cpu0 = 0, in0 = 0, out0 = 0, up0 = 0;
        std::uint64_t udp_sent0 = 0, udp_recv0 = 0;
        late_.clear();
        for (;;) {
            const std::uint64_t now = now_us();
            connect_more(now, start);
            // Ticks due: each host's rooms send their inputs, then one flush.
            for (int h = 0; h < hosts; ++h) {
                auto& nf = next_fire[static_cast<std::size_t>(h)];
                while (now >= nf) {
                    if (measuring_) {
                        late_.push_back(static_cast<std::uint32_t>(now - nf));
                        delay_log_.late(late_.back());
                    }
                    fire(h, now, now - nf);
                    nf += kPeriodUs;
                }
            }
            const int live = count_live();
            if (o_.verbose && now >= next_debug_) {
                next_debug_ = now + 1000000;
                int conn = 0, wel = 0, clk = 0;
                for (const auto& c : clients_) {
                    conn += c.connected;
                    wel += c.welcomed;
                    clk += c.has_clock;
                }
                std::fprintf(stderr, "t=%.1f connected %d welcomed %d clock %d live rooms %d disconnects %llu\n",
                             static_cast<double>(now - start) / 1e6, conn, wel, clk, live, static_cast<unsigned long long>(disconnects_));
            }
            if (!window_start && live == static_cast<int>(rooms_.size())) {
                if (!warm_at_) warm_at_ = now + static_cast<std::uint64_t>(o_.warmup * 1e6);
                if (now >= warm_at_) {
                    window_start = now;
                    window_end = now + static_cast<std::uint64_t>(o_.seconds * 1e6);
                    measuring_ = true;
                    cpu0 = server.pid ? process_cpu_s(server.pid, &sys0) : 0;
                    gen_cpu0 = process_cpu_s(getpid());
                    in0 = status_number(server.status_file, "datagrams_in");
                    out0 = status_number(server.status_file, "datagrams_out");
                    up0 = status_number(server.status_file, "uptime_s");
                    udp_sent0 = udp_sent();
                    udp_recv0 = udp_received();
                }
            }
            if (!window_start && now > ramp_limit) {
                res.rooms_live = live;
                std::fprintf(stderr, "relay_bench: only %d of %zu rooms started within 30 s\n", live, rooms_.size());
                return res;
            }
            if (window_start && now >= window_end) {
                const double wall = static_cast<double>(now - window_start) / 1e6;
                res.rooms_live = live;
                double sys1 = 0;
                res.server_cpu = server.pid ? (process_cpu_s(server.pid, &sys1) - cpu0) / wall : 0;
                res.server_sys = server.pid ? (sys1 - sys0) / wall : 0;
                res.server_rss_mib = server.pid ? rss_mib(server.pid) : 0;
                res.client_cpu = (process_cpu_s(getpid()) - gen_cpu0) / wall;
                // The status file is rewritten every second: rates over its own uptime.
                const double up1 = status_number(server.status_file, "uptime_s");
                if (up0 >= 0 && up1 > up0) {
                    res.relay_in_per_s = (status_number(server.status_file, "datagrams_in") - in0) / (up1 - up0);
                    res.relay_out_per_s = (status_number(server.status_file, "datagrams_out") - out0) / (up1 - up0);
                }
                res.udp_in_per_s = static_cast<double>(udp_sent() - udp_sent0) / wall;
                res.udp_out_per_s = static_cast<double>(udp_received() - udp_recv0) / wall;
                res.samples = delays_.size();
                res.p50_us = percentile(delays_, 0.50);
                res.p99_us = percentile(delays_, 0.99);
                res.max_us = delays_.empty() ? 0 : *std::max_element(delays_.begin(), delays_.end());
                res.replaced = replaced_;
                res.unsent = unsent_;
                res.late_p99_us = percentile(late_, 0.99);
                res.late_max_us = late_.empty() ? 0 : *std::max_element(late_.begin(), late_.end());
                res.loadavg = loadavg();
                res.disconnects = disconnects_;
                res.sustained = res.rooms_live == res.rooms && res.disconnects == 0 && res.samples > 0 && res.p99_us <= o_.goal_us &&
                                res.replaced == 0 && res.unsent == 0;
                return res;
            }
            // Wait for traffic until the next tick is due.
            std::uint64_t wake = *std::min_element(next_fire.begin(), next_fire.end());
            const std::uint64_t t = now_us();
            {
                const std::uint64_t wait_us = wake > t ? std::min<std::uint64_t>(wake - t, 999'999) : 0;
                const timespec ts{0, static_cast<long>(wait_us * 1000)};
                std::fill(readable.begin(), readable.end(), 0);
                const int n = epoll_pwait2(ep, ready_events.data(), hosts, &ts, nullptr);
                for (int i = 0; i < n; ++i) readable[ready_events[static_cast<std::size_t>(i)].data.u32] = 1;
            }
            // Readable hosts are serviced at once, the others every few milliseconds (ENet's own
            // timers: connects, pings, acks).
            const std::uint64_t t2 = now_us();
            for (int h = 0; h < hosts; ++h) {
                auto& last = last_service_[static_cast<std::size_t>(h)];
                if (readable[static_cast<std::size_t>(h)] || t2 - last >= 5000) {
                    last = t2;
                    service(h);
                }
            }
        }
    }

private:
    int count_live() const {
        int n = 0;
        for (const auto& r : rooms_) n += r.live ? 1 : 0;
        return n;
    }
    std::uint64_t udp_sent() const {
        std::uint64_t n = 0;
        for (auto* h : hosts_) n += h->totalSentPackets;
        return n;
    }
    std::uint64_t udp_received() const {
        std::uint64_t n = 0;
        for (auto* h : hosts_) n += h->totalReceivedPackets;
        return n;
    }

    void send_hello(Client& c) {
        RelayHello h;
        h.room_id = rooms_[static_cast<std::size_t>(c.room)].id;
        h.scene_checksum = 0x5EED;
        h.players = kPlayers;
        h.input_size = kInputSize;
        h.tick_rate = kTickRate;
        h.slot = static_cast<std::uint8_t>(c.slot);
        h.stamp_us = now_us();
        bytes_.clear();
        encode(h, bytes_);
        enet_peer_send(c.peer, 1, enet_packet_create(bytes_.data(), bytes_.size(), ENET_PACKET_FLAG_RELIABLE));
    }

    // A bot's input: a slow, deterministic pattern (a held direction changes every 30 frames).
    static void bot_input(int room, int slot, std::uint32_t frame, std::uint8_t* out) {
        const std::uint32_t phase = (frame / 30 + static_cast<std::uint32_t>(room * 7 + slot * 3)) % 9;
        out[0] = static_cast<std::uint8_t>(static_cast<int>(phase % 3) - 1);
        out[1] = static_cast<std::uint8_t>(static_cast<int>(phase / 3) - 1);
        out[2] = 0;
    }

    // Queues one RelayInput: the client's own inputs for [first, first + count) (none: a
    // heartbeat) and its acknowledgement.
    void send_input(Client& c, std::uint32_t first, std::uint32_t count, std::uint64_t now) {
        RelayInput& m = input_;
        m.confirmed_ack = c.confirmed_next;
        m.first_frame = first;
        m.frame_count = static_cast<std::uint8_t>(count);
        m.slots = static_cast<std::uint16_t>(1u << c.slot);
        m.inputs.resize(count * kInputSize);
        for (std::uint32_t i = 0; i < count; ++i) bot_input(c.room, c.slot, first + i, &m.inputs[i * kInputSize]);
        m.stamp = static_cast<std::uint16_t>(now / 100);
        m.checksum_count = 0;
        bytes_.clear();
        encode(m, kInputSize, bytes_);
        enet_peer_send(c.peer, 0, enet_packet_create(bytes_.data(), bytes_.size(), ENET_PACKET_FLAG_UNSEQUENCED));
    }

    void fire(int h, std::uint64_t now, std::uint64_t late_us) {
        bool queued = false;
        for (std::size_t r = static_cast<std::size_t>(h); r < rooms_.size(); r += hosts_.size()) {
            Room& room = rooms_[r];
            bool ready = true;
            for (auto* c : room.c) ready = ready && c->peer && c->welcomed && c->has_clock;
            if (!ready) {
                // Waiting for the partner or the first Frames: a welcomed client still says
                // something every tick, as a real one would, or the room drops it as silent.
                for (auto* c : room.c)
                    if (c->peer && c->welcomed) {
                        send_input(*c, 0, 0, now);
                        queued = true;
                    }
                continue;
            }
            if (!room.live) {
                // Join the room clock: the first input is for the frame the clock reaches
                // input_delay frames from now.
                const Client& c = *room.c[0];
                const double clock = c.clock_frame + static_cast<double>(now - c.clock_at_us) / static_cast<double>(kPeriodUs);
                room.first_frame = static_cast<std::uint32_t>(std::ceil(clock)) + static_cast<std::uint32_t>(o_.input_delay);
                room.next_frame = room.first_frame;
                room.live = true;
            }
            const std::uint32_t f = room.next_frame++;
            for (auto* c : room.c) {
                const std::uint32_t first = std::min(f, std::max({c->input_ack, room.first_frame, f + 1 - std::min(f + 1, kMaxResend)}));
                send_input(*c, first, f + 1 - first, now);
                queued = true;
            }
            room.sent_frame[f % kRing] = f + 1;
            room.sent_us[f % kRing] = 0;  // stamped at the flush below
            room.sent_late_us[f % kRing] = static_cast<std::uint32_t>(std::min<std::uint64_t>(late_us, 0xFFFFFFFF));
        }
        if (!queued) return;
        const std::uint64_t t = now_us();
        for (std::size_t r = static_cast<std::size_t>(h); r < rooms_.size(); r += hosts_.size()) {
            Room& room = rooms_[r];
            if (room.live) {
                const std::uint32_t f = room.next_frame - 1;
                if (room.sent_frame[f % kRing] == f + 1 && room.sent_us[f % kRing] == 0) room.sent_us[f % kRing] = t;
            }
        }
        (void)now;
        enet_host_flush(hosts_[static_cast<std::size_t>(h)]);
    }

    void on_frames(Client& c, std::span<const std::uint8_t> d, std::uint64_t at) {
        if (decode(d, kPlayers, kInputSize, frames_) != nullptr) {
            ++bad_;
            return;
        }
        c.input_ack = std::max(c.input_ack, frames_.input_ack);
        c.clock_frame = frames_.server_frame + frames_.server_subframe / 65536.0;
        c.clock_at_us = at;
        c.has_clock = true;
        Room& room = rooms_[static_cast<std::size_t>(c.room)];
        const std::uint32_t end = frames_.first_frame + frames_.frame_count;
        for (std::uint32_t f = std::max(c.confirmed_next, frames_.first_frame); f < end; ++f) {
            if (!measuring_ || !room.live || f < room.first_frame) continue;
            const std::uint32_t i = f - frames_.first_frame;
            const bool unsent = room.sent_frame[f % kRing] != f + 1 || room.sent_us[f % kRing] == 0;
            if (c.slot == 0)
                for (int p = 0; p < kPlayers; ++p)
                    if (frames_.flags[i * kPlayers + static_cast<std::uint32_t>(p)] & kRelayReplaced) {
                        ++replaced_;
                        log_.note(c.room, p, unsent || room.sent_late_us[f % kRing] >= kGeneratorLateUs);
                    }
            if (unsent) {
                if (c.slot == 0) ++unsent_;
                continue;
            }
            delays_.push_back(static_cast<std::uint32_t>(std::min<std::uint64_t>(at - room.sent_us[f % kRing], 0xFFFFFFFF)));
            delay_log_.delay(delays_.back());
        }
        // Frames arrive in order on loopback; a gap (a lost datagram) is re-sent by the server
        // from our acknowledgement on.
        if (frames_.first_frame <= c.confirmed_next) c.confirmed_next = std::max(c.confirmed_next, end);
    }

    void service(int h) {
        ENetEvent e;
        while (enet_host_service(hosts_[static_cast<std::size_t>(h)], &e, 0) > 0) {
            Client* c = e.peer ? static_cast<Client*>(e.peer->data) : nullptr;
            if (!c) {
                if (e.packet) enet_packet_destroy(e.packet);
                continue;
            }
            switch (e.type) {
                case ENET_EVENT_TYPE_CONNECT:
                    enet_peer_throttle_configure(e.peer, ENET_PEER_PACKET_THROTTLE_INTERVAL, ENET_PEER_PACKET_THROTTLE_ACCELERATION, 0);
                    c->connected = true;
                    send_hello(*c);
                    break;
                case ENET_EVENT_TYPE_DISCONNECT:
                    ++disconnects_;
                    c->peer = nullptr;
                    break;
                case ENET_EVENT_TYPE_RECEIVE: {
                    const std::uint64_t at = now_us();
                    const std::span<const std::uint8_t> d(e.packet->data, e.packet->dataLength);
                    const auto kind = peek_relay_kind(d);
                    if (kind == RelayKind::Frames) on_frames(*c, d, at);
                    else if (kind == RelayKind::Welcome) {
                        if (decode(d, welcome_) == nullptr && welcome_.refusal == RelayRefusal::None) c->welcomed = true;
                        else
                            std::fprintf(stderr, "relay_bench: room %d slot %d refused: %s\n", c->room, c->slot,
                                         relay_refusal_name(welcome_.refusal));
                    }
                    enet_packet_destroy(e.packet);
                    break;
                }
                default: break;
            }
        }
    }

    const Options& o_;
    ReplacedLog& log_;
    DelayLog& delay_log_;
    ENetAddress address_{};
    std::size_t connected_rooms_ = 0;
    std::vector<Room> rooms_;
    std::vector<Client> clients_;
    std::vector<ENetHost*> hosts_;
    std::vector<std::uint8_t> bytes_;
    RelayInput input_;
    RelayFrames frames_;
    RelayWelcome welcome_;
    std::vector<std::uint32_t> delays_, late_;
    std::vector<std::uint64_t> last_service_;
    std::uint64_t replaced_ = 0, unsent_ = 0, bad_ = 0, disconnects_ = 0, warm_at_ = 0;
    bool measuring_ = false;
    std::uint64_t next_debug_ = 0;
};

}  // namespace

RunResult run_generator(const Options& o, int rooms, const std::string& host, std::uint16_t port, std::uint64_t run_id,
                        ReplacedLog& log, DelayLog& delay_log, const ServerChild& server) {
    Generator g(o, rooms, host, port, run_id, log, delay_log);
    return g.run(server);
}

}  // namespace lockroll::bench
