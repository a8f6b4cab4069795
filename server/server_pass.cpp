#include "server/server_pass.h"

#include <spdlog/spdlog.h>

namespace lockroll::server {

void ServerPass::run(transport::EnetServer& enet, RelayServer& server, std::uint64_t now, spdlog::logger* log, bool flush) {
    for (transport::ServerConnectionEvent e; enet.next_event(e);) {
        if (e.type == transport::ServerConnectionEvent::Type::Connected) {
            if (log) log->debug("connection {} from {}", e.connection, e.address);
            server.on_connect(e.connection, now);
        } else {
            if (log) log->debug("connection {} closed", e.connection);
            server.on_disconnect(e.connection, now);
        }
    }
    while (enet.receive(d_)) server.receive(d_.connection, d_.bytes, d_.time_us);
    server.tick(now);
    server.send_outgoing([&](const Outgoing& o) { enet.send(o.to, o.bytes, o.reliable); });
    for (ConnectionId k; server.next_kick(k);) enet.disconnect(k);
    if (flush) enet.flush();
    for (ServerEvent e; server.next_event(e);) {
        if (!log) continue;
        const bool bad = e.kind == ServerEvent::Kind::Kicked || e.kind == ServerEvent::Kind::Refused ||
                         e.kind == ServerEvent::Kind::Desync || e.kind == ServerEvent::Kind::Throttled;
        log->log(bad ? spdlog::level::warn : spdlog::level::info, "room {:x} {} slot {} frame {} connection {}{}{}", e.room,
                 server_event_name(e.kind), e.slot, e.frame, e.connection, e.detail.empty() ? "" : ": ", e.detail);
    }
}

}  // namespace lockroll::server
