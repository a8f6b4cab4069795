// StatusWriter (server/status_writer.h): post() hands the text over without waiting for the
// write, a write that hangs on the filesystem holds up only the writer's thread, posts made
// meanwhile leave only the newest to write, and wait_written() returns once it is written.
// No timing: the blocked write is a latch the test opens.
#include <gtest/gtest.h>

#include <condition_variable>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <string>
#include <vector>

#include "server/status_writer.h"

namespace {

using lockroll::server::StatusWriter;

// A write that blocks until opened, recording what it was given.
struct Gate {
    std::mutex mu;
    std::condition_variable cv;
    bool open = false;
    int entered = 0;
    std::vector<std::string> texts;

    StatusWriter::WriteFn fn() {
        return [this](const std::string&, const std::string& text) {
            std::unique_lock lock(mu);
            ++entered;
            cv.notify_all();
            cv.wait(lock, [&] { return open; });
            texts.push_back(text);
        };
    }
    void wait_entered(int n) {
        std::unique_lock lock(mu);
        cv.wait(lock, [&] { return entered >= n; });
    }
    void release() {
        {
            std::lock_guard lock(mu);
            open = true;
        }
        cv.notify_all();
    }
};

TEST(StatusWriter, PostDoesNotWaitForABlockedWriteAndOnlyTheNewestWaits) {
    Gate gate;
    StatusWriter w("unused", gate.fn());
    w.post("first");
    gate.wait_entered(1);  // the writer is now stuck in the filesystem
    // The loop's side: every post returns while the write hangs.
    for (int i = 0; i < 100; ++i) w.post("second " + std::to_string(i));
    w.post("newest");
    EXPECT_EQ(w.written(), 0u);
    gate.release();
    w.wait_written();
    EXPECT_EQ(gate.texts, (std::vector<std::string>{"first", "newest"}));
    EXPECT_EQ(w.written(), 2u);
}

TEST(StatusWriter, WritesTheFileWholeUnderItsName) {
    const auto dir = std::filesystem::temp_directory_path() / ("status_writer_test." + std::to_string(::getpid()));
    std::filesystem::create_directories(dir);
    const auto path = (dir / "status.json").string();
    {
        StatusWriter w(path);
        w.post("{\"state\": \"ready\"}\n");
        w.wait_written();
        std::ifstream f(path);
        EXPECT_EQ(std::string((std::istreambuf_iterator<char>(f)), {}), "{\"state\": \"ready\"}\n");
        EXPECT_FALSE(std::filesystem::exists(path + ".tmp"));
        w.post("{\"state\": \"draining\"}\n");
    }  // the destructor writes what was waiting
    std::ifstream f(path);
    EXPECT_EQ(std::string((std::istreambuf_iterator<char>(f)), {}), "{\"state\": \"draining\"}\n");
    std::filesystem::remove_all(dir);
}

}  // namespace
