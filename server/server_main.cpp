// lockroll-server: the relay server alone (what the container image ships). The same options
// as `lockroll server`; it links neither sim/ nor the session core.
// Exit status: 0 drained cleanly, 2 bad options, 1 failure (cannot listen, drain timed out).
// Unlike `lockroll server`, it batches its socket's syscalls (server/enet_socket_batching.h).
#include <CLI/CLI.hpp>

#include <cstdio>
#include <exception>
#include <string>

#include "server/enet_socket_batching.h"
#include "server/server_cli.h"

int main(int argc, char** argv) {
    CLI::App app{"lockroll relay server: rooms that collect, confirm and broadcast inputs; runs no simulation"};
    namespace batching = lockroll::server::enet_socket_batching;
    bool plain = false;
    app.add_flag("--plain-syscalls", plain, "One recvmsg / sendmsg per datagram, as plain ENet (the baseline of the batching)");
    lockroll::server::add_server_options(app, {[&plain](int fd) {
                                                   return plain ? std::string("--plain-syscalls") : batching::install(fd, batching::Mode::Batch);
                                               },
                                               [] { batching::flush(); },
                                               [&plain]() { return plain ? nullptr : &batching::fanout(); }});
    try {
        app.parse(argc, argv);
    } catch (const CLI::CallForHelp& e) {
        return app.exit(e);
    } catch (const CLI::ParseError& e) {
        app.exit(e);
        return 2;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "lockroll-server: error: %s\n", e.what());
        return 1;
    }
    return 0;
}
