// StatusWriter: the relay server's status file, written off the relay loop. The loop hands over
// the newest text (post) and goes on at once; a thread of its own writes it to a temporary name
// and renames it over the file, so a probe never reads half a file. The loop never waits on the
// filesystem: on a machine whose disk is busy (a build's links, another process's fsync forcing
// an ext4 journal commit) creating and renaming a file took tens of milliseconds here, and it
// blocks for as long as the journal does; the soak saw the server stall 1.4-2.2 s while every
// client around it kept its 60 Hz (docs/reliability.md, "Relay soak"), and a stalled relay loop
// replaces every room's inputs past the deadline. A post while a write is under way replaces
// the text still waiting: the file always ends at the newest, never a queue of stale ones.
// wait_written() blocks until what was posted is on disk (the process's last status, at exit).
#pragma once

#include <condition_variable>
#include <cstdint>
#include <functional>
#include <mutex>
#include <string>
#include <thread>

namespace lockroll::server {

class StatusWriter {
public:
    // write(path, text): how a text reaches the file (default: write_file_replacing).
    using WriteFn = std::function<void(const std::string& path, const std::string& text)>;
    explicit StatusWriter(std::string path, WriteFn write = {});
    ~StatusWriter();  // waits for the write under way (and the one waiting) to end
    StatusWriter(const StatusWriter&) = delete;
    StatusWriter& operator=(const StatusWriter&) = delete;

    // Never waits for the filesystem (only for the mutex, which no write holds).
    void post(std::string text);
    void wait_written();
    // Texts written so far (a post replaced while waiting is never written).
    std::uint64_t written() const;

private:
    void run();

    std::string path_;
    WriteFn write_;
    mutable std::mutex mu_;
    std::condition_variable cv_;
    std::string pending_;
    bool has_pending_ = false;
    bool writing_ = false;
    bool stop_ = false;
    std::uint64_t written_ = 0;
    std::thread thread_;  // last: started once the members above exist
};

// Writes text to path + ".tmp" and renames it over path (the same filesystem: atomic for a
// reader). Errors are ignored: the next second's status tries again.
void write_file_replacing(const std::string& path, const std::string& text);

}  // namespace lockroll::server
