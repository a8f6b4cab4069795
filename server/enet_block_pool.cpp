#include "server/enet_block_pool.h"

#include <enet/enet.h>

#include <cstdlib>

namespace lockroll::server {

namespace {
// The header before each block: its class, or kLarge for a block straight from malloc.
constexpr std::uint32_t kLarge = 0xFFFFFFFFu;

static_assert(EnetBlockPool::kClassBytes == std::array<std::size_t, 4>{64, 128, 256, 512}, "class_of() below");
std::uint32_t class_of(std::size_t bytes) {
    if (bytes <= 64) return 0;
    if (bytes <= 128) return 1;
    if (bytes <= 256) return 2;
    return bytes <= 512 ? 3 : kLarge;
}
}  // namespace

EnetBlockPool::~EnetBlockPool() {
    for (Free*& head : free_)
        while (head != nullptr) {
            Free* next = head->next;
            std::free(reinterpret_cast<unsigned char*>(head) - kHeaderBytes);
            head = next;
        }
}

void* EnetBlockPool::allocate(std::size_t bytes) {
    const std::uint32_t c = class_of(bytes);
    if (c != kLarge) {
        if (Free* f = free_[c]) {
            free_[c] = f->next;
            --free_count_[c];
            return f;  // its header still names class c
        }
        ++counters_.from_malloc;
    } else {
        ++counters_.large;
    }
    const std::size_t size = kHeaderBytes + (c != kLarge ? kClassBytes[c] : bytes);
    if (size < bytes) return nullptr;  // overflow
    auto* base = static_cast<unsigned char*>(std::malloc(size));  // malloc aligns to 16 on x86-64 Linux
    if (base == nullptr) return nullptr;
    *reinterpret_cast<std::uint32_t*>(base) = c;
    return base + kHeaderBytes;
}

void EnetBlockPool::release(void* p) {
    if (p == nullptr) return;
    auto* base = static_cast<unsigned char*>(p) - kHeaderBytes;
    const std::uint32_t c = *reinterpret_cast<const std::uint32_t*>(base);
    if (c == kLarge || free_count_[c] >= kMaxFreePerClass) {
        ++counters_.to_malloc;
        std::free(base);
        return;
    }
    auto* f = static_cast<Free*>(p);
    f->next = free_[c];
    free_[c] = f;
    ++free_count_[c];
}

namespace enet_block_pool {
namespace {
EnetBlockPool* g_pool = nullptr;  // never destroyed: ENet may free blocks until the process ends

void* pool_malloc(size_t n) { return g_pool->allocate(n); }
void pool_free(void* p) { g_pool->release(p); }
}  // namespace

std::string install() {
    if (g_pool != nullptr) return "already installed";
    g_pool = new EnetBlockPool();
    ENetCallbacks callbacks{};
    callbacks.malloc = pool_malloc;
    callbacks.free = pool_free;
    if (enet_initialize_with_callbacks(ENET_VERSION, &callbacks) != 0) {
        delete g_pool;
        g_pool = nullptr;
        return "enet_initialize_with_callbacks failed";
    }
    return "";
}

const EnetBlockPool* installed() { return g_pool; }

}  // namespace enet_block_pool

}  // namespace lockroll::server
