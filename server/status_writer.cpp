#include "server/status_writer.h"

#include <filesystem>
#include <fstream>
#include <utility>

namespace lockroll::server {

void write_file_replacing(const std::string& path, const std::string& text) {
    const std::string tmp = path + ".tmp";
    {
        std::ofstream f(tmp, std::ios::trunc);
        f << text;
        if (!f) return;
    }
    std::error_code ec;
    std::filesystem::rename(tmp, path, ec);
}

StatusWriter::StatusWriter(std::string path, WriteFn write)
    : path_(std::move(path)), write_(write ? std::move(write) : WriteFn(write_file_replacing)), thread_([this] { run(); }) {}

StatusWriter::~StatusWriter() {
    {
        std::lock_guard lock(mu_);
        stop_ = true;
    }
    cv_.notify_all();
    thread_.join();
}

void StatusWriter::post(std::string text) {
    {
        std::lock_guard lock(mu_);
        pending_ = std::move(text);
        has_pending_ = true;
    }
    cv_.notify_all();
}

void StatusWriter::wait_written() {
    std::unique_lock lock(mu_);
    cv_.wait(lock, [&] { return !has_pending_ && !writing_; });
}

std::uint64_t StatusWriter::written() const {
    std::lock_guard lock(mu_);
    return written_;
}

void StatusWriter::run() {
    std::unique_lock lock(mu_);
    for (;;) {
        cv_.wait(lock, [&] { return has_pending_ || stop_; });
        if (!has_pending_) return;  // stopping, nothing left to write
        std::string text = std::move(pending_);
        has_pending_ = false;
        writing_ = true;
        lock.unlock();
        write_(path_, text);  // the filesystem's time, on this thread only
        lock.lock();
        writing_ = false;
        ++written_;
        cv_.notify_all();
    }
}

}  // namespace lockroll::server
