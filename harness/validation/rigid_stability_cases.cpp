#include "harness/validation/rigid_stability_cases.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "harness/validation/stability_measures.h"
#include "sim/world.h"

namespace lockroll::harness::stability {

using namespace measure;

// ---------------------------------------------------------------------------------------------
// 15-21. Rigid bodies (scenes with "rigid"; docs/physics.md)

namespace {

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
}  // namespace

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

namespace {
// Turn about z of a body that only turns about z, in degrees.
LD turn_z_degrees(const sim::Quat& q) { return 2 * std::atan2(num(q.z), num(q.w)) * 180 / 3.14159265358979323846L; }

}  // namespace

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

namespace {
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
}  // namespace

Outcome rigid_pyramid() { return rigid_stack_case("stability/rigid_pyramid_10"); }
Outcome rigid_stack() { return rigid_stack_case("stability/rigid_stack_20"); }

}  // namespace lockroll::harness::stability
