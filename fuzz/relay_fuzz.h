// The relay fuzzer's input format, shared by the target and the seed writer: a script of
// operations on one RelayServer, each [op][connection][length lo][length hi][bytes...]:
//   op % 5 == 0  connection opens          3  time passes: bytes[0] milliseconds, then tick()
//   op % 5 == 1  connection closes         4  the server's outgoing queue and kicks are taken
//   op % 5 == 2  datagram `bytes` from the connection
#pragma once

#include <cstdint>
#include <vector>

namespace lockroll::fuzz {

enum RelayOp : std::uint8_t { kOpen = 0, kClose = 1, kDatagram = 2, kTime = 3, kTake = 4 };

inline void relay_op(std::vector<std::uint8_t>& script, RelayOp op, std::uint8_t connection,
                     const std::vector<std::uint8_t>& bytes = {}) {
    script.push_back(op);
    script.push_back(connection);
    script.push_back(static_cast<std::uint8_t>(bytes.size()));
    script.push_back(static_cast<std::uint8_t>(bytes.size() >> 8));
    script.insert(script.end(), bytes.begin(), bytes.end());
}

}  // namespace lockroll::fuzz
