#include "net/runner_base.h"

#include <stdexcept>

#include "net/tick_schedule.h"

namespace lockroll::net {

RunnerBase::RunnerBase(const RunnerConfig& config, transport::Transport& transport, InputSource input, RunnerObserver* observer)
    : config_(config), transport_(transport), input_(std::move(input)), observer_(observer),
      loop_(std::make_unique<TickLoop>(config_)) {
    if (config_.tick_rate < 1 || config_.tick_rate > 1000) throw std::invalid_argument("RunnerConfig: tick_rate must be 1..1000");
    if (!(config_.max_stretch >= 0 && config_.max_stretch <= 0.5))
        throw std::invalid_argument("RunnerConfig: max_stretch must be 0..0.5");
    if (config_.max_catch_up < 1) throw std::invalid_argument("RunnerConfig: max_catch_up must be >= 1");
    if (config_.service_interval_us < 100) throw std::invalid_argument("RunnerConfig: service_interval_us must be >= 100");
    if (!input_) throw std::invalid_argument("RunnerConfig: no input source");
    period_us_ = 1000000u / static_cast<unsigned>(config_.tick_rate);
}

RunnerBase::~RunnerBase() = default;

std::uint64_t RunnerBase::schedule_resets() const { return loop_->schedule_resets(); }

UpdateResult RunnerBase::update() {
    events_.clear();
    UpdateResult r = loop_->update(
        [this] { return config_.clock.now_us(); }, stop_, observer_, [this](std::uint64_t now) { return service(now); },
        [this](std::uint64_t now, std::uint64_t due) {
            const std::uint32_t depth = tick(now, due);
            return TickDone{stretch_.last_us, depth};
        },
        [this] { return status(); });
    r.events = events_;
    return r;
}

void RunnerBase::wait() const { wait_for_tick(config_, *loop_); }

RunOutcome RunnerBase::run() {
    return run_until_over([this] { return update(); }, [this] { wait(); });
}

}  // namespace lockroll::net
