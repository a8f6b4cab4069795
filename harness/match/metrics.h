// What a match measures. Doubles live here only: they are computed from fixed-point state for
// reporting and never flow back into a simulation.
//
// Position error (the seed paper's metric): each client records every dynamic body's position
// the first time it simulates a frame (forward simulation, never resimulation) — what it showed.
// For every frame and body, the distance between every pair of clients (a < b) is one sample.
// With two clients that is exactly the paper's definition.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <lockroll/sim/vec3.h>

namespace lockroll::harness {

// Running mean / max / count of a non-negative figure, plus a p99 when samples are kept.
struct Stat {
    double sum = 0, max = 0;
    std::uint64_t count = 0, nonzero = 0;
    std::vector<double> samples;  // only when keep_samples
    bool keep_samples = false;

    void add(double v);
    // Adds every sample of another Stat (its sums when it kept none): many clients' figures as one.
    void merge(const Stat& other);
    double mean() const { return count ? sum / static_cast<double>(count) : 0.0; }
    double percentile(double p) const;  // needs keep_samples
    static Stat keeping_samples() {
        Stat s;
        s.keep_samples = true;
        return s;
    }
};

double distance_m(const sim::Vec3& a, const sim::Vec3& b);

// One row of frames.csv: error against run time.
struct FrameRow {
    std::uint32_t frame = 0;
    double time_s = 0;            // virtual time client 0 first showed the frame
    double mean_error = 0, max_error = 0;
    std::uint32_t rollbacks = 0;           // rollbacks (all clients) that ended on this displayed frame
    std::uint32_t max_rollback_depth = 0;  // the deepest of them
    double ticks_per_second = 0;  // client 0's frames shown in the last second
};

// Collects forward-simulated positions from all clients and reduces each frame as soon as
// every client has shown it, so memory stays bounded on long runs.
class PositionErrorTracker {
public:
    PositionErrorTracker(int clients, std::size_t bodies, bool keep_positions);
    void record(int client, std::uint32_t frame, double time_s, const std::vector<sim::Vec3>& positions);
    void note_rollback(std::uint32_t displayed_frame, std::uint32_t depth);
    void set_tick_rate(std::uint32_t frame, double ticks_per_second);
    // Reduces the frames not every client showed (a client killed, joined late or failed),
    // over the pairs of clients that did show them. Call once, after the last record().
    void finish();

    const Stat& error() const { return error_; }
    // Per pair (a, b), a < b, in order (0,1), (0,2), ..., (1,2), ...
    const std::vector<Stat>& pair_errors() const { return pair_error_; }
    // Per dynamic body index, over all pairs and frames.
    const std::vector<Stat>& body_errors() const { return body_error_; }
    const std::vector<FrameRow>& rows() const { return rows_; }
    // frame,client,body,x,y,z lines (only with keep_positions).
    const std::string& positions_csv() const { return positions_csv_; }
    std::vector<double> per_body_max() const { return body_max_; }

private:
    struct Pending {
        std::vector<std::vector<sim::Vec3>> by_client;
        std::uint32_t have = 0;
        double time_s = 0;
    };
    void reduce(std::uint32_t frame, Pending& p);

    int clients_;
    std::size_t bodies_;
    bool keep_positions_;
    std::map<std::uint32_t, Pending> pending_;
    std::map<std::uint32_t, std::pair<std::uint32_t, std::uint32_t>> rollbacks_;  // frame -> (count, max depth)
    std::map<std::uint32_t, double> tick_rate_;
    Stat error_;
    std::vector<Stat> pair_error_, body_error_;
    std::vector<double> body_max_;
    std::vector<FrameRow> rows_;
    std::string positions_csv_;
};

struct ClientResult {
    double ticks_per_second = 0;
    double stall_fraction = 0;
    std::uint64_t ticks = 0, frames = 0, stall_ticks = 0, time_sync_waits = 0;
    std::uint64_t rollbacks = 0, resimulated_frames = 0;
    std::uint32_t max_rollback_depth = 0;
    std::uint64_t bytes_sent = 0, bytes_received = 0, packets_sent = 0, packets_received = 0;
    std::uint64_t mispredictions = 0, malformed_packets = 0;
    std::uint64_t desyncs = 0;
    std::uint64_t final_checksum = 0;
    bool final_confirmed = false;
    // Played from frame 0. A joiner's catch-up shows frames faster than the match runs, so only
    // these clients make the match's tick rate and stall fraction (RunResult::ticks_per_second).
    bool from_start = true;
    // Issue 21: dropped by the others while cut off (partitioned since that frame, if it said
    // so) and rejoined their view by a snapshot of rejoined_at_frame once the network healed; or,
    // with outcome "partitioned", cut off from a majority of the view since that frame (the
    // session's `partitioned` event) and not healed when the match ended.
    std::optional<std::uint32_t> partitioned_since_frame, rejoined_at_frame;
    // How an in-process match ended for this client (summary.json "outcome" of each client):
    // "completed" (it confirmed the last frame), "partitioned" (it did not, and was in an unhealed
    // partition episode at the end: it never says completed), "incomplete" (neither: the run's
    // time limit). nullptr where the run does not judge it (a real process's figures: its own
    // summary's top-level outcome says it).
    const char* outcome = nullptr;
    // A drop left it the only running voter of its view (the two-player rule, in a match of two
    // or one shrunk to two) from this frame to the end: it agreed with nobody since.
    std::optional<std::uint32_t> alone_since_frame;
};

struct DesyncRecord {
    int client = 0;
    // From the diverging frame first being shown (by any client) to this client's checksum
    // alert, and to its narrowed report; virtual ms.
    double alert_ms = 0, report_ms = 0;
    std::string summary;
    std::string evidence_file;
    std::uint32_t detected_frame = 0, frame = 0, body = 0;
    std::string field;
};

// Something that happened at a moment of the run, for error_vs_time.png and events.csv:
// "loss" (a datagram client sent was lost), "partition" (one was cut by --partition; value:
// the peer), "stall", "rollback" (value: depth),
// "correction" (value: jump in m), "time_sync_wait" (value: frames), "rejoin" (the others dropped
// the client and it starts again as a joiner; value: the frame it had been partitioned since, 0
// if it was not).
struct RunEvent {
    double time_s = 0;
    int client = 0;
    std::uint32_t frame = 0;  // the frame the client was showing
    const char* kind = "";
    double value = 0;
};

// One client's time sync on one tick, for time_sync.png and timesync.csv.
struct TimeSyncSample {
    double time_s = 0;
    int client = 0;
    std::uint32_t frame = 0;
    double frames_ahead = 0;  // of the slowest peer, averaged over the time-sync window
    int wait_frames = 0;      // the adjustment recommended on this tick (0: none)
};

// Round-trip time one client measured to one peer, sampled every tick once measured.
struct PeerRtt {
    int client = 0, peer = 0;
    Stat rtt_ms = Stat::keeping_samples();
};

struct RunResult {
    std::string mode, scene, bot;
    int players = 0, frames = 0, tick_rate = 0, input_delay = 0, prediction = 0;
    bool adaptive_delay = false;
    int input_delay_min = 0, input_delay_max = 0;  // over the match, all clients
    std::uint64_t input_delay_changes = 0;          // adaptive changes, all clients
    Stat input_delay_used;                          // each client's delay on each tick
    std::uint64_t seed = 0;
    double latency_ms = 0, jitter_ms = 0, loss = 0, duplicate = 0, reorder = 0, burst_loss = 0;
    double rtt_p50_ms = 0, rtt_p95_ms = 0;  // measured in the ping phase
    // --partition: how many cuts, and the datagrams they dropped (all links). Reported only
    // when there are cuts, so runs without them write what they always wrote.
    std::uint64_t partition_cuts = 0, partitioned_datagrams = 0;
    double virtual_seconds = 0;
    bool completed = false;  // every client confirmed the last frame before the time limit
    // What happened to clients outside the figures (a process killed on purpose), one line each;
    // the console and the report print them.
    std::vector<std::string> notes;
    // Why a figure has no sample (key: the summary field, e.g. "input_latency_remote"): the
    // report prints such a figure as "n/a" with this reason, never as 0.
    std::map<std::string, std::string> unmeasured;

    Stat position_error;
    Stat correction_jump;      // how far a shown body moved when a rollback changed its frame
    Stat input_latency_local = Stat::keeping_samples();  // ms from an input change to the first frame showing it
    Stat input_latency_remote = Stat::keeping_samples();
    Stat cpu_us_per_tick = Stat::keeping_samples();  // all ticks of all clients
    Stat resim_us_per_tick;    // resimulation part, over all ticks
    // CPU time of every physics step (forward and resimulated) of this scene in this run.
    Stat physics_step_us = Stat::keeping_samples();
    // Every rollback of every client that ended on a measured frame (<= frames): the depth
    // statistics, the histogram and rollbacks() all count this same set.
    Stat rollback_depth;
    std::vector<std::uint64_t> rollback_depth_histogram;  // [depth] -> rollbacks
    std::uint64_t confirmed_mismatches = 0, confirmed_compared = 0;
    std::vector<DesyncRecord> desyncs;
    std::vector<ClientResult> clients;
    std::vector<FrameRow> rows;
    std::vector<Stat> pair_error;            // position error per client pair (a < b)
    std::vector<Stat> body_error;            // position error per dynamic body index
    std::vector<std::uint32_t> body_ids;     // dynamic body index -> scene body id
    std::vector<int> body_player;            // dynamic body index -> player slot, -1 if none
    std::vector<Stat> displayed_vs_confirmed;  // per client: shown position vs confirmed state
    std::vector<PeerRtt> rtt;
    std::vector<TimeSyncSample> time_sync;
    std::vector<RunEvent> events;
    std::string positions_csv;
    // With positions: index,id,player,dynamic,shape,x,z,radius,hx,hz for every body (dynamic
    // bodies by their index in positions.csv; static ones with their fixed place), for the viewer.
    std::string bodies_csv;
    std::vector<double> per_body_max_error;
    // Client 0's confirmed inputs, frame by frame (players * 3 bytes each), and the confirmed
    // checksums of frames 0..frames, when recorded.
    std::vector<std::vector<std::uint8_t>> confirmed_inputs;
    std::vector<std::uint64_t> confirmed_checksums;
    std::uint64_t initial_checksum = 0;

    double ticks_per_second() const;   // mean over clients that played from frame 0 (all when none did)
    double stall_fraction() const;     // mean over the same clients
    double bytes_sent_per_s() const;   // mean payload per client
    double bytes_received_per_s() const;
    double packets_sent_per_s() const;
    std::uint64_t rollbacks() const;
    double tick_budget_us() const { return tick_rate ? 1e6 / tick_rate : 0; }
    std::uint64_t resimulated_frames() const;
    double resim_frames_per_s() const;      // per client
    // A rollback across the whole window: window x CPU per resimulated frame (measured, or the
    // physics step when nothing was resimulated).
    double full_window_rollback_us() const;
    std::uint64_t desync_count() const;
};

}  // namespace lockroll::harness
