// libFuzzer target: arbitrary bytes as a replay file (rollback/replay.h, docs/replay-format.md).
// Property: decode_replay never crashes, and what it accepts encodes back to the same bytes (the
// format has one encoding per replay, so nothing unchecked can hide in an accepted file).
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <span>

#include "rollback/replay.h"

using namespace lockroll::rollback;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const std::span<const std::uint8_t> bytes(data, size);
    Replay r;
    if (decode_replay(bytes, r)) return 0;
    const auto again = encode_replay(r);
    if (!std::equal(again.begin(), again.end(), bytes.begin(), bytes.end())) std::abort();
    return 0;
}
