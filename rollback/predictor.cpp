#include "rollback/predictor.h"

#include <algorithm>

namespace lockroll::rollback {

void RepeatLastPredictor::predict(PlayerId, std::uint32_t, std::span<const std::uint8_t> last_confirmed,
                                  std::uint32_t, std::span<std::uint8_t> out) {
    if (last_confirmed.size() == out.size())
        std::copy(last_confirmed.begin(), last_confirmed.end(), out.begin());
    else
        std::fill(out.begin(), out.end(), std::uint8_t{0});
}

}  // namespace lockroll::rollback
