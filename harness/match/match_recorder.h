// What one client measures of its own match, the same code for a client of an in-process match
// (virtual time, harness/match/match.cpp) and for a real process (`lockroll peer` / `lockroll client`,
// harness/peer_command.cpp): when it first showed each frame and what it showed, its rollbacks
// and visual corrections, how long its own input changes took to show, CPU per tick and per
// physics step, the round trip it measured to each peer, what it showed against the state later
// confirmed, and every confirmed checksum.
//
// Contract: the recorder never reads a clock. Every time is the caller's, in µs on one clock
// (virtual time, or CLOCK_MONOTONIC for real processes: the same clock in every process of one
// machine, so times of different processes can be compared). Only frames 1..target are measured.
//
// Samples are kept raw, not summarised: samples_json() writes them (a real process's
// samples.json) and RecordedSamples::from_json() reads them back, so that a report over many
// processes computes every percentile and maximum from what was measured, and a figure nobody
// measured stays absent (count 0), to be printed "n/a", never 0.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "harness/match/metrics.h"
#include "rollback/events.h"
#include "rollback/simulation.h"
#include "rollback/world_simulation.h"
#include "sim/world.h"

namespace lockroll::harness {

// A shown frame's time stamps: (frame, µs) in the order shown.
using ShownTimes = std::vector<std::pair<std::uint32_t, std::uint64_t>>;

// The tick-rate figures of one client from the times it first showed its frames (frame order),
// one policy for virtual and real runs.
struct TickFigures {
    double ticks_per_second = 0;  // frames shown per second, from the first frame this client showed
    std::uint64_t intervals = 0;  // frames shown after the first
    // Periods in which a frame was due and none came: a frame shown more than one tick period
    // after the previous one was late, and each whole period it was late by counts as one.
    std::uint64_t stalled_periods = 0;
    double stall_fraction = 0;    // stalled_periods / (stalled_periods + intervals)
    bool measured = false;        // at least two frames shown
};
TickFigures tick_figures(const ShownTimes& shown, int tick_rate);

// One client's raw samples, as recorded or as read back from samples.json.
struct RecordedSamples {
    int slot = 0;
    ShownTimes shown;                                   // first showing of each frame
    std::vector<std::pair<std::uint32_t, std::uint64_t>> confirmed;  // (frame, checksum), every frame
    Stat input_latency_local = Stat::keeping_samples();  // ms
    Stat cpu_us_per_tick = Stat::keeping_samples();
    Stat resim_us_per_tick = Stat::keeping_samples();
    Stat physics_step_us = Stat::keeping_samples();
    Stat rollback_depth = Stat::keeping_samples();
    std::vector<std::uint64_t> rollback_depth_histogram;  // [depth] -> rollbacks
    Stat correction_jump = Stat::keeping_samples();       // m
    Stat displayed_vs_confirmed;                          // m, every body of every shown frame
    std::map<int, Stat> rtt_ms;                           // peer -> samples, one per tick once measured
    // This client's input changes: (input frame, bytes, µs made).
    struct Input {
        std::uint32_t frame = 0;
        std::array<std::uint8_t, 3> bytes{};
        std::uint64_t made_us = 0;
    };
    std::vector<Input> inputs_made;
    // Other players' inputs as this client first simulated with them: (player, input frame) ->
    // each distinct value and when it was first used (a misprediction, then the real one).
    std::map<std::pair<int, std::uint32_t>, std::vector<std::pair<std::array<std::uint8_t, 3>, std::uint64_t>>> inputs_seen;

    nlohmann::json to_json() const;
    static RecordedSamples from_json(const nlohmann::json& j);  // throws nlohmann::json::exception when malformed
};

// Remote input latency, ms: for every input change one client made, the time until each other
// client first simulated a frame with it (clients: every process of a match; times on one clock).
Stat remote_input_latency(const std::vector<const RecordedSamples*>& clients);

// Confirmed-state agreement over every confirmed checksum the clients recorded: each frame's
// checksum of every client after the first to confirm it, against the first's. Returns
// (compared, mismatches).
std::pair<std::uint64_t, std::uint64_t> confirmed_agreement(const std::vector<const RecordedSamples*>& clients);

// Adds one player's samples to a run's figures (input latency, CPU per tick, resimulation,
// physics steps, rollbacks and their histogram, corrections, shown against confirmed): the one
// reduction of a virtual match's clients and of a live run's processes.
void add_client_samples(RunResult& r, const RecordedSamples& m);

class MatchRecorder {
public:
    // slot: the player (or spectator id, >= players: no local input). sim: the client's
    // simulation (read for confirmed states). record_remote_inputs: keep inputs_seen, for
    // remote_input_latency across processes. keep_positions: keep every shown frame's
    // positions for shown_positions() (a real process's positions.csv); without it they are
    // dropped once confirmed (a virtual run reduces them as it goes).
    MatchRecorder(int slot, int players, std::uint32_t target, const rollback::WorldSimulation& sim,
                  bool record_remote_inputs, bool keep_positions);

    // The input offered to the session for input_frame (the session takes the first offer per frame).
    void input_offered(std::uint64_t now_us, std::uint32_t input_frame, const std::array<std::uint8_t, 3>& bytes);
    // When f is the first showing of a measured frame: the positions shown (valid until the
    // next call), else nullptr.
    const std::vector<sim::Vec3>* frame_simulated(std::uint64_t now_us, const rollback::FrameSimulated& f);
    void rollback_begin();
    // Returns the correction jump in m when the shown frame changed, else nullopt; nothing for
    // rollbacks ending past the target.
    std::optional<double> rollback_end(const rollback::RollbackInfo& r);
    // state: the saved state of f.frame when the session still holds it.
    void frame_confirmed(const rollback::FrameConfirmed& f, std::optional<std::span<const std::uint8_t>> state);
    void tick(double cpu_us, double resim_us);
    void rtt(int peer, double ms);

    // A virtual client's frame 0 counts as shown one period before frame 1, its first tick (N
    // frames take N periods): recorded as frame 0 of shown. A real process starts at its first
    // frame shown (a joiner or relay client is frames in) and never calls this.
    void frame0_shown(std::uint64_t now_us);
    // Frames shown per second over the last second up to the latest frame shown (frames.csv's
    // ticks_per_second): the frames of that second over the time since the frame before them.
    // In the first second, since the client started: frame 0, or one period before its first
    // frame, so one frame just shown reads the nominal rate (not 30000 ticks/s).
    double recent_tick_rate(int tick_rate) const;

    Stat& physics_step_us() { return s_.physics_step_us; }  // for TimedSimulation
    const RecordedSamples& samples() const { return s_; }
    // With keep_positions: first-shown positions of measured frames, in order.
    const std::vector<std::pair<std::uint32_t, std::vector<sim::Vec3>>>& shown_positions() const { return shown_positions_; }
    std::optional<std::uint64_t> final_checksum() const { return final_; }

private:
    std::vector<sim::Vec3> positions() const;

    const rollback::WorldSimulation& sim_;
    int players_;
    std::uint32_t target_;
    bool remote_, keep_positions_;
    RecordedSamples s_;
    std::vector<std::pair<std::uint32_t, std::vector<sim::Vec3>>> shown_positions_;
    std::map<std::uint32_t, std::vector<sim::Vec3>> awaiting_confirmation_;  // shown, not yet confirmed
    std::vector<sim::Vec3> before_rollback_;
    std::map<std::uint32_t, std::pair<std::uint64_t, std::array<std::uint8_t, 3>>> pending_local_;
    std::array<std::uint8_t, 3> last_bytes_{};
    std::uint32_t last_frame_ = 0;
    bool have_last_ = false;
    std::optional<std::uint64_t> final_;
};

}  // namespace lockroll::harness
