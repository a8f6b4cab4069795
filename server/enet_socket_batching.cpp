#include "server/enet_socket_batching.h"

#include <dlfcn.h>
#include <enet/enet.h>
#include <poll.h>

#include <cstring>
#include <memory>
#include <vector>

#include "server/datagram_batch.h"

namespace lockroll::server::enet_socket_batching {
namespace {

using SendFn = int (*)(ENetSocket, const ENetAddress*, const ENetBuffer*, size_t);
using ReceiveFn = int (*)(ENetSocket, ENetAddress*, ENetBuffer*, size_t);
using WaitFn = int (*)(ENetSocket, enet_uint32*, enet_uint32);
using DestroyFn = void (*)(ENetSocket);

// ENet's own definitions (libenet.so.7), the next ones after this executable's.
template <typename F>
F next(const char* name) {
    return reinterpret_cast<F>(dlsym(RTLD_NEXT, name));
}
struct EnetOwn {
    SendFn send;
    ReceiveFn receive;
    WaitFn wait;
    DestroyFn destroy;
};
const EnetOwn& enet_own() {
    static const EnetOwn e{next<SendFn>("enet_socket_send"), next<ReceiveFn>("enet_socket_receive"),
                           next<WaitFn>("enet_socket_wait"), next<DestroyFn>("enet_socket_destroy")};
    return e;
}

struct Installed {
    int fd = -1;
    Mode mode = Mode::Count;
    std::unique_ptr<DatagramBatch> batch;  // Batch mode only
};

struct State {
    std::vector<Installed> sockets;
    Counts counts;           // the Count-mode sockets' calls, and the closed Batch-mode ones'
    std::uint64_t seen_send = 0, seen_receive = 0;  // every call that reached this file (self-check)
};

State& state() {
    static State s;
    return s;
}

Installed* find(int fd) {
    for (auto& s : state().sockets)
        if (s.fd == fd) return &s;
    return nullptr;
}

void add_batch_counts(Counts& c, const DatagramBatchCounters& b) {
    c.receive_syscalls += b.receive_calls;
    c.send_syscalls += b.send_calls;
    c.datagrams_in += b.datagrams_in;
    c.datagrams_out += b.datagrams_out;
    c.dropped += b.dropped_oversized + b.dropped_send;
}

sockaddr_in to_sockaddr(const ENetAddress& a) {
    sockaddr_in s{};
    s.sin_family = AF_INET;
    s.sin_port = ENET_HOST_TO_NET_16(a.port);
    s.sin_addr.s_addr = a.host;
    return s;
}

// ENetBuffer is laid out as struct iovec on Unix (enet/unix.h says so; ENet casts it itself).
static_assert(sizeof(ENetBuffer) == sizeof(iovec));
const iovec* as_iovec(const ENetBuffer* b) { return reinterpret_cast<const iovec*>(b); }

// A Count-mode socket's call to ENet's own function: one syscall, a datagram if it moved one.
void count_call(std::uint64_t& syscalls, std::uint64_t& datagrams, int result) {
    ++syscalls;
    if (result > 0) ++datagrams;
}

bool self_check(std::string& why) {
    ENetAddress a{};
    enet_address_set_host(&a, "127.0.0.1");
    a.port = 0;
    ENetHost* probe = enet_host_create(&a, 1, 1, 0, 0);
    if (probe == nullptr) {
        why = "self-check could not create an ENet host on 127.0.0.1";
        return false;
    }
    enet_socket_get_address(probe->socket, &a);
    const std::uint64_t sends = state().seen_send, receives = state().seen_receive;
    enet_host_connect(probe, &a, 1, 0);  // to itself: a connect command, sent and read back
    enet_host_flush(probe);
    ENetEvent e;
    enet_host_service(probe, &e, 0);
    const bool live = state().seen_send > sends && state().seen_receive > receives;
    enet_host_destroy(probe);
    if (!live) why = "ENet's socket calls do not reach lockroll's (libenet binds them to its own: not interposable)";
    return live;
}

}  // namespace

std::string install(int fd, Mode mode) {
    if (!enet_own().send || !enet_own().receive || !enet_own().wait || !enet_own().destroy) return "ENet's own socket functions not found (dlsym)";
    std::string why;
    if (!self_check(why)) return why;
    if (find(fd) != nullptr) return "socket already installed";
    Installed s;
    s.fd = fd;
    s.mode = mode;
    if (mode == Mode::Batch) s.batch = std::make_unique<DatagramBatch>(fd);
    state().sockets.push_back(std::move(s));
    return "";
}

void flush() {
    for (auto& s : state().sockets)
        if (s.batch && s.batch->queued() > 0) s.batch->flush();
}

Counts counts() {
    Counts c = state().counts;
    for (const auto& s : state().sockets)
        if (s.batch) add_batch_counts(c, s.batch->counters());
    return c;
}

}  // namespace lockroll::server::enet_socket_batching

// The interposed functions. Same contracts as ENet's (enet.h, unix.c): send returns the bytes
// sent (here: queued), 0 when the socket would block, -1 on error; receive returns the length,
// 0 when nothing waits, -1 on error; wait sets *condition to what is ready.
using namespace lockroll::server::enet_socket_batching;

extern "C" int enet_socket_send(ENetSocket socket, const ENetAddress* address, const ENetBuffer* buffers, size_t count) {
    State& st = state();
    ++st.seen_send;
    Installed* s = find(socket);
    if (s != nullptr && s->batch && address != nullptr) return s->batch->send(to_sockaddr(*address), as_iovec(buffers), count);
    const int n = enet_own().send(socket, address, buffers, count);
    if (s != nullptr) count_call(st.counts.send_syscalls, st.counts.datagrams_out, n);
    return n;
}

extern "C" int enet_socket_receive(ENetSocket socket, ENetAddress* address, ENetBuffer* buffers, size_t count) {
    State& st = state();
    ++st.seen_receive;
    Installed* s = find(socket);
    if (s != nullptr && s->batch) {
        sockaddr_in from{};
        const int n = s->batch->receive(from, as_iovec(buffers), count);
        if (n > 0 && address != nullptr) {
            address->host = from.sin_addr.s_addr;
            address->port = ENET_NET_TO_HOST_16(from.sin_port);
        }
        return n;
    }
    const int n = enet_own().receive(socket, address, buffers, count);
    if (s != nullptr) count_call(st.counts.receive_syscalls, st.counts.datagrams_in, n);
    return n;
}

extern "C" int enet_socket_wait(ENetSocket socket, enet_uint32* condition, enet_uint32 timeout) {
    Installed* s = find(socket);
    if (s != nullptr && s->batch) {
        if (s->batch->queued() > 0) s->batch->flush();  // never sleep on datagrams not yet sent
        if ((*condition & ENET_SOCKET_WAIT_RECEIVE) != 0 && s->batch->has_buffered()) {
            *condition = ENET_SOCKET_WAIT_RECEIVE;
            return 0;
        }
    }
    if (s != nullptr) ++state().counts.wait_syscalls;
    return enet_own().wait(socket, condition, timeout);
}

extern "C" void enet_socket_destroy(ENetSocket socket) {
    State& st = state();
    for (auto it = st.sockets.begin(); it != st.sockets.end(); ++it) {
        if (it->fd != socket) continue;
        if (it->batch) {
            it->batch->flush();  // what ENet sent last (disconnects) still leaves
            add_batch_counts(st.counts, it->batch->counters());
        }
        st.sockets.erase(it);
        break;
    }
    enet_own().destroy(socket);
}
