#include "harness/validation/precision_sweep.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "harness/match/atomic_file.h"
#include "harness/match/cli_error.h"
#include "harness/report/output_path.h"
#include "harness/report/plot_script.h"
#include "harness/validation/reference_world.h"
#include "harness/match/scene_loader.h"
#include "sim/step_kernel.h"
#include "sim/world.h"

namespace lockroll::harness {

namespace {
namespace fs = std::filesystem;
using sim::BodyId;

double num(sim::Fixed f) { return std::ldexp(static_cast<double>(f.raw), -sim::Fixed::kFracBits); }
DVec3 dv(const sim::Vec3& v) { return {num(v.x), num(v.y), num(v.z)}; }
double norm(const DVec3& v) { return std::sqrt(v.x * v.x + v.y * v.y + v.z * v.z); }

// Solver modes swept: the default (the seed paper's solver) and the opt-in exact handling of
// static geometry (ballistic integrator + continuous collision, docs/stability.md).
enum class Mode { Default, ExactStatics };
const char* mode_name(Mode m) { return m == Mode::Default ? "default" : "ballistic+continuous"; }

struct Setting {
    int rate, iterations, substeps;
    Mode mode = Mode::Default;
};

// What a case compares: positions against a fine reference run (non-chaotic cases), or the
// drift of a conserved quantity, energy (chaotic: trajectories part ways whatever the number
// type, so only conserved quantities mean anything).
enum class Metric { Trajectory, EnergyDrift };

struct PrecisionCase {
    std::string name;
    std::string scene;
    Metric metric;
    double seconds;
};

// Samples every 0.1 s: a whole number of steps at every rate swept (240, 120, 60, 30, 20 Hz).
constexpr double kSample = 0.1;

sim::SceneDesc scene_for(const PrecisionCase& c, const Setting& s) {
    sim::SceneDesc scene;
    try {
        scene = load_scene(c.scene);
    } catch (const SceneError& e) {
        throw std::runtime_error(e.what());
    }
    scene.tick_rate = s.rate;
    scene.iterations = s.iterations;
    scene.solver.substeps = s.substeps;
    if (s.mode == Mode::ExactStatics) {
        scene.solver.integrator = sim::Integrator::Ballistic;
        scene.solver.continuous = true;
    }
    return scene;
}

// Positions of the dynamic bodies at each sample, and energy (kinetic + potential from y = 0).
struct Track {
    std::vector<std::vector<DVec3>> pos;  // [sample][dynamic index]
    std::vector<double> energy;
};

template <class W, class Pos, class Vel>
void sample(const sim::SceneDesc& scene, const std::vector<BodyId>& ids, const W& w, Pos position, Vel velocity, Track& t) {
    std::vector<DVec3> p;
    double e = 0;
    const DVec3 g = dv(scene.gravity);
    for (BodyId id : ids) {
        const DVec3 x = position(w, id), v = velocity(w, id);
        p.push_back(x);
        const double m = num(scene.bodies[id].mass);
        e += m * (v.x * v.x + v.y * v.y + v.z * v.z) / 2 - m * num(scene.bodies[id].gravity_scale) * (g.x * x.x + g.y * x.y + g.z * x.z);
    }
    t.pos.push_back(std::move(p));
    t.energy.push_back(e);
}

Track run_fixed(const sim::SceneDesc& scene, double seconds) {
    sim::World w(scene);
    const int per_sample = static_cast<int>(std::lround(kSample * scene.tick_rate));
    const int samples = static_cast<int>(std::lround(seconds / kSample));
    auto pos = [](const sim::World& w, BodyId id) { return dv(w.position(id)); };
    auto vel = [](const sim::World& w, BodyId id) { return dv(w.velocity(id)); };
    Track t;
    sample(scene, w.dynamic_ids(), w, pos, vel, t);
    for (int s = 0; s < samples; ++s) {
        for (int k = 0; k < per_sample; ++k) w.step({});
        sample(scene, w.dynamic_ids(), w, pos, vel, t);
    }
    return t;
}

Track run_double(const sim::SceneDesc& scene, double seconds) {
    ReferenceWorld w(scene);
    const int per_sample = static_cast<int>(std::lround(kSample * scene.tick_rate));
    const int samples = static_cast<int>(std::lround(seconds / kSample));
    auto pos = [](const ReferenceWorld& w, BodyId id) { return w.position(id); };
    auto vel = [](const ReferenceWorld& w, BodyId id) { return w.velocity(id); };
    Track t;
    sample(scene, w.kernel().dynamic_ids(), w, pos, vel, t);
    for (int s = 0; s < samples; ++s) {
        for (int k = 0; k < per_sample; ++k) w.step();
        sample(scene, w.kernel().dynamic_ids(), w, pos, vel, t);
    }
    return t;
}

// Microseconds per step of the Q32.32 world over the case's whole run: the fastest of `reps`
// timings (the machine is shared; the minimum is the least disturbed), each repeating the run
// until it has taken at least 20 ms so that the clock's resolution does not matter.
double time_fixed(const sim::SceneDesc& scene, double seconds, int reps) {
    using clock = std::chrono::steady_clock;
    const int steps = static_cast<int>(std::lround(seconds * scene.tick_rate));
    double best = 1e300;
    for (int r = 0; r < reps; ++r) {
        double us = 0;
        long total = 0;
        while (us < 20000) {
            sim::World w(scene);
            const auto t0 = clock::now();
            for (int k = 0; k < steps; ++k) w.step({});
            us += std::chrono::duration<double, std::micro>(clock::now() - t0).count();
            total += steps;
        }
        best = std::min(best, us / static_cast<double>(total));
    }
    return best;
}

double max_distance(const Track& a, const Track& b) {
    double d = 0;
    for (std::size_t s = 0; s < a.pos.size() && s < b.pos.size(); ++s)
        for (std::size_t i = 0; i < a.pos[s].size(); ++i) d = std::max(d, norm(a.pos[s][i] - b.pos[s][i]));
    return d;
}

double max_drift(const Track& t) {
    double d = 0;
    for (double e : t.energy) d = std::max(d, std::fabs(e - t.energy.front()) / std::fabs(t.energy.front()));
    return d;
}

// The first sample (s) at which two runs of a chaotic case are more than 1 mm apart.
double divergence_time(const Track& a, const Track& b) {
    for (std::size_t s = 0; s < a.pos.size() && s < b.pos.size(); ++s)
        for (std::size_t i = 0; i < a.pos[s].size(); ++i)
            if (norm(a.pos[s][i] - b.pos[s][i]) > 1e-3) return static_cast<double>(s) * kSample;
    return static_cast<double>(a.pos.size() - 1) * kSample;
}

struct Row {
    std::string name;
    Metric metric;
    Setting s;
    double us_per_step, error, double_error, rounding, diverge_s;
};

}  // namespace

void run_precision_sweep(const PrecisionOptions& o) {
    check_output_dir("--out", o.out);
    const std::vector<PrecisionCase> cases = {
        {"ball", "stability/precision_ball", Metric::Trajectory, 3.0},
        {"stack", "stability/precision_stack", Metric::Trajectory, 3.0},
        {"gas", "stability/precision_gas", Metric::EnergyDrift, 10.0},
    };
    const std::vector<int> rates = o.quick ? std::vector<int>{60, 20} : std::vector<int>{240, 120, 60, 30, 20};
    const std::vector<int> iterations = o.quick ? std::vector<int>{1, 4} : std::vector<int>{1, 2, 4, 8, 16};
    const std::vector<int> substeps = o.quick ? std::vector<int>{1, 2} : std::vector<int>{1, 2, 4};
    // The trajectory reference: the double build at 240 Hz x 16 substeps (3840 physics steps per
    // second), 16 iterations, with exact static contacts; 16 times finer than the finest
    // setting swept. Both modes converge to the same physics as dt shrinks; this one has no
    // integrator error in flight and no timing error at walls, so it is the better reference.
    const Setting ref_setting{240, 16, 16, Mode::ExactStatics};
    std::vector<Setting> settings;
    for (int rate : rates)
        for (int it : iterations)
            for (int sub : substeps) settings.push_back({rate, it, sub, Mode::Default});
    for (int rate : rates)
        for (int sub : substeps) settings.push_back({rate, 4, sub, Mode::ExactStatics});

    std::vector<Row> rows;
    for (const PrecisionCase& c : cases) {
        Track reference;
        if (c.metric == Metric::Trajectory) reference = run_double(scene_for(c, ref_setting), c.seconds);
        for (const Setting& s : settings) {
            const sim::SceneDesc scene = scene_for(c, s);
            const Track fx = run_fixed(scene, c.seconds);
            const Track db = run_double(scene, c.seconds);
            Row r{c.name, c.metric, s, time_fixed(scene, c.seconds, o.reps), 0, 0, 0, 0};
            if (c.metric == Metric::Trajectory) {
                r.error = max_distance(fx, reference);
                r.double_error = max_distance(db, reference);
                r.rounding = max_distance(fx, db);
            } else {
                r.error = max_drift(fx);
                r.double_error = max_drift(db);
                r.rounding = std::fabs(fx.energy.back() - db.energy.back()) / std::fabs(fx.energy.front());
                r.diverge_s = divergence_time(fx, db);
            }
            rows.push_back(r);
            std::printf("%-6s %-20s %3d Hz %2d it %d sub  %9.3f us/step  error %.3e  (double %.3e, fixed-vs-double %.3e)\n",
                        c.name.c_str(), mode_name(s.mode), s.rate, s.iterations, s.substeps, r.us_per_step, r.error,
                        r.double_error, r.rounding);
            std::fflush(stdout);
        }
    }

    std::ostringstream csv;
    csv << "case,metric,solver,tick_rate,iterations,substeps,physics_hz,us_per_step,us_per_sim_second,error,double_error,"
           "fixed_vs_double,divergence_s\n";
    char line[512];
    for (const Row& r : rows) {
        std::snprintf(line, sizeof line, "%s,%s,%s,%d,%d,%d,%d,%.4f,%.2f,%.6e,%.6e,%.6e,%.2f\n", r.name.c_str(),
                      r.metric == Metric::Trajectory ? "max_position_error_m" : "max_energy_drift_rel", mode_name(r.s.mode), r.s.rate,
                      r.s.iterations, r.s.substeps, r.s.rate * r.s.substeps, r.us_per_step, r.us_per_step * r.s.rate,
                      r.error, r.double_error, r.rounding, r.diverge_s);
        csv << line;
    }
    fs::create_directories(o.out);
    const fs::path csv_path = fs::path(o.out) / "precision.csv";
    write_file_atomic(csv_path, csv.str());
    std::printf("written %s\n", csv_path.string().c_str());

    // Pareto front per case: the settings no other setting beats on both cost and error.
    for (const PrecisionCase& c : cases) {
        std::vector<const Row*> mine;
        for (const Row& r : rows)
            if (r.name == c.name) mine.push_back(&r);
        std::sort(mine.begin(), mine.end(), [](const Row* a, const Row* b) {
            return a->us_per_step * a->s.rate < b->us_per_step * b->s.rate;
        });
        std::printf("%s: Pareto front (us per simulated second -> error):\n", c.name.c_str());
        double best = 1e300;
        for (const Row* r : mine)
            if (r->error < best) {
                best = r->error;
                std::printf("    %-20s %3d Hz %2d it %d sub  %10.1f us/s  %.3e\n", mode_name(r->s.mode), r->s.rate,
                            r->s.iterations, r->s.substeps, r->us_per_step * r->s.rate, r->error);
            }
    }

    if (!o.no_plot) {
        const fs::path png = fs::path(o.out) / "precision.png";
        if (const std::string err = run_plot_script("plot_precision.py", {csv_path.string(), png.string()}); !err.empty())
            throw std::runtime_error(err);
        std::printf("written %s\n", png.string().c_str());
    }
}

}  // namespace lockroll::harness
