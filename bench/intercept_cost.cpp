// intercept_cost: what the client's stale-verify rule (transport/enet_stale_verify.h, run by
// EnetTransport's ENet intercept on every datagram its host receives) costs per received
// datagram, countable with callgrind on a busy machine.
//
// Two raw ENet hosts on 127.0.0.1, connected; the server sends --datagrams datagrams of
// --commands unsequenced packets each (one flush a datagram), in batches of --batch, and the
// client receives each batch with enet_host_service. The client host's intercept is --intercept:
//   none          no intercept (ENet parses every datagram itself)
//   empty         a callback that returns 0 (what installing any intercept costs: ENet's call)
//   stale-verify  a callback that drops a stale VERIFY_CONNECT (is_stale_verify_connect), as
//                 EnetTransport::intercept does first
// so stale-verify minus empty is the rule's own cost, stale-verify minus none the whole of it.
// Count only the client's receiving:
//
//   valgrind --tool=callgrind --toggle-collect='*intercept_cost_receive*' build/bench/intercept_cost --intercept stale-verify
//
// and divide the instructions by the datagrams received it prints (ENet's totalReceivedPackets).
// Kernel time (recvfrom) is not in the count. Wall time is not printed: the count is the figure.
#include <CLI/CLI.hpp>
#include <enet/enet.h>

#include <cstdio>
#include <stdexcept>
#include <string>
#include <vector>

#include "transport/enet_stale_verify.h"

namespace {

std::uint64_t g_stale = 0;  // datagrams the stale-verify callback dropped (none expected here)

int ENET_CALLBACK empty_intercept(ENetHost*, ENetEvent*) { return 0; }

int ENET_CALLBACK stale_verify_intercept(ENetHost* host, ENetEvent*) {
    if (lockroll::transport::is_stale_verify_connect(host)) {
        ++g_stale;
        return 1;
    }
    return 0;
}

// The measured region (callgrind --toggle-collect): the client host takes what has arrived.
// Returns the packets it delivered.
[[gnu::noinline]] std::uint64_t intercept_cost_receive(ENetHost* client) {
    std::uint64_t packets = 0;
    ENetEvent event;
    while (enet_host_service(client, &event, 0) > 0) {
        if (event.type == ENET_EVENT_TYPE_RECEIVE) {
            ++packets;
            enet_packet_destroy(event.packet);
        }
    }
    return packets;
}

void connect(ENetHost* server, ENetHost* client, ENetPeer* to_server) {
    bool server_up = false, client_up = false;
    for (int i = 0; i < 2000 && !(server_up && client_up); ++i) {
        ENetEvent e;
        while (enet_host_service(server, &e, 1) > 0)
            if (e.type == ENET_EVENT_TYPE_CONNECT) server_up = true;
        while (enet_host_service(client, &e, 1) > 0)
            if (e.type == ENET_EVENT_TYPE_CONNECT && e.peer == to_server) client_up = true;
    }
    if (!(server_up && client_up)) throw std::runtime_error("the hosts did not connect on 127.0.0.1");
}

// Sends and receives; returns 0 when every packet arrived, 1 otherwise. Throws
// std::runtime_error naming what when ENet cannot start, bind or connect.
int run(const std::string& intercept, int datagrams, int commands, int batch, int bytes);

}  // namespace

int main(int argc, char** argv) {
    CLI::App app{"intercept_cost: the client's ENet intercept per received datagram (for callgrind)"};
    std::string intercept = "stale-verify";
    int datagrams = 20'000;
    int commands = 1;
    int batch = 50;
    int bytes = 24;
    app.add_option("--intercept", intercept, "none, empty or stale-verify")->check(CLI::IsMember({"none", "empty", "stale-verify"}));
    app.add_option("--datagrams", datagrams, "Datagrams the server sends")->check(CLI::Range(1, 10'000'000));
    app.add_option("--commands", commands, "Unsequenced packets in each datagram")->check(CLI::Range(1, 32));
    app.add_option("--batch", batch, "Datagrams sent before the client receives")->check(CLI::Range(1, 1000));
    app.add_option("--bytes", bytes, "Payload bytes of each packet (a relay input message is ~24)")->check(CLI::Range(1, 1000));
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        const int code = app.exit(e);
        return code == 0 ? 0 : 2;  // a bad flag: exit 2, as every lockroll program
    }
    try {
        return run(intercept, datagrams, commands, batch, bytes);
    } catch (const std::exception& e) {
        // ENet could not start, bind 127.0.0.1 or connect: this machine's trouble, not a result.
        std::fprintf(stderr, "intercept_cost: %s\n", e.what());
        return 1;
    }
}

namespace {

int run(const std::string& intercept, int datagrams, int commands, int batch, int bytes) {
    if (enet_initialize() != 0) throw std::runtime_error("enet_initialize failed");
    ENetAddress address{};
    enet_address_set_host(&address, "127.0.0.1");
    address.port = 0;
    ENetHost* server = enet_host_create(&address, 1, 1, 0, 0);
    ENetHost* client = enet_host_create(nullptr, 1, 1, 0, 0);
    if (server == nullptr || client == nullptr) throw std::runtime_error("enet_host_create failed on 127.0.0.1");
    ENetAddress bound{};
    enet_socket_get_address(server->socket, &bound);
    if (intercept == "empty") client->intercept = empty_intercept;
    if (intercept == "stale-verify") client->intercept = stale_verify_intercept;
    ENetPeer* to_server = enet_host_connect(client, &bound, 1, 0);
    connect(server, client, to_server);
    ENetPeer* to_client = &server->peers[0];

    const std::vector<enet_uint8> payload(static_cast<std::size_t>(bytes), 0x5a);
    const enet_uint32 received_before = client->totalReceivedPackets;
    std::uint64_t packets = 0;
    for (int sent = 0; sent < datagrams;) {
        for (int b = 0; b < batch && sent < datagrams; ++b, ++sent) {
            for (int c = 0; c < commands; ++c)
                enet_peer_send(to_client, 0, enet_packet_create(payload.data(), payload.size(), ENET_PACKET_FLAG_UNSEQUENCED));
            enet_host_flush(server);  // one datagram
        }
        packets += intercept_cost_receive(client);
        ENetEvent e;
        while (enet_host_service(server, &e, 0) > 0) {}  // the client's pings and acks
    }
    const std::uint64_t received = client->totalReceivedPackets - received_before;
    std::printf("intercept %s: %d datagrams of %d packets sent, %llu datagrams received, %llu packets delivered, %llu stale verifies dropped\n",
                intercept.c_str(), datagrams, commands, static_cast<unsigned long long>(received),
                static_cast<unsigned long long>(packets), static_cast<unsigned long long>(g_stale));
    enet_peer_disconnect_now(to_server, 0);
    enet_host_destroy(client);
    enet_host_destroy(server);
    enet_deinitialize();
    return packets == static_cast<std::uint64_t>(datagrams) * static_cast<std::uint64_t>(commands) ? 0 : 1;
}

}  // namespace
