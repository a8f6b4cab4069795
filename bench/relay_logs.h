// relay_bench's per-second CSV logs (--replaced-log, --delay-log): each sums what happened in a
// wall-clock second and writes the second once the next one begins. An empty path: no log, and
// every call does nothing.
#pragma once

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>

namespace lockroll::bench {

// A per-second CSV log: nullptr when path is empty (no log), else the file with its header.
inline std::FILE* open_log(const std::string& path, const char* header) {
    if (path.empty()) return nullptr;
    std::FILE* f = std::fopen(path.c_str(), "w");
    if (!f) throw std::runtime_error("cannot write " + path);
    std::fprintf(f, "%s\n", header);
    return f;
}

inline long long wall_second_ms() {
    const auto ms = std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::system_clock::now().time_since_epoch()).count();
    return ms / 1000 * 1000;
}

// The replaced slot-frames of the measurement window, summed per wall-clock second (the
// system clock: the soak script stamps its hostile clients with `date`), room and slot:
//   time_ms,run,room,slot,frames,generator_late
// time_ms the second's start (ms since the epoch), room the index 0..R-1, frames the slot's
// replaced frames confirmed in that second, generator_late how many of them were the generator's
// own lateness (kGeneratorLateUs: sent that far behind their tick, or not yet sent when
// confirmed): no one else's doing. A second is written once the next one begins, and at the end
// of the run.
class ReplacedLog {
public:
    explicit ReplacedLog(const std::string& path) : f_(open_log(path, "time_ms,run,room,slot,frames,generator_late")) {}
    ~ReplacedLog() {
        if (!f_) return;
        flush();
        std::fclose(f_);
    }
    ReplacedLog(const ReplacedLog&) = delete;
    ReplacedLog& operator=(const ReplacedLog&) = delete;

    void begin_run(int run) {
        flush();
        run_ = run;
    }
    void note(int room, int slot, bool generator_late) {
        if (!f_) return;
        const long long second = wall_second_ms();
        if (second != second_) flush();
        second_ = second;
        auto& [frames, late] = counts_[{room, slot}];
        ++frames;
        late += generator_late ? 1 : 0;
    }
    void flush() {
        if (!f_) return;
        for (const auto& [key, n] : counts_)
            std::fprintf(f_, "%lld,%d,%d,%d,%u,%u\n", second_, run_, key.first, key.second, n.first, n.second);
        counts_.clear();
        std::fflush(f_);
    }

private:
    std::FILE* f_ = nullptr;
    int run_ = 0;
    long long second_ = 0;
    std::map<std::pair<int, int>, std::pair<std::uint32_t, std::uint32_t>> counts_;
};

// The measurement window's relay delay and generator lateness, per wall-clock second (when a
// stall happened, not only how long the worst was: tells a stall of the server, whose delay
// rises while the generator keeps time, from one of the generator):
//   time_ms,samples,delay_max_us,late_max_us
class DelayLog {
public:
    explicit DelayLog(const std::string& path) : f_(open_log(path, "time_ms,samples,delay_max_us,late_max_us"), &std::fclose) {}
    ~DelayLog() {
        if (f_) flush();
    }
    DelayLog(const DelayLog&) = delete;
    DelayLog& operator=(const DelayLog&) = delete;

    void delay(std::uint32_t us) {
        if (!f_) return;
        roll();
        ++samples_;
        delay_max_ = std::max(delay_max_, us);
    }
    void late(std::uint32_t us) {
        if (!f_) return;
        roll();
        late_max_ = std::max(late_max_, us);
    }

private:
    void roll() {
        const long long second = wall_second_ms();
        if (second != second_) flush();
        second_ = second;
    }
    void flush() {
        if (second_ && (samples_ || late_max_)) std::fprintf(f_.get(), "%lld,%u,%u,%u\n", second_, samples_, delay_max_, late_max_);
        samples_ = delay_max_ = late_max_ = 0;
        std::fflush(f_.get());
    }
    std::unique_ptr<std::FILE, int (*)(std::FILE*)> f_;
    long long second_ = 0;
    std::uint32_t samples_ = 0, delay_max_ = 0, late_max_ = 0;
};

}  // namespace lockroll::bench
