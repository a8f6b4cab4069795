// The relay server process's orchestration hooks (docs/deployment.md), on a real lockroll-server
// process on 127.0.0.1: the ready line and ready file, the status file (ready, then draining on
// SIGTERM), exit 0 once drained, the room limit, bad flags refused with exit 2 before binding.
// A small ENet client speaks the relay protocol directly (rollback/relay_messages.h). Every wait
// is bounded; children are stopped by their pid (harness/live/child_process.h).
#include <enet/enet.h>
#include <gtest/gtest.h>
#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "harness/live/child_process.h"
#include "rollback/relay_messages.h"

namespace {

using namespace lockroll::rollback;
using lockroll::harness::ChildProcess;
using Clock = std::chrono::steady_clock;
namespace fs = std::filesystem;

struct TempDir {
    fs::path path;
    TempDir() {
        char tmpl[] = "/tmp/server_process_test.XXXXXX";
        path = mkdtemp(tmpl);
    }
    ~TempDir() {
        std::error_code ec;
        fs::remove_all(path, ec);
    }
};

std::string read_file(const fs::path& p) {
    std::ifstream f(p);
    return std::string((std::istreambuf_iterator<char>(f)), {});
}

// Waits (bounded) until pred() holds.
template <class Pred>
bool eventually(Pred pred, int timeout_ms) {
    const auto until = Clock::now() + std::chrono::milliseconds(timeout_ms);
    while (Clock::now() < until) {
        if (pred()) return true;
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    return pred();
}

// A lockroll-server child; its port from the "ready PORT" line.
struct Server {
    std::unique_ptr<ChildProcess> child;
    std::uint16_t port = 0;
    std::vector<std::string> lines;

    Server(const std::vector<std::string>& flags, const fs::path& log) {
        std::vector<std::string> argv{LOCKROLL_SERVER_EXE, "--listen", "127.0.0.1:0"};
        argv.insert(argv.end(), flags.begin(), flags.end());
        child = std::make_unique<ChildProcess>(argv, log.string(), true);
        eventually(
            [&] {
                for (auto& l : child->read_lines()) {
                    lines.push_back(l);
                    unsigned p = 0;
                    if (std::sscanf(l.c_str(), "ready %u", &p) == 1) port = static_cast<std::uint16_t>(p);
                }
                return port != 0 || !child->running();
            },
            10000);
    }
};

// One ENet connection speaking the relay protocol.
class RelayClient {
public:
    explicit RelayClient(std::uint16_t port) {
        host_ = enet_host_create(nullptr, 1, 2, 0, 0);
        ENetAddress a{};
        enet_address_set_host(&a, "127.0.0.1");
        a.port = port;
        peer_ = host_ ? enet_host_connect(host_, &a, 2, 0) : nullptr;
    }
    ~RelayClient() {
        if (peer_ && connected_) enet_peer_disconnect_now(peer_, 0);
        if (host_) {
            enet_host_flush(host_);
            enet_host_destroy(host_);
        }
    }
    bool connect(int timeout_ms) {
        return pump_until([&] { return connected_; }, timeout_ms);
    }
    void hello(std::uint64_t room, std::uint8_t slot, std::uint8_t players = 2) {
        RelayHello h;
        h.room_id = room;
        h.players = players;
        h.slot = slot;
        std::vector<std::uint8_t> bytes;
        encode(h, bytes);
        enet_peer_send(peer_, 1, enet_packet_create(bytes.data(), bytes.size(), ENET_PACKET_FLAG_RELIABLE));
        enet_host_flush(host_);
    }
    std::optional<RelayWelcome> welcome(int timeout_ms) {
        pump_until([&] { return welcome_.has_value(); }, timeout_ms);
        return welcome_;
    }
    bool got_notice(RelayNoticeKind k, int timeout_ms) {
        return pump_until([&] {
            for (auto n : notices_)
                if (n == k) return true;
            return false;
        }, timeout_ms);
    }
    void leave() {
        if (peer_ && connected_) {
            enet_peer_disconnect(peer_, 0);
            pump_until([&] { return !connected_; }, 2000);
        }
    }

private:
    template <class Pred>
    bool pump_until(Pred pred, int timeout_ms) {
        const auto until = Clock::now() + std::chrono::milliseconds(timeout_ms);
        while (!pred() && Clock::now() < until) {
            ENetEvent e;
            if (enet_host_service(host_, &e, 10) <= 0) continue;
            if (e.type == ENET_EVENT_TYPE_CONNECT) connected_ = true;
            if (e.type == ENET_EVENT_TYPE_DISCONNECT) connected_ = false;
            if (e.type == ENET_EVENT_TYPE_RECEIVE) {
                const std::span<const std::uint8_t> d(e.packet->data, e.packet->dataLength);
                const auto kind = peek_relay_kind(d);
                RelayWelcome w;
                RelayNotice n;
                if (kind == RelayKind::Welcome && decode(d, w) == nullptr) welcome_ = w;
                if (kind == RelayKind::Notice && decode(d, n) == nullptr) notices_.push_back(n.kind);
                enet_packet_destroy(e.packet);
            }
        }
        return pred();
    }
    ENetHost* host_ = nullptr;
    ENetPeer* peer_ = nullptr;
    bool connected_ = false;
    std::optional<RelayWelcome> welcome_;
    std::vector<RelayNoticeKind> notices_;
};

// Connects, says hello for (room, slot), and returns the server's answer (nullopt: none in time).
std::optional<RelayWelcome> join(RelayClient& c, std::uint64_t room, std::uint8_t slot) {
    if (!c.connect(3000)) return std::nullopt;
    c.hello(room, slot);
    return c.welcome(3000);
}

class ServerProcessTest : public ::testing::Test {
protected:
    static void SetUpTestSuite() { ASSERT_EQ(enet_initialize(), 0); }
    static void TearDownTestSuite() { enet_deinitialize(); }
    TempDir dir;
};

TEST_F(ServerProcessTest, ReadyLineReadyFileAndStatusFile) {
    const fs::path ready = dir.path / "ready", status = dir.path / "status.json";
    Server s({"--ready-file", ready.string(), "--status-file", status.string()}, dir.path / "server.log");
    ASSERT_NE(s.port, 0) << read_file(dir.path / "server.log");
    EXPECT_EQ(read_file(ready), std::to_string(s.port) + "\n");
    ASSERT_TRUE(eventually([&] { return fs::exists(status); }, 3000));
    const std::string json = read_file(status);
    EXPECT_NE(json.find("\"state\": \"ready\""), std::string::npos) << json;
    EXPECT_NE(json.find("\"port\": " + std::to_string(s.port)), std::string::npos) << json;
    EXPECT_NE(json.find("\"rooms\": 0"), std::string::npos) << json;
    // Idle: SIGTERM drains at once, exit 0.
    s.child->signal(SIGTERM);
    ASSERT_TRUE(eventually([&] { return !s.child->running(); }, 5000));
    EXPECT_EQ(s.child->poll_exit(), 0);
    EXPECT_NE(read_file(status).find("\"state\": \"draining\""), std::string::npos);
}

// The status file's write hangs on the filesystem (its temporary name is a FIFO nobody reads: an
// open that never returns, as a create can wait seconds on a busy ext4 journal): the server
// still welcomes a client, i.e. its relay loop does not wait for the status file (2026-12-06: a
// soak's server stalled 1.4-2.2 s while every process around it ran). Then the FIFO is read:
// the status the writer held is the server's, and the file is written from then on.
TEST_F(ServerProcessTest, AStatusFileWriteBlockedOnTheFilesystemDoesNotStallTheRelay) {
    const fs::path status = dir.path / "status.json", fifo = dir.path / "status.json.tmp";
    ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
    Server s({"--status-file", status.string()}, dir.path / "server.log");
    ASSERT_NE(s.port, 0) << read_file(dir.path / "server.log");
    RelayClient a(s.port);
    const auto w = join(a, 1, 0);
    // Whatever happened, let the blocked write go on (the server can be stopped then).
    const int fd = open(fifo.c_str(), O_RDONLY | O_NONBLOCK);
    ASSERT_GE(fd, 0);
    std::string held;
    eventually(
        [&] {
            char buf[512];
            for (ssize_t n; (n = read(fd, buf, sizeof buf)) > 0;) held.append(buf, static_cast<std::size_t>(n));
            return held.find('\n') != std::string::npos;
        },
        3000);
    close(fd);
    ASSERT_TRUE(w) << "no welcome while the status file's write was blocked";
    EXPECT_EQ(w->refusal, RelayRefusal::None);
    EXPECT_NE(held.find("\"state\": \"ready\""), std::string::npos) << held;
    // The writer renamed the FIFO to status.json; the next second's file replaces it (a FIFO is
    // not read here: an open for reading would wait for a writer).
    const auto status_has = [&](const std::string& what) {
        return fs::is_regular_file(status) && read_file(status).find(what) != std::string::npos;
    };
    ASSERT_TRUE(eventually([&] { return status_has("\"rooms\": 1"); }, 5000));
    a.leave();
    EXPECT_EQ(s.child->stop(5000), 0);
}

TEST_F(ServerProcessTest, RoomLimitRefusesTheNextRoom) {
    // With a pass interval (the loop sleeps between passes): the same answers, just batched.
    Server s({"--max-rooms", "1", "--pass-interval-us", "2000"}, dir.path / "server.log");
    ASSERT_NE(s.port, 0);
    RelayClient a(s.port), b(s.port), c(s.port);
    auto wa = join(a, 1, 0);
    ASSERT_TRUE(wa);
    EXPECT_EQ(wa->refusal, RelayRefusal::None);
    auto wb = join(b, 2, 0);  // a second room: over the limit
    ASSERT_TRUE(wb);
    EXPECT_EQ(wb->refusal, RelayRefusal::Full);
    auto wc = join(c, 1, 1);  // the existing room still takes its second player
    ASSERT_TRUE(wc);
    EXPECT_EQ(wc->refusal, RelayRefusal::None);
    a.leave();
    c.leave();
    EXPECT_EQ(s.child->stop(5000), 0);  // SIGTERM with no room left: drained at once
}

TEST_F(ServerProcessTest, SigtermDrainsRefusesNewHellosAndExitsZeroOnceEmpty) {
    const fs::path status = dir.path / "status.json";
    Server s({"--status-file", status.string(), "--drain-timeout", "30"}, dir.path / "server.log");
    ASSERT_NE(s.port, 0);
    RelayClient player(s.port);
    auto w = join(player, 7, 0);
    ASSERT_TRUE(w);
    ASSERT_EQ(w->refusal, RelayRefusal::None);
    ASSERT_TRUE(eventually([&] { return read_file(status).find("\"rooms\": 1") != std::string::npos; }, 3000));

    s.child->signal(SIGTERM);
    ASSERT_TRUE(eventually([&] { return read_file(status).find("\"state\": \"draining\"") != std::string::npos; }, 3000))
        << read_file(status);
    EXPECT_TRUE(player.got_notice(RelayNoticeKind::Draining, 3000));
    // The room plays on: the process waits for it.
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    EXPECT_TRUE(s.child->running());
    // A new hello is refused with the reason.
    RelayClient late(s.port);
    auto wl = join(late, 8, 0);
    ASSERT_TRUE(wl);
    EXPECT_EQ(wl->refusal, RelayRefusal::Draining);
    // The last room's player leaves: drained, exit 0.
    player.leave();
    ASSERT_TRUE(eventually([&] { return !s.child->running(); }, 10000));
    EXPECT_EQ(s.child->poll_exit(), 0);
}

TEST_F(ServerProcessTest, BadFlagsExitTwoBeforeBinding) {
    const fs::path ready = dir.path / "ready", status = dir.path / "status.json";
    const std::vector<std::vector<std::string>> bad{
        {"--listen", "nonsense"},     {"--listen", "127.0.0.1:70000"}, {"--max-rooms", "0"},
        {"--input-deadline", "0"},    {"--max-connections", "1"},      {"--per-address", "0"},
        {"--log-level", "loud"},      {"--no-such-flag"},              {"--pass-interval-us", "-1"},
    };
    for (const auto& flags : bad) {
        std::vector<std::string> argv{LOCKROLL_SERVER_EXE, "--ready-file", ready.string(), "--status-file", status.string()};
        argv.insert(argv.end(), flags.begin(), flags.end());
        ChildProcess p(argv, (dir.path / "bad.log").string(), true);
        ASSERT_TRUE(eventually([&] { return !p.running(); }, 5000)) << flags[0];
        EXPECT_EQ(p.poll_exit(), 2) << flags[0];
        for (const auto& l : p.read_lines()) EXPECT_EQ(l.rfind("ready", 0), std::string::npos) << flags[0];
        EXPECT_FALSE(fs::exists(ready)) << flags[0];
        EXPECT_FALSE(fs::exists(status)) << flags[0];
    }
    // The message names the flag.
    EXPECT_NE(read_file(dir.path / "bad.log").find("--max-rooms"), std::string::npos);
}

}  // namespace
