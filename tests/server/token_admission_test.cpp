// A relay server started with a key (connect tokens, server/connect_token.h) through its sans-IO
// API in virtual time: token-less, forged, expired, mismatched, replayed and stolen-slot hellos
// are refused with their reason and counted, the room takes its parameters from the token, and
// the honest holders play on. Links lockroll_server only.
#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <vector>

#include "server/relay_server.h"

namespace lockroll::server {
namespace {

using namespace lockroll::rollback;

constexpr std::uint64_t kRoom = 7;
constexpr std::uint64_t kUnixStart = 1'800'000'000;  // the wall clock at the test's start, s

class Tokens : public ::testing::Test {
protected:
    void SetUp() override {
        key = new_token_key();
        ServerConfig c;
        c.token_key = key;
        server = std::make_unique<RelayServer>(c);
        server->set_wall_clock(kUnixStart * 1'000'000, now);
    }

    std::map<ConnectionId, std::uint16_t> plays;  // by hello()
    ConnectGrant grant(int slot, std::uint64_t client_id, std::uint64_t expires_in_s = 600) const {
        ConnectGrant g;
        g.room_id = kRoom;
        g.client_id = client_id;
        g.expires_unix_s = kUnixStart + expires_in_s;
        g.slot = static_cast<std::uint8_t>(slot);
        g.players = 2;
        g.input_size = 2;
        g.tick_rate = 60;
        g.scene_checksum = 5;
        return g;
    }
    std::vector<std::uint8_t> token(int slot, std::uint64_t client_id, std::uint64_t expires_in_s = 600) const {
        return seal_token(grant(slot, client_id, expires_in_s), key);
    }
    // A hello on connection c with the grant's parameters, carrying `tok`.
    void hello(ConnectionId c, int slot, const std::vector<std::uint8_t>& tok, std::uint64_t incarnation = 0,
               std::uint8_t players = 2, std::uint16_t also = 0) {
        if (!seen.count(c)) server->on_connect(c, now);
        seen[c] = true;
        RelayHello h;
        h.room_id = kRoom;
        h.players = players;
        h.input_size = 2;
        h.tick_rate = 60;
        h.scene_checksum = 5;
        h.slot = static_cast<std::uint8_t>(slot);
        h.also_slots = also;
        plays[c] = relay_hello_slots(h);
        h.incarnation = incarnation ? incarnation : 1000 + c;
        h.token = tok;
        std::vector<std::uint8_t> b;
        encode(h, b);
        server->receive(c, b, now);
        drain();
    }
    void inputs(ConnectionId c, std::uint32_t first, int count) {
        RelayInput m;
        m.first_frame = first;
        m.frame_count = static_cast<std::uint8_t>(count);
        m.slots = plays[c];  // the slot this connection said hello for
        m.inputs.assign(static_cast<std::size_t>(count) * 2 * static_cast<std::size_t>(relay_slot_count(m.slots)), 1);
        std::vector<std::uint8_t> b;
        encode(m, 2, b);
        server->receive(c, b, now);
    }
    void advance(std::uint64_t us) {
        for (std::uint64_t t = 0; t < us; t += 1000) {
            now += 1000;
            server->tick(now);
        }
        drain();
    }
    void drain() {
        std::vector<Outgoing> out;
        server->take_outgoing(out);
        for (auto& o : out)
            if (peek_relay_kind(o.bytes) == RelayKind::Welcome) {
                RelayWelcome w;
                ASSERT_EQ(decode(o.bytes, w), nullptr);
                last[o.to] = w.refusal;
            }
        for (ConnectionId k; server->next_kick(k);) {
            kicked.push_back(k);
            server->on_disconnect(k, now);
            seen.erase(k);  // a later hello on this id is a new connection
        }
    }
    bool was_kicked(ConnectionId c) const { return std::find(kicked.begin(), kicked.end(), c) != kicked.end(); }
    // Slots 0 and 1 on connections 1 and 2, client ids 11 and 12, started.
    void start_room() {
        hello(1, 0, tok0);
        hello(2, 1, tok1);
        ASSERT_EQ(last[1], RelayRefusal::None);
        ASSERT_EQ(last[2], RelayRefusal::None);
        ASSERT_TRUE(server->room(kRoom)->started());
    }

    // The room started, then slot 1 silent for over a second (replace_silent_us), still held,
    // while slot 0 plays.
    void start_with_slot1_silent() {
        tok0 = token(0, 11);
        tok1 = token(1, 12);
        start_room();
        for (int i = 0; i < 80; ++i) {
            inputs(1, static_cast<std::uint32_t>(i), 1);
            advance(16'667);
        }
        ASSERT_EQ(server->room(kRoom)->slot_of(2), 1);
    }

    TokenKey key{};
    std::unique_ptr<RelayServer> server;
    std::uint64_t now = 1'000'000;
    std::map<ConnectionId, bool> seen;
    std::map<ConnectionId, RelayRefusal> last;
    std::vector<ConnectionId> kicked;
    std::vector<std::uint8_t> tok0 = {}, tok1 = {};
};

TEST_F(Tokens, HonestTokensStartTheRoomWithTheTokensParameters) {
    tok0 = token(0, 11);
    tok1 = token(1, 12);
    start_room();
    const RelayRoom& room = *server->room(kRoom);
    EXPECT_EQ(room.players(), 2);
    EXPECT_EQ(room.tick_rate(), 60);
    EXPECT_EQ(room.slot_of(1), 0);
    EXPECT_EQ(room.slot_of(2), 1);
    inputs(1, 0, 4);
    inputs(2, 0, 4);
    EXPECT_EQ(room.confirmed_frames(), 4u);
    EXPECT_EQ(server->counters().tokens_refused, 0u);
}

TEST_F(Tokens, ATokenlessHelloIsRefusedAndCreatesNoRoom) {
    hello(1, 0, {});
    EXPECT_EQ(last[1], RelayRefusal::TokenMissing);
    EXPECT_TRUE(was_kicked(1));
    EXPECT_EQ(server->room_count(), 0u);
    EXPECT_EQ(server->counters().tokens_refused, 1u);
}

TEST_F(Tokens, ForgedTokensAreRefused) {
    // Random bytes of the right size, a real token with a flipped byte, a token of another key.
    hello(1, 0, std::vector<std::uint8_t>(kConnectTokenBytes, 0x5a));
    EXPECT_EQ(last[1], RelayRefusal::TokenInvalid);
    auto flipped = token(0, 11);
    flipped[30] ^= 1;
    hello(2, 0, flipped);
    EXPECT_EQ(last[2], RelayRefusal::TokenInvalid);
    hello(3, 0, seal_token(grant(0, 11), new_token_key()));
    EXPECT_EQ(last[3], RelayRefusal::TokenInvalid);
    EXPECT_EQ(server->room_count(), 0u);
    EXPECT_EQ(server->counters().tokens_refused, 3u);
    EXPECT_EQ(server->counters().kicks, 3u);
}

TEST_F(Tokens, AnExpiredTokenIsRefusedAndAReconnectAfterExpiryToo) {
    hello(1, 0, token(0, 11, 0));  // expires at the start
    EXPECT_EQ(last[1], RelayRefusal::TokenExpired);
    tok0 = token(0, 11, 2);  // valid two more seconds
    tok1 = token(1, 12, 600);
    start_room();
    // Slot 0's process loses its connection after the expiry: its token no longer admits it,
    // even with its own incarnation.
    server->on_disconnect(1, now);
    advance(3'000'000);
    hello(4, 0, tok0, 1000 + 1);
    EXPECT_EQ(last[4], RelayRefusal::TokenExpired);
    EXPECT_EQ(server->room(kRoom)->slot_of(4), -1);
}

// A couch (one connection, slots 0 and 1) holds one token listing both: it admits exactly that
// set; a one-slot token of another client id cannot take either slot while the couch holds it.
TEST_F(Tokens, ACouchTokenAdmitsItsSlotsTogether) {
    ConnectGrant couch = grant(0, 21);
    couch.also_slots = 0x2;
    const auto tok = seal_token(couch, key);
    hello(1, 0, tok);  // slot 0 alone with the couch's token
    EXPECT_EQ(last[1], RelayRefusal::TokenMismatch);
    hello(2, 0, token(0, 21), 0, 2, 0x2);  // both slots with a one-slot token
    EXPECT_EQ(last[2], RelayRefusal::TokenMismatch);
    EXPECT_EQ(server->room_count(), 0u);
    hello(3, 0, tok, 0, 2, 0x2);
    ASSERT_EQ(last[3], RelayRefusal::None);
    ASSERT_TRUE(server->room(kRoom)->started());  // one connection fills the 2-player room
    EXPECT_EQ(server->room(kRoom)->connection_slots(3), 0x3);
    inputs(3, 0, 4);
    EXPECT_EQ(server->room(kRoom)->confirmed_frames(), 4u);
    // Slot 1 belongs to the couch's client id: another's token for it is refused.
    hello(4, 1, token(1, 22));
    EXPECT_EQ(last[4], RelayRefusal::SlotOwned);
    EXPECT_EQ(server->counters().bad_packets, 0u);
}

TEST_F(Tokens, ATokenForAnotherSlotRoomOrParametersIsRefused) {
    tok0 = token(0, 11);
    hello(1, 1, tok0);  // slot 0's token naming slot 1
    EXPECT_EQ(last[1], RelayRefusal::TokenMismatch);
    hello(2, 0, tok0, 0, 3);  // a hello that would make the room 3 players
    EXPECT_EQ(last[2], RelayRefusal::TokenMismatch);
    ConnectGrant other = grant(0, 11);
    other.room_id = kRoom + 1;
    hello(3, 0, seal_token(other, key));
    EXPECT_EQ(last[3], RelayRefusal::TokenMismatch);
    EXPECT_EQ(server->room_count(), 0u);
    // Whoever speaks first does not set the parameters: a first hello for 3 players with a
    // 2-player token created nothing, and the honest 2-player room starts.
    tok1 = token(1, 12);
    start_room();
    EXPECT_EQ(server->room(kRoom)->players(), 2);
}

TEST_F(Tokens, AReplayedTokenCannotTakeALiveSlot) {
    tok0 = token(0, 11);
    tok1 = token(1, 12);
    start_room();
    inputs(1, 0, 2);
    inputs(2, 0, 2);
    // Another process (another incarnation) presents slot 1's token while its holder plays.
    hello(3, 1, tok1, 999);
    EXPECT_EQ(last[3], RelayRefusal::TokenInUse);
    EXPECT_TRUE(was_kicked(3));
    EXPECT_EQ(server->counters().token_replays, 1u);
    EXPECT_FALSE(was_kicked(2));
    EXPECT_EQ(server->room(kRoom)->slot_of(2), 1);
    inputs(1, 2, 2);
    inputs(2, 2, 2);
    EXPECT_EQ(server->room(kRoom)->confirmed_frames(), 4u);  // nothing replaced: both play on
    EXPECT_EQ(server->room(kRoom)->slot_counters(1).replaced, 0u);
    // The holder's own process on a new connection (its incarnation) resumes with it.
    hello(4, 1, tok1, 1000 + 2);
    EXPECT_EQ(last[4], RelayRefusal::None);
    EXPECT_EQ(server->room(kRoom)->slot_of(4), 1);
    EXPECT_TRUE(was_kicked(2));
}

TEST_F(Tokens, ASilentSlotGoesBackOnlyToItsClientId) {
    start_with_slot1_silent();
    // A valid token for slot 1, of another client id: the slot is not its to take.
    hello(3, 1, token(1, 99), 999);
    EXPECT_EQ(last[3], RelayRefusal::SlotOwned);
    EXPECT_EQ(server->room(kRoom)->slot_of(2), 1);
    EXPECT_EQ(server->counters().tokens_refused, 1u);
    // Slot 0's token cannot be turned on slot 1 either.
    hello(4, 1, tok0, 998);
    EXPECT_EQ(last[4], RelayRefusal::TokenMismatch);
    // The same client id, restarted (new incarnation, a token the backend issued again): takes it back.
    hello(5, 1, token(1, 12), 997);
    EXPECT_EQ(last[5], RelayRefusal::None);
    EXPECT_EQ(server->room(kRoom)->slot_of(5), 1);
    EXPECT_TRUE(was_kicked(2));
    EXPECT_FALSE(was_kicked(1));
}

TEST_F(Tokens, ASilentHoldersOwnTokenTakesItsSlotBack) {
    start_with_slot1_silent();
    // Silent: the same token from a restarted process is a reconnect, not a replay.
    hello(3, 1, tok1, 999);
    EXPECT_EQ(last[3], RelayRefusal::None);
    EXPECT_EQ(server->room(kRoom)->slot_of(3), 1);
    EXPECT_EQ(server->counters().token_replays, 0u);
}

TEST(TokensOff, AServerWithoutAKeyKeepsTheOpenBehaviour) {
    RelayServer s(ServerConfig{});
    s.on_connect(1, 0);
    RelayHello h;
    h.room_id = kRoom;
    h.input_size = 2;
    std::vector<std::uint8_t> b;
    encode(h, b);
    s.receive(1, b, 0);
    EXPECT_EQ(s.room_count(), 1u);  // created by the first hello, as ever
    EXPECT_EQ(s.room(kRoom)->slot_of(1), 0);
}

}  // namespace
}  // namespace lockroll::server
