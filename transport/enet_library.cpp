#include "transport/enet_library.h"

#include <enet/enet.h>

#include <cstdlib>
#include <mutex>
#include <stdexcept>

namespace lockroll::transport {

void ensure_enet_initialized() {
    static std::once_flag once;
    static bool ok = false;
    std::call_once(once, [] {
        ok = enet_initialize() == 0;
        if (ok) std::atexit(enet_deinitialize);
    });
    if (!ok) throw std::runtime_error("ENet: enet_initialize failed");
}

}  // namespace lockroll::transport
