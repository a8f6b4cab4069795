// RelayServer: the relay's whole logic, sans-IO. It holds many rooms (RelayRoom), binds each
// connection to one room and one slot, and polices what connections send. It reads no clock and
// owns no socket: the process (server/server_process.h) hands it connection events and
// datagrams with the time, calls tick(), and sends what it queued. So the same code runs under
// the tests' virtual time, the fuzzer and ENet.
//
// Contract
//  - A room is created by the first hello carrying its id, with that hello's parameters (slots,
//    input size, tick rate, scene checksum, absent slots); a later hello with other parameters is
//    refused (RoomParams). Its clock starts once every slot not absent at frame 0 has a player.
//  - The slot comes from the connection: a hello binds a connection to (room, slot) once (or to
//    a set of slots: several local players, RelayRoom's contract); every later datagram of that
//    connection speaks for those slots, and no packet field can grant another (an input's slots
//    mask must be exactly the connection's). A second hello for another slot or set is refused
//    (Spoof) and counted as bad.
//  - Never trust a client: malformed datagrams, inputs outside [confirmed frame, room clock +
//    max_frames_ahead), reports for frames not confirmed yet, and anything before a hello count
//    as bad; past max_bad_packets the connection is kicked. Each connection has a token bucket
//    (packets_per_second, packet_burst); datagrams beyond it are dropped (throttled), and past
//    flood_kick_after throttled datagrams the connection is kicked. None of this changes what the
//    room's other connections, or other rooms, receive.
//  - Kicks are requests: next_kick() hands them to the process, which closes the connection and
//    then reports on_disconnect().
//  - Connect tokens (server/connect_token.h), when config.token_key is set: a hello is admitted
//    only with a token that opens under the key, has not expired by the wall clock
//    (set_wall_clock) and grants this room, slot (or a spectator place) and room parameters:
//    the room is created with the token's parameters, never with a hello's own. A slot whose
//    connection is there (live or silent) is taken over only by a token of the same client id
//    (a reconnect), else SlotOwned. A token held by a live connection (heard within
//    replace_silent_us) is refused to any other connection of another process (TokenInUse,
//    counted in token_replays): a copied token cannot take the slot while its holder plays.
//    Every refusal names its reason to the client. Without a key: the open behaviour above.
//  - Draining (start_drain): a hello that would create a room or join one not yet started is
//    refused (Draining); a hello into a running room (a player reconnecting after ENet dropped
//    it, a restarted process) is admitted as ever, so the room can finish. Bound clients get a
//    Draining notice; running rooms go on until their last connection leaves; drained() is then
//    true.
//  - Memory per room is bounded by its history (history_s of confirmed frames), its slots' input
//    windows and at most kMaxPendingChecks checksum rounds; per connection by constant state.
#pragma once

#include <cstdint>
#include <deque>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <unordered_map>
#include <vector>

#include "server/connect_token.h"
#include "server/relay_room.h"

namespace lockroll::server {

struct ServerConfig {
    RoomConfig room;                          // deadline, checksum interval, history, limits
    std::size_t max_rooms = 1000;
    std::size_t max_connections = 4000;
    int max_bad_packets = 16;
    double packets_per_second = 240;          // per connection, refill of its token bucket
    double packet_burst = 240;
    std::uint64_t flood_kick_after = 480;     // throttled datagrams before the kick
    std::uint64_t hello_timeout_us = 5'000'000;  // a connection that never says hello is kicked
    std::optional<TokenKey> token_key;        // set: every hello needs a connect token sealed with it
};

// Throws std::invalid_argument naming the field.
void validate(const ServerConfig& config);

struct ServerCounters {
    std::uint64_t rooms_created = 0;
    std::uint64_t rooms_closed = 0;
    std::uint64_t hellos_refused = 0;
    std::uint64_t tokens_refused = 0;    // hellos refused for their token: missing, invalid, expired, mismatched, slot owned
    std::uint64_t token_replays = 0;     // hellos refused for a token a live connection holds
    std::uint64_t bad_packets = 0;       // malformed, out of window, before hello, spoofed
    std::uint64_t throttled = 0;         // dropped by a token bucket
    std::uint64_t kicks = 0;
    std::uint64_t datagrams_in = 0;
    std::uint64_t datagrams_out = 0;
    std::uint64_t bytes_in = 0;
    std::uint64_t bytes_out = 0;
};

// What happened, for the process's log and the tests (drained with next_event()).
struct ServerEvent {
    enum class Kind : std::uint8_t {
        RoomCreated, RoomStarted, RoomClosed, Joined, Left, Refused, Kicked, Desync, Throttled,
    };
    Kind kind = Kind::RoomCreated;
    std::uint64_t room = 0;
    int slot = -1;               // -1: none / not bound
    std::uint32_t frame = 0;
    ConnectionId connection = 0;
    std::string detail;
};
const char* server_event_name(ServerEvent::Kind k);

class RelayServer {
public:
    explicit RelayServer(const ServerConfig& config);  // throws std::invalid_argument
    ~RelayServer();
    RelayServer(const RelayServer&) = delete;
    RelayServer& operator=(const RelayServer&) = delete;

    void on_connect(ConnectionId c, std::uint64_t now_us);
    void on_disconnect(ConnectionId c, std::uint64_t now_us);
    // A datagram from connection c. Never throws or asserts on its content.
    void receive(ConnectionId c, std::span<const std::uint8_t> datagram, std::uint64_t now_us);
    // Deadlines, periodic sends, silence. Call often (every millisecond or so).
    void tick(std::uint64_t now_us);
    // Moves the queued datagrams into out (appending).
    void take_outgoing(std::vector<Outgoing>& out);
    // Hands each queued datagram to send(Outgoing&) and empties the queue, keeping its buffers
    // for the next pass (the process's path: no allocation per datagram).
    template <class Send>
    void send_outgoing(Send&& send) {
        send_pending();
        for (Outgoing& o : out_.items()) {
            ++counters_.datagrams_out;
            counters_.bytes_out += o.bytes.size();
            send(o);
        }
        out_.clear();
    }
    bool next_kick(ConnectionId& out);
    bool next_event(ServerEvent& out);

    // The wall clock (Unix microseconds) at now_us: token expiry is judged on it. The process
    // sets it at start and every second; until then it is now_us itself.
    void set_wall_clock(std::uint64_t unix_us, std::uint64_t now_us);
    std::uint64_t unix_s(std::uint64_t now_us) const;

    void start_drain(std::uint64_t now_us);
    bool draining() const { return draining_; }
    bool drained() const { return draining_ && rooms_.empty(); }

    std::size_t room_count() const { return rooms_.size(); }
    std::size_t connection_count() const { return connections_.size(); }
    const ServerCounters& counters() const { return counters_; }
    // nullptr when no such room.
    const RelayRoom* room(std::uint64_t id) const;
    const ServerConfig& config() const { return config_; }

private:
    struct Connection {
        std::uint64_t room = 0;
        bool bound = false;
        std::uint64_t connected_us = 0;
        double tokens = 0;
        std::uint64_t refill_us = 0;
        std::uint64_t bad = 0;
        std::uint64_t throttled = 0;
        bool kicked = false;
        // With a key: what its token granted (a reconnect must show the same client id).
        std::uint64_t client_id = 0;
        std::uint64_t incarnation = 0;
        TokenTag token_tag{};
    };
    void handle_hello(ConnectionId c, Connection& conn, std::span<const std::uint8_t> d, std::uint64_t now_us);
    // None, or why the hello's connect token does not admit it (fills grant_, tag_).
    RelayRefusal check_token(ConnectionId c, const rollback::RelayHello& h, std::uint64_t now_us);
    void bad(ConnectionId c, Connection& conn, const char* why, std::uint64_t now_us);
    // Emits the room's verdicts from index `from` on and kicks the liars it found.
    void report_verdicts(RelayRoom& room, std::uint64_t id, std::size_t from, std::uint64_t now_us);
    void kick(ConnectionId c, Connection& conn, const char* why, std::uint64_t now_us);
    void refuse(ConnectionId c, RelayRefusal why, const rollback::RelayHello& h);
    void collect(RelayRoom& room);
    void close_room_if_done(std::uint64_t id);
    // Broadcasts the frames rooms confirmed since the last call (RelayRoom::send_pending).
    void send_pending();
    // Runs room id's periodic work (its tick, silence) if `due` is still its scheduled time.
    void service_room(std::uint64_t id, std::uint64_t due, std::uint64_t now_us);
    // Makes room id due by `due_us` at the latest.
    void schedule(std::uint64_t id, std::uint64_t due_us);
    struct RoomSlot;
    void schedule(RoomSlot& r, std::uint64_t id, std::uint64_t due_us);
    void emit(ServerEvent e);

    ServerConfig config_;
    std::unordered_map<ConnectionId, Connection> connections_;
    // A room and when its periodic work is next due (0: not scheduled).
    struct RoomSlot {
        std::unique_ptr<RelayRoom> room;
        std::uint64_t due = 0;
    };
    std::unordered_map<std::uint64_t, RoomSlot> rooms_;
    // tick() visits only the rooms that are due (a pass of a busy server must not walk a
    // thousand rooms): each room has one live entry (due, room) in a timing wheel of 1 ms slots
    // (kWheelSlots of them, a lap longer than any room's period), its time in RoomSlot::due;
    // entries whose time is no longer the room's are stale and skipped, entries a lap or more
    // ahead are kept until their time. A room is due at its next tick once started, else one
    // tick period after the last look (silence). Scheduling and taking are O(1): a binary heap
    // of a thousand rooms cost ~400 instructions per room tick.
    struct DueEntry {
        std::uint64_t due;
        std::uint64_t room;
    };
    static constexpr std::uint64_t kWheelSlots = 2048;  // ms
    std::vector<std::vector<DueEntry>> wheel_ = std::vector<std::vector<DueEntry>>(kWheelSlots);
    std::uint64_t wheel_ms_ = 0;           // slots before this ms are done
    bool wheel_started_ = false;
    std::vector<DueEntry> wheel_scratch_;
    // Connections not bound yet, in connection order, for the hello timeout: (id, connected_us).
    std::deque<std::pair<ConnectionId, std::uint64_t>> unbound_;
    std::vector<ConnectionId> silent_;
    std::vector<ConnectionId> liars_;  // report_verdicts() scratch
    std::vector<std::uint64_t> pending_rooms_;  // rooms with confirmed frames not broadcast yet
    Outbox out_;
    std::deque<ConnectionId> kicks_;
    std::deque<ServerEvent> events_;
    ServerCounters counters_;
    bool draining_ = false;
    rollback::RelayHello hello_;
    // Tokens of bound connections (by the first 8 bytes of their tag), for replays.
    std::unordered_map<std::uint64_t, ConnectionId> tokens_in_use_;
    std::int64_t wall_offset_us_ = 0;
    ConnectGrant grant_;
    TokenTag tag_{};
    std::vector<std::uint8_t> scratch_;
};

}  // namespace lockroll::server
