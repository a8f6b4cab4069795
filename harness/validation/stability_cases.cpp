#include "harness/validation/stability_cases.h"

#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <memory>

#include "harness/match/scene_loader.h"
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

// ---------------------------------------------------------------------------------------------
// Measuring: Q32.32 values are read exactly into long double (64-bit mantissa), never fed back.

LD num(Fixed f) { return static_cast<LD>(f.raw) / 4294967296.0L; }

struct P3 {
    LD x = 0, y = 0, z = 0;
};
P3 p3(const Vec3& v) { return {num(v.x), num(v.y), num(v.z)}; }
P3 operator-(P3 a, P3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
P3 operator+(P3 a, P3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
P3 operator*(P3 a, LD s) { return {a.x * s, a.y * s, a.z * s}; }
LD dot(P3 a, P3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
LD norm(P3 a) { return std::sqrt(dot(a, a)); }

std::string fmt(LD v, const char* unit = "") {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.4Lg%s%s", v, *unit ? " " : "", unit);
    return buf;
}

sim::SceneDesc scene_named(const std::string& name) {
    try {
        return load_scene(name);
    } catch (const SceneError& e) {
        throw std::runtime_error(e.what());  // a shipped scene that does not load is a failure, not usage
    }
}

std::vector<sim::PlayerInput> neutral(const World& w) {
    return std::vector<sim::PlayerInput>(static_cast<std::size_t>(w.player_count()));
}

// Kinetic plus potential energy (J) of the dynamic bodies; potential measured from y = 0.
LD energy(const World& w) {
    const sim::SceneDesc& s = w.scene();
    const P3 g = p3(s.gravity);
    LD e = 0;
    for (BodyId id : w.dynamic_ids()) {
        const sim::BodyDesc& b = s.bodies[id];
        const LD m = num(b.mass);
        const P3 v = p3(w.velocity(id));
        e += m * dot(v, v) / 2 - m * num(b.gravity_scale) * dot(g, p3(w.position(id)));
    }
    return e;
}

LD kinetic(const World& w) {
    LD e = 0;
    for (BodyId id : w.dynamic_ids()) {
        const P3 v = p3(w.velocity(id));
        e += num(w.scene().bodies[id].mass) * dot(v, v) / 2;
    }
    return e;
}

LD max_speed(const World& w) {
    LD m = 0;
    for (BodyId id : w.dynamic_ids()) m = std::max(m, norm(p3(w.velocity(id))));
    return m;
}

// The interior of a room built by the scene's "room" key: the six walls are bodies 0..5.
struct Room {
    P3 lo, hi;
};
Room room_of(const World& w) {
    auto wall = [&](BodyId id) {
        const sim::BodyDesc& b = w.scene().bodies[id];
        return std::pair<P3, P3>{p3(b.position), p3(b.half_extents)};
    };
    const auto [f, fh] = wall(0);
    const auto [c, ch] = wall(1);
    const auto [xl, xlh] = wall(2);
    const auto [xh, xhh] = wall(3);
    const auto [zl, zlh] = wall(4);
    const auto [zh, zhh] = wall(5);
    return {{xl.x + xlh.x, f.y + fh.y, zl.z + zlh.z}, {xh.x - xhh.x, c.y - ch.y, zh.z - zhh.z}};
}

// How far (m) the body's centre lies outside the room's interior: beyond its bounding radius
// the whole body is in or behind a wall, which is what "escaped" means here.
LD outside(const World& w, const Room& r, BodyId id) {
    const P3 p = p3(w.position(id));
    LD d = 0;
    d = std::max({d, r.lo.x - p.x, p.x - r.hi.x, r.lo.y - p.y, p.y - r.hi.y, r.lo.z - p.z, p.z - r.hi.z});
    return d;
}
LD bounding_radius(const World& w, BodyId id) {
    const sim::BodyDesc& b = w.scene().bodies[id];
    switch (b.shape) {
        case sim::Shape::Sphere: return num(b.radius);
        case sim::Shape::Capsule: return num(b.radius) + num(b.half_height);
        case sim::Shape::Box: return std::max({num(b.half_extents.x), num(b.half_extents.y), num(b.half_extents.z)});
    }
    return 0;
}
int escaped(const World& w, const Room& r) {
    int n = 0;
    for (BodyId id : w.dynamic_ids()) n += outside(w, r, id) > bounding_radius(w, id);
    return n;
}

// Deepest overlap between any two dynamic bodies or a dynamic and a static body (m), from the
// narrowphase itself; O(n^2), for the small scenes that ask for it.
LD deepest_overlap(const World& w) {
    const auto& k = w.kernel();
    LD deepest = 0;
    auto collider_pair = [&](BodyId a, BodyId b) -> LD {
        sim::Contact c;
        const bool ra = k.shape(a) != sim::Shape::Box, rb = k.shape(b) != sim::Shape::Box;
        const sim::RoundCollider rca{w.position(a), k.core_half(a), k.radius(a)}, rcb{w.position(b), k.core_half(b), k.radius(b)};
        const sim::BoxCollider bca{w.position(a), k.half_extents(a)}, bcb{w.position(b), k.half_extents(b)};
        bool hit;
        if (ra && rb) hit = sim::collide(rca, rcb, c);
        else if (ra) hit = sim::collide(rca, bcb, c);
        else if (rb) hit = sim::collide(rcb, bca, c);
        else hit = sim::collide(bca, bcb, c);
        return hit ? num(c.depth) : 0;
    };
    const std::size_t n = w.body_count();
    for (std::size_t i = 0; i < n; ++i)
        for (std::size_t j = i + 1; j < n; ++j) {
            const auto a = static_cast<BodyId>(i), b = static_cast<BodyId>(j);
            if (w.is_static(a) && w.is_static(b)) continue;
            deepest = std::max(deepest, collider_pair(a, b));
        }
    return deepest;
}


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

// ---------------------------------------------------------------------------------------------
// 15-17. Rigid bodies (scenes with "rigid"; docs/physics.md)

// Body axis k (column k of the rotation) of a Q32.32 orientation, in world space.
P3 body_axis(const sim::Quat& q, int k) {
    const LD w = num(q.w), x = num(q.x), y = num(q.y), z = num(q.z);
    if (k == 0) return {1 - 2 * (y * y + z * z), 2 * (x * y + w * z), 2 * (x * z - w * y)};
    if (k == 1) return {2 * (x * y - w * z), 1 - 2 * (x * x + z * z), 2 * (y * z + w * x)};
    return {2 * (x * z + w * y), 2 * (y * z - w * x), 1 - 2 * (x * x + y * y)};
}

// Principal moments of a body, from the scene (what the World uses, here in long double).
P3 moments(const sim::BodyDesc& b) {
    const LD m = num(b.mass);
    if (b.shape == sim::Shape::Box) {
        const LD x = num(b.half_extents.x), y = num(b.half_extents.y), z = num(b.half_extents.z);
        return {m * (y * y + z * z) / 3, m * (x * x + z * z) / 3, m * (x * x + y * y) / 3};
    }
    const LD i = 0.4L * m * num(b.radius) * num(b.radius);  // spheres (the only other shape used here)
    return {i, i, i};
}

// World angular momentum L = R I R^T w and rotational energy w . L / 2 of body id.
void spin_state(const World& w, BodyId id, P3& l, LD& e) {
    const sim::Quat& q = w.orientation(id);
    const P3 a[3] = {body_axis(q, 0), body_axis(q, 1), body_axis(q, 2)};
    const P3 om = p3(w.angular_velocity(id)), i = moments(w.scene().bodies[id]);
    const LD lb[3] = {i.x * dot(a[0], om), i.y * dot(a[1], om), i.z * dot(a[2], om)};
    l = a[0] * lb[0] + a[1] * lb[1] + a[2] * lb[2];
    e = dot(om, l) / 2;
}

// Slip speed at the contact point of a ball on the floor (x direction): v_x + w_z r.
LD slip(const World& w, BodyId id) { return num(w.velocity(id).x) + num(w.angular_velocity(id).z) * num(w.kernel().radius(id)); }

// Steps until the ball rolls (|slip| below 1 mm/s); returns the roll-onset time, read between
// frames from the last sliding frames' constant slip rate (the frame itself is 1/60 s coarse).
LD roll_onset(World& w, BodyId id, int max_steps, int& frames) {
    const LD dt = num(w.dt());
    LD prev2 = slip(w, id), prev = prev2;
    for (int n = 1; n <= max_steps; ++n) {
        w.step(neutral(w));
        const LD s = slip(w, id);
        if (std::fabs(s) < 1e-3L) {
            frames = n;
            const LD rate = n >= 2 ? prev2 - prev : prev - s;  // slip lost per sliding frame
            return (n - 1) * dt + dt * prev / rate;
        }
        prev2 = prev;
        prev = s;
    }
    frames = -1;
    return -1;
}

Outcome rigid_roll() {
    Outcome o;
    const sim::SceneDesc scene = scene_named("stability/rigid_roll");
    World w(scene);
    const BodyId id = 1;
    const LD v0 = num(scene.bodies[id].velocity.x), g = -num(scene.gravity.y), mu = num(scene.rigid.friction[0][1]);
    const LD t_ref = 2 * v0 / (7 * mu * g), v_ref = 5 * v0 / 7;
    int frames = 0;
    const LD t = roll_onset(w, id, 600, frames);
    for (int n = 0; n < 60; ++n) w.step(neutral(w));  // and it keeps rolling
    const LD v = num(w.velocity(id).x);
    const LD et = std::fabs(t - t_ref) / t_ref, ev = std::fabs(v - v_ref) / v_ref;
    o.check("rolls at 5/7 v0 (" + fmt(v_ref, "m/s") + "), relative error 1 s later", "<= 1%", fmt(ev), ev <= 0.01L);
    o.check("starts rolling at 2 v0 / (7 mu g) = " + fmt(t_ref, "s") + " (frame " + std::to_string(frames) +
                "), relative error",
            "<= 1%", fmt(et), frames > 0 && et <= 0.01L);
    o.report("slip speed 1 s after rolling began", fmt(std::fabs(slip(w, id)), "m/s"));
    o.details = {{"roll_time_s", t}, {"roll_time_ref_s", t_ref}, {"speed_mps", v}, {"speed_ref_mps", v_ref}};
    return o;
}

Outcome rigid_backspin() {
    Outcome o;
    const sim::SceneDesc scene = scene_named("stability/rigid_backspin");
    const LD g = -num(scene.gravity.y), mu = num(scene.rigid.friction[0][1]);
    for (BodyId id : {BodyId{1}, BodyId{2}}) {
        World w(scene);
        const sim::BodyDesc& b = scene.bodies[id];
        const LD v0 = num(b.velocity.x), w0 = num(b.angular_velocity.z), r = num(b.radius);
        const LD v_ref = (5 * v0 - 2 * w0 * r) / 7;
        // Slip falls at mu g (1 + m r^2 / I) = 7/2 mu g from v0 + w0 r.
        const LD t_ref = (v0 + w0 * r) / (3.5L * mu * g);
        int frames = 0;
        const LD t = roll_onset(w, id, 1200, frames);
        for (int n = 0; n < 60; ++n) w.step(neutral(w));
        const LD v = num(w.velocity(id).x);
        const LD ev = std::fabs(v - v_ref) / std::fabs(v_ref), et = std::fabs(t - t_ref) / t_ref;
        const std::string what = "v0 " + fmt(v0, "m/s") + ", w0 " + fmt(w0, "rad/s") + ": ";
        o.check(what + "rolls at (5 v0 - 2 w0 r) / 7 = " + fmt(v_ref, "m/s") + (v_ref < 0 ? " (comes back)" : "") +
                    ", relative error",
                "<= 1%", fmt(ev), ev <= 0.01L && (v < 0) == (v_ref < 0));
        o.check(what + "starts rolling at (v0 + w0 r) / (7/2 mu g) = " + fmt(t_ref, "s") + ", relative error", "<= 1%",
                fmt(et), frames > 0 && et <= 0.01L);
        o.details["body_" + std::to_string(id)] = {{"speed_mps", v}, {"speed_ref_mps", v_ref}, {"roll_time_s", t},
                                                   {"roll_time_ref_s", t_ref}};
    }
    return o;
}

Outcome rigid_spin() {
    Outcome o;
    const sim::SceneDesc scene = scene_named("stability/rigid_spin");
    World w(scene);
    const int steps = 10 * scene.tick_rate;
    P3 l0[4];
    LD e0[4];
    for (BodyId id = 0; id < 4; ++id) spin_state(w, id, l0[id], e0[id]);
    LD worst_l = 0, worst_e = 0;
    // Alignment of each nudged box's spin axis with its (conserved) angular momentum.
    LD min_align[4] = {1, 1, 1, 1};
    int flips = 0;
    bool was_flipped = false;
    for (int n = 1; n <= steps; ++n) {
        w.step(neutral(w));
        P3 l;
        LD e;
        spin_state(w, 0, l, e);
        worst_l = std::max(worst_l, norm(l - l0[0]) / norm(l0[0]));
        worst_e = std::max(worst_e, std::fabs(e - e0[0]) / e0[0]);
        for (int k = 0; k < 3; ++k) {
            const BodyId id = static_cast<BodyId>(k + 1);
            const LD align = dot(body_axis(w.orientation(id), k), l0[id] * (1 / norm(l0[id])));
            min_align[id] = std::min(min_align[id], align);
            if (k == 1) {
                if (align < -0.9L && !was_flipped) ++flips, was_flipped = true;
                if (align > 0.9L && was_flipped) ++flips, was_flipped = false;
            }
        }
    }
    o.check("skew spin: angular momentum, largest relative change over 10 s", "<= 1e-4", fmt(worst_l), worst_l <= 1e-4L);
    o.check("skew spin: rotational energy, largest relative drift over 10 s", "<= 1e-3", fmt(worst_e), worst_e <= 1e-3L);
    o.check("spin about the smallest axis stays: lowest axis . L/|L|", ">= 0.99", fmt(min_align[1]), min_align[1] >= 0.99L);
    o.check("spin about the intermediate axis flips (Dzhanibekov): flips in 10 s", ">= 1", std::to_string(flips),
            flips >= 1 && min_align[2] < -0.9L);
    o.check("spin about the largest axis stays: lowest axis . L/|L|", ">= 0.99", fmt(min_align[3]), min_align[3] >= 0.99L);
    o.details = {{"momentum_rel_change", worst_l}, {"energy_rel_drift", worst_e}, {"intermediate_flips", flips},
                 {"align_min", {min_align[1], min_align[2], min_align[3]}}};
    return o;
}

Outcome rigid_ramp() {
    Outcome o;
    const LD pi = 3.14159265358979323846L, theta = pi / 6;
    const P3 down{-std::cos(theta), -std::sin(theta), 0};
    {
        const sim::SceneDesc scene = scene_named("stability/rigid_ramp_stick");
        World w(scene);
        for (int n = 0; n < 30; ++n) w.step(neutral(w));  // settle onto the ramp
        const P3 x0 = p3(w.position(1));
        for (int n = 0; n < 5 * scene.tick_rate; ++n) w.step(neutral(w));
        const LD moved = norm(p3(w.position(1)) - x0);
        o.check("mu = 0.7 > tan 30: distance moved in 5 s after settling", "<= 1 mm", fmt(moved, "m"), moved <= 1e-3L);
        o.details["stick_moved_m"] = moved;
    }
    {
        const sim::SceneDesc scene = scene_named("stability/rigid_ramp_slide");
        World w(scene);
        const LD g = -num(scene.gravity.y), mu = num(scene.rigid.friction[1][1]);
        const LD a_ref = g * (std::sin(theta) - mu * std::cos(theta));
        const int t1 = scene.tick_rate / 2, t2 = 3 * scene.tick_rate / 2;
        LD v1 = 0;
        for (int n = 1; n <= t2; ++n) {
            w.step(neutral(w));
            if (n == t1) v1 = dot(p3(w.velocity(1)), down);
        }
        const LD a = (dot(p3(w.velocity(1)), down) - v1) / (num(w.dt()) * (t2 - t1));
        const LD err = std::fabs(a - a_ref) / a_ref;
        o.check("mu = 0.3: acceleration down the ramp vs g (sin 30 - mu cos 30) = " + fmt(a_ref, "m/s^2") +
                    ", relative error (0.5..1.5 s)",
                "<= 1%", fmt(err), err <= 0.01L);
        o.details["slide"] = {{"accel_mps2", a}, {"accel_ref_mps2", a_ref}};
    }
    return o;
}

// Turn about z of a body that only turns about z, in degrees.
LD turn_z_degrees(const sim::Quat& q) { return 2 * std::atan2(num(q.z), num(q.w)) * 180 / 3.14159265358979323846L; }

Outcome rigid_tip() {
    Outcome o;
    const sim::SceneDesc scene = scene_named("stability/rigid_tip");
    World w(scene);
    for (int n = 0; n < 4 * scene.tick_rate; ++n) w.step(neutral(w));
    const LD over = turn_z_degrees(w.orientation(1)), back = turn_z_degrees(w.orientation(2));
    const LD spin = std::max(norm(p3(w.angular_velocity(1))), norm(p3(w.angular_velocity(2))));
    o.check("turned 47 deg (past the 45 deg balance): falls onto its face, turn after 4 s", "90 +- 1 deg", fmt(over, "deg"),
            std::fabs(over - 90) <= 1);
    o.check("turned 43 deg (short of it): rights itself, turn after 4 s", "0 +- 1 deg", fmt(back, "deg"), std::fabs(back) <= 1);
    o.check("both at rest after 4 s: largest angular speed", "<= 0.01 rad/s", fmt(spin, "rad/s"), spin <= 0.01L);
    o.details = {{"fell_deg", over}, {"righted_deg", back}, {"angular_speed", spin}};
    return o;
}

Outcome rigid_stack_case(const char* name) {
    Outcome o;
    {
        const sim::SceneDesc scene = scene_named(name);
        World w(scene);
        std::vector<P3> x0;
        for (BodyId id : w.dynamic_ids()) x0.push_back(p3(w.position(id)));
        LD drift = 0, tilt = 0;
        for (int n = 0; n < 10 * scene.tick_rate; ++n) {
            w.step(neutral(w));
            for (std::size_t i = 0; i < x0.size(); ++i) {
                const BodyId id = w.dynamic_ids()[i];
                drift = std::max(drift, norm(p3(w.position(id)) - x0[i]));
                tilt = std::max(tilt, 1 - body_axis(w.orientation(id), 1).y);
            }
        }
        const std::string short_name = std::string(name).substr(10);
        o.check(short_name + ": largest distance of any box from its start over 10 s", "<= 1 cm", fmt(drift, "m"),
                drift <= 0.01L);
        o.report(short_name + ": largest tilt over 10 s, 1 - cos", fmt(tilt));
        // Standing or fallen: the highest box's height after 10 s against its start.
        const BodyId top = w.dynamic_ids().back();
        const LD height = p3(w.position(top)).y, start = x0.back().y;
        o.report(short_name + ": last box's height after 10 s / at the start", fmt(height, "m") + " / " + fmt(start, "m"));
        o.details[short_name] = {{"drift_m", drift}, {"tilt_1_minus_cos", tilt}, {"last_height_m", height}};
    }
    return o;
}
Outcome rigid_pyramid() { return rigid_stack_case("stability/rigid_pyramid_10"); }
Outcome rigid_stack() { return rigid_stack_case("stability/rigid_stack_20"); }

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
