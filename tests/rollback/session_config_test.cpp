// validate(SessionConfig) (rollback/session.h) on its own: the defaults pass, and each
// unusable field is refused by a message that names it.
#include "rollback/session.h"

#include <gtest/gtest.h>

#include <functional>
#include <stdexcept>
#include <string>

using namespace lockroll::rollback;

namespace {
// The message validate() throws for the config `change` makes of the defaults ("" if none).
std::string refusal(const std::function<void(SessionConfig&)>& change) {
    SessionConfig c;
    change(c);
    try {
        validate(c);
    } catch (const std::invalid_argument& e) {
        return e.what();
    }
    return "";
}
}  // namespace

TEST(SessionConfig, DefaultsPass) { EXPECT_EQ(refusal([](SessionConfig&) {}), ""); }

TEST(SessionConfig, EachBadFieldIsNamed) {
    const struct {
        std::function<void(SessionConfig&)> change;
        const char* names;
    } cases[] = {
        {[](SessionConfig& c) { c.players = 0; }, "players"},
        {[](SessionConfig& c) { c.players = kMaxPlayers + 1; }, "players"},
        {[](SessionConfig& c) { c.local_player = 2; }, "local_player"},
        {[](SessionConfig& c) { c.input_size = 0; }, "input_size"},
        {[](SessionConfig& c) { c.input_capacity = 100; }, "input_capacity"},
        {[](SessionConfig& c) { c.input_delay = 257; }, "input_delay"},
        {[](SessionConfig& c) { c.prediction_window = 121; }, "prediction_window"},
        {[](SessionConfig& c) { c.checksum_interval = 0; }, "checksum_interval"},
        {[](SessionConfig& c) { c.interrupt_us = c.disconnect_us; }, "interrupt_us"},
        {[](SessionConfig& c) { c.role = Role::Joiner; }, "handshake"},
        {[](SessionConfig& c) { c.absent_slots = 1; }, "absent"},
        {[](SessionConfig& c) { c.slot_hosts = {0}; }, "slot_hosts"},
        {[](SessionConfig& c) { c.slot_hosts = {1, 1}; }, "slot_hosts[0]"},
        // Any int is refused without overflow (found by fuzz/capi_fuzz.cpp through spectators()).
        {[](SessionConfig& c) { c.max_spectators = 2147483647; }, "max_spectators"},
        {[](SessionConfig& c) { c.max_spectators = 254; }, "max_spectators"},
    };
    for (const auto& k : cases) {
        const std::string why = refusal(k.change);
        EXPECT_EQ(why.rfind("session config: ", 0), 0u) << why;
        EXPECT_NE(why.find(k.names), std::string::npos) << why << " should name " << k.names;
    }
}

TEST(SessionConfig, AShortInputRingRefusesAWindowItCannotKeep) {
    // 64 frames keep a quarter (16) behind: a window of 16 does not fit, 15 does.
    EXPECT_NE(refusal([](SessionConfig& c) {
                  c.input_capacity = 64;
                  c.prediction_window = 16;
              }).find("prediction_window"),
              std::string::npos);
    EXPECT_EQ(refusal([](SessionConfig& c) {
                  c.input_capacity = 64;
                  c.prediction_window = 15;
                  c.input_delay = 2;
              }),
              "");
}
