// ServerLog (server/server_log.h): a line is handed to the queue without waiting for the sink; a
// sink that blocks holds up only the worker, the queue keeps the newest lines and counts the
// dropped oldest ones; report_dropped() says how many, once; close() writes everything queued,
// and with a sink that never returns it gives up after its bound instead of hanging.
// No timing: the blocked sink is a latch the test opens (the one bound is close()'s own).
#include <gtest/gtest.h>

#include <spdlog/sinks/base_sink.h>
#include <spdlog/spdlog.h>

#include <chrono>
#include <condition_variable>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "server/server_log.h"

namespace {

using lockroll::server::ServerLog;

// A sink whose writes block until opened (when gated), recording each line's text.
class GatedSink final : public spdlog::sinks::base_sink<std::mutex> {
public:
    explicit GatedSink(bool gated) : open_(!gated) {}
    void wait_entered(int n) {
        std::unique_lock lock(mu_);
        cv_.wait(lock, [&] { return entered_ >= n; });
    }
    void release() {
        {
            std::lock_guard lock(mu_);
            open_ = true;
        }
        cv_.notify_all();
    }
    void wait_lines(std::size_t n) {
        std::unique_lock lock(mu_);
        cv_.wait(lock, [&] { return lines_.size() >= n; });
    }
    std::vector<std::string> lines() {
        std::lock_guard lock(mu_);
        return lines_;
    }

protected:
    void sink_it_(const spdlog::details::log_msg& msg) override {
        std::unique_lock lock(mu_);
        ++entered_;
        cv_.notify_all();
        cv_.wait(lock, [&] { return open_; });
        lines_.emplace_back(msg.payload.data(), msg.payload.size());
        cv_.notify_all();
    }
    void flush_() override {}

private:
    std::mutex mu_;
    std::condition_variable cv_;
    bool open_;
    int entered_ = 0;
    std::vector<std::string> lines_;
};

TEST(ServerLog, CloseWritesEverythingQueuedInOrder) {
    auto sink = std::make_shared<GatedSink>(false);
    ServerLog log("info", sink, 64);
    for (int i = 0; i < 50; ++i) log->info("line {}", i);
    log->debug("below the level");
    EXPECT_TRUE(log.close());
    const std::vector<std::string> lines = sink->lines();
    ASSERT_EQ(lines.size(), 50u);
    for (int i = 0; i < 50; ++i) EXPECT_EQ(lines[static_cast<std::size_t>(i)], "line " + std::to_string(i));
    EXPECT_EQ(log.dropped(), 0u);
}

TEST(ServerLog, ABlockedSinkNeverHoldsTheCallerAndTheNewestLinesAreKept) {
    auto sink = std::make_shared<GatedSink>(true);
    constexpr std::size_t kQueue = 16;
    ServerLog log("info", sink, kQueue);
    log->warn("first");
    sink->wait_entered(1);  // the worker is now stuck in the sink, as in write() on a full pipe
    // The loop's side: every call returns while the sink hangs (were one to wait, the test
    // would hang here).
    constexpr int kMore = 1000;
    for (int i = 0; i < kMore; ++i) log->warn("line {}", i);
    EXPECT_EQ(log.dropped(), kMore - kQueue);  // the oldest waiting ones, one for each over the queue
    sink->release();
    EXPECT_TRUE(log.close());
    const std::vector<std::string> lines = sink->lines();
    ASSERT_EQ(lines.size(), 1 + kQueue);
    EXPECT_EQ(lines.front(), "first");
    EXPECT_EQ(lines.back(), "line " + std::to_string(kMore - 1));  // the newest survived
    EXPECT_EQ(lines[1], "line " + std::to_string(kMore - static_cast<int>(kQueue)));
}

TEST(ServerLog, ReportDroppedSaysHowManyOnce) {
    auto sink = std::make_shared<GatedSink>(true);
    ServerLog log("info", sink, 4);
    log->info("first");
    sink->wait_entered(1);
    for (int i = 0; i < 10; ++i) log->info("line {}", i);
    ASSERT_EQ(log.dropped(), 6u);
    log.report_dropped();  // queued itself, behind lines 6..9: it drops line 6
    EXPECT_EQ(log.dropped(), 7u);
    sink->release();
    sink->wait_lines(5);   // first, lines 7..9, the report
    log.report_dropped();  // the one the report cost
    sink->wait_lines(6);
    log.report_dropped();  // nothing new: no line
    ASSERT_TRUE(log.close());
    const std::vector<std::string> lines = sink->lines();
    ASSERT_EQ(lines.size(), 6u);
    EXPECT_EQ(lines[3], "line 9");
    EXPECT_EQ(lines[4].rfind("log: 6 lines dropped (6 in all)", 0), 0u) << lines[4];
    EXPECT_EQ(lines[5].rfind("log: 1 lines dropped (7 in all)", 0), 0u) << lines[5];
}

TEST(ServerLog, CloseGivesUpOnASinkThatNeverReturns) {
    auto sink = std::make_shared<GatedSink>(true);
    {
        ServerLog log("info", sink, 8);
        log->info("stuck");
        sink->wait_entered(1);
        log->info("queued behind it");
        EXPECT_FALSE(log.close(std::chrono::milliseconds(50)));  // returns: the process can exit
        EXPECT_FALSE(log.close());                                // the first answer, at once
        log->error("after close: goes nowhere, and does not throw");
    }  // the destructor does not wait again
    // The worker, left behind, still holds the sink; let it finish (the sink outlives it: the
    // queued lines own the logger, which owns the sink).
    sink->release();
}

}  // namespace
