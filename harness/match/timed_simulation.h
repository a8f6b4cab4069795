// A Simulation that times each step() of another one with a CPU clock, so the report's
// "physics step" is the steps of the scene in this very run (forward and resimulated), read on
// the same clock as CPU per tick. Everything else is passed through unchanged.
#pragma once

#include <cstdint>
#include <functional>

#include "harness/match/metrics.h"
#include "rollback/simulation.h"

namespace lockroll::harness {

class TimedSimulation final : public rollback::Simulation {
public:
    // inner and out must outlive this object.
    TimedSimulation(rollback::Simulation& inner, std::function<std::uint64_t()> cpu_clock, Stat& out)
        : inner_(inner), clock_(std::move(cpu_clock)), out_(out) {}

    using rollback::Simulation::step;  // any other overload reaches the timed one below
    void step(std::span<const std::uint8_t> inputs) override {
        const std::uint64_t t0 = clock_();
        inner_.step(inputs);
        out_.add(static_cast<double>(clock_() - t0) / 1000.0);
    }
    std::size_t state_size() const override { return inner_.state_size(); }
    void save(std::span<std::uint8_t> out) const override { inner_.save(out); }
    std::string load(std::span<const std::uint8_t> in) override { return inner_.load(in); }
    std::uint64_t checksum(std::span<const std::uint8_t> state) const override { return inner_.checksum(state); }
    std::uint32_t body_count() const override { return inner_.body_count(); }
    std::uint32_t body_id(std::uint32_t index) const override { return inner_.body_id(index); }
    std::uint64_t body_hash(std::span<const std::uint8_t> state, std::uint32_t index) const override {
        return inner_.body_hash(state, index);
    }
    int field_count() const override { return inner_.field_count(); }
    const char* field_name(int field) const override { return inner_.field_name(field); }
    std::int64_t field_value(std::span<const std::uint8_t> state, std::uint32_t index, int field) const override {
        return inner_.field_value(state, index, field);
    }
    std::string describe_state(std::span<const std::uint8_t> state) const override { return inner_.describe_state(state); }
    bool flip_bit(std::uint32_t body_id, int field, int bit) override { return inner_.flip_bit(body_id, field, bit); }

private:
    rollback::Simulation& inner_;
    std::function<std::uint64_t()> clock_;
    Stat& out_;
};

}  // namespace lockroll::harness
