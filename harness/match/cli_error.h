// Errors a command reports to the user. UsageError (bad flags, bad scene, bad input file)
// exits with status 2; anything else that escapes a command exits with status 1.
#pragma once

#include <stdexcept>

namespace lockroll::harness {

struct UsageError : std::runtime_error {
    using std::runtime_error::runtime_error;
};

}  // namespace lockroll::harness
