// The Transport interface over real UDP, through ENet, fit for hostile networks: one ENet host
// per local peer, one ENet connection per remote peer.
//
// Channels: inputs travel on channel 0 as unreliable *unsequenced* packets (no ordering, no
// retransmission, no head-of-line blocking: the session resends inputs itself); send_reliable()
// uses channel 1, reliable and ordered, for control messages and snapshot chunks. Both are
// limited to kMaxDatagramBytes per send.
//
// Peer ids travel in ENet's connect data. Either side may connect. For each remote id one
// connection holds the id, with at most one provisional claimant beside it (below):
//  - crossed connects (both sides connect at once) keep the connection initiated by the lower id,
//    on both sides, whatever order the handshakes finish in (the higher id sees its own closed
//    as Disconnected; a restarted higher id whose old connection still looks alive retries);
//  - a connection claiming an id whose current connection is silent (no datagram, ping or
//    acknowledgement for EnetConfig::silent_after_us of the caller's time) is admitted as that
//    id's claimant, provisionally: the silent connection stays open. Datagrams from both are
//    delivered as from the id, and sends to the id go to both. If the silent connection is
//    heard again, the claim is void: it keeps the id and the claimant is closed ("id held by a
//    live connection", claims_voided). If it stays silent until dead_after_us ends it (or its
//    peer closes it), the claimant holds the id from then on (replaced). So a killed and
//    restarted process is heard at once, without waiting for any timeout, and an outsider that
//    claims an id during a loss burst of the honest process never cuts its connection: a claim
//    never ends a connection sooner than its silence would (issue 21; the session weighs the
//    claimant's hello itself, docs/sessions.md "A restart is a claim");
//  - any other claim to a held id (live, or silent with a live claimant already), or to our own
//    id, is refused and counted.
// Ids are not authenticated: this is for experiments among cooperating processes.
//
// Host limits (each against a demonstrated attack; see docs/network-model.md):
//  - at most max_connections_per_address connections (half-open included) from one IP address,
//    so a flood of connection requests from one address leaves slots for real peers; half-open
//    connections time out in seconds (timeout_*_ms, not ENet's 30 s), established ones after
//    dead_after_us of silence (first_word_after_us for ours that never heard a word);
//  - ENet's maximumPacketSize / maximumWaitingData are set to max_packet_bytes (4 KB) and
//    max_waiting_bytes (256 KB per connection), so no client can make us reassemble megabytes;
//  - poll() drains every event ENet has, keeps going past receive errors (a UDP datagram over
//    ENet's 4 KB buffer makes enet_host_service return an error with the rest unread) and is
//    bounded per call; the inbox of undelivered datagrams is bounded too.
//
// Time: ENet keeps its own millisecond clock for its protocol (handshake, pings, retransmission,
// timeouts): that is ENet's business. This wrapper never reads a clock: it takes `now` from the
// caller to stamp datagrams and to judge silence. It never blocks (service timeout 0).
//
// Not thread-safe; one EnetTransport per thread. Not copyable or movable.
#pragma once

#include <cstdint>
#include <deque>
#include <map>
#include <string>
#include <unordered_map>
#include <vector>

#include <lockroll/transport/transport.h>

struct _ENetHost;
struct _ENetPeer;
struct _ENetEvent;

namespace lockroll::transport {

struct EnetConfig {
    PeerId local_id = 0;
    std::string bind_host = "127.0.0.1";  // address to listen on ("0.0.0.0" for every interface)
    std::uint16_t port = 0;               // 0: an ephemeral port chosen by the OS (see port())
    std::size_t max_peers = 64;           // ENet connection slots, incoming and outgoing
    // Connections (half-open included) one IP address may hold; a flood from one address leaves
    // the other max_peers minus this slots free. All peers of a match on one machine share
    // 127.0.0.1 (and a restarted peer's dead connection counts until it times out, dead_after_us):
    // 16 covers 16 players on one machine. Keep max_peers well above it.
    std::size_t max_connections_per_address = 16;
    // A connection silent this long (caller's time) may be claimed by a new connection for its
    // id: the claimant is admitted beside it and takes the id over only if it stays silent
    // until dead_after_us (see the header).
    Micros silent_after_us = 1'000'000;
    // An established connection from which nothing (datagram, ping, acknowledgement) was heard
    // for this long (caller's time) is closed as timed out (Disconnected). This, not ENet's own
    // timeout, ends established connections: ENet's retransmission time doubles after each loss
    // and it gives up after a few, so under 30 % loss it closed live connections every few
    // seconds (one ping and its ack both get through only half the time).
    Micros dead_after_us = 5'000'000;
    // A connection we initiated that has been silent ever since it was established is closed
    // after this long instead (0: only dead_after_us), so the caller connects again: the other
    // side may never have received our last handshake acknowledgement and given up (3 lost in a
    // row, 1 connect in 8 at 30 % loss), and nothing it sends will then reach us. A live peer's
    // session says hello every 50 ms at the start; an idle link hears ENet's ping answered.
    Micros first_word_after_us = 2'000'000;
    // ENet's timeouts for slots not yet established (enet_peer_timeout): half-open and
    // connecting slots are dropped once a reliable command (the handshake) goes unacknowledged
    // past timeout_max_ms, or past timeout_min_ms after timeout_limit retries. ENet's defaults
    // are 32 / 5000 / 30000. Established connections get ENet timeouts it never reaches (see
    // dead_after_us).
    std::uint32_t timeout_limit = 4;
    std::uint32_t timeout_min_ms = 2'000;
    std::uint32_t timeout_max_ms = 5'000;
    // Largest packet ENet accepts or reassembles (ENetHost::maximumPacketSize; default 32 MB).
    std::size_t max_packet_bytes = 4'096;
    // Bytes one connection may have waiting in ENet: out-of-order reliable packets and fragments
    // (ENetHost::maximumWaitingData; default 32 MB). Reliable data beyond it is lost.
    std::size_t max_waiting_bytes = 256 * 1024;
    std::size_t max_inbox = 4'096;   // received datagrams not yet taken by receive()
    std::size_t max_events = 256;    // connection events not yet taken by next_event()
};

// Everything EnetTransport refused or dropped, by cause. Each also counts in
// TransportCounters::rejected, except crossed connects, claims, replacements and disconnects.
struct EnetCounters {
    std::uint64_t refused_own_id = 0;          // a connection claimed our own id
    std::uint64_t refused_duplicate_id = 0;    // a connection claimed an id held by a live one
    std::uint64_t refused_address_limit = 0;   // connect request over max_connections_per_address
    std::uint64_t refused_no_slot = 0;         // connect request with every slot taken
    std::uint64_t crossed_connects = 0;        // crossed connects resolved (not counted as rejected)
    std::uint64_t replace_claims = 0;          // connections admitted as claimants of a silent id
                                               // (not counted as rejected)
    std::uint64_t claims_voided = 0;           // claimants closed: the connection they claimed
                                               // was heard again
    std::uint64_t replaced = 0;                // silent connections taken over by their claimant
                                               // (not counted as rejected)
    std::uint64_t disconnects = 0;             // connections lost (timeouts, closed by the peer)
    std::uint64_t dropped_unknown_peer = 0;    // datagrams on a connection without an id
    std::uint64_t dropped_oversized = 0;       // datagrams over kMaxDatagramBytes or sends too large
    std::uint64_t dropped_bad_channel = 0;     // datagrams on a channel we do not use
    std::uint64_t dropped_inbox_full = 0;      // datagrams dropped because receive() fell behind
    std::uint64_t dropped_events = 0;          // events dropped because next_event() fell behind
    std::uint64_t dropped_stale_verify = 0;    // server answers (VERIFY_CONNECT) to a connect of ours given
                                               // up, ignored: they would end the slot's next connect
    std::uint64_t receive_errors = 0;          // enet_host_service errors: UDP datagrams over ENet's
                                               // 4 KB buffer, ICMP errors; all skipped
};

class EnetTransport final : public Transport {
public:
    // Throws std::runtime_error naming host:port when ENet cannot initialise or bind, and
    // std::invalid_argument for limits that cannot work (0 slots, max_packet_bytes below
    // kMaxDatagramBytes).
    explicit EnetTransport(const EnetConfig& config);
    ~EnetTransport() override;
    EnetTransport(const EnetTransport&) = delete;
    EnetTransport& operator=(const EnetTransport&) = delete;

    // The UDP port actually bound (the ephemeral one when config.port was 0).
    std::uint16_t port() const { return port_; }

    // Starts connecting to the peer `remote` listening at host:port. Returns false, with a
    // reason in *error if given, when the id is ours, a live connection for it exists (a silent
    // one gets the new one as its claimant, as above), the host does not resolve, or no
    // connection slot is free. The
    // connection completes during later poll() or receive() calls; is_connected() and a
    // Connected event tell when.
    bool connect(PeerId remote, const std::string& host, std::uint16_t port, std::string* error = nullptr) override;
    bool is_connected(PeerId remote) const override;
    std::vector<PeerId> connected_peers() const;

    // Lets ENet send and receive without blocking: completes handshakes, answers pings, queues
    // arrived datagrams (stamped with `now`) and events. receive() calls it when its queue is
    // empty; call it every tick anyway.
    void poll(Micros now) override;

    PeerId local_id() const override { return local_id_; }
    // Unreliable unsequenced, channel 0. Sends at once (flushes the host): one send, one datagram.
    bool send(PeerId to, std::span<const std::uint8_t> bytes, Micros now) override;
    // Reliable and ordered, channel 1; flushed at once, retransmitted by ENet until acknowledged.
    bool send_reliable(PeerId to, std::span<const std::uint8_t> bytes, Micros now) override;
    bool receive(Datagram& out, Micros now) override;
    const TransportCounters& counters() const override { return counters_; }
    bool next_event(TransportEvent& out) override;

    const EnetCounters& enet_counters() const { return enet_counters_; }

    // UDP payload bytes this host sent / received: our datagrams plus ENet's own headers,
    // handshakes, acknowledgements and pings (ENetHost::totalSentData / totalReceivedData).
    // Add kUdpIpv4HeaderBytes per datagram for IP-level figures.
    std::uint64_t wire_bytes_sent() const;
    std::uint64_t wire_bytes_received() const;

    // ENet service errors seen by poll() (same as enet_counters().receive_errors).
    std::uint64_t service_errors() const { return enet_counters_.receive_errors; }

    // Called by ENet for every UDP datagram it receives, before it parses it (ENetHost::intercept);
    // public only so the callback can reach it. Counts and swallows connect requests the host
    // limits refuse, and answers to connects of ours given up (dropped_stale_verify). Returns 1
    // to swallow, 0 to let ENet handle the datagram.
    int intercept(_ENetHost* host);

private:
    struct Connection {
        _ENetPeer* peer = nullptr;
        bool established = false;
        bool outgoing = false;             // we initiated it
        Micros last_heard_us = 0;          // caller's time when ENet last heard from it
        std::uint32_t enet_last_receive = 0;  // ENet's lastReceiveTime when we last looked
        bool heard_since_up = false;       // anything heard since it was established
        Micros up_us = 0;                  // caller's time when our connect completed
        Micros claimed_us = 0;             // a claimant: caller's time its claim began
    };

    void handle(const _ENetEvent& event, Micros now);
    void handle_connect(const _ENetEvent& event, Micros now);
    void refuse(_ENetPeer* peer, std::uint32_t code);
    // Closes and forgets the connection `from` holds for `id`; no event.
    void drop_connection(std::map<PeerId, Connection>& from, PeerId id, std::uint32_t code);
    // The connection holding `id` (in by_id_) is gone: closed with `close_code` and forgotten.
    // Its claimant, if one stands, takes the id over; otherwise a Disconnected event (`why`).
    void held_gone(PeerId id, std::uint32_t close_code, std::string why);
    // The connection (held or claimant) on an ENet peer, with its id; nullptr for none.
    Connection* connection_of(_ENetPeer* peer, PeerId* id, bool* claimant = nullptr);
    bool silent(const Connection& c) const;
    void push_event(TransportEvent::Type type, PeerId peer, std::string reason);
    bool send_on(PeerId to, std::span<const std::uint8_t> bytes, bool reliable);

    EnetConfig config_;
    PeerId local_id_;
    _ENetHost* host_ = nullptr;
    std::uint16_t port_ = 0;
    Micros last_now_ = 0;
    std::map<PeerId, Connection> by_id_;      // the connection holding each id
    std::map<PeerId, Connection> claimants_;  // a new connection claiming a silent held id
    std::unordered_map<_ENetPeer*, PeerId> by_peer_;
    std::deque<Datagram> inbox_;
    std::deque<TransportEvent> events_;
    TransportCounters counters_;
    EnetCounters enet_counters_;
};

}  // namespace lockroll::transport
