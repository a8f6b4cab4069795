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

}  // namespace
}  // namespace lockroll::harness
