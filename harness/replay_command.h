// `lockroll replay FILE`: re-run a recorded replay and verify the checksum of every frame.
// Exit 0 when all match; 1 naming the first frame that differs; 2 when the file is unreadable,
// corrupted or truncated (the message names what and where).
#pragma once

#include <CLI/CLI.hpp>
#include <cstdint>
#include <filesystem>
#include <string>

#include "rollback/replay.h"

namespace lockroll::harness {

void add_replay_command(CLI::App& app);

// The text a replay embeds for a scene given as a shipped name or a path: the scene file's
// bytes, so the replay verifies even after the file changes. Throws UsageError if unreadable.
std::string scene_text_for_replay(const std::string& name_or_path);

// Writes a replay atomically (harness/match/atomic_file.h).
void write_replay_file(const std::filesystem::path& path, const rollback::Replay& replay);

// Replay files are read whole; larger ones are refused before reading (--max-mib raises it).
// 256 MiB holds 20 hours of a 16-player match at 60 Hz.
inline constexpr std::uint64_t kDefaultReplayMaxMiB = 256;

// Loads and verifies, printing a one-line summary unless quiet. Throws UsageError for a file
// that is not a regular file, larger than max_bytes, unreadable, corrupted or truncated (exit 2)
// and std::runtime_error naming the first bad frame (exit 1).
void run_replay(const std::filesystem::path& path, bool quiet, std::uint64_t max_bytes = kDefaultReplayMaxMiB << 20);

}  // namespace lockroll::harness
