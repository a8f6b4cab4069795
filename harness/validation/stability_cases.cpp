#include "harness/validation/stability_cases.h"

#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <memory>

#include "harness/match/scene_loader.h"
#include "harness/validation/rigid_stability_cases.h"
#include "harness/validation/stability_measures.h"
#include "sim/contact.h"
#include "sim/step_kernel.h"
#include "sim/world.h"

namespace lockroll::harness::stability {

namespace {
using nlohmann::json;
using sim::BodyId;
using sim::Fixed;
using sim::Vec3;
using sim::World;
using LD = long double;
using namespace measure;

// ---------------------------------------------------------------------------------------------
// 1. Free fall

Outcome free_fall() {
    Outcome o;
    const sim::SceneDesc scene = scene_named("stability/free_fall");
    World w(scene);
    const BodyId id = 0;
    const P3 x0 = p3(scene.bodies[0].position), v0 = p3(scene.bodies[0].velocity), g = p3(scene.gravity);
    const LD dt = 1.0L / scene.tick_rate;
    const int steps = 2 * scene.tick_rate;
    LD ex = 0, ev = 0, cx = 0, cv = 0;
    for (int n = 1; n <= steps; ++n) {
        w.step(neutral(w));
        // Semi-implicit Euler solved exactly: v_n = v0 + n g dt, x_n = x0 + n v0 dt + g dt^2 n(n+1)/2.
        const P3 vn = v0 + g * (n * dt);
        const P3 xn = x0 + v0 * (n * dt) + g * (dt * dt * n * (n + 1) / 2);
        const LD t = n * dt;
        const P3 xc = x0 + v0 * t + g * (t * t / 2), vc = v0 + g * t;
        ex = std::max(ex, norm(p3(w.position(id)) - xn));
        ev = std::max(ev, norm(p3(w.velocity(id)) - vn));
        cx = std::max(cx, norm(p3(w.position(id)) - xc));
        cv = std::max(cv, norm(p3(w.velocity(id)) - vc));
    }
    o.check("position vs the integrator's exact solution, 2 s", "<= 1e-6 m", fmt(ex, "m"), ex <= 1e-6L);
    o.check("velocity vs the integrator's exact solution, 2 s", "<= 1e-6 m/s", fmt(ev, "m/s"), ev <= 1e-6L);
    o.report("position vs the continuous solution (Euler's O(dt) error)", fmt(cx, "m"));
    o.report("velocity vs the continuous solution", fmt(cv, "m/s"));

    // The opt-in ballistic integrator is exact for constant acceleration: only rounding remains.
    sim::SceneDesc b = scene;
    b.solver.integrator = sim::Integrator::Ballistic;
    World wb(b);
    LD bx = 0;
    for (int n = 1; n <= steps; ++n) {
        wb.step(neutral(wb));
        const LD t = n * dt;
        bx = std::max(bx, norm(p3(wb.position(id)) - (x0 + v0 * t + g * (t * t / 2))));
    }
    o.check("opt-in ballistic integrator vs the continuous solution", "<= 1e-6 m", fmt(bx, "m"), bx <= 1e-6L);
    o.details = {{"integrator_position_error_m", ex}, {"integrator_velocity_error_mps", ev},
                 {"continuous_position_error_m", cx}, {"continuous_velocity_error_mps", cv},
                 {"ballistic_continuous_position_error_m", bx}};
    return o;
}

// ---------------------------------------------------------------------------------------------
// 2. Bounce

// The continuous bounce of a ball dropped from rest at height y0 onto a floor where its centre
// stops at s: impacts at or above v_th bounce back with e times their speed, slower ones stop it
// (the scene's continuous_min_speed: faster impacts are exact events, slower ones inelastic).
struct BounceReference {
    LD y0, s, g, e, v_th;
    std::vector<LD> impact_t, launch_v;  // launch_v: speed after each impact (0: at rest)
    BounceReference(LD y0_, LD s_, LD g_, LD e_, LD v_th_) : y0(y0_), s(s_), g(g_), e(e_), v_th(v_th_) {
        LD t = std::sqrt(2 * (y0 - s) / g), u = g * t;
        for (int k = 0; k < 10000; ++k) {
            impact_t.push_back(t);
            const LD w = u >= v_th ? e * u : 0;
            launch_v.push_back(w);
            if (w == 0) break;
            t += 2 * w / g;
            u = w;
        }
    }
    LD y(LD t) const {
        if (t < impact_t[0]) return y0 - g * t * t / 2;
        std::size_t k = std::upper_bound(impact_t.begin(), impact_t.end(), t) - impact_t.begin() - 1;
        if (launch_v[k] == 0) return s;
        const LD tau = t - impact_t[k];
        return s + launch_v[k] * tau - g * tau * tau / 2;
    }
};

Outcome bounce() {
    Outcome o;
    constexpr int kSteps = 1000;
    // e = 1: every apex back at the start height. In flight, y + v^2 / 2g is the apex of the
    // current parabola (exact for the ballistic integrator the scene opts in to).
    {
        const sim::SceneDesc scene = scene_named("stability/bounce_e1");
        World w(scene);
        const BodyId id = 1;
        const LD h0 = num(scene.bodies[id].position.y), g = -num(scene.gravity.y);
        const LD s = num(scene.bodies[0].position.y + scene.bodies[0].half_extents.y) + num(scene.bodies[id].radius);
        LD worst = 0, lowest_apex = h0, highest_apex = h0;
        int bounces = 0;
        LD prev_vy = 0;
        for (int n = 0; n < kSteps; ++n) {
            w.step(neutral(w));
            const LD y = num(w.position(id).y), vy = num(w.velocity(id).y);
            if (prev_vy < 0 && vy > 0) ++bounces;
            prev_vy = vy;
            if (y <= s) continue;  // touching: not in flight
            const LD apex = y + vy * vy / (2 * g);
            worst = std::max(worst, std::fabs(apex - h0));
            lowest_apex = std::min(lowest_apex, apex);
            highest_apex = std::max(highest_apex, apex);
        }
        o.check("e=1: apex height vs start height, 1000 steps (" + std::to_string(bounces) + " bounces)", "<= 1e-5 m",
                fmt(worst, "m"), worst <= 1e-5L && bounces >= 10);
        o.details["e1"] = {{"worst_apex_error_m", worst}, {"bounces", bounces}, {"lowest_apex_m", lowest_apex},
                           {"highest_apex_m", highest_apex}};
        // The default solver, for comparison (what the opt-in buys).
        sim::SceneDesc d = scene;
        d.solver = sim::SolverDesc{};
        World wd(d);
        LD dworst = 0;
        for (int n = 0; n < kSteps; ++n) {
            wd.step(neutral(wd));
            const LD y = num(wd.position(id).y), vy = num(wd.velocity(id).y);
            if (y > s) dworst = std::max(dworst, std::fabs(y + vy * vy / (2 * g) - h0));
        }
        o.report("e=1 with the default solver (no opt-in), same measure", fmt(dworst, "m"));
        o.details["e1"]["default_solver_worst_apex_error_m"] = dworst;
    }
    // e = 0.8: every step against the continuous solution with the same restitution threshold.
    {
        const sim::SceneDesc scene = scene_named("stability/bounce_e08");
        World w(scene);
        const BodyId id = 1;
        const LD g = -num(scene.gravity.y);
        const LD s = num(scene.bodies[0].position.y + scene.bodies[0].half_extents.y) + num(scene.bodies[id].radius);
        const BounceReference ref(num(scene.bodies[id].position.y), s, g, num(scene.restitution[0][1]),
                                  num(scene.solver.continuous_min_speed));
        const LD dt = num(w.dt());
        LD worst = 0;
        int worst_step = 0;
        for (int n = 1; n <= kSteps; ++n) {
            w.step(neutral(w));
            const LD err = std::fabs(num(w.position(id).y) - ref.y(n * dt));
            if (err > worst) {
                worst = err;
                worst_step = n;
            }
        }
        o.check("e=0.8: height vs the analytic bounce at every step, 1000 steps (" +
                    std::to_string(ref.impact_t.size()) + " impacts)",
                "<= 1e-6 m", fmt(worst, "m"), worst <= 1e-6L);
        o.details["e08"] = {{"worst_error_m", worst}, {"worst_step", worst_step},
                            {"impacts", ref.impact_t.size()}, {"rest_time_s", ref.impact_t.back()}};
    }
    // e = 0: lands, stops, and stays exactly where it stopped (default solver).
    {
        const sim::SceneDesc scene = scene_named("stability/bounce_e0");
        World w(scene);
        const BodyId id = 1;
        const LD s = num(scene.bodies[0].position.y + scene.bodies[0].half_extents.y) + num(scene.bodies[id].radius);
        int rest_step = -1;
        Fixed rest_y;
        LD creep = 0;
        for (int n = 1; n <= kSteps; ++n) {
            w.step(neutral(w));
            if (rest_step < 0 && w.velocity(id) == Vec3{} && n > 1) {
                rest_step = n;
                rest_y = w.position(id).y;
            } else if (rest_step >= 0) {
                creep = std::max(creep, std::fabs(num(w.position(id).y) - num(rest_y)));
            }
        }
        const LD offset = rest_step < 0 ? 1 : std::fabs(num(rest_y) - s);
        o.check("e=0: at rest on the floor (velocity exactly 0) by step", "<= 120",
                rest_step < 0 ? "never" : std::to_string(rest_step), rest_step > 0 && rest_step <= 120);
        o.check("e=0: rest height vs floor contact height", "<= 1e-9 m", fmt(offset, "m"), offset <= 1e-9L);
        o.check("e=0: creep after coming to rest, to step 1000", "<= 1e-9 m", fmt(creep, "m"), creep <= 1e-9L);
        o.details["e0"] = {{"rest_step", rest_step}, {"rest_offset_m", offset}, {"creep_m", creep}};
    }
    return o;
}

// ---------------------------------------------------------------------------------------------
// 3. Head-on

// Total momentum in raw Q32.32 units times integer masses: exact integer arithmetic.
__int128 raw_momentum_x(const World& w) {
    __int128 p = 0;
    for (BodyId id : w.dynamic_ids()) p += static_cast<__int128>(w.velocity(id).x.raw) * (w.scene().bodies[id].mass.raw >> 32);
    return p;
}

Outcome head_on() {
    Outcome o;
    const sim::SceneDesc scene = scene_named("stability/head_on");
    World w(scene);
    const __int128 p0 = raw_momentum_x(w);
    const LD e0 = kinetic(w);
    for (int n = 0; n < 60; ++n) w.step(neutral(w));
    const LD va = num(w.velocity(0).x), vb = num(w.velocity(1).x);
    const LD swap = std::max(std::fabs(va - num(scene.bodies[1].velocity.x)), std::fabs(vb - num(scene.bodies[0].velocity.x)));
    const __int128 dp = raw_momentum_x(w) - p0;
    const LD de = (kinetic(w) - e0) / e0;
    o.check("velocities swap (+5, -10 -> -10, +5 m/s)", "<= 1e-5 m/s", fmt(swap, "m/s"), swap <= 1e-5L);
    o.check("momentum change, exact integer units of 2^-32 kg m/s", "== 0", std::to_string(static_cast<long long>(dp)), dp == 0);
    o.report("kinetic energy, relative change", fmt(de));
    o.details = {{"va", va}, {"vb", vb}, {"momentum_change_raw", static_cast<long long>(dp)}, {"energy_rel_change", de}};
    return o;
}

// ---------------------------------------------------------------------------------------------
// 4. Newton's cradle

Outcome newton_cradle() {
    Outcome o;
    const sim::SceneDesc scene = scene_named("stability/newton_cradle");
    auto run = [&](const sim::SceneDesc& s, LD& last, LD& others, __int128& dp, LD& de) {
        World w(s);
        const __int128 p0 = raw_momentum_x(w);
        const LD e0 = kinetic(w);
        for (int n = 0; n < 120; ++n) w.step(neutral(w));
        const auto& ids = w.dynamic_ids();
        last = num(w.velocity(ids.back()).x);
        others = 0;
        for (std::size_t i = 0; i + 1 < ids.size(); ++i) others = std::max(others, norm(p3(w.velocity(ids[i]))));
        dp = raw_momentum_x(w) - p0;
        de = (kinetic(w) - e0) / e0;
    };
    const LD v0 = num(scene.bodies[0].velocity.x);
    LD last, others, de;
    __int128 dp;
    run(scene, last, others, dp, de);
    // The criterion: the impulse travels down the chain whole, as in the ideal cradle: the far
    // ball leaves with the striker's speed and every other ball is left at rest.
    o.check("far ball leaves with the striker's speed, |v - v0| / v0", "<= 1e-6", fmt(std::fabs(last - v0) / v0),
            std::fabs(last - v0) / v0 <= 1e-6L);
    o.check("largest speed left in the other five balls, / v0", "<= 1e-6", fmt(others / v0), others / v0 <= 1e-6L);
    o.check("momentum change (raw units)", "== 0", std::to_string(static_cast<long long>(dp)), dp == 0);
    o.check("kinetic energy, relative change", "<= 1e-9", fmt(std::fabs(de)), std::fabs(de) <= 1e-9L);
    o.details = {{"far_ball_v", last}, {"others_max_speed", others}, {"energy_rel_change", de}};
    // For comparison: Box2D v3's ordering (inelastic iterations, restitution afterwards) spreads
    // the impulse over the chain when the balls overlap slightly, as a resting row does.
    sim::SceneDesc b = scene;
    for (std::size_t i = 2; i < b.bodies.size(); ++i)
        b.bodies[i].position.x = b.bodies[i].position.x - Fixed::from_raw(Fixed::kOne / 1000 * static_cast<std::int64_t>(i - 1));
    LD last_d, others_d, de_d;
    __int128 dp_d;
    run(b, last_d, others_d, dp_d, de_d);
    b.solver.restitution_after = true;
    LD last_b, others_b, de_b;
    __int128 dp_b;
    run(b, last_b, others_b, dp_b, de_b);
    o.report("balls pre-compressed by 1 mm each: default solver, far ball / v0", fmt(last_d / v0));
    o.report("same with opt-in restitution_after: far ball / v0 (others up to " + fmt(others_b / v0) + ")", fmt(last_b / v0));
    o.details["overlapping_default"] = {{"far_ball_v", last_d}, {"others_max_speed", others_d}};
    o.details["overlapping_restitution_after"] = {{"far_ball_v", last_b}, {"others_max_speed", others_b}};
    return o;
}

// ---------------------------------------------------------------------------------------------
// 5. Stacks

struct StackFigures {
    LD compression = 0;  // ideal top height minus actual, at the end (m)
    LD lateral = 0;      // largest horizontal displacement of any box (m)
    LD jitter = 0;       // peak-to-peak of the top box's height over the last 5 s (m)
    LD speed = 0;        // largest speed of any box over the last 5 s (m/s)
    LD worst_overlap = 0;
};

StackFigures run_stack(const sim::SceneDesc& scene, int steps) {
    World w(scene);
    StackFigures f;
    const auto& ids = w.dynamic_ids();
    const BodyId top = ids.back();
    const LD ideal = num(scene.bodies[top].position.y);
    LD lo = 1e30L, hi = -1e30L;
    for (int n = 1; n <= steps; ++n) {
        w.step(neutral(w));
        for (BodyId id : ids) {
            const P3 d = p3(w.position(id)) - p3(scene.bodies[id].position);
            f.lateral = std::max(f.lateral, std::hypot(d.x, d.z));
        }
        if (n > steps / 2) {
            const LD y = num(w.position(top).y);
            lo = std::min(lo, y);
            hi = std::max(hi, y);
            f.speed = std::max(f.speed, max_speed(w));
        }
    }
    f.compression = ideal - num(w.position(top).y);
    f.jitter = hi - lo;
    f.worst_overlap = deepest_overlap(w);
    return f;
}

Outcome stacks() {
    Outcome o;
    for (const char* name : {"stability/stack_10", "stability/stack_24"}) {
        const sim::SceneDesc scene = scene_named(name);
        const int boxes = static_cast<int>(scene.bodies.size()) - 1;
        const StackFigures f = run_stack(scene, 10 * scene.tick_rate);
        // Each of the `boxes` contacts (floor included) may rest up to the slop deep: the stack
        // may settle by boxes x slop and no further; beyond that, nothing may move.
        const LD slop = num(scene.solver.slop);
        const LD allowed = boxes * slop + 1e-6L;
        const std::string tag = std::to_string(boxes) + " boxes: ";
        o.check(tag + "settling (top box below its stacked height) after 10 s",
                "<= boxes x slop + 1e-6 = " + fmt(allowed, "m"), fmt(f.compression, "m"),
                f.compression <= allowed && f.compression >= -1e-9L);
        o.check(tag + "deepest contact after 10 s", "<= slop + 1e-6 = " + fmt(slop + 1e-6L, "m"), fmt(f.worst_overlap, "m"),
                f.worst_overlap <= slop + 1e-6L);
        o.check(tag + "lateral drift of any box", "<= 1e-9 m", fmt(f.lateral, "m"), f.lateral <= 1e-9L);
        o.check(tag + "top box jitter, peak to peak over the last 5 s", "<= 1e-6 m", fmt(f.jitter, "m"), f.jitter <= 1e-6L);
        o.check(tag + "largest box speed over the last 5 s", "<= 1e-4 m/s", fmt(f.speed, "m/s"), f.speed <= 1e-4L);
        o.details[std::to_string(boxes)] = {{"compression_m", f.compression}, {"lateral_m", f.lateral},
                                            {"jitter_m", f.jitter}, {"max_speed_mps", f.speed},
                                            {"deepest_overlap_m", f.worst_overlap}};
        sim::SceneDesc d = scene;
        d.solver = sim::SolverDesc{};
        const StackFigures fd = run_stack(d, 10 * scene.tick_rate);
        o.report(tag + "default solver: settling / jitter / speed",
                 fmt(fd.compression, "m") + " / " + fmt(fd.jitter, "m") + " / " + fmt(fd.speed, "m/s"));
        o.details[std::to_string(boxes)]["default_solver"] = {
            {"compression_m", fd.compression}, {"jitter_m", fd.jitter}, {"max_speed_mps", fd.speed}};
    }
    return o;
}

// ---------------------------------------------------------------------------------------------
// 6. Mass ratios

Outcome mass_ratio_run(const sim::SceneDesc& scene) {
    Outcome o;
    World w(scene);
    const char* labels[4] = {"1:100 heavy on light", "1:100 light on heavy", "1:1000 heavy on light", "1:1000 light on heavy"};
    LD pen[4] = {0, 0, 0, 0}, speed = 0, end_pen[4] = {0, 0, 0, 0};
    const LD floor_top = num(scene.bodies[0].position.y + scene.bodies[0].half_extents.y);
    const int steps = 10 * scene.tick_rate;
    for (int n = 1; n <= steps; ++n) {
        w.step(neutral(w));
        for (int k = 0; k < 4; ++k) {
            const auto lo = static_cast<BodyId>(1 + 2 * k), hi = static_cast<BodyId>(2 + 2 * k);
            const LD ylo = num(w.position(lo).y), yhi = num(w.position(hi).y);
            const LD h = num(scene.bodies[lo].half_extents.y);
            // Overlap box-box and bottom box into the floor.
            const LD p = std::max(2 * h - (yhi - ylo), h - (ylo - floor_top));
            pen[k] = std::max(pen[k], p);
            if (n == steps) end_pen[k] = p;
        }
        if (n > scene.tick_rate) speed = std::max(speed, max_speed(w));
    }
    // The bound: no contact deeper than the slop it is allowed to rest at (plus rounding).
    const LD bound = num(scene.solver.slop) + 1e-6L;
    for (int k = 0; k < 4; ++k)
        o.check(std::string(labels[k]) + ": deepest penetration over 10 s", "<= slop + 1e-6 = " + fmt(bound, "m"),
                fmt(pen[k], "m"), pen[k] <= bound);
    o.check("no explosion: largest speed after the first second", "<= 1e-4 m/s", fmt(speed, "m/s"), speed <= 1e-4L);
    o.details = {{"deepest_m", std::vector<LD>(pen, pen + 4)}, {"final_m", std::vector<LD>(end_pen, end_pen + 4)},
                 {"max_speed_mps", speed}};
    return o;
}

Outcome mass_ratio() {
    const sim::SceneDesc scene = scene_named("stability/mass_ratio");
    Outcome o = mass_ratio_run(scene);
    sim::SceneDesc d = scene;
    d.solver = sim::SolverDesc{};
    const Outcome od = mass_ratio_run(d);
    LD worst = 0;
    for (LD p : od.details["deepest_m"].get<std::vector<LD>>()) worst = std::max(worst, p);
    o.report("default solver: deepest penetration of the four stacks", fmt(worst, "m"));
    o.details["default_solver"] = od.details;
    return o;
}

// ---------------------------------------------------------------------------------------------
// 7. Overlapping spawn

Outcome overlap_spawn_run(const sim::SceneDesc& scene) {
    Outcome o;
    World w(scene);
    const Room room = room_of(w);
    const LD dt = num(w.dt());
    const P3 g = p3(scene.gravity);
    // Free-flight displacement in one frame for the scene's integrator and substeps: whatever
    // moves a body beyond that was the solver pushing it.
    const int S = scene.solver.substeps;
    const LD ds = dt / S;
    const LD gcoef = scene.solver.integrator == sim::Integrator::Ballistic ? dt * dt / 2 : ds * ds * S * (S + 1) / 2;
    LD push = 0, speed = 0, across = 0, beyond = 0;
    int escapes = 0;
    const int steps = 5 * scene.tick_rate;
    std::vector<P3> x(w.body_count()), v(w.body_count());
    for (int n = 1; n <= steps; ++n) {
        for (BodyId id : w.dynamic_ids()) {
            x[id] = p3(w.position(id));
            v[id] = p3(w.velocity(id));
        }
        w.step(neutral(w));
        for (BodyId id : w.dynamic_ids()) {
            const P3 moved = p3(w.position(id)) - x[id], free = v[id] * dt + g * gcoef;
            push = std::max(push, norm(moved - free) / dt);
            beyond = std::max(beyond, outside(w, room, id));
            const P3 vel = p3(w.velocity(id));
            across = std::max(across, std::hypot(vel.x, vel.z));
        }
        speed = std::max(speed, max_speed(w));
        escapes = std::max(escapes, escaped(w, room));
    }
    const LD overlap = deepest_overlap(w);
    const LD cap = num(scene.solver.max_push_speed) > 0 ? num(scene.solver.max_push_speed) : 3;  // Box2D's default
    o.check("push-out speed (displacement beyond free flight / dt)", "<= " + fmt(cap, "m/s"), fmt(push, "m/s"),
            push <= cap * (1 + 1e-6L));
    o.check("largest body speed (no gravity: all of it comes from the solver)", "<= " + fmt(cap, "m/s"), fmt(speed, "m/s"),
            speed <= cap * (1 + 1e-6L));
    o.check("bodies outside the room", "== 0", std::to_string(escapes), escapes == 0);
    o.check("deepest remaining overlap after 5 s", "<= 1e-3 m", fmt(overlap, "m"), overlap <= 1e-3L);
    o.details = {{"push_out_mps", push}, {"max_speed_mps", speed}, {"max_horizontal_speed_mps", across}, {"escapes", escapes},
                 {"deepest_center_outside_m", beyond}, {"final_overlap_m", overlap}};
    return o;
}

Outcome overlap_spawn() {
    const sim::SceneDesc scene = scene_named("stability/overlap_spawn");
    Outcome o = overlap_spawn_run(scene);
    sim::SceneDesc d = scene;
    d.solver = sim::SolverDesc{};
    const Outcome od = overlap_spawn_run(d);
    o.report("default solver (no cap): push-out speed", fmt(od.details["push_out_mps"].get<LD>(), "m/s"));
    o.details["default_solver"] = od.details;
    return o;
}

// ---------------------------------------------------------------------------------------------
// 8. Tunneling

Outcome tunneling() {
    Outcome o;
    const sim::SceneDesc scene = scene_named("stability/tunneling");
    auto run = [&](const sim::SceneDesc& s, int& through, LD& deepest) {
        World w(s);
        const LD face = num(s.bodies[0].position.x - s.bodies[0].half_extents.x);
        through = 0;
        deepest = 0;
        std::vector<bool> passed(w.body_count(), false);
        for (int n = 0; n < 2 * s.tick_rate; ++n) {
            w.step(neutral(w));
            for (BodyId id : w.dynamic_ids()) {
                const LD front = num(w.position(id).x) + num(w.kernel().extent()[id].x);
                deepest = std::max(deepest, front - face);
                if (num(w.position(id).x) > num(s.bodies[0].position.x)) passed[id] = true;
            }
        }
        for (BodyId id : w.dynamic_ids()) through += passed[id];
    };
    int through;
    LD deepest;
    run(scene, through, deepest);
    o.check("bodies whose centre passed the wall (3 bodies, 150-250 m/s)", "== 0", std::to_string(through), through == 0);
    o.check("deepest reach past the wall's face", "<= 1e-6 m", fmt(deepest, "m"), deepest <= 1e-6L);
    sim::SceneDesc d = scene;
    d.solver = sim::SolverDesc{};
    int through_d;
    LD deepest_d;
    run(d, through_d, deepest_d);
    o.report("default solver (no continuous collision): bodies through the wall", std::to_string(through_d));
    o.details = {{"through", through}, {"deepest_m", deepest}, {"default_solver_through", through_d}};
    return o;
}

// ---------------------------------------------------------------------------------------------
// 9. Far from the origin

Outcome far_origin() {
    Outcome o;
    const sim::SceneDesc base = scene_named("stability/far_origin");
    const Fixed off = Fixed::from_int(1000000);
    auto run = [&](sim::BroadphaseKind kind, long& first_diff, int& diff_steps) {
        sim::SceneDesc a = base, b = base;
        a.broadphase = b.broadphase = kind;
        for (auto& body : b.bodies) body.position = body.position + Vec3{off, off, off};
        World wa(a), wb(b);
        first_diff = -1;
        diff_steps = 0;
        for (int n = 1; n <= 10 * base.tick_rate; ++n) {
            wa.step(neutral(wa));
            wb.step(neutral(wb));
            bool same = true;
            for (BodyId id : wa.dynamic_ids())
                same = same && wb.position(id) - Vec3{off, off, off} == wa.position(id) && wb.velocity(id) == wa.velocity(id);
            if (!same) {
                ++diff_steps;
                if (first_diff < 0) first_diff = n;
            }
        }
    };
    long first;
    int diffs;
    run(sim::BroadphaseKind::Auto, first, diffs);
    o.check("steps (of 600) whose relative state differs in any bit, offset (1e6, 1e6, 1e6) m", "== 0",
            std::to_string(diffs), diffs == 0);
    long first_g;
    int diffs_g;
    run(sim::BroadphaseKind::Grid, first_g, diffs_g);
    o.report("same with the grid broadphase forced (scenes above 2048 bodies use it)", std::to_string(diffs_g) + " steps differ");
    o.details = {{"differing_steps", diffs}, {"first_differing_step", first},
                 {"grid_differing_steps", diffs_g}, {"grid_first_differing_step", first_g}};
    return o;
}

// ---------------------------------------------------------------------------------------------
// 10. Tiny and huge

Outcome tiny_huge() {
    Outcome o;
    const sim::SceneDesc scene = scene_named("stability/tiny_huge");
    World w(scene);
    std::vector<P3> start(w.body_count());
    for (BodyId id : w.dynamic_ids()) start[id] = p3(w.position(id));
    const int steps = 10 * scene.tick_rate;
    LD worst_pen_rel = 0;
    for (int n = 1; n <= steps; ++n) {
        w.step(neutral(w));
        if (n % 30 == 0 || n == steps) {
            // Penetration of each small ball into the floor and the two big bodies, relative to its radius.
            const auto& k = w.kernel();
            for (BodyId id : w.dynamic_ids()) {
                if (id <= 2) continue;
                const sim::RoundCollider ball{w.position(id), k.core_half(id), k.radius(id)};
                sim::Contact c;
                LD d = 0;
                if (sim::collide(ball, sim::BoxCollider{w.position(0), k.half_extents(0)}, c)) d = std::max(d, num(c.depth));
                if (sim::collide(ball, sim::BoxCollider{w.position(1), k.half_extents(1)}, c)) d = std::max(d, num(c.depth));
                if (sim::collide(ball, sim::RoundCollider{w.position(2), k.core_half(2), k.radius(2)}, c))
                    d = std::max(d, num(c.depth));
                worst_pen_rel = std::max(worst_pen_rel, d / num(k.radius(id)));
            }
        }
    }
    LD big_drift = 0, lowest = 1e30L;
    for (BodyId id : w.dynamic_ids()) {
        if (id <= 2) big_drift = std::max(big_drift, norm(p3(w.position(id)) - start[id]));
        else lowest = std::min(lowest, num(w.position(id).y));
    }
    o.check("deepest small-ball penetration into floor or big bodies (sampled), / radius", "<= 0.1",
            fmt(worst_pen_rel), worst_pen_rel <= 0.1L);
    o.check("lowest small-ball centre (floor top at 0, radius 0.005)", ">= 0.0045 m", fmt(lowest, "m"), lowest >= 0.0045L);
    o.check("big bodies' drift over 10 s", "<= 1e-6 m", fmt(big_drift, "m"), big_drift <= 1e-6L);
    o.check("overflow counter", "== 0", std::to_string(w.overflow_count()), w.overflow_count() == 0);
    o.details = {{"worst_penetration_rel", worst_pen_rel}, {"lowest_small_y_m", lowest}, {"big_drift_m", big_drift},
                 {"overflow_count", w.overflow_count()}};
    return o;
}

// ---------------------------------------------------------------------------------------------
// 11. Q32.32 limits

Outcome q32_limits() {
    Outcome o;
    const sim::SceneDesc scene = scene_named("stability/q32_limits");
    World w(scene);
    sim::SceneDesc alone = scene;
    alone.bodies = {scene.bodies[5]};
    World control(alone);
    const Fixed dt = w.dt();
    // Saturating integer reference for a free body: x + round(v * dt), clamped to the range.
    auto expect = [&](Fixed x, Fixed v) {
        const __int128 prod = static_cast<__int128>(v.raw) * dt.raw;
        const __int128 r = sim::round_shift(prod, Fixed::kFracBits);
        const __int128 s = static_cast<__int128>(x.raw) + r;
        return Fixed::from_raw(s > INT64_MAX ? INT64_MAX : s < INT64_MIN ? INT64_MIN : static_cast<std::int64_t>(s));
    };
    int wrong = 0, control_diff = 0;
    bool at_limits = true;
    for (int n = 1; n <= 2 * scene.tick_rate; ++n) {
        Vec3 before[6];
        for (BodyId id = 0; id < 6; ++id) before[id] = w.position(id);
        Vec3 vel[6];
        for (BodyId id = 0; id < 6; ++id) vel[id] = w.velocity(id);
        w.step(neutral(w));
        control.step(neutral(control));
        for (BodyId id : {0u, 1u, 4u, 5u}) {
            const Vec3 e{expect(before[id].x, vel[id].x), expect(before[id].y, vel[id].y), expect(before[id].z, vel[id].z)};
            wrong += !(w.position(id) == e);
        }
        at_limits = at_limits && w.position(0).x == Fixed::max() && w.position(1).x == Fixed::min();
        control_diff += !(control.position(0) == w.position(5) && control.velocity(0) == w.velocity(5));
    }
    const LD v2 = num(w.velocity(2).x), v3 = num(w.velocity(3).x);
    o.check("overflow counter (saturations counted)", "> 0", std::to_string(w.overflow_count()), w.overflow_count() > 0);
    o.check("free bodies off the exact saturating update (x + v dt clamped), body-steps", "== 0", std::to_string(wrong), wrong == 0);
    o.check("bodies 0 and 1 pinned at +max and -max (no wrap to the other sign)", "yes", at_limits ? "yes" : "no", at_limits);
    o.check("bystander differs from the same ball simulated alone, steps", "== 0", std::to_string(control_diff), control_diff == 0);
    o.check("head-on pair at 1.5e9 m/s separates, in range (exact physics: -1.5e9, +1.5e9; the closing speed saturated)",
            "v2 <= 0 <= v3", fmt(v2, "m/s") + ", " + fmt(v3, "m/s"), v2 <= 0 && v3 >= 0);
    o.details = {{"overflow_count", w.overflow_count()}, {"v2_mps", v2}, {"v3_mps", v3}};
    return o;
}

// ---------------------------------------------------------------------------------------------
// 12. Paper scene across time steps and iterations

Outcome paper_sweep() {
    Outcome o;
    const sim::SceneDesc base = scene_named("paper");
    int worst_escapes = 0;
    LD worst_rise = -1e30L, worst_gain = 0;
    std::string worst_rise_at, worst_gain_at;
    json rows = json::array();
    for (int rate : {240, 120, 60, 30, 20})
        for (int iters : {1, 2, 4, 8, 16}) {
            sim::SceneDesc s = base;
            s.tick_rate = rate;
            s.iterations = iters;
            World w(s);
            const Room room = room_of(w);
            const LD e0 = energy(w);
            LD emax = e0, emin = e0, gain = 0;
            int esc = 0;
            for (int n = 0; n < 10 * rate; ++n) {
                w.step(neutral(w));
                const LD e = energy(w);
                emax = std::max(emax, e);
                emin = std::min(emin, e);
                gain = std::max(gain, (e - emin) / e0);  // energy the solver put back after a low
                esc = std::max(esc, escaped(w, room));
            }
            const LD rise = (emax - e0) / e0;
            if (gain > worst_gain) {
                worst_gain = gain;
                worst_gain_at = std::to_string(rate) + " Hz x " + std::to_string(iters) + " it";
            }
            worst_escapes = std::max(worst_escapes, esc);
            if (rise > worst_rise) {
                worst_rise = rise;
                worst_rise_at = std::to_string(rate) + " Hz x " + std::to_string(iters) + " it";
            }
            rows.push_back({{"tick_rate", rate}, {"iterations", iters}, {"escapes", esc}, {"energy_max_rise", rise},
                            {"energy_max_gain_over_running_min", gain},
                            {"energy_final_rel", (energy(w) - e0) / e0}, {"overflow_count", w.overflow_count()}});
        }
    o.check("bodies outside the room, worst of 25 settings, 10 s each", "== 0", std::to_string(worst_escapes), worst_escapes == 0);
    o.check("energy above its start, worst (" + worst_rise_at + ")", "<= 5%", fmt(100 * worst_rise, "%"), worst_rise <= 0.05L);
    o.check("energy regained after its lowest point so far, / start, worst (" + worst_gain_at + ")", "<= 5%",
            fmt(100 * worst_gain, "%"), worst_gain <= 0.05L);
    o.details = {{"runs", rows}};
    return o;
}

// ---------------------------------------------------------------------------------------------
// 13. Resting pile

Outcome resting_pile_run(const sim::SceneDesc& scene) {
    Outcome o;
    World w(scene);
    const Room room = room_of(w);
    const int steps = 15 * scene.tick_rate;
    int esc = 0;
    for (int n = 0; n < steps; ++n) {
        w.step(neutral(w));
        esc = std::max(esc, escaped(w, room));
    }
    const LD ke = kinetic(w), speed = max_speed(w);
    const LD per_body = ke / static_cast<LD>(w.dynamic_count());
    o.check("residual kinetic energy per ball after 15 s", "<= 1e-6 J", fmt(per_body, "J"), per_body <= 1e-6L);
    o.check("largest ball speed after 15 s", "<= 1e-3 m/s", fmt(speed, "m/s"), speed <= 1e-3L);
    o.check("balls outside the bin", "== 0", std::to_string(esc), esc == 0);
    o.report("total residual kinetic energy", fmt(ke, "J"));
    o.details = {{"kinetic_total_j", ke}, {"kinetic_per_ball_j", per_body}, {"max_speed_mps", speed}, {"escapes", esc}};
    return o;
}

Outcome resting_pile() {
    const sim::SceneDesc scene = scene_named("stability/resting_pile");
    Outcome o = resting_pile_run(scene);
    sim::SceneDesc d = scene;
    d.solver = sim::SolverDesc{};
    const Outcome od = resting_pile_run(d);
    o.report("default solver: kinetic energy per ball / largest speed after 15 s",
             fmt(od.details["kinetic_per_ball_j"].get<LD>(), "J") + " / " + fmt(od.details["max_speed_mps"].get<LD>(), "m/s"));
    o.details["default_solver"] = od.details;
    return o;
}

// ---------------------------------------------------------------------------------------------
// 14. Dense chaos

Outcome dense_chaos() {
    Outcome o;
    const sim::SceneDesc scene = scene_named("bodies_10k");
    World w(scene);
    const Room room = room_of(w);
    const LD e0 = energy(w);
    LD emax = e0, emin = e0, gain = 0;
    int esc = 0;
    for (int n = 0; n < 10 * scene.tick_rate; ++n) {
        w.step(neutral(w));
        if (n % 6 == 5) {
            const LD e = energy(w);
            emax = std::max(emax, e);
            emin = std::min(emin, e);
            gain = std::max(gain, (e - emin) / e0);
            esc = std::max(esc, escaped(w, room));
        }
    }
    const LD rise = (emax - e0) / e0;
    o.check("overflow counter after 10 s", "== 0", std::to_string(w.overflow_count()), w.overflow_count() == 0);
    o.check("bodies outside the room (sampled every 0.1 s)", "== 0", std::to_string(esc), esc == 0);
    o.check("energy above its start (sampled every 0.1 s)", "<= 5%", fmt(100 * rise, "%"), rise <= 0.05L);
    o.check("energy regained after its lowest point so far, / start", "<= 5%", fmt(100 * gain, "%"), gain <= 0.05L);
    o.report("energy after 10 s, relative to start", fmt((energy(w) - e0) / e0));
    o.details = {{"overflow_count", w.overflow_count()}, {"escapes", esc}, {"energy_max_rise", rise}, {"energy_max_gain", gain},
                 {"energy_final_rel", (energy(w) - e0) / e0}};
    return o;
}


}  // namespace

std::vector<Case> all_cases() {
    return {
        {"free_fall", "1. free fall, 2 s", false, false, free_fall},
        {"bounce", "2. bounce, e = 1 / 0.8 / 0", false, false, bounce},
        {"head_on", "3. head-on elastic pair", false, false, head_on},
        {"newton_cradle", "4. Newton's cradle", false, false, newton_cradle},
        {"stacks", "5. stacks of 10 and 24 boxes, 10 s", false, false, stacks},
        {"mass_ratio", "6. mass ratios 1:100 and 1:1000", false, false, mass_ratio},
        {"overlap_spawn", "7. 50 overlapping spawns", false, false, overlap_spawn},
        {"tunneling", "8. tunneling at 200 m/s", false, false, tunneling},
        {"far_origin", "9. 1e6 m from the origin", false, false, far_origin},
        {"tiny_huge", "10. 1 cm and 100 m bodies", false, false, tiny_huge},
        {"q32_limits", "11. Q32.32 limits", false, false, q32_limits},
        {"paper_sweep", "12. paper scene, 240..20 Hz x 1..16 iterations", false, false, paper_sweep},
        {"resting_pile", "13. resting pile of 200 balls", false, false, resting_pile},
        {"dense_chaos", "14. 10,000 bodies, 10 s", true, false, dense_chaos},
        {"rigid_roll", "15. rigid: sliding ball ends rolling at 5/7 v0", false, false, rigid_roll},
        {"rigid_backspin", "16. rigid: backspin ball, incl. coming back", false, false, rigid_backspin},
        {"rigid_spin", "17. rigid: torque-free box, momentum, energy, Dzhanibekov", false, false, rigid_spin},
        {"rigid_ramp", "18. rigid: box on a 30 deg ramp, mu 0.7 sticks, mu 0.3 slides", false, false, rigid_ramp},
        {"rigid_tip", "19. rigid: box tipped on an edge, 2 deg past / short of balance", false, false, rigid_tip},
        {"rigid_pyramid", "20. rigid: 10-box pyramid with friction, 10 s", false, false, rigid_pyramid},
        // Warm starting, four-corner manifolds, block normal rows and split impulses: docs/physics.md.
        {"rigid_stack", "21. rigid: 20-box stack with friction, 10 s", false, false, rigid_stack},
    };
}

}  // namespace lockroll::harness::stability
