#include "server/enet_socket_batching.h"

#include <dlfcn.h>
#include <enet/enet.h>
#include <poll.h>

#include <algorithm>
#include <cstring>
#include <span>
#include <memory>
#include <vector>

#include "server/datagram_batch.h"
#include "server/datagram_demux.h"
#include "transport/enet_handshakes.h"
#include "transport/enet_server.h"

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

// Several ENet hosts over one installed socket (fanout()): the socket is read in batches into a
// pool of slots, each datagram routed to its host's queue (DatagramDemux); host k reads its
// queue through enet_socket_receive(ids[k]) and sends through the socket's batch.
constexpr int kFirstSharedId = -16;  // host k >= 1 gets the id kFirstSharedId - (k - 1): never a descriptor
constexpr std::size_t kReceiveChunk = 64;     // datagrams per recvmmsg
constexpr std::size_t kPoolSlots = 1024;      // datagrams read per receive() at most

struct Shared {
    int fd = -1;  // the socket (host 0's); -1: no fanout
    std::unique_ptr<DatagramDemux> demux;
    std::vector<std::uint8_t> bytes;
    std::vector<sockaddr_in> from;
    std::vector<iovec> iov;
    std::vector<mmsghdr> headers;
    std::size_t used = 0;
    std::vector<std::vector<std::uint32_t>> queue;  // per host: pool slots, in arrival order
    std::vector<std::size_t> next;                  // per host: the next slot of its queue to read
    std::vector<std::size_t> listed;                // hosts whose queues were filled by the last receive
    std::vector<std::uint8_t> is_listed;
    std::uint64_t receive_calls = 0, datagrams_in = 0, dropped = 0;
    transport::SocketFanout::Claim claim = nullptr;  // EnetServer takes some datagrams itself
    void* claim_context = nullptr;
    transport::SocketFanout::Abandon abandon = nullptr;  // EnetServer resets the ENet peers of abandoned handshakes
    void* abandon_context = nullptr;

    // The host reading through socket id s, or -1 when s is none of the fanout's.
    int host_of(int s) const {
        if (fd < 0) return -1;
        if (s == fd) return 0;
        if (s > kFirstSharedId) return -1;
        const std::size_t k = static_cast<std::size_t>(kFirstSharedId - s) + 1;
        return k < queue.size() ? static_cast<int>(k) : -1;
    }
};

struct State {
    Shared shared;
    std::vector<Installed> sockets;
    Counts counts;           // the Count-mode sockets' calls, and the closed Batch-mode ones'
    std::uint64_t seen_send = 0, seen_receive = 0;  // every call that reached this file (self-check)
};

// Constant-initialized, not a function-local static: every ENet socket call of the server goes
// through state(), and a local static's guard was a measurable part of each (docs/performance.md).
constinit State g_state;
State& state() { return g_state; }

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
    const Shared& sh = state().shared;
    c.receive_syscalls += sh.receive_calls;
    c.datagrams_in += sh.datagrams_in;
    c.dropped += sh.dropped;
    return c;
}

namespace {

class Fanout final : public transport::SocketFanout {
public:
    std::vector<int> attach(int socket, std::size_t hosts, std::size_t capacity, std::size_t connections,
                            std::size_t max_per_address, std::string& why) override {
        Shared& sh = state().shared;
        if (sh.fd >= 0) {
            why = "the fanout already serves a socket";
            return {};
        }
        if (hosts == 0 || capacity == 0) {
            why = "no hosts";
            return {};
        }
        DatagramDemuxConfig dc;
        dc.hosts = hosts;
        dc.capacity_per_host = capacity;
        dc.connections = connections;
        dc.max_per_ip = max_per_address;
        // A handshake's count lasts as long as its ENet peer may (a second more: its repeats must
        // still reach its host), not ENet's 30 s default.
        dc.pending_us = (std::uint64_t{transport::kHandshakeTimeoutMs} + 1'000) * 1'000;
        try {
            sh.demux = std::make_unique<DatagramDemux>(dc);
        } catch (const std::invalid_argument& e) {
            why = e.what();
            return {};
        }
        why = install(socket, Mode::Batch);
        if (!why.empty()) {
            sh.demux.reset();
            return {};
        }
        sh.bytes.assign(kPoolSlots * DatagramBatch::kMaxBytes, 0);
        sh.from.assign(kPoolSlots, {});
        sh.iov.resize(kPoolSlots);
        sh.headers.resize(kPoolSlots);
        for (std::size_t i = 0; i < kPoolSlots; ++i) {
            sh.iov[i] = {&sh.bytes[i * DatagramBatch::kMaxBytes], DatagramBatch::kMaxBytes};
            msghdr& h = sh.headers[i].msg_hdr;
            h = {};
            h.msg_name = &sh.from[i];
            h.msg_namelen = sizeof(sockaddr_in);
            h.msg_iov = &sh.iov[i];
            h.msg_iovlen = 1;
        }
        sh.used = 0;
        sh.queue.assign(hosts, {});
        sh.next.assign(hosts, 0);
        sh.is_listed.assign(hosts, 0);
        sh.listed.clear();
        sh.fd = socket;
        std::vector<int> ids(hosts);
        ids[0] = socket;
        for (std::size_t k = 1; k < hosts; ++k) ids[k] = kFirstSharedId - static_cast<int>(k - 1);
        return ids;
    }

    void receive(std::uint64_t now_us, std::vector<std::size_t>& ready) override {
        Shared& sh = state().shared;
        if (sh.fd < 0) return;
        for (std::size_t h : sh.listed) {
            sh.queue[h].clear();
            sh.next[h] = 0;
            sh.is_listed[h] = 0;
        }
        sh.listed.clear();
        // The kernel rewrites msg_namelen, msg_flags and msg_len of the headers it filled: reset
        // the name lengths of those, the rest was set once (attach).
        for (std::size_t i = 0; i < sh.used; ++i) sh.headers[i].msg_hdr.msg_namelen = sizeof(sockaddr_in);
        sh.used = 0;
        while (sh.used + kReceiveChunk <= kPoolSlots) {
            ++sh.receive_calls;
            const int n = recvmmsg(sh.fd, &sh.headers[sh.used], static_cast<unsigned>(kReceiveChunk), MSG_DONTWAIT, nullptr);
            if (n <= 0) break;
            const std::size_t end = sh.used + static_cast<std::size_t>(n);
            for (std::size_t i = sh.used; i < end; ++i) {
                const mmsghdr& m = sh.headers[i];
                if ((m.msg_hdr.msg_flags & MSG_TRUNC) != 0) {
                    ++sh.dropped;
                    continue;
                }
                const std::span<std::uint8_t> d(&sh.bytes[i * DatagramBatch::kMaxBytes], m.msg_len);
                const int h = sh.demux->route(sh.from[i].sin_addr.s_addr, ENET_NET_TO_HOST_16(sh.from[i].sin_port), d, now_us);
                for (AbandonedHandshake a; sh.demux->next_abandoned(a);)
                    if (sh.abandon != nullptr) sh.abandon(sh.abandon_context, a.host, a.ip, a.port, a.connect_id);
                if (h < 0) {
                    ++sh.dropped;
                    continue;
                }
                ++sh.datagrams_in;
                const auto k = static_cast<std::size_t>(h);
                if (sh.claim != nullptr && sh.claim(sh.claim_context, k, sh.from[i].sin_addr.s_addr, ENET_NET_TO_HOST_16(sh.from[i].sin_port), d))
                    continue;  // taken by the server, not its host's ENet
                sh.queue[k].push_back(static_cast<std::uint32_t>(i));
                if (!sh.is_listed[k]) {
                    sh.is_listed[k] = 1;
                    sh.listed.push_back(k);
                    ready.push_back(k);
                }
            }
            sh.used = end;
            if (static_cast<std::size_t>(n) < kReceiveChunk) break;
        }
    }

    void set_claim(Claim claim, void* context) override {
        state().shared.claim = claim;
        state().shared.claim_context = context;
    }
    void set_abandon(Abandon abandon, void* context) override {
        state().shared.abandon = abandon;
        state().shared.abandon_context = context;
    }

    bool holds(std::size_t host) const override {
        const Shared& sh = state().shared;
        return host < sh.queue.size() && sh.next[host] < sh.queue[host].size();
    }

    void connected(std::size_t host, std::uint32_t ip, std::uint16_t port, std::uint32_t connect_id) override {
        if (state().shared.demux) state().shared.demux->connected(host, ip, port, connect_id);
    }
    void disconnected(std::size_t host, std::uint32_t ip, std::uint16_t port, std::uint32_t connect_id) override {
        if (state().shared.demux) state().shared.demux->disconnected(host, ip, port, connect_id);
    }
};

// Host k's next routed datagram into ENet's buffers; 0 when its queue is empty.
int shared_receive(Shared& sh, std::size_t k, ENetAddress* address, ENetBuffer* buffers, size_t count) {
    if (sh.next[k] >= sh.queue[k].size()) return 0;
    const std::uint32_t i = sh.queue[k][sh.next[k]++];
    const auto* src = &sh.bytes[i * DatagramBatch::kMaxBytes];
    std::size_t left = sh.headers[i].msg_len, copied = 0;
    for (std::size_t b = 0; b < count && left > 0; ++b) {
        const std::size_t n = left < buffers[b].dataLength ? left : buffers[b].dataLength;
        std::memcpy(buffers[b].data, src + copied, n);
        copied += n;
        left -= n;
    }
    if (address != nullptr) {
        address->host = sh.from[i].sin_addr.s_addr;
        address->port = ENET_NET_TO_HOST_16(sh.from[i].sin_port);
    }
    return static_cast<int>(copied);
}

}  // namespace

transport::SocketFanout& fanout() {
    static Fanout f;
    return f;
}

}  // namespace lockroll::server::enet_socket_batching

// The interposed functions. Same contracts as ENet's (enet.h, unix.c): send returns the bytes
// sent (here: queued), 0 when the socket would block, -1 on error; receive returns the length,
// 0 when nothing waits, -1 on error; wait sets *condition to what is ready.
using namespace lockroll::server::enet_socket_batching;

extern "C" int enet_socket_send(ENetSocket socket, const ENetAddress* address, const ENetBuffer* buffers, size_t count) {
    State& st = state();
    ++st.seen_send;
    if (const int k = st.shared.host_of(socket); k > 0) {
        // A host of the fanout: the shared socket, its VERIFY_CONNECT naming the server's peer id.
        Installed* s = find(st.shared.fd);
        if (s == nullptr || !s->batch || address == nullptr) return -1;
        const int n = s->batch->send(to_sockaddr(*address), as_iovec(buffers), count);
        if (n > 0) st.shared.demux->outgoing(static_cast<std::size_t>(k), s->batch->last_queued());
        return n;
    }
    Installed* s = find(socket);
    if (s != nullptr && s->batch && address != nullptr) return s->batch->send(to_sockaddr(*address), as_iovec(buffers), count);
    const int n = enet_own().send(socket, address, buffers, count);
    if (s != nullptr) count_call(st.counts.send_syscalls, st.counts.datagrams_out, n);
    return n;
}

extern "C" int enet_socket_receive(ENetSocket socket, ENetAddress* address, ENetBuffer* buffers, size_t count) {
    State& st = state();
    ++st.seen_receive;
    if (const int k = st.shared.host_of(socket); k >= 0) return shared_receive(st.shared, static_cast<std::size_t>(k), address, buffers, count);
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
    if (st.shared.host_of(socket) > 0) return;  // an id of the fanout's, no descriptor
    if (st.shared.fd >= 0 && socket == st.shared.fd) {
        st.counts.receive_syscalls += st.shared.receive_calls;
        st.counts.datagrams_in += st.shared.datagrams_in;
        st.counts.dropped += st.shared.dropped;
        st.shared = Shared{};
    }
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
