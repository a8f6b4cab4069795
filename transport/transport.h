// A datagram transport with time passed in: the one interface sessions and the real-time runners
// (net/peer_runner.h, net/relay_runner.h) use to move bytes, so the same code runs over the
// in-process simulated network (virtual time, reproducible), over real UDP (ENet, the default),
// and over a game's own transport (Steam networking sockets, WebRTC data channels, plain UDP:
// docs/guide.md maps them; examples/counter/udp_socket_transport.h is one over plain UDP).
//
// Contract
//  - Peers and connections: a peer is a value id (the session's slot or spectator id). The
//    runner tells the transport where a peer is only through connect(id, host, port), whose
//    host and port mean whatever the transport's addressing is (ENet and UDP: a host and a UDP
//    port; Steam: a SteamID as text and a virtual port; WebRTC: a signalling id). The runner
//    calls connect() for a peer it is not connected to for the whole run (so a restarted peer
//    is reached again), backing off from every half second to every 4 s while it stays away
//    (net/redial_backoff.h), and only from one side of each pair (the lower id; a
//    spectator to everyone): the other side learns the peer from its incoming connection. A
//    transport reports a connection that comes up (either side's) as a Connected event and
//    is_connected() true; one that goes away as Disconnected. A connectionless transport keeps
//    the defaults: every peer reachable, connect() false, no events.
//  - Identity: a received datagram's `from` is the id the transport bound to its connection or
//    sender (ENet: the id claimed at connect, one connection per id, and beside a silent one a
//    provisional claimant's that gives way if the old one speaks again), never a field a
//    datagram may set freely on each send.
//  - poll(now) is called on every runner wake-up (about every millisecond under run(), once per
//    NetSession::update() in a game's loop): a transport with a handshake, keep-alives or
//    acknowledgements does that work there. It never blocks.
//  - Unreliable datagrams: a send may be lost, duplicated or reordered; a datagram that arrives
//    arrives whole. Reliability (resending inputs until acknowledged) is the session's job.
//    send_reliable() asks for more where the transport has it (ENet: a reliable, ordered
//    channel for control messages and snapshot chunks); by default it is plain send(), so a
//    session must still cope with its loss (re-request what it misses).
//  - Time is a uint64 count of microseconds supplied by the caller. A Transport never reads the
//    wall clock to decide anything; its only randomness is a private generator seeded explicitly.
//  - Peers are named by value ids (PeerId), never by pointers or addresses.
//  - Input from the network never asserts or throws: malformed or unexpected traffic is dropped
//    and counted. Programming errors in configuration throw std::invalid_argument.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace lockroll::transport {

using PeerId = std::uint32_t;
using Micros = std::uint64_t;

// Every transport accepts datagrams up to this size: one datagram then fits a 1280-byte IPv6
// minimum MTU (and any Ethernet path) after IP, UDP and ENet headers, so nothing fragments.
inline constexpr std::size_t kMaxDatagramBytes = 1200;

struct Datagram {
    PeerId from = 0;
    // When the datagram became deliverable: the simulated network's scheduled arrival time, or
    // for real transports the `now` of the receive call that first saw it.
    Micros time_us = 0;
    std::vector<std::uint8_t> bytes;
    // Sent with send_reliable() over a transport that has a reliable channel.
    bool reliable = false;
};

// A change in a connection-oriented transport's peers, for the runner to log or act on.
struct TransportEvent {
    enum class Type : std::uint8_t {
        Connected,     // `peer` is reachable (first time, or a new connection claims or took over
                       // a silent one's id)
        Disconnected,  // `peer` has no connection any more (timed out, closed, refused by it)
        Refused,       // an incoming connection claiming `peer` was refused
    };
    Type type = Type::Connected;
    PeerId peer = 0;
    std::string reason;
};

// Monotonic counters since the transport was created. "sent" counts datagrams the transport
// accepted (a lost one still counts as sent: it left the sender).
struct TransportCounters {
    std::uint64_t datagrams_sent = 0;
    std::uint64_t bytes_sent = 0;         // payload bytes only; see docs/network-model.md for headers
    std::uint64_t datagrams_received = 0;
    std::uint64_t bytes_received = 0;
    std::uint64_t dropped = 0;            // accepted sends that never reached the wire or were lost
    std::uint64_t duplicated = 0;         // extra copies the network made of this endpoint's sends
    std::uint64_t rejected = 0;           // refused sends (unknown peer, too large) + bad traffic
};

class Transport {
public:
    virtual ~Transport() = default;

    virtual PeerId local_id() const = 0;

    // Queues one datagram for `to`. Returns false (and counts `rejected`) when the transport
    // cannot even try: unknown or unconnected peer, the local id itself, or more than
    // kMaxDatagramBytes. true does not mean it will arrive.
    virtual bool send(PeerId to, std::span<const std::uint8_t> bytes, Micros now) = 0;

    // Like send(), but delivered reliably and in order (among reliable sends to the same peer)
    // where the transport can; the same size limit. Default: send() (SimNetwork keeps it: the
    // session's own protocol re-requests what is lost).
    virtual bool send_reliable(PeerId to, std::span<const std::uint8_t> bytes, Micros now) {
        return send(to, bytes, now);
    }

    // Moves the next datagram deliverable by `now` into `out` (reusing out.bytes' capacity) and
    // returns true; false when nothing is deliverable yet. Call until false each tick.
    virtual bool receive(Datagram& out, Micros now) = 0;

    virtual const TransportCounters& counters() const = 0;

    // Moves the oldest connection event into `out`; false when there is none. Transports
    // without connections (SimNetwork) never have any.
    virtual bool next_event(TransportEvent& /*out*/) { return false; }

    // Starts reaching peer `remote` at host:port (see the contract). Returns false, with a
    // reason in *error if given, when it cannot even try: our own id, a connection for it exists
    // or is pending, an address the transport cannot use, no room. The connection completes
    // later (a Connected event). Default, for connectionless transports: false.
    virtual bool connect(PeerId /*remote*/, const std::string& /*host*/, std::uint16_t /*port*/,
                         std::string* /*error*/ = nullptr) {
        return false;
    }
    // Whether `remote` can be sent to now. Default (connectionless): true.
    virtual bool is_connected(PeerId /*remote*/) const { return true; }
    // Does the transport's own work without blocking (handshakes, keep-alives, queuing
    // arrivals stamped with `now`). Default: nothing to do.
    virtual void poll(Micros /*now*/) {}
};

}  // namespace lockroll::transport
