// `lockroll view DIR` (and --view on run and compare): DIR/view.html, a self-contained page
// showing two chosen clients' views of the room side by side, frame by frame, with a scrubber,
// play/pause and the error-against-time plot linked to the frame (harness/view_page.h).
//
// DIR is a run directory (positions.csv, bodies.csv, frames.csv, events.csv, as written by a
// run with --positions) or a compare directory (its rollback/ run is shown). Missing or bad
// files: UsageError naming the file and line, and no view.html is written.
#pragma once

#include <filesystem>

#include <CLI/CLI.hpp>

namespace lockroll::harness {

// Returns the path written.
std::filesystem::path write_view(const std::filesystem::path& dir);

void add_view_command(CLI::App& app);

}  // namespace lockroll::harness
