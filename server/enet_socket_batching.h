// ENet's socket calls for the relay server's own socket, batched: one recvmmsg / sendmmsg per
// batch (DatagramBatch) instead of ENet's one recvmsg / sendmsg per datagram. ENet's API has no
// batching, but Debian's libenet.so.7 calls its own enet_socket_send / enet_socket_receive /
// enet_socket_wait / enet_socket_destroy through the PLT, so an executable that defines them
// (server/enet_socket_batching.cpp) is called in their place. Only fds given to install() are
// batched; every other socket (a bench's clients, anything else) goes to ENet's own function,
// found with dlsym(RTLD_NEXT), exactly as without this file.
//
// Link it ONLY into lockroll-server and bench/relay_cost (target lockroll_enet_socket_batching,
// which exports the four symbols): never into a library, the lockroll CLI or a client, where it
// would take over sockets nobody installed (they would pass through, but nobody asked for it).
//
// Contract for the loop: install(fd) once the socket is bound; flush() after each poll of ENet
// and after each enet_host_flush (the datagrams ENet "sent" wait in the batch until then).
// enet_socket_wait flushes before it sleeps, and reports a buffered datagram at once.
// Not thread-safe (one server loop).
#pragma once

#include <cstdint>
#include <string>

namespace lockroll::transport {
class SocketFanout;
}

namespace lockroll::server::enet_socket_batching {

enum class Mode : std::uint8_t {
    Count,  // ENet's own calls, one syscall each, counted (the baseline of the same driver)
    Batch,  // recvmmsg / sendmmsg through DatagramBatch
};

struct Counts {
    std::uint64_t receive_syscalls = 0, send_syscalls = 0, wait_syscalls = 0;
    std::uint64_t datagrams_in = 0, datagrams_out = 0, dropped = 0;
    std::uint64_t syscalls() const { return receive_syscalls + send_syscalls + wait_syscalls; }
};

// Checks first that ENet's calls reach this file (an ENet host on 127.0.0.1 sends and reads one
// datagram); then takes fd (a bound UDP socket of ENet's) in the mode. Returns "" when installed,
// otherwise why not: the socket then stays ENet's own, one syscall per datagram (the caller logs it).
// Call after enet_initialize.
std::string install(int fd, Mode mode);
// Sends what the installed sockets queued. Cheap when nothing is queued.
void flush();
// The installed sockets' syscalls and datagrams so far.
Counts counts();
// Several ENet hosts over one socket (transport::SocketFanout; EnetServerConfig::fanout): its
// attach() installs the socket in Batch mode, then reads it in batches of up to 1,024 datagrams
// per receive() and routes each to its host by the sender's address (server/datagram_demux.h);
// the other hosts get socket ids that are no descriptors (enet_socket_destroy ignores them).
// One socket at a time.
transport::SocketFanout& fanout();

}  // namespace lockroll::server::enet_socket_batching
