// libFuzzer target: the relay server fed scripts of connections and datagrams from fuzzed
// clients (fuzz/relay_fuzz.h), with time passing. Properties beyond "no crash, no sanitizer
// report": every datagram the server sends decodes with the relay decoders; connections, rooms
// and queued output stay within the configured bounds; kicked connections are never bound.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <span>
#include <vector>

#include "fuzz/relay_fuzz.h"
#include "server/relay_server.h"

using namespace lockroll;
using namespace lockroll::rollback;

namespace {
void check(bool ok) {
    if (!ok) std::abort();
}

// Every outgoing datagram must be a well-formed relay message.
void check_outgoing(const server::Outgoing& o) {
    const auto kind = peek_relay_kind(o.bytes);
    check(kind.has_value());
    switch (*kind) {
        case RelayKind::Welcome: {
            RelayWelcome w;
            check(decode(o.bytes, w) == nullptr);
            break;
        }
        case RelayKind::Frames: {
            RelayFrames f;
            check(o.bytes.size() > 18);
            check(decode(o.bytes, o.bytes[17], o.bytes[18], f) == nullptr);
            break;
        }
        case RelayKind::Forward: {
            RelayForward f;
            check(decode(o.bytes, f) == nullptr);
            break;
        }
        case RelayKind::Notice: {
            RelayNotice n;
            check(decode(o.bytes, n) == nullptr);
            break;
        }
        default: check(false);  // the server never sends client messages
    }
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    server::ServerConfig config;
    config.max_rooms = 4;
    config.max_connections = 16;
    config.room.history_s = 2;
    config.room.max_spectators = 2;
    config.max_bad_packets = 8;
    config.packet_burst = 64;
    server::RelayServer s(config);
    std::uint64_t now = 1'000'000;
    std::vector<server::Outgoing> out;
    std::size_t i = 0;
    while (i + 4 <= size) {
        const std::uint8_t op = data[i] % 5;
        const std::uint32_t c = 1 + data[i + 1] % 24;
        const std::size_t n = std::min<std::size_t>(static_cast<std::size_t>(data[i + 2] | data[i + 3] << 8), size - i - 4);
        const std::span<const std::uint8_t> bytes(data + i + 4, n);
        i += 4 + n;
        switch (op) {
            case fuzz::kOpen: s.on_connect(c, now); break;
            case fuzz::kClose: s.on_disconnect(c, now); break;
            case fuzz::kDatagram: s.receive(c, bytes, now); break;
            case fuzz::kTime:
                now += 1000 * (n > 0 ? bytes[0] : 1);
                s.tick(now);
                break;
            default: {
                out.clear();
                s.take_outgoing(out);
                for (const auto& o : out) check_outgoing(o);
                for (server::ConnectionId k; s.next_kick(k);) s.on_disconnect(k, now);
                for (server::ServerEvent e; s.next_event(e);) {
                }
            }
        }
        check(s.room_count() <= config.max_rooms);
        check(s.connection_count() <= config.max_connections + 1);  // one over the limit, kicked at once
    }
    out.clear();
    s.take_outgoing(out);
    for (const auto& o : out) check_outgoing(o);
    return 0;
}
