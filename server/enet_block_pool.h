// EnetBlockPool: the allocator lockroll-server hands ENet (enet_initialize_with_callbacks).
// ENet allocates and frees a packet, its data and a command for every datagram it carries, in
// and out: at 1,000 rooms that was ~150 of the server's ~2,400 instructions per relayed datagram
// under mimalloc (docs/performance.md, "Density, third pass"). These blocks are small and of a
// few sizes, so free lists of fixed size classes serve them in a handful of instructions: a
// block carries its class in a 16-byte header, a freed block goes on its class's list, and a
// request above the largest class (a host's peer array, a big packet) goes to malloc.
//
// Contract
//  - allocate(n) returns memory for n bytes aligned to 16, or nullptr when malloc fails; release()
//    takes back exactly what allocate() returned (never memory from malloc itself: ENet's
//    callbacks must be installed before ENet allocates anything, install() below).
//  - Memory: what a class's list holds is at most its peak of live blocks, and at most
//    kMaxFreePerClass blocks (beyond that a released block goes back to malloc): a burst that
//    ENet's own limits allowed cannot pin memory forever.
//  - Not thread-safe: one pool per thread that uses ENet. lockroll-server runs ENet on one thread.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>

namespace lockroll::server {

class EnetBlockPool {
public:
    static constexpr std::array<std::size_t, 4> kClassBytes{64, 128, 256, 512};
    static constexpr std::size_t kMaxFreePerClass = 1 << 16;
    static constexpr std::size_t kHeaderBytes = 16;

    EnetBlockPool() = default;
    ~EnetBlockPool();  // returns the free lists' blocks to malloc
    EnetBlockPool(const EnetBlockPool&) = delete;
    EnetBlockPool& operator=(const EnetBlockPool&) = delete;

    void* allocate(std::size_t bytes);
    void release(void* p);

    // The slow paths only (the fast ones count nothing: they are a few instructions each).
    struct Counters {
        std::uint64_t from_malloc = 0, large = 0, to_malloc = 0;
    };
    const Counters& counters() const { return counters_; }
    std::size_t free_blocks(std::size_t cls) const { return free_count_[cls]; }

private:
    struct Free {
        Free* next;
    };
    std::array<Free*, kClassBytes.size()> free_{};
    std::array<std::size_t, kClassBytes.size()> free_count_{};
    Counters counters_;
};

namespace enet_block_pool {
// Makes a process-wide pool ENet's malloc and free (enet_initialize_with_callbacks). Call it
// once, before anything else in the process uses ENet; returns "" or why not.
std::string install();
// The installed pool (nullptr when install() was not called or failed).
const EnetBlockPool* installed();
}  // namespace enet_block_pool

}  // namespace lockroll::server
