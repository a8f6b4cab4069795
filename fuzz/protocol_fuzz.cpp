// libFuzzer target: arbitrary bytes into every wire-message decoder (rollback/protocol.h).
// Property beyond "no crash, no sanitizer report": whatever a decoder accepts, the encoder can
// write again (no std::invalid_argument) and decoding that gives the same message back.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <span>
#include <vector>

#include "rollback/protocol.h"

using namespace lockroll::rollback;

namespace {
bool same(const InputMessage& a, const InputMessage& b) {
    if (a.ack != b.ack || a.first_frame != b.first_frame || a.frame_count != b.frame_count || a.inputs != b.inputs ||
        a.has_time_sync != b.has_time_sync || a.checksum_count != b.checksum_count)
        return false;
    if (a.has_time_sync && (a.sender_frame != b.sender_frame || a.advantage != b.advantage || a.stamp != b.stamp ||
                            a.echo != b.echo || a.hold != b.hold))
        return false;
    if (a.has_extension != b.has_extension || a.slots.size() != b.slots.size() || a.blocks.size() != b.blocks.size())
        return false;
    for (std::size_t i = 0; i < a.slots.size(); ++i)
        if (a.slots[i].slot != b.slots[i].slot || a.slots[i].state != b.slots[i].state ||
            a.slots[i].epoch != b.slots[i].epoch || a.slots[i].count != b.slots[i].count)
            return false;
    for (std::size_t i = 0; i < a.blocks.size(); ++i)
        if (a.blocks[i].slot != b.blocks[i].slot || a.blocks[i].absent != b.blocks[i].absent ||
            a.blocks[i].first_frame != b.blocks[i].first_frame || a.blocks[i].frame_count != b.blocks[i].frame_count ||
            a.blocks[i].inputs != b.blocks[i].inputs)
            return false;
    for (int i = 0; i < a.checksum_count; ++i)
        if (a.checksum_frames[i] != b.checksum_frames[i] || a.checksums[i] != b.checksums[i]) return false;
    return true;
}

void check(bool ok) {
    if (!ok) std::abort();
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    if (size == 0) return 0;
    // First byte: the input size the receiver expects (1..64); the rest is the datagram.
    const std::size_t input_size = 1 + data[0] % kMaxInputSize;
    const std::span<const std::uint8_t> d(data + 1, size - 1);
    (void)peek_kind(d);
    std::vector<std::uint8_t> again;

    InputMessage im, im2;
    if (decode(d, input_size, im) == nullptr) {
        encode(im, input_size, again);
        check(again.size() <= kMaxDatagramBytes);
        check(decode(again, input_size, im2) == nullptr && same(im, im2));
    }
    QueryMessage qm, qm2;
    if (decode(d, qm) == nullptr) {
        again.clear();
        encode(qm, again);
        check(decode(again, qm2) == nullptr && qm2.what == qm.what && qm2.frame == qm.frame && qm2.start == qm.start &&
              qm2.count == qm.count);
        check(std::equal(again.begin(), again.end(), d.begin(), d.end()));  // one encoding per query
    }
    ReplyMessage rm, rm2;
    if (decode(d, rm) == nullptr) {
        again.clear();
        encode(rm, again);
        check(decode(again, rm2) == nullptr && rm2.what == rm.what && rm2.available == rm.available &&
              rm2.frame == rm.frame && rm2.start == rm.start && rm2.count == rm.count && rm2.values == rm.values &&
              rm2.fields == rm.fields);
        check(std::equal(again.begin(), again.end(), d.begin(), d.end()));
    }
    return 0;
}
