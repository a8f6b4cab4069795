#include "server/connect_token.h"

#include <sodium.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <stdexcept>

#include "rollback/bytes.h"

namespace lockroll::server {

using rollback::RelayHello;
using rollback::RelayRefusal;
using rollback::RelayRole;

namespace {
static_assert(crypto_aead_xchacha20poly1305_ietf_KEYBYTES == std::tuple_size_v<TokenKey>);
static_assert(crypto_aead_xchacha20poly1305_ietf_NPUBBYTES == kTokenNonceBytes);
static_assert(crypto_aead_xchacha20poly1305_ietf_ABYTES == kTokenTagBytes);
constexpr std::size_t kAdBytes = 2 + kTokenNonceBytes;  // version and nonce: authenticated, not secret

// sodium_init is idempotent and thread-safe; it must have run before any other call.
bool sodium_ready() {
    static const bool ok = sodium_init() >= 0;
    return ok;
}

void require_sodium() {
    if (!sodium_ready()) throw std::runtime_error("libsodium failed to initialise");
}

bool grant_in_range(const ConnectGrant& g) {
    return g.players >= 1 && g.players <= rollback::kRelayMaxPlayers && g.input_size >= 1 &&
           g.input_size <= rollback::kRelayMaxInputSize && g.tick_rate >= 1 && g.tick_rate <= 1000 &&
           static_cast<std::uint8_t>(g.role) <= rollback::kLastRelayRole &&
           (g.role == RelayRole::Spectator ? g.also_slots == 0
                                           : g.slot < g.players && (g.also_slots >> g.players) == 0 &&
                                                 (g.also_slots & ((2u << g.slot) - 1)) == 0);
}

std::string read_text(const std::string& path, const char* what) {
    std::ifstream f(path, std::ios::binary);
    if (!f) throw std::invalid_argument(std::string(what) + " file '" + path + "' cannot be read");
    std::string text((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
    if (text.size() > 4096) throw std::invalid_argument(std::string(what) + " file '" + path + "' is too large");
    const auto first = text.find_first_not_of(" \t\r\n");
    if (first == std::string::npos) return {};
    return text.substr(first, text.find_last_not_of(" \t\r\n") - first + 1);
}

// Hex text to bytes (libsodium's decoder); throws naming the file.
std::vector<std::uint8_t> unhex(const std::string& text, const std::string& path, const char* what) {
    require_sodium();
    if (text.empty()) throw std::invalid_argument(std::string(what) + " file '" + path + "' is empty");
    std::vector<std::uint8_t> out(text.size() / 2 + 1);
    std::size_t n = 0;
    const char* end = nullptr;
    if (text.size() % 2 != 0 ||
        sodium_hex2bin(out.data(), out.size(), text.data(), text.size(), nullptr, &n, &end) != 0 ||
        end != text.data() + text.size())
        throw std::invalid_argument(std::string(what) + " file '" + path + "' is not hex text");
    out.resize(n);
    return out;
}

void write_hex(const std::string& path, std::span<const std::uint8_t> bytes, const char* what) {
    require_sodium();
    std::string hex(bytes.size() * 2 + 1, '\0');
    sodium_bin2hex(hex.data(), hex.size(), bytes.data(), bytes.size());
    hex.back() = '\n';
    std::ofstream f(path, std::ios::binary | std::ios::trunc);
    f << hex;
    if (!f) throw std::invalid_argument(std::string(what) + " file '" + path + "' cannot be written");
}
}  // namespace

bool operator==(const ConnectGrant& a, const ConnectGrant& b) {
    return a.room_id == b.room_id && a.client_id == b.client_id && a.expires_unix_s == b.expires_unix_s &&
           a.role == b.role && a.slot == b.slot && a.also_slots == b.also_slots && a.players == b.players && a.input_size == b.input_size &&
           a.tick_rate == b.tick_rate && a.scene_checksum == b.scene_checksum && a.absent_slots == b.absent_slots;
}

TokenKey new_token_key() {
    require_sodium();
    TokenKey key;
    crypto_aead_xchacha20poly1305_ietf_keygen(key.data());
    return key;
}

std::vector<std::uint8_t> seal_token(const ConnectGrant& g, const TokenKey& key) {
    require_sodium();
    if (!grant_in_range(g)) throw std::invalid_argument("connect token: grant out of range");
    std::vector<std::uint8_t> plain;
    rollback::ByteWriter w(plain);
    w.u64(g.room_id);
    w.u64(g.client_id);
    w.u64(g.expires_unix_s);
    w.u8(static_cast<std::uint8_t>(g.role));
    w.u8(g.slot);
    w.u16(g.also_slots);
    w.u8(g.players);
    w.u8(g.input_size);
    w.u16(g.tick_rate);
    w.u64(g.scene_checksum);
    w.u16(g.absent_slots);
    std::vector<std::uint8_t> token;
    rollback::ByteWriter t(token);
    t.u16(kConnectTokenVersion);
    token.resize(kConnectTokenBytes);
    randombytes_buf(token.data() + 2, kTokenNonceBytes);
    unsigned long long sealed = 0;
    crypto_aead_xchacha20poly1305_ietf_encrypt(token.data() + kAdBytes, &sealed, plain.data(), plain.size(), token.data(),
                                               kAdBytes, nullptr, token.data() + 2, key.data());
    token.resize(kAdBytes + static_cast<std::size_t>(sealed));
    return token;
}

const char* open_token(std::span<const std::uint8_t> token, const TokenKey& key, ConnectGrant& g, TokenTag& tag) {
    if (!sodium_ready()) return "connect token: libsodium failed to initialise";
    if (token.size() != kConnectTokenBytes) return "connect token: wrong length";
    rollback::ByteReader head(token);
    if (head.u16() != kConnectTokenVersion) return "connect token: unknown version";
    std::array<std::uint8_t, kConnectGrantBytes> plain{};
    unsigned long long n = 0;
    if (crypto_aead_xchacha20poly1305_ietf_decrypt(plain.data(), &n, nullptr, token.data() + kAdBytes,
                                                   token.size() - kAdBytes, token.data(), kAdBytes, token.data() + 2,
                                                   key.data()) != 0 ||
        n != kConnectGrantBytes)
        return "connect token: does not open under this key (forged, corrupted or another key)";
    rollback::ByteReader r(plain);
    g.room_id = r.u64();
    g.client_id = r.u64();
    g.expires_unix_s = r.u64();
    const std::uint8_t role = r.u8();
    g.slot = r.u8();
    g.also_slots = r.u16();
    g.players = r.u8();
    g.input_size = r.u8();
    g.tick_rate = r.u16();
    g.scene_checksum = r.u64();
    g.absent_slots = r.u16();
    if (!r.ok() || !r.at_end()) return "connect token: grant of the wrong size";
    if (role > rollback::kLastRelayRole) return "connect token: unknown role";
    g.role = static_cast<RelayRole>(role);
    // Only the key's holder seals, so this is a backend's bug, still refused rather than trusted.
    if (!grant_in_range(g)) return "connect token: grant out of range";
    std::copy(token.end() - static_cast<std::ptrdiff_t>(kTokenTagBytes), token.end(), tag.begin());
    return nullptr;
}

RelayRefusal check_grant(const ConnectGrant& g, const RelayHello& h, std::uint64_t unix_s) {
    if (unix_s >= g.expires_unix_s) return RelayRefusal::TokenExpired;
    const bool spectator = g.role == RelayRole::Spectator;
    if (h.room_id != g.room_id || (h.role == RelayRole::Spectator) != spectator || (!spectator && (h.slot != g.slot || h.also_slots != g.also_slots)) ||
        h.players != g.players || h.input_size != g.input_size || h.tick_rate != g.tick_rate ||
        h.scene_checksum != g.scene_checksum || h.absent_slots != g.absent_slots)
        return RelayRefusal::TokenMismatch;
    return RelayRefusal::None;
}

TokenKey read_token_key(const std::string& path) {
    const auto bytes = unhex(read_text(path, "key"), path, "key");
    TokenKey key;
    if (bytes.size() != key.size())
        throw std::invalid_argument("key file '" + path + "' must hold 64 hex digits (32 bytes), not " +
                                    std::to_string(bytes.size()) + " bytes");
    std::copy(bytes.begin(), bytes.end(), key.begin());
    return key;
}

void write_token_key(const std::string& path, const TokenKey& key) {
    write_hex(path, key, "key");
    std::error_code ec;  // a secret: readable by its owner only (where the filesystem has modes)
    std::filesystem::permissions(path, std::filesystem::perms::owner_read | std::filesystem::perms::owner_write,
                                 std::filesystem::perm_options::replace, ec);
}

std::vector<std::uint8_t> read_token_file(const std::string& path) {
    auto bytes = unhex(read_text(path, "token"), path, "token");
    // Opaque to the client: only its size is checked here (the hello's limit); the server judges the rest.
    if (bytes.size() > rollback::kRelayMaxTokenBytes)
        throw std::invalid_argument("token file '" + path + "' holds " + std::to_string(bytes.size()) +
                                    " bytes: a token is at most " + std::to_string(rollback::kRelayMaxTokenBytes));
    return bytes;
}

void write_token_file(const std::string& path, std::span<const std::uint8_t> token) { write_hex(path, token, "token"); }

}  // namespace lockroll::server
