// harness/live/process_output.h: numbers as the child processes parse them back, and a
// process's files read back (missing ones read as nothing).
#include "harness/live/process_output.h"

#include <unistd.h>

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

namespace lockroll::harness {
namespace {

namespace fs = std::filesystem;

TEST(ProcessOutput, NumIsTheShortestStreamForm) {
    EXPECT_EQ(num(0), "0");
    EXPECT_EQ(num(28.5), "28.5");
    EXPECT_EQ(num(0.05), "0.05");
    EXPECT_EQ(num(1234567), "1.23457e+06");
}

TEST(ProcessOutput, ReadsTextAndCsvRowsAfterTheHeader) {
    const fs::path dir = fs::temp_directory_path() / ("lockroll_process_output_test_" + std::to_string(::getpid()));
    fs::create_directories(dir);
    {
        std::ofstream(dir / "frames.csv") << "frame,wall_ms\n1,16.5\n2,33,extra\n";
    }
    EXPECT_EQ(read_text(dir / "frames.csv"), "frame,wall_ms\n1,16.5\n2,33,extra\n");
    const auto rows = read_csv_rows(dir / "frames.csv");
    ASSERT_EQ(rows.size(), 2u);
    EXPECT_EQ(rows[0], (std::vector<std::string>{"1", "16.5"}));
    EXPECT_EQ(rows[1], (std::vector<std::string>{"2", "33", "extra"}));
    EXPECT_EQ(read_text(dir / "missing.json"), "");
    EXPECT_TRUE(read_csv_rows(dir / "missing.csv").empty());
    fs::remove_all(dir);
}

// A failed child's log names its cause in one line, in this order of trust: a sanitizer's
// report (the process's own last words may be a consequence), then the program's own error
// line, then the last error-level log line.
TEST(ProcessOutput, FailureLineNamesTheCauseFromAChildsLog) {
    const fs::path dir = fs::temp_directory_path() / ("lockroll_failure_line_test_" + std::to_string(::getpid()));
    fs::create_directories(dir);
    const auto line_of = [&](const std::string& text) {
        std::ofstream(dir / "p0.stderr.log") << text;
        return failure_line(dir / "p0.stderr.log");
    };
    const std::string info = "[2026-12-07 08:23:28.039] [info] [slot 0] listening on 127.0.0.1:27589\n";
    const std::string logged = "[2026-12-07 08:23:29.000] [error] [slot 0] session failed: peer 1 sent garbage\n";
    const std::string own = "lockroll: error: cannot create a host bound to 127.0.0.1:27589\n";
    const std::string asan = "=================================================================\n"
                             "==123==ERROR: AddressSanitizer: heap-buffer-overflow on address 0x602000000014\n"
                             "    #0 0x4f1 in lockroll::f() net/x.cpp:12\n";
    const std::string ubsan = "harness/match/metrics.cpp:34:12: runtime error: -1 is outside the range of representable values\n";
    EXPECT_EQ(line_of(info), "");
    EXPECT_EQ(line_of(info + logged), logged.substr(0, logged.size() - 1));
    EXPECT_EQ(line_of(info + logged + own), own.substr(0, own.size() - 1));
    EXPECT_EQ(line_of(info + asan + logged + own), "==123==ERROR: AddressSanitizer: heap-buffer-overflow on address 0x602000000014");
    EXPECT_EQ(line_of(info + ubsan + own), ubsan.substr(0, ubsan.size() - 1));
    EXPECT_EQ(line_of(std::string(1000, 'x') + "\nlockroll: " + std::string(1000, 'y') + "\n").size(), 300u);
    EXPECT_EQ(failure_line(dir / "missing.log"), "");
    fs::remove_all(dir);
}

}  // namespace
}  // namespace lockroll::harness
