// libFuzzer target: arbitrary bytes into the handshake and snapshot-transfer decoders
// (rollback/control_messages.h), the transfer blob parser and the chunk assembler
// (rollback/snapshot_transfer.h) — what a late joiner, a spectator or a recovering peer takes
// from the network before it loads anything.
// Properties beyond "no crash, no sanitizer report": whatever a decoder accepts re-encodes to the
// same bytes; the assembler never accepts a chunk of the wrong length or index and hands out a
// blob only when its hash matches; the blob parser accepts only what re-packs to the same bytes.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <span>
#include <vector>

#include "rollback/control_messages.h"
#include "rollback/snapshot_transfer.h"

using namespace lockroll::rollback;

namespace {
void check(bool ok) {
    if (!ok) std::abort();
}

template <class M>
void round_trip(std::span<const std::uint8_t> d) {
    M m;
    if (decode(d, m) != nullptr) return;
    std::vector<std::uint8_t> again;
    encode(m, again);
    check(std::equal(again.begin(), again.end(), d.begin(), d.end()));
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    if (size < 2) return 0;
    const std::span<const std::uint8_t> d(data + 1, size - 1);
    switch (data[0] % 4) {
        case 0:
            round_trip<HelloMessage>(d);
            round_trip<WelcomeMessage>(d);
            round_trip<SnapshotRequestMessage>(d);
            round_trip<SnapshotOfferMessage>(d);
            round_trip<SnapshotChunkMessage>(d);
            break;
        case 1: {
            // The blob parser, for a small world: state of at most 48 bytes (a variable-size
            // state saves fewer, Simulation::saved_size), 3 players, 3-byte inputs.
            TransferContents t;
            if (unpack_transfer(d, 48, 3, 3, 512, t).empty()) {
                check(t.state.size() <= 48 && t.streams.size() == 3);
                check(pack_transfer(t, 3) == std::vector<std::uint8_t>(d.begin(), d.end()));
            }
            break;
        }
        default: {
            // An offer for a blob of up to 4 KiB whose hash is the bytes' own, then the rest as a
            // script of chunks: [index][len lo][len hi][bytes...].
            if (d.size() < 2) return 0;
            const std::size_t blob_size = 1 + (d[0] | d[1] << 8) % 4096;
            std::vector<std::uint8_t> blob(blob_size);
            for (std::size_t i = 0; i < blob_size; ++i) blob[i] = static_cast<std::uint8_t>(i * 31 + 7);
            SnapshotOfferMessage offer;
            offer.transfer_id = 1;
            offer.size = static_cast<std::uint32_t>(blob_size);
            offer.hash = transfer_hash(blob);
            TransferReceiver rx(offer);
            std::size_t at = 2;
            while (at + 3 <= d.size()) {
                SnapshotChunkMessage c;
                c.transfer_id = d[at] & 0x80 ? 2 : 1;
                c.chunk = d[at] & 0x7F;
                const std::size_t len = (d[at + 1] | d[at + 2] << 8) % (kSnapshotChunkBytes + 1);
                at += 3;
                const std::size_t n = std::min(len, d.size() - at);
                c.bytes.assign(d.begin() + static_cast<std::ptrdiff_t>(at), d.begin() + static_cast<std::ptrdiff_t>(at + n));
                at += n;
                const bool fits = c.transfer_id == 1 && c.chunk < rx.chunk_count() &&
                                  c.bytes.size() == std::min<std::size_t>(kSnapshotChunkBytes, blob_size - c.chunk * kSnapshotChunkBytes);
                check(rx.add(c) == fits);
            }
            if (const auto v = rx.verified()) check(std::equal(v->begin(), v->end(), blob.begin(), blob.end()));
            std::vector<std::uint32_t> due;
            rx.due_requests(1000, 100, 8, due);
            check(due.size() <= 8);
            break;
        }
    }
    return 0;
}
