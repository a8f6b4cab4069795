// What the SessionBuilder tests (tests/net/session_builder*_test.cpp) share: what start()
// throws, a NetSession's events, and a real `lockroll-server` to play through.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "harness/live/child_process.h"  // RelayServerProcess (link harness/live/child_process.cpp)
#include "net/session_builder.h"

namespace lockroll::net::test_support {

// What start() throws for these settings on a fresh Sim (it binds nothing when it throws);
// "(started)" when it does not throw.
template <class Sim>
std::string start_error(const SessionBuilder& b) {
    Sim sim;
    std::string what = "(started)";
    try {
        (void)b.start(sim);
    } catch (const std::invalid_argument& e) {
        what = e.what();
    }
    return what;
}

// Every event queued so far, oldest first.
inline std::vector<rollback::SessionEvent> drain(NetSession& s) {
    std::vector<rollback::SessionEvent> out;
    for (rollback::SessionEvent e; s.next_event(e);) out.push_back(e);
    return out;
}
inline bool has(const std::vector<rollback::SessionEvent>& ev, rollback::SessionEvent::Kind k) {
    return std::any_of(ev.begin(), ev.end(), [k](const auto& e) { return e.kind == k; });
}

#ifdef LOCKROLL_SERVER_EXE  // the tests that play through a server (CMake gives them its path)
// A real `lockroll-server` on 127.0.0.1: a free port it picks itself (--listen 127.0.0.1:0, read
// from its "ready PORT" line), bounded to 60 s of running (--run-seconds), stopped by its pid
// (harness::ChildProcess). port is 0 when it did not get ready within 4 s. `extra` are further
// server flags (--key FILE, --max-spectators N, ...).

inline std::vector<std::string> relay_server_argv(const std::string& name, const std::vector<std::string>& extra) {
    std::vector<std::string> argv = {LOCKROLL_SERVER_EXE, "--listen", "127.0.0.1:0", "--ready-file",
                                     ::testing::TempDir() + "/" + name + "-ready", "--run-seconds", "60"};
    argv.insert(argv.end(), extra.begin(), extra.end());
    return argv;
}

struct RelayServerProcess {
    explicit RelayServerProcess(const std::string& name, const std::vector<std::string>& extra = {})
        : log_path(::testing::TempDir() + "/" + name + "-server.log"), process(relay_server_argv(name, extra), log_path, true) {
        for (int i = 0; i < 200 && port == 0; ++i) {
            for (const auto& line : process.read_lines())
                if (line.rfind("ready ", 0) == 0) port = static_cast<std::uint16_t>(std::stoi(line.substr(6)));
            std::this_thread::sleep_for(std::chrono::milliseconds(20));
        }
    }
    std::string log_path;  // the server's stderr: its log, one line per room event
    harness::ChildProcess process;
    std::uint16_t port = 0;
};

#endif  // LOCKROLL_SERVER_EXE

}  // namespace lockroll::net::test_support
