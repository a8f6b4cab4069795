// Connect tokens (server/connect_token.h): the sealed grant round trips, and every token the
// server must refuse is refused: a flipped byte anywhere, a wrong key, a wrong length or version,
// an expired token, a token for another room, slot, role or room parameters; the key and token
// files say what is wrong with them.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>

#include "server/connect_token.h"

namespace lockroll::server {
namespace {

using rollback::RelayHello;
using rollback::RelayRefusal;
using rollback::RelayRole;

ConnectGrant grant() {
    ConnectGrant g;
    g.room_id = 0x1122334455667788;
    g.client_id = 42;
    g.expires_unix_s = 1'800'000'000;
    g.slot = 1;
    g.players = 3;
    g.input_size = 3;
    g.tick_rate = 60;
    g.scene_checksum = 0xabcdef;
    g.absent_slots = 0x4;
    return g;
}

// The hello a client of this grant sends.
RelayHello hello_for(const ConnectGrant& g) {
    RelayHello h;
    h.room_id = g.room_id;
    h.slot = g.slot;
    h.also_slots = g.also_slots;
    h.role = g.role;
    h.players = g.players;
    h.input_size = g.input_size;
    h.tick_rate = g.tick_rate;
    h.scene_checksum = g.scene_checksum;
    h.absent_slots = g.absent_slots;
    return h;
}

TEST(ConnectToken, RoundTripsUnderItsKey) {
    const TokenKey key = new_token_key();
    const auto token = seal_token(grant(), key);
    EXPECT_EQ(token.size(), kConnectTokenBytes);
    EXPECT_EQ(token[0] | token[1] << 8, kConnectTokenVersion);  // little-endian version first
    ConnectGrant g;
    TokenTag tag{};
    ASSERT_EQ(open_token(token, key, g, tag), nullptr);
    EXPECT_EQ(g, grant());
    EXPECT_TRUE(std::equal(tag.begin(), tag.end(), token.end() - kTokenTagBytes));
    EXPECT_EQ(check_grant(g, hello_for(g), 1'799'999'999), RelayRefusal::None);
    // A fresh nonce per token: the same grant seals to other bytes and another tag.
    const auto again = seal_token(grant(), key);
    EXPECT_NE(again, token);
    TokenTag tag2{};
    ASSERT_EQ(open_token(again, key, g, tag2), nullptr);
    EXPECT_NE(tag2, tag);
}

TEST(ConnectToken, AFlippedByteAnywhereIsRefused) {
    const TokenKey key = new_token_key();
    const auto token = seal_token(grant(), key);
    ConnectGrant g;
    TokenTag tag{};
    for (std::size_t i = 0; i < token.size(); ++i)
        for (int bit : {0, 7}) {
            auto bad = token;
            bad[i] ^= static_cast<std::uint8_t>(1u << bit);
            EXPECT_NE(open_token(bad, key, g, tag), nullptr) << "byte " << i << " bit " << bit;
        }
}

TEST(ConnectToken, AnotherKeyAWrongLengthOrVersionIsRefused) {
    const TokenKey key = new_token_key();
    TokenKey other = key;
    other[31] ^= 1;
    const auto token = seal_token(grant(), key);
    ConnectGrant g;
    TokenTag tag{};
    EXPECT_STREQ(open_token(token, other, g, tag), "connect token: does not open under this key (forged, corrupted or another key)");
    EXPECT_STREQ(open_token(std::span(token).first(token.size() - 1), key, g, tag), "connect token: wrong length");
    auto longer = token;
    longer.push_back(0);
    EXPECT_NE(open_token(longer, key, g, tag), nullptr);
    EXPECT_NE(open_token({}, key, g, tag), nullptr);
    auto v1 = token;  // a version-1 token (no also_slots) is not read as this version
    v1[0] = 1;
    EXPECT_STREQ(open_token(v1, key, g, tag), "connect token: unknown version");
    // An all-zero token of the right size (a guess) does not open either.
    EXPECT_NE(open_token(std::vector<std::uint8_t>(kConnectTokenBytes, 0), key, g, tag), nullptr);
}

TEST(ConnectToken, ExpiredIsRefused) {
    const ConnectGrant g = grant();
    EXPECT_EQ(check_grant(g, hello_for(g), g.expires_unix_s - 1), RelayRefusal::None);
    EXPECT_EQ(check_grant(g, hello_for(g), g.expires_unix_s), RelayRefusal::TokenExpired);
    EXPECT_EQ(check_grant(g, hello_for(g), g.expires_unix_s + 3600), RelayRefusal::TokenExpired);
}

TEST(ConnectToken, AnotherRoomSlotRoleOrParametersIsRefused) {
    const ConnectGrant g = grant();
    const std::uint64_t now = g.expires_unix_s - 60;
    auto refused = [&](auto change) {
        RelayHello h = hello_for(g);
        change(h);
        return check_grant(g, h, now) == RelayRefusal::TokenMismatch;
    };
    EXPECT_TRUE(refused([](RelayHello& h) { h.room_id += 1; }));
    EXPECT_TRUE(refused([](RelayHello& h) { h.slot = 0; }));
    EXPECT_TRUE(refused([](RelayHello& h) { h.role = RelayRole::Spectator; }));
    EXPECT_TRUE(refused([](RelayHello& h) { h.players = 2; }));
    EXPECT_TRUE(refused([](RelayHello& h) { h.input_size = 2; }));
    EXPECT_TRUE(refused([](RelayHello& h) { h.tick_rate = 30; }));
    EXPECT_TRUE(refused([](RelayHello& h) { h.scene_checksum = 1; }));
    EXPECT_TRUE(refused([](RelayHello& h) { h.absent_slots = 0; }));
    // A player grant admits a joiner of the same slot (the server admits both alike).
    EXPECT_FALSE(refused([](RelayHello& h) { h.role = RelayRole::Joiner; }));
    // A spectator grant names no slot: any hello slot is fine, a player's hello is not.
    ConnectGrant s = g;
    s.role = RelayRole::Spectator;
    RelayHello h = hello_for(s);
    h.slot = 0;
    EXPECT_EQ(check_grant(s, h, now), RelayRefusal::None);
    h.role = RelayRole::Player;
    EXPECT_EQ(check_grant(s, h, now), RelayRefusal::TokenMismatch);
}

// A token lists every slot of its connection (several local players): the hello must name
// exactly that set, no slot more or less.
TEST(ConnectToken, ATokenForSeveralSlotsAdmitsExactlyThatSet) {
    const TokenKey key = new_token_key();
    ConnectGrant g = grant();  // slot 1 of 3
    g.absent_slots = 0;
    g.slot = 0;
    g.also_slots = 0x4;  // slots 0 and 2
    ConnectGrant opened;
    TokenTag tag{};
    ASSERT_EQ(open_token(seal_token(g, key), key, opened, tag), nullptr);
    EXPECT_EQ(opened.also_slots, 0x4);
    EXPECT_EQ(opened, g);
    const std::uint64_t now = g.expires_unix_s - 60;
    RelayHello h = hello_for(g);
    EXPECT_EQ(check_grant(g, h, now), RelayRefusal::None);
    h.also_slots = 0x6;  // slot 1 as well
    EXPECT_EQ(check_grant(g, h, now), RelayRefusal::TokenMismatch);
    h.also_slots = 0;  // slot 0 alone
    EXPECT_EQ(check_grant(g, h, now), RelayRefusal::TokenMismatch);
    // A one-slot token does not admit a couch either.
    RelayHello couch = hello_for(grant());
    couch.also_slots = 0x4;
    EXPECT_EQ(check_grant(grant(), couch, now), RelayRefusal::TokenMismatch);
    // Out of range: a further slot not above the first, past the room, or for a spectator.
    g.slot = 2;
    g.also_slots = 0x1;
    EXPECT_THROW(seal_token(g, key), std::invalid_argument);
    g.slot = 0;
    g.also_slots = 0x8;
    EXPECT_THROW(seal_token(g, key), std::invalid_argument);
    g.also_slots = 0x2;
    g.role = RelayRole::Spectator;
    EXPECT_THROW(seal_token(g, key), std::invalid_argument);
}

TEST(ConnectToken, AGrantOutOfRangeIsNotSealed) {
    const TokenKey key = new_token_key();
    ConnectGrant g = grant();
    g.slot = g.players;
    EXPECT_THROW(seal_token(g, key), std::invalid_argument);
    g = grant();
    g.players = 0;
    EXPECT_THROW(seal_token(g, key), std::invalid_argument);
    g = grant();
    g.tick_rate = 0;
    EXPECT_THROW(seal_token(g, key), std::invalid_argument);
}

TEST(ConnectToken, KeyAndTokenFilesRoundTripAndSayWhatIsWrong) {
    const auto dir = std::filesystem::temp_directory_path() / ("lockroll-token-test-" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir);
    const std::string key_path = (dir / "key").string(), token_path = (dir / "token").string();
    const TokenKey key = new_token_key();
    write_token_key(key_path, key);
    EXPECT_EQ(read_token_key(key_path), key);
    const auto token = seal_token(grant(), key);
    write_token_file(token_path, token);
    EXPECT_EQ(read_token_file(token_path), token);
    auto message = [](auto read, const std::string& path) {
        try {
            read(path);
        } catch (const std::invalid_argument& e) {
            return std::string(e.what());
        }
        return std::string("no error");
    };
    auto write = [](const std::string& path, const std::string& text) { std::ofstream(path, std::ios::trunc) << text; };
    const auto read_key = [](const std::string& p) { return read_token_key(p); };
    const auto read_tok = [](const std::string& p) { return read_token_file(p); };
    EXPECT_NE(message(read_key, (dir / "missing").string()).find("cannot be read"), std::string::npos);
    write(key_path, "00ff");
    EXPECT_NE(message(read_key, key_path).find("must hold 64 hex digits"), std::string::npos);
    write(key_path, std::string(64, 'g'));
    EXPECT_NE(message(read_key, key_path).find("is not hex text"), std::string::npos);
    write(key_path, "\n");
    EXPECT_NE(message(read_key, key_path).find("is empty"), std::string::npos);
    write(token_path, std::string(2 * (rollback::kRelayMaxTokenBytes + 1), 'a'));
    EXPECT_NE(message(read_tok, token_path).find("at most"), std::string::npos);
    EXPECT_NE(message(read_tok, key_path).find(key_path), std::string::npos);  // names the file
    std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace lockroll::server
