// `lockroll replay` and `lockroll synctest` as a person runs them: exit status 0 for a good
// replay, 1 naming the first bad frame, 2 (with what and where) for a corrupted or truncated file.
#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "rollback/replay.h"

namespace lockroll::rollback {
namespace {

struct CliRun {
    int status = -1;
    std::string output;
};

CliRun run_cli(const std::string& args) {
    const std::string cmd = std::string(LOCKROLL_EXE) + " " + args + " 2>&1";
    CliRun r;
    FILE* p = popen(cmd.c_str(), "r");
    if (!p) return r;
    char buf[512];
    while (std::fgets(buf, sizeof buf, p)) r.output += buf;
    const int st = pclose(p);
    r.status = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
    return r;
}

std::vector<std::uint8_t> read(const std::filesystem::path& p) {
    std::ifstream in(p, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void write(const std::filesystem::path& p, const std::vector<std::uint8_t>& b) {
    std::ofstream out(p, std::ios::binary);
    out.write(reinterpret_cast<const char*>(b.data()), static_cast<std::streamsize>(b.size()));
}

class ReplayCli : public ::testing::Test {
protected:
    void SetUp() override {
        dir_ = std::filesystem::temp_directory_path() /
               ("lockroll_replay_cli_" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()) + "_" +
                std::to_string(getpid()));
        std::filesystem::create_directories(dir_);
        good_ = dir_ / "paper.replay";
        const CliRun r = run_cli("synctest --scene paper --frames 300 --distance 4 --record " + good_.string());
        ASSERT_EQ(r.status, 0) << r.output;
    }
    void TearDown() override { std::filesystem::remove_all(dir_); }
    std::filesystem::path dir_, good_;
};

TEST_F(ReplayCli, GoodReplayVerifies) {
    const CliRun r = run_cli("replay " + good_.string());
    EXPECT_EQ(r.status, 0) << r.output;
    EXPECT_NE(r.output.find("300 frames: every checksum matches"), std::string::npos) << r.output;
}

TEST_F(ReplayCli, WrongChecksumNamesFirstBadFrame) {
    Replay replay;
    ASSERT_FALSE(decode_replay(read(good_), replay).has_value());
    replay.checksums[122] ^= 0x100;  // frame 123
    const auto bad = dir_ / "wrong.replay";
    write(bad, encode_replay(replay));
    const CliRun r = run_cli("replay " + bad.string());
    EXPECT_EQ(r.status, 1) << r.output;
    EXPECT_NE(r.output.find("first bad frame 123 of 300"), std::string::npos) << r.output;
}

TEST_F(ReplayCli, CorruptedAndTruncatedAreRejectedWithWhere) {
    auto bytes = read(good_);
    auto corrupt = bytes;
    corrupt[corrupt.size() - 100] ^= 0x01;
    write(dir_ / "corrupt.replay", corrupt);
    CliRun r = run_cli("replay " + (dir_ / "corrupt.replay").string());
    EXPECT_EQ(r.status, 2) << r.output;
    EXPECT_NE(r.output.find("corrupt.replay: byte "), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("block 1 (frames 256..299"), std::string::npos) << r.output;

    bytes.resize(bytes.size() / 2);
    write(dir_ / "short.replay", bytes);
    r = run_cli("replay " + (dir_ / "short.replay").string());
    EXPECT_EQ(r.status, 2) << r.output;
    EXPECT_NE(r.output.find("truncated"), std::string::npos) << r.output;

    r = run_cli("replay " + (dir_ / "missing.replay").string());
    EXPECT_EQ(r.status, 2) << r.output;
}

// Issue 11's fault list: a replay cut off anywhere (empty, inside the header, inside the scene
// text, inside a block, one byte short) exits 2 naming the file, and never runs a frame.
TEST_F(ReplayCli, TruncatedAnywhereExitsTwo) {
    const auto bytes = read(good_);
    ASSERT_GT(bytes.size(), 200u);
    for (const std::size_t keep : {std::size_t{0}, std::size_t{1}, std::size_t{7}, std::size_t{30}, bytes.size() / 4,
                                   bytes.size() / 2, bytes.size() - 9, bytes.size() - 1}) {
        const auto path = dir_ / ("cut" + std::to_string(keep) + ".replay");
        write(path, std::vector<std::uint8_t>(bytes.begin(), bytes.begin() + static_cast<std::ptrdiff_t>(keep)));
        const CliRun r = run_cli("replay " + path.string());
        EXPECT_EQ(r.status, 2) << "kept " << keep << " of " << bytes.size() << " bytes: " << r.output;
        EXPECT_NE(r.output.find(path.filename().string()), std::string::npos) << r.output;
        EXPECT_EQ(r.output.find("every checksum matches"), std::string::npos) << r.output;
    }
}

}  // namespace
}  // namespace lockroll::rollback
