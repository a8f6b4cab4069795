#include "rollback/restart_claim.h"

namespace lockroll::rollback {

bool RestartClaim::claim(std::uint64_t now_us, std::uint64_t last_heard_us, std::uint64_t confirm_us) {
    // Heard at the very time the claim began (one batch of datagrams) is not "heard since": only
    // a datagram after the claim answers it.
    if (!stands(last_heard_us)) {
        pending_ = true;
        since_us_ = now_us;
    }
    return now_us >= since_us_ && now_us - since_us_ >= confirm_us;
}

}  // namespace lockroll::rollback
