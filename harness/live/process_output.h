// Text between `lockroll live` and its child processes: a number written as a flag's value (or
// a report cell) the way the processes parse it back, and the files a process wrote (its
// summary, status and events as text, its CSVs as rows). A file that is missing or unreadable
// reads as empty text, or no rows: a process killed on purpose leaves none, and the caller says
// so rather than failing.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace lockroll::harness {

// v as an ostream writes it (shortest form at 6 significant digits).
std::string num(double v);
// The whole file; empty when it cannot be read.
std::string read_text(const std::filesystem::path& p);
// Comma-separated cells of every line after the header line (no quoting: the processes write
// none).
std::vector<std::vector<std::string>> read_csv_rows(const std::filesystem::path& p);
// The line of a child's stderr log that says why it failed, so a run's report names the cause
// without anyone opening the log: a sanitizer's first report line ("ERROR: AddressSanitizer:
// ...", "...: runtime error: ..."), else the program's last own line ("lockroll: error: ..."),
// else the last error- or critical-level log line; trimmed to 300 bytes. Empty when the log is
// missing or holds none of these.
std::string failure_line(const std::filesystem::path& stderr_log);

}  // namespace lockroll::harness
