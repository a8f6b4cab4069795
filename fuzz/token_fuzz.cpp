// libFuzzer target: connect tokens (server/connect_token.h) as a keyed relay server meets them.
// The input is a token. Properties beyond "no crash, no sanitizer report":
//  - a token that opens re-seals and opens to the same grant;
//  - the server admits a hello carrying the token exactly when the codec says so: a token that
//    does not open, or whose grant refuses the hello (expired, mismatched), creates no room and
//    its connection is kicked; one that opens and fits binds its connection in the grant's room.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <span>
#include <vector>

#include "fuzz/token_fuzz.h"
#include "server/relay_server.h"

using namespace lockroll;
using namespace lockroll::rollback;

namespace {
void check(bool ok) {
    if (!ok) std::abort();
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const std::span<const std::uint8_t> token(data, std::min(size, kRelayMaxTokenBytes));
    server::ConnectGrant g;
    server::TokenTag tag{};
    const bool opened = server::open_token(token, fuzz::kFuzzTokenKey, g, tag) == nullptr;
    if (opened) {
        server::ConnectGrant again;
        server::TokenTag tag2{};
        check(server::open_token(server::seal_token(g, fuzz::kFuzzTokenKey), fuzz::kFuzzTokenKey, again, tag2) == nullptr);
        check(again == g);
    }
    // The hello a client of the grant would send (a fixed one when the token does not open).
    RelayHello h;
    h.room_id = opened ? g.room_id : 7;
    h.role = opened ? g.role : RelayRole::Player;
    h.slot = opened ? g.slot : 0;
    h.also_slots = opened && g.role != RelayRole::Spectator ? g.also_slots : 0;  // a couch's token: all its slots
    h.players = opened ? g.players : 2;
    h.input_size = opened ? g.input_size : 3;
    h.tick_rate = opened ? g.tick_rate : 60;
    h.scene_checksum = opened ? g.scene_checksum : 0;
    h.absent_slots = opened ? g.absent_slots : 0;
    h.incarnation = 1;
    h.token.assign(token.begin(), token.end());
    const bool admitted = opened && server::check_grant(g, h, fuzz::kFuzzUnixS) == RelayRefusal::None;

    server::ServerConfig config;
    config.token_key = fuzz::kFuzzTokenKey;
    server::RelayServer s(config);
    const std::uint64_t now = 1'000'000;
    s.set_wall_clock(fuzz::kFuzzUnixS * 1'000'000, now);
    s.on_connect(1, now);
    std::vector<std::uint8_t> bytes;
    encode(h, bytes);
    s.receive(1, bytes, now);
    server::ConnectionId kicked = 0;
    const bool was_kicked = s.next_kick(kicked);
    if (admitted) {
        check(!was_kicked && s.room(h.room_id) != nullptr && s.room(h.room_id)->slot_of(1) >= 0);
        check(s.room(h.room_id)->connection_slots(1) == relay_hello_slots(h));
        check(s.counters().tokens_refused == 0);
    } else {
        check(was_kicked && kicked == 1 && s.room_count() == 0);
        check(s.counters().tokens_refused == 1);
    }
    return 0;
}
