// relay_bench: how many two-player rooms one lockroll-server process sustains on one core.
//
// A load generator on loopback. For each room count R of a sweep it starts one lockroll-server
// (pinned to --server-cpu; the generator pins itself to --client-cpu), connects 2R ENet client
// peers spread over a few ENet hosts, and speaks the relay protocol directly
// (rollback/relay_messages.h): every peer says hello for its room and slot, then sends one
// RelayInput per tick at 60 Hz, as a client with an input delay of --input-delay frames would
// (its input for frame f leaves while the room clock is about f - delay). Rooms are spread
// evenly over the tick: host g carries the rooms of phase g / hosts, and sends all of them in
// one flush.
//
// Relay delay of frame f: from the flush that sent the later of the room's two inputs for f to
// the receipt, by each of the two clients, of the first Frames message that carries f (one
// sample per client and frame; loopback both ways, ENet on both ends and the generator's own
// event handling are included). Reported per run over the measurement window: p50 / p99 delay,
// replaced inputs (frames the server confirmed without a slot's input: the deadline passed),
// relay datagrams per second in and out (the server's own counters, from its status file), UDP
// datagrams the generator sent and received (ENet's counters: pings and acks included), the
// server's CPU (utime + stime from /proc/PID/stat over the window, as a share of one core; stime
// alone as its kernel share) and
// its RSS at the end. With --replaced-log FILE, every replaced slot-frame is also written there,
// summed per wall-clock second, room and slot (the relay soak, tests/server/relay_soak.sh, sets
// them beside the times and rooms of its hostile clients to tell whether those caused any).
// With --delay-log FILE, the largest relay delay and generator lateness of each second (when a
// stall happened, and whose it was).
// A run "sustains" R when every room played, p99 <= --goal-us and nothing
// was replaced. The generator's own lateness (how late it fired ticks) is reported too: a run
// whose generator fell behind measures the generator, not the server.
//
// With --echo build/bench/udp_echo, each server run is paired with a run of the bare UDP echo
// (one syscall per datagram), pinned and niced as the server and loaded at the UDP datagram rate
// the server saw: the ratio of their CPU times is the "server / echo" figure of
// docs/performance.md ("Density"), measured in the same run on the same machine. With
// --echo-batch N as well, the same echo batched (udp_echo --batch N: recvmmsg / sendmmsg, the
// floor of any relay that sends as many datagrams as it receives) at the same rate in the same
// run, the two echoes' order alternating run by run: server / batched echo and batched echo /
// echo are reported beside server / echo, with each process's datagrams in and out per relayed
// input (the server's ENet pings and acknowledgements are datagrams the echo is loaded with too).
// --echo-pass-us P runs the batched echo in passes, as the server's --pass-interval-us P (match
// them). The ratios' medians leave out runs that replaced inputs or whose echo fell behind.
//
// A benchmark, not a test: run by hand (docs/performance.md, "Relay server"), e.g.
//
// Its parts: bench/relay_bench.h (the options, the load, the results), bench/relay_generator.h
// (the rooms' clients), bench/child_process.h (the server and echo processes, /proc),
// bench/echo_run.h (the echo baseline), bench/relay_logs.h (the per-second logs).
#include <CLI/CLI.hpp>
#include <enet/enet.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "bench/child_process.h"
#include "bench/echo_run.h"
#include "bench/median.h"
#include "bench/relay_bench.h"
#include "bench/relay_generator.h"
#include "bench/relay_logs.h"

namespace {

using namespace lockroll::bench;

double ratio(double a, double b) { return b > 0 ? a / b : 0; }

// One echo run's line: its rate, CPU (kernel, user), and the server's CPU over it.
void print_echo(const char* name, const EchoResult& e, const RunResult& r) {
    std::printf("       %s at %.0f datagrams/s in, %.0f out (%.4f out per in; %.3f receive, %.3f send calls per datagram): CPU %.1f%% "
                "(kernel %.1f%%, user %.1f%%); server / %s %.3f, server kernel / %s %.3f\n",
                name, e.in_per_s, e.out_per_s, ratio(e.out_per_s, e.in_per_s), e.receive_calls, e.send_calls, e.cpu * 100, e.sys * 100,
                (e.cpu - e.sys) * 100, name, ratio(r.server_cpu, e.cpu), name, ratio(r.server_sys, e.cpu));
}

}  // namespace

int main(int argc, char** argv) {
    Options o;
    CLI::App app{"relay_bench: R two-player rooms of 60 Hz bot inputs against one lockroll-server on loopback"};
    app.add_option("--server", o.server, "lockroll-server binary to start for each run");
    app.add_option("--connect", o.connect, "127.0.0.1:PORT of a server started by hand (one run per R)");
    app.add_option("--server-pid", o.server_pid, "with --connect: its pid, for CPU and RSS");
    app.add_option("--rooms", o.rooms, "room counts to sweep")->delimiter(',')->capture_default_str();
    app.add_option("--seconds", o.seconds, "measurement window per run")->check(CLI::Range(1.0, 3600.0))->capture_default_str();
    app.add_option("--warmup", o.warmup, "seconds after every room started before measuring")->check(CLI::Range(0.0, 60.0))->capture_default_str();
    app.add_option("--repeat", o.repeat, "runs per room count (medians reported)")->check(CLI::Range(1, 50))->capture_default_str();
    app.add_option("--hosts", o.hosts, "ENet client hosts (tick phases)")->check(CLI::Range(1, 64))->capture_default_str();
    app.add_option("--ramp", o.ramp_rooms_per_s, "rooms connected per second before measuring")->check(CLI::Range(1.0, 100000.0))->capture_default_str();
    app.add_option("--input-delay", o.input_delay, "frames a bot's input leads the room clock")->check(CLI::Range(0, 60))->capture_default_str();
    app.add_option("--server-cpu", o.server_cpu, "CPU the server is pinned to (-1: none)")->capture_default_str();
    app.add_option("--client-cpu", o.client_cpu, "CPU the generator is pinned to (-1: none)")->capture_default_str();
    app.add_option("--nice", o.nice, "nice value of the server and the generator (-20: a shared machine's other jobs yield the core)")
        ->check(CLI::Range(-20, 19))
        ->capture_default_str();
    app.add_option("--goal-us", o.goal_us, "p99 relay delay a sustained run stays within")->capture_default_str();
    app.add_flag("--verbose", o.verbose, "print the ramp's progress every second");
    app.add_option("--csv", o.csv, "append one row per run here");
    app.add_option("--delay-log", o.delay_log, "write the relay delay's and the generator's lateness's maximum per second here (CSV)");
    app.add_option("--replaced-log", o.replaced_log,
                   "write the replaced slot-frames here, per second, room and slot (CSV: time_ms,run,room,slot,frames,generator_late)");
    app.add_option("--server-arg", o.server_args, "extra lockroll-server flag (repeatable)");
    app.add_option("--echo", o.echo,
                   "bench/udp_echo binary: after each server run, the bare echo (one syscall per datagram) at that run's UDP "
                   "datagram rate, its CPU as the baseline of the server's (the ratio's median is reported)");
    app.add_option("--echo-batch", o.echo_batch,
                   "with --echo: also the batched echo (udp_echo --batch N: recvmmsg / sendmmsg of up to N; the server takes 64) "
                   "at the same rate, the two echoes' order alternating run by run (0: not)")
        ->check(CLI::Range(0, 1024))
        ->capture_default_str();
    app.add_option("--echo-pass-us", o.echo_pass_us,
                   "with --echo-batch: the batched echo in passes at most one per P us (udp_echo --pass-us; as the server's "
                   "--pass-interval-us, which it should match; 0: a pass per wake-up)")
        ->check(CLI::Range(0, 100000))
        ->capture_default_str();
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        const int code = app.exit(e);
        return code == 0 ? 0 : 2;  // a bad flag: exit 2, as every lockroll program
    }
    if (o.echo_batch > 0 && o.echo.empty()) {
        std::fprintf(stderr, "relay_bench: --echo-batch needs --echo (the udp_echo binary)\n");
        return 2;
    }
    if (o.echo_pass_us > 0 && o.echo_batch == 0) {
        std::fprintf(stderr, "relay_bench: --echo-pass-us needs --echo-batch (only the batched echo runs in passes)\n");
        return 2;
    }
    if (o.server.empty() == o.connect.empty()) {
        std::fprintf(stderr, "relay_bench: give exactly one of --server and --connect\n");
        return 2;
    }
    for (int r : o.rooms)
        if (r < 1 || r > 2000) {
            std::fprintf(stderr, "relay_bench: --rooms: %d is outside 1..2000 (a process holds at most 4000 connections)\n", r);
            return 2;
        }
    if (enet_initialize() != 0) return 1;
    pin_to(o.client_cpu);
    if (o.nice != 0) {
        if (setpriority(PRIO_PROCESS, 0, o.nice) != 0) std::perror("relay_bench: setpriority");
        // With autogroup scheduling a process's nice ranks it only within its session; the
        // session's own weight is its autogroup's nice (the server child shares the session).
        std::ofstream ag("/proc/self/autogroup");
        if (ag) ag << o.nice << "\n";
    }
    const std::string dir = std::filesystem::temp_directory_path() / ("relay_bench." + std::to_string(getpid()));
    std::filesystem::create_directories(dir);
    FILE* csv = o.csv.empty() ? nullptr : std::fopen(o.csv.c_str(), "a");
    ReplacedLog replaced_log(o.replaced_log);
    DelayLog delay_log(o.delay_log);
    int run_number = 0;
    if (csv && std::ftell(csv) == 0)
        std::fprintf(csv, "rooms,run,rooms_live,p50_us,p99_us,max_us,samples,replaced,unsent,relay_in_per_s,relay_out_per_s,"
                          "udp_in_per_s,udp_out_per_s,server_cpu,server_rss_mib,generator_cpu,generator_late_p99_us,loadavg,sustained,"
                          "server_sys,echo_cpu,echo_sys,echo_in_per_s,echo_out_per_s,echo_batch,batched_echo_cpu,batched_echo_sys,"
                          "batched_echo_in_per_s,batched_echo_out_per_s,echo_pass_us,echo_receive_calls,batched_echo_receive_calls\n");
    std::printf("%6s %4s %8s %8s %8s %10s %10s %10s %10s %7s %7s %8s %7s %8s %5s %s\n", "rooms", "run", "p50_us", "p99_us", "max_us",
                "replaced", "relay_in/s", "relay_out/s", "udp_in/s", "srv_cpu", "srv_sys", "rss_MiB", "gen_cpu", "late_p99", "load",
                "sustained");
    int best = 0;
    std::uint64_t run_id = static_cast<std::uint64_t>(getpid()) << 8;
    for (int rooms : o.rooms) {
        std::vector<RunResult> runs;
        for (int k = 0; k < o.repeat; ++k) {
            ServerChild server;
            std::string host = "127.0.0.1";
            if (o.server.empty()) {
                const auto colon = o.connect.rfind(':');
                host = o.connect.substr(0, colon);
                server.port = static_cast<std::uint16_t>(std::stoi(o.connect.substr(colon + 1)));
                server.pid = o.server_pid;
            } else {
                server = start_server(o, rooms, dir);
            }
            replaced_log.begin_run(run_number++);
            RunResult r = run_generator(o, rooms, host, server.port, ++run_id, replaced_log, delay_log, server);
            if (!o.server.empty()) stop_server(server);
            if (!o.echo.empty() && r.udp_in_per_s > 0) {
                // Alternating which echo runs first: neither always gets the machine just after the server.
                const bool batched_first = o.echo_batch > 0 && k % 2 == 1;
                if (batched_first) r.batched = run_echo(o, r.udp_in_per_s, o.echo_batch, dir);
                r.echo = run_echo(o, r.udp_in_per_s, 0, dir);
                if (o.echo_batch > 0 && !batched_first) r.batched = run_echo(o, r.udp_in_per_s, o.echo_batch, dir);
            }
            std::printf("%6d %4d %8.0f %8.0f %8.0f %10llu %10.0f %10.0f %10.0f %6.0f%% %6.0f%% %8.1f %6.0f%% %8.0f %5.1f %s\n", rooms,
                        k, r.p50_us, r.p99_us, r.max_us, static_cast<unsigned long long>(r.replaced + r.unsent), r.relay_in_per_s,
                        r.relay_out_per_s, r.udp_in_per_s, r.server_cpu * 100, r.server_sys * 100, r.server_rss_mib, r.client_cpu * 100,
                        r.late_p99_us, r.loadavg, r.sustained ? "yes" : "no");
            if (!o.echo.empty()) {
                // Per relayed input (the server's relay_in): what the server received and sent, ENet's
                // pings and acknowledgements included; each echo sends what it is sent.
                std::printf("       server per relayed input: %.4f datagrams in, %.4f out (%.4f out per in); CPU kernel %.1f%%, user %.1f%%\n",
                            ratio(r.udp_in_per_s, r.relay_in_per_s), ratio(r.udp_out_per_s, r.relay_in_per_s),
                            ratio(r.udp_out_per_s, r.udp_in_per_s), r.server_sys * 100, (r.server_cpu - r.server_sys) * 100);
                print_echo("echo", r.echo, r);
                if (o.echo_batch > 0) {
                    print_echo("batched echo", r.batched, r);
                    std::printf("       batched echo / echo %.3f\n", ratio(r.batched.cpu, r.echo.cpu));
                }
            }
            std::fflush(stdout);
            if (csv)
                std::fprintf(csv, "%d,%d,%d,%.0f,%.0f,%.0f,%llu,%llu,%llu,%.0f,%.0f,%.0f,%.0f,%.4f,%.1f,%.4f,%.0f,%.2f,%d,%.4f,%.4f,%.4f,%.0f,%.0f,%d,%.4f,%.4f,%.0f,%.0f,%d,%.4f,%.4f\n", rooms, k,
                             r.rooms_live, r.p50_us, r.p99_us, r.max_us, static_cast<unsigned long long>(r.samples),
                             static_cast<unsigned long long>(r.replaced), static_cast<unsigned long long>(r.unsent),
                             r.relay_in_per_s, r.relay_out_per_s, r.udp_in_per_s, r.udp_out_per_s, r.server_cpu,
                             r.server_rss_mib, r.client_cpu, r.late_p99_us, r.loadavg, r.sustained ? 1 : 0, r.server_sys,
                             r.echo.cpu, r.echo.sys, r.echo.in_per_s, r.echo.out_per_s, o.echo_batch, r.batched.cpu, r.batched.sys,
                             r.batched.in_per_s, r.batched.out_per_s, o.echo_pass_us, r.echo.receive_calls, r.batched.receive_calls);
            if (r.disconnects) std::fprintf(stderr, "relay_bench: %llu clients disconnected (server logs in %s)\n",
                                            static_cast<unsigned long long>(r.disconnects), dir.c_str());
            runs.push_back(r);
        }
        // Medians of the runs in which every room started: a run that never got its rooms going
        // measured nothing, and its zeros are no figures (it still counts against "sustained").
        std::vector<const RunResult*> started;
        for (const auto& r : runs)
            if (r.rooms_live == rooms && r.samples > 0) started.push_back(&r);
        auto med = [&](auto field) {
            std::vector<double> v;
            for (const RunResult* r : started) v.push_back(field(*r));
            return median(v);
        };
        int sustained = 0;
        for (const auto& r : runs) sustained += r.sustained ? 1 : 0;
        const bool ok = sustained * 2 > static_cast<int>(runs.size());
        if (ok) best = std::max(best, rooms);
        if (started.empty()) {
            std::printf("median %6d rooms: n/a (no run started every room); sustained in %d of %zu runs\n", rooms, sustained,
                        runs.size());
            std::fflush(stdout);
            continue;
        }
        if (started.size() < runs.size())
            std::printf("median %6d rooms over the %zu of %zu runs that started every room (the others measured nothing):\n",
                        rooms, started.size(), runs.size());
        std::printf("median %6d rooms: p50 %.0f us, p99 %.0f us, relay in %.0f/s out %.0f/s, server CPU %.0f%% of a core "
                    "(kernel %.0f%%; %.1f us per room-second), RSS %.1f MiB, replaced %.0f; sustained in %d of %zu runs\n",
                    rooms, med([](const RunResult& r) { return r.p50_us; }), med([](const RunResult& r) { return r.p99_us; }),
                    med([](const RunResult& r) { return r.relay_in_per_s; }), med([](const RunResult& r) { return r.relay_out_per_s; }),
                    med([](const RunResult& r) { return r.server_cpu * 100; }), med([](const RunResult& r) { return r.server_sys * 100; }),
                    med([&](const RunResult& r) { return r.server_cpu * 1e6 / rooms; }),
                    med([](const RunResult& r) { return r.server_rss_mib; }),
                    med([](const RunResult& r) { return static_cast<double>(r.replaced + r.unsent); }), sustained, runs.size());
        // The ratios' medians: runs in which nothing was replaced (the server kept up) and the
        // echoes kept up (echo_kept_up): a stalled run measured the stall.
        std::vector<const RunResult*> paired;
        for (const RunResult* r : started)
            if (r->replaced + r->unsent == 0 && echo_kept_up(r->echo, r->udp_in_per_s) &&
                (o.echo_batch == 0 || echo_kept_up(r->batched, r->udp_in_per_s)))
                paired.push_back(r);
        auto med_paired = [&](auto field) {
            std::vector<double> v;
            for (const RunResult* r : paired) v.push_back(field(*r));
            return median(v);
        };
        if (!o.echo.empty() && paired.size() < started.size())
            std::printf("median %6d rooms: echo ratios over the %zu of %zu runs in which nothing was replaced and every echo kept up\n",
                        rooms, paired.size(), started.size());
        if (!o.echo.empty())
            std::printf("median %6d rooms: server CPU / echo CPU at the same datagram rate %.3f (paired runs), echo CPU %.1f%%"
                        " (kernel %.1f%%), server kernel / echo %.3f\n",
                        rooms, med_paired([](const RunResult& r) { return ratio(r.server_cpu, r.echo.cpu); }),
                        med_paired([](const RunResult& r) { return r.echo.cpu * 100; }),
                        med_paired([](const RunResult& r) { return r.echo.sys * 100; }),
                        med_paired([](const RunResult& r) { return ratio(r.server_sys, r.echo.cpu); }));
        if (o.echo_batch > 0)
            std::printf("median %6d rooms: server / batched echo (--batch %d) %.3f, batched echo / echo %.3f, batched echo CPU %.1f%%"
                        " (kernel %.1f%%), server kernel / batched echo %.3f\n",
                        rooms, o.echo_batch, med_paired([](const RunResult& r) { return ratio(r.server_cpu, r.batched.cpu); }),
                        med_paired([](const RunResult& r) { return ratio(r.batched.cpu, r.echo.cpu); }),
                        med_paired([](const RunResult& r) { return r.batched.cpu * 100; }),
                        med_paired([](const RunResult& r) { return r.batched.sys * 100; }),
                        med_paired([](const RunResult& r) { return ratio(r.server_sys, r.batched.cpu); }));
        std::fflush(stdout);
    }
    std::printf("largest room count sustained (p99 <= %.0f us, nothing replaced, in most runs): %d\n", o.goal_us, best);
    if (csv) std::fclose(csv);
    std::printf("server logs: %s\n", dir.c_str());
    enet_deinitialize();
    return 0;
}
