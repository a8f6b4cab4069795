#include "bench/child_process.h"

#include <poll.h>
#include <sched.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <sstream>
#include <stdexcept>
#include <thread>

namespace lockroll::bench {

double process_cpu_s(int pid, double* sys_s) {
    std::ifstream f("/proc/" + std::to_string(pid) + "/stat");
    std::string text((std::istreambuf_iterator<char>(f)), {});
    const auto close = text.rfind(')');
    if (close == std::string::npos) return 0;
    std::istringstream in(text.substr(close + 2));
    std::string field;
    unsigned long long utime = 0, stime = 0;
    for (int i = 3; i <= 15 && in >> field; ++i) {
        if (i == 14) utime = std::stoull(field);
        if (i == 15) stime = std::stoull(field);
    }
    const auto tick = static_cast<double>(sysconf(_SC_CLK_TCK));
    if (sys_s) *sys_s = static_cast<double>(stime) / tick;
    return static_cast<double>(utime + stime) / tick;
}

double rss_mib(int pid) {
    std::ifstream f("/proc/" + std::to_string(pid) + "/status");
    for (std::string line; std::getline(f, line);)
        if (line.rfind("VmRSS:", 0) == 0) return std::stod(line.substr(6)) / 1024.0;
    return 0;
}

double loadavg() {
    std::ifstream f("/proc/loadavg");
    double l = 0;
    f >> l;
    return l;
}

double status_number(const std::string& path, const std::string& key) {
    std::ifstream f(path);
    std::string text((std::istreambuf_iterator<char>(f)), {});
    const auto at = text.find("\"" + key + "\":");
    if (at == std::string::npos) return -1;
    return std::strtod(text.c_str() + at + key.size() + 3, nullptr);
}

void pin_to(int cpu) {
    if (cpu < 0) return;
    cpu_set_t set;
    CPU_ZERO(&set);
    CPU_SET(cpu, &set);
    if (sched_setaffinity(0, sizeof set, &set) != 0) std::perror("relay_bench: sched_setaffinity");
}

ServerChild spawn_ready(const Options& o, std::vector<std::string> args, const std::string& log) {
    ServerChild s;
    int fds[2];
    if (pipe(fds) != 0) throw std::runtime_error("pipe failed");
    s.pid = fork();
    if (s.pid < 0) throw std::runtime_error("fork failed");
    if (s.pid == 0) {
        pin_to(o.server_cpu);
        if (o.nice != 0) setpriority(PRIO_PROCESS, 0, o.nice);
        dup2(fds[1], 1);
        close(fds[0]);
        close(fds[1]);
        if (FILE* f = std::fopen(log.c_str(), "w")) dup2(fileno(f), 2);
        std::vector<char*> argv;
        for (auto& a : args) argv.push_back(a.data());
        argv.push_back(nullptr);
        execv(argv[0], argv.data());
        std::perror("relay_bench: exec");
        _exit(127);
    }
    close(fds[1]);
    std::string line;
    const std::uint64_t until = now_us() + 10'000'000;
    while (now_us() < until && line.find('\n') == std::string::npos) {
        pollfd p{fds[0], POLLIN, 0};
        if (::poll(&p, 1, 100) <= 0) continue;
        char c[64];
        const ssize_t n = read(fds[0], c, sizeof c);
        if (n <= 0) break;
        line.append(c, static_cast<std::size_t>(n));
    }
    close(fds[0]);
    unsigned port = 0;
    if (std::sscanf(line.c_str(), "ready %u", &port) != 1 || port == 0) {
        kill(s.pid, SIGKILL);
        waitpid(s.pid, nullptr, 0);
        throw std::runtime_error(args[0] + " did not print 'ready PORT' (see " + log + ")");
    }
    s.port = static_cast<std::uint16_t>(port);
    return s;
}

ServerChild start_server(const Options& o, int rooms, const std::string& dir) {
    const std::string status_file = dir + "/status.json";
    std::vector<std::string> args{o.server, "--listen", "127.0.0.1:0", "--max-rooms", std::to_string(rooms + 16),
                                  "--per-address", "4095", "--status-file", status_file, "--log-level", "warn"};
    // Sized as a deployment would size it (docs/deployment.md): ENet walks every connection
    // slot of its host on each pass, used or not.
    if (std::find(o.server_args.begin(), o.server_args.end(), "--max-connections") == o.server_args.end()) {
        args.push_back("--max-connections");
        args.push_back(std::to_string(std::min(4095, 2 * rooms + 64)));
    }
    args.insert(args.end(), o.server_args.begin(), o.server_args.end());
    static int runs = 0;
    ServerChild s = spawn_ready(o, args, dir + "/server-" + std::to_string(rooms) + "-" + std::to_string(runs++) + ".log");
    s.status_file = status_file;
    return s;
}

void stop_server(const ServerChild& s) {
    kill(s.pid, SIGTERM);
    for (int i = 0; i < 100; ++i) {
        if (waitpid(s.pid, nullptr, WNOHANG) == s.pid) return;
        std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    kill(s.pid, SIGKILL);
    waitpid(s.pid, nullptr, 0);
}

}  // namespace lockroll::bench
