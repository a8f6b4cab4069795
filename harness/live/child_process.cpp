#include "harness/live/child_process.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <stdexcept>
#include <thread>

namespace lockroll::harness {

ChildProcess::ChildProcess(const std::vector<std::string>& argv, const std::string& log_path, bool capture_stdout) {
    if (argv.empty()) throw std::invalid_argument("ChildProcess: empty argv");
    int pipefd[2] = {-1, -1};
    if (capture_stdout && ::pipe2(pipefd, O_CLOEXEC) != 0)
        throw std::runtime_error(std::string("pipe: ") + std::strerror(errno));
    const int log = ::open(log_path.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
    if (log < 0) throw std::runtime_error("cannot open " + log_path + ": " + std::strerror(errno));
    std::vector<char*> args;
    for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
    args.push_back(nullptr);
    pid_ = ::fork();
    if (pid_ == 0) {
        ::dup2(capture_stdout ? pipefd[1] : log, 1);
        ::dup2(log, 2);
        ::execv(args[0], args.data());
        _exit(127);
    }
    ::close(log);
    if (capture_stdout) ::close(pipefd[1]);
    if (pid_ < 0) {
        if (capture_stdout) ::close(pipefd[0]);
        throw std::runtime_error(std::string("fork: ") + std::strerror(errno));
    }
    if (capture_stdout) {
        fd_ = pipefd[0];
        ::fcntl(fd_, F_SETFL, ::fcntl(fd_, F_GETFL) | O_NONBLOCK);
    }
}

ChildProcess::~ChildProcess() {
    if (!status_ && pid_ > 0) {
        ::kill(pid_, SIGKILL);
        int st = 0;
        ::waitpid(pid_, &st, 0);
    }
    if (fd_ >= 0) ::close(fd_);
}

std::vector<std::string> ChildProcess::read_lines(std::size_t max_bytes) {
    std::vector<std::string> lines;
    if (fd_ < 0) return lines;
    char buf[4096];
    for (;;) {
        const ssize_t n = ::read(fd_, buf, sizeof buf);
        if (n <= 0) {
            if (n == 0) {  // end of file: the child closed stdout
                ::close(fd_);
                fd_ = -1;
            }
            break;
        }
        for (ssize_t i = 0; i < n; ++i) {
            if (buf[i] == '\n') {
                lines.push_back(std::move(partial_));
                partial_.clear();
            } else if (partial_.size() < max_bytes) {
                partial_.push_back(buf[i]);
            }
        }
    }
    return lines;
}

std::optional<int> ChildProcess::poll_exit() {
    if (status_ || pid_ <= 0) return status_;
    int st = 0;
    if (::waitpid(pid_, &st, WNOHANG) == pid_)
        status_ = WIFEXITED(st) ? WEXITSTATUS(st) : 128 + (WIFSIGNALED(st) ? WTERMSIG(st) : 0);
    return status_;
}

void ChildProcess::signal(int sig) {
    if (!poll_exit() && pid_ > 0) ::kill(pid_, sig);
}

int ChildProcess::stop(int grace_ms) {
    signal(SIGTERM);
    for (int waited = 0; waited < grace_ms && !poll_exit(); waited += 10)
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
    if (!poll_exit()) {
        ::kill(pid_, SIGKILL);
        int st = 0;
        ::waitpid(pid_, &st, 0);
        status_ = 128 + SIGKILL;
    }
    return *status_;
}

}  // namespace lockroll::harness
