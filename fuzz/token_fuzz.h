// The token fuzzer's fixed key and wall clock, shared by the target and the seed writer (which
// seals the seed tokens with this key, so the fuzzer starts from tokens that open).
#pragma once

#include <cstdint>

#include "server/connect_token.h"

namespace lockroll::fuzz {

inline constexpr server::TokenKey kFuzzTokenKey = {0x6c, 0x6f, 0x63, 0x6b, 0x72, 0x6f, 0x6c, 0x6c, 1,  2,  3,
                                                   4,    5,    6,    7,    8,    9,    10,   11,   12, 13, 14,
                                                   15,   16,   17,   18,   19,   20,   21,   22,   23, 24};
inline constexpr std::uint64_t kFuzzUnixS = 1'800'000'000;  // the server's wall clock in the target

}  // namespace lockroll::fuzz
