// Output files are written whole or not at all: a temporary file beside the target, flushed,
// then renamed over it. A crash or a full disk never leaves a half-written summary behind.
#pragma once

#include <filesystem>
#include <string_view>

namespace lockroll::harness {

// Throws std::runtime_error naming the path on failure; the target is then untouched.
void write_file_atomic(const std::filesystem::path& path, std::string_view content);

}  // namespace lockroll::harness
