// A match: N clients, each with its own World and Session, playing one scene over the simulated
// network, as a discrete-event simulation in virtual time. Same config and seed, same result,
// bit for bit (CPU-time figures aside, which are measured, not simulated).
//
// Per client tick (client clocks run at tick_rate, each with its own drift):
//   receive every datagram due by now -> bot input for frame()+delay -> Session::advance
//   (skipped while time sync says wait) -> Session::poll -> send.
// A client that has shown the last frame keeps receiving and polling until every client has
// confirmed it, so the final checksums are of confirmed state.
//
// run_match plays a match to the end; Match is the same match one client tick at a time, for a
// caller that shows it while it runs (harness/web steps it from JavaScript). Stepping a Match
// to the end and calling finish() gives exactly what run_match gives.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "harness/match/bots.h"
#include "harness/match/metrics.h"
#include <lockroll/rollback/session_types.h>
#include <lockroll/sim/scene.h>
#include <lockroll/sim/world.h>
#include "transport/link_conditions.h"
#include "transport/partition_schedule.h"

namespace lockroll::harness {

enum class Mode { Rollback, Lockstep };
const char* mode_name(Mode m);

struct NetConditions {
    double latency_ms = 0;   // one-way
    double jitter_ms = 0;    // uniform +-, per packet
    double loss = 0;         // independent loss probability
    double burst_loss = 0;   // probability per packet of entering a loss burst (mean length 2)
    double duplicate = 0;
    double reorder = 0;
};

// The simulated link every directed link gets for these conditions (also what `lockroll proxy`
// applies to real traffic). validate() throws UsageError naming the flag.
transport::LinkConditions link_for(const NetConditions& n);
void validate(const NetConditions& n);

// --inject-desync CLIENT:FRAME:BODY — flip one bit of one body on one client when it produces
// that frame (bit 20 of position.x unless given as CLIENT:FRAME:BODY:FIELD:BIT).
struct DesyncInjection {
    int client = 0;
    std::uint32_t frame = 0;
    std::uint32_t body = 0;
    int field = 0;
    int bit = 20;
};

// Why a session of this scene (players already added) would refuse the injection, "" when it
// takes it. Asked of a session itself, so the rule stays the session's: a command that starts
// processes checks its --inject-desync with this before starting any (exit 2 naming the flag)
// instead of letting the one process that gets it refuse it mid-start.
std::string injection_error(const sim::SceneDesc& scene, int players, const DesyncInjection& d);

struct RunConfig {
    sim::SceneDesc scene;
    Mode mode = Mode::Rollback;
    int players = 2;
    int frames = 720;
    int tick_rate = 60;
    int input_delay = -1;         // frames; -1 = auto (from a measured ping phase)
    // Adaptive input delay: every second each client re-picks its delay from the RTT it has
    // measured in the last two seconds (adaptive_input_delay); input_delay is the start.
    bool adaptive_delay = false;
    int prediction = 8;           // window W in rollback mode (lockstep always uses 0)
    int checksum_interval = 1;
    NetConditions net;
    // Cuts between sets of slots (--partition), in microseconds since frame 0: the match shifts
    // them to its start (after the ping phase, which is never cut), so frame F of the flag is
    // F * 1e6 / tick_rate us into the match. Empty: the run is what it was without partitions.
    transport::PartitionSchedule partitions;
    std::uint64_t seed = 1;
    BotKind bot = BotKind::Random;
    double drift_ppm = 0;         // each client's clock drifts by a seeded value in [-d, +d]
    std::vector<DesyncInjection> injections;
    bool record_positions = false;
    bool record_inputs = false;   // keep client 0's confirmed inputs in RunResult
    std::string evidence_dir;     // where desync evidence files go ("" = none)
    // Called now and then with (frames shown by client 0, target); for terminal progress.
    std::function<void(int, int)> progress;
    // The CPU clock every figure in CPU time is read from (ns). Empty: this thread's CPU time.
    // Tests pass a counting clock to check what is inside and outside a measurement.
    std::function<std::uint64_t()> cpu_clock;
    // Called at the start of each of the harness's own observer callbacks (tests use it to make
    // the harness's work visible on a fake cpu_clock).
    std::function<void()> on_observer;
};

// Throws UsageError naming the option for values out of range.
void validate(const RunConfig& config);

// The scene, with player bodies added (copies of the last player body, spaced 1.5 m apart
// along z) when the scene has fewer than `players`.
sim::SceneDesc with_players(const sim::SceneDesc& scene, int players);

// Input delay --input-delay auto picks from a measured round-trip distribution: lockstep needs
// the 95th-percentile one-way time covered, plus one frame for tick phase; rollback takes half
// of that (rounded up), trading a little latency for shallower rollbacks, and widens its
// window to match (auto_prediction_window).
int auto_input_delay(Mode mode, double rtt_p50_ms, double rtt_p95_ms, int tick_rate);

// The prediction window auto-tuned rollback uses: at least the configured one, and wide enough
// that delay + window exceeds lockstep's delay, so that rollback never stalls more than lockstep
// at the same conditions (it stalls when an input is older than delay + window frames).
int auto_prediction_window(int configured, int lockstep_delay, int rollback_delay);

// The delay adaptive mode moves to during the match, from a client's recent RTT (p50, and p95
// widened by twice the mean deviation, as jitter the smoothed RTT hides). Lockstep: as
// auto_input_delay. Rollback: half of that, but never so little that delay + window falls to
// lockstep's delay or below: the window is fixed mid-match, so rollback would stall more.
int adaptive_input_delay(Mode mode, double rtt_p50_ms, double rtt_p95_ms, int tick_rate, int window);

RunResult run_match(const RunConfig& config);

class Match {
public:
    // Validates (UsageError naming the option), runs the ping phase that picks an auto input
    // delay, and builds the clients; the first step() is the first client tick.
    explicit Match(const RunConfig& config);
    ~Match();
    Match(const Match&) = delete;
    Match& operator=(const Match&) = delete;

    // Every client has confirmed the last frame, or the run's time limit has passed (a network
    // that loses everything); step() does nothing then.
    bool finished() const;
    // Runs the next client tick (the client whose clock ticks first) in virtual time.
    void step();
    std::uint64_t next_tick_us() const;  // virtual time of the tick step() runs next
    std::uint64_t now_us() const;        // virtual time of the last tick run
    std::uint64_t start_us() const;      // virtual time the match started (after the ping phase)

    int clients() const;
    int input_delay() const;  // frames, as picked at the start
    int prediction() const;   // the window W (0 in lockstep)
    // What a client shows now, its frame and its session's counters; clients 0..clients()-1.
    const sim::World& world(int client) const;
    std::uint32_t frame(int client) const;
    const rollback::SessionStats& stats(int client) const;
    // The client's confirmed checksum of the last frame, once it has one.
    std::optional<std::uint64_t> final_checksum(int client) const;
    // Error against time so far: one row per frame every client has shown (frames.csv).
    const std::vector<FrameRow>& rows() const;

    // New conditions on every link, for datagrams sent from now on (a live slider); the input
    // delay stays as picked at the start. Throws UsageError naming the flag.
    void set_conditions(const NetConditions& n);

    // The run's figures, as run_match returns them; call once, when finished() (or earlier, for
    // an incomplete run).
    RunResult finish();

private:
    struct State;
    std::unique_ptr<State> s_;
};

// bodies.csv of a world (what the viewer draws: id, player, shape, size), as run --positions
// writes it.
std::string bodies_csv(const sim::World& w);

}  // namespace lockroll::harness
