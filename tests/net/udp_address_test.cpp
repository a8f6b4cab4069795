#include "net/udp_address.h"

#include <gtest/gtest.h>

#include <string>

namespace lockroll::net {
namespace {

TEST(UdpAddress, ParsesLoopbackForms) {
    std::string error;
    auto a = parse_udp_address("127.0.0.1:9000", &error);
    ASSERT_TRUE(a) << error;
    EXPECT_EQ(a->port(), 9000);
    EXPECT_TRUE(a->is_loopback());
    EXPECT_EQ(a->to_string(), "127.0.0.1:9000");

    a = parse_udp_address("[::1]:7", &error);
    ASSERT_TRUE(a) << error;
    EXPECT_TRUE(a->is_loopback());
    EXPECT_EQ(a->to_string(), "[::1]:7");

    a = parse_udp_address("127.8.9.10:0", &error);
    ASSERT_TRUE(a) << error;
    EXPECT_TRUE(a->is_loopback());  // all of 127.0.0.0/8

    a = parse_udp_address("localhost:5", &error);
    ASSERT_TRUE(a) << error;
    EXPECT_EQ(a->to_string(), "127.0.0.1:5");

    a = parse_udp_address("4242", &error, "127.0.0.1");  // bare port where a default host is given
    ASSERT_TRUE(a) << error;
    EXPECT_EQ(a->to_string(), "127.0.0.1:4242");
    EXPECT_EQ(a->with_port(1).port(), 1);
}

TEST(UdpAddress, NonLoopbackParsesButIsNotLoopback) {
    std::string error;
    for (const char* text : {"10.0.0.1:1", "128.0.0.1:1", "[2001:db8::1]:1", "[::ffff:127.0.0.1]:1", "0.0.0.0:1"}) {
        const auto a = parse_udp_address(text, &error);
        ASSERT_TRUE(a) << text << ": " << error;
        EXPECT_FALSE(a->is_loopback()) << text;
    }
}

TEST(UdpAddress, RejectsMalformedTextNamingIt) {
    for (const char* text : {"", "127.0.0.1", "127.0.0.1:", "127.0.0.1:65536", "127.0.0.1:-1", "127.0.0.1:80x",
                             "::1:80", "[::1]80", "[::1", "example.com:80", "4242"}) {
        std::string error;
        EXPECT_FALSE(parse_udp_address(text, &error)) << text;
        EXPECT_NE(error.find(std::string("'") + text + "'"), std::string::npos) << text << ": " << error;
    }
}

TEST(UdpAddress, KeysTellEndpointsApart) {
    std::string error;
    const auto a = *parse_udp_address("127.0.0.1:1000", &error);
    EXPECT_EQ(a.key(), parse_udp_address("127.0.0.1:1000", &error)->key());
    EXPECT_NE(a.key(), parse_udp_address("127.0.0.1:1001", &error)->key());
    EXPECT_NE(a.key(), parse_udp_address("127.0.0.2:1000", &error)->key());
    EXPECT_NE(a.key(), parse_udp_address("[::1]:1000", &error)->key());
}

}  // namespace
}  // namespace lockroll::net
