// ServerPass: one pass of the relay server's loop, after the socket was polled: connection
// events, datagrams, the rooms' tick, sending what they queued, kicks, then the server's events
// to the log. Unreliable datagrams (the Frames) are written to the socket as they are sent
// (EnetServer's direct_unsequenced; lockroll-server's batch flush after the pass sends them);
// the others leave at the next EnetServer::poll (ENet sends what is queued before
// it reads; with several hosts, the poll flushes the hosts that have sends first) or, with
// flush, at once: a loop that polls again right away saves a walk of a single host's connection
// slots per pass by not flushing; one that sleeps first must flush. The process (server/server_process.cpp) runs it after every poll;
// bench/relay_cost.cpp runs exactly the same code under a virtual clock, so the cost of a relayed
// datagram can be counted (callgrind) on a busy machine.
// Holds the buffers a pass reuses; not thread-safe; reads no clock (now is passed in).
#pragma once

#include <cstdint>
#include <vector>

#include "server/relay_server.h"
#include "transport/enet_server.h"

namespace spdlog {
class logger;
}

namespace lockroll::server {

class ServerPass {
public:
    // log == nullptr: the server's events are taken and dropped.
    void run(transport::EnetServer& enet, RelayServer& server, std::uint64_t now_us, spdlog::logger* log, bool flush);

private:
    transport::ServerDatagram d_;
};

}  // namespace lockroll::server
