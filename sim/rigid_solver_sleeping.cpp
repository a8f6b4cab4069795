// RigidSolver's sleeping (rigid.sleeping; sim/rigid_solver.h, docs/physics.md "Sleeping"):
// which bodies a step moves, waking, and falling asleep. All of it runs on the stepping thread,
// in body-id order or as a function of the candidate pair set alone, so a step gives the same
// bits at any worker count and whatever order the broadphase's ranges ran in. A scene without
// sleeping never calls into this file.
#include <algorithm>

#include "sim/rigid_solver.h"
#include "sim/world.h"

namespace lockroll::sim {

namespace {
constexpr std::uint32_t kAsleep = World::kAsleep;
// wake()'s marks (mark_, by id): a sleeping body an awake dynamic body touches, and the root of
// a component of sleeping bodies that wakes.
constexpr std::uint8_t kTouched = 1, kWakes = 2;
}  // namespace

void RigidSolver::awake_set(const std::vector<std::uint32_t>& sleep) {
    dynamic_.clear();
    for (BodyId id : every_dynamic_)
        if (sleep[id] != kAsleep) dynamic_.push_back(id);
}

void RigidSolver::wake(std::vector<Vec3>& vel, const std::vector<Quat>& orient, const std::vector<Vec3>& angvel,
                       std::vector<std::uint32_t>& sleep) {
    if (dynamic_.size() == every_dynamic_.size()) return;  // nobody asleep: every pair has an awake end
    const auto asleep = [&](BodyId id) { return sleep[id] == kAsleep; };
    const auto awake_dynamic = [&](BodyId id) { return inv_mass_[id].raw != 0 && !asleep(id); };
    // mark_: kTouched for a sleeping body that has a pair with an awake dynamic body.
    sleep_links_.clear();
    woken_.clear();
    for (const BodyPair& p : pairs_) {
        const bool sa = asleep(p.a), sb = asleep(p.b);
        if (sa && sb)
            sleep_links_.push_back(p);
        else if (sa && awake_dynamic(p.b))
            mark_[p.a] = kTouched;
        else if (sb && awake_dynamic(p.a))
            mark_[p.b] = kTouched;
    }
    bool any = false;
    for (BodyId id : every_dynamic_) any = any || mark_[id] != 0;
    if (any) {
        // Components of sleeping bodies over their pairs (every dynamic body alone first, so an
        // awake one stays alone): one with a touched body wakes whole. The order of waking is
        // immaterial (woken_ is sorted below).
        for (BodyId id : every_dynamic_) components_.isolate(id);
        for (const BodyPair& p : sleep_links_) components_.unite(p.a, p.b);
        for (BodyId id : every_dynamic_)
            if ((mark_[id] & kTouched) != 0) mark_[components_.find(id)] |= kWakes;
        for (BodyId id : every_dynamic_)
            if ((mark_[components_.find(id)] & kWakes) != 0 && asleep(id)) {
                sleep[id] = 0;
                woken_.push_back(id);
            }
        for (BodyId id : every_dynamic_) mark_[id] = 0;
    }
    if (!woken_.empty()) {
        // The woken bodies' per-body phases (v = w = 0 while asleep: no damping or control to
        // apply), over dynamic_ swapped for them, then the awake set again in id order.
        std::sort(woken_.begin(), woken_.end());
        for (BodyId id : woken_) vel[id] += gravity_dv_[id];
        dynamic_.swap(woken_);
        update_inertia(orient, 0, dynamic_.size());
        closing_reach(vel, angvel, 0, dynamic_.size());
        dynamic_.swap(woken_);
        awake_set(sleep);
    }
    // Contact generation skips pairs with no awake dynamic end (after waking, a pair with a
    // sleeping end has its other end asleep or static): the same order otherwise.
    pairs_.erase(std::remove_if(pairs_.begin(), pairs_.end(),
                                [&](const BodyPair& p) { return !awake_dynamic(p.a) && !awake_dynamic(p.b); }),
                 pairs_.end());
}

void RigidSolver::fall_asleep(std::vector<Vec3>& vel, std::vector<Vec3>& angvel, std::vector<ContactImpulse>& impulses,
                              std::vector<std::uint32_t>& sleep) {
    bool any_ready = false;
    for (BodyId id : dynamic_) {
        const bool still = !player_[id] && length_sq_wide(vel[id]) < sleep_lin_sq_ && length_sq_wide(angvel[id]) < sleep_ang_sq_;
        sleep[id] = still ? std::min(sleep[id] + 1, sleep_frames_) : 0;
        any_ready = any_ready || sleep[id] == sleep_frames_;
    }
    if (!any_ready) return;  // no island can fall asleep: every one needs a ready body
    // Islands over this step's pairs (each has an awake dynamic end, the other awake or static;
    // static ends join nothing): a union-find over the awake bodies' ids (the smaller root
    // wins, so the forest is a function of the pairs alone). An island falls asleep when no
    // body of it is short of the time to sleep: mark_ taints the roots of those that are.
    // (Islands::build gives the same components but also numbers and sorts the links, which
    // cost 160 M instructions over bodies_1k_rigid's 720 frames: docs/performance.md.)
    for (BodyId id : dynamic_) components_.isolate(id);
    for (const BodyPair& p : pairs_)
        if (inv_mass_[p.a].raw != 0 && inv_mass_[p.b].raw != 0) components_.unite(p.a, p.b);
    for (BodyId id : dynamic_)
        if (sleep[id] != sleep_frames_) mark_[components_.find(id)] = 1;
    bool fell = false;
    for (BodyId id : dynamic_) {
        if (sleep[id] != sleep_frames_ || mark_[components_.find(id)] != 0) continue;
        sleep[id] = kAsleep;
        vel[id] = Vec3{};
        angvel[id] = Vec3{};
        closing_[id] = Fixed::zero();
        fell = true;
    }
    for (BodyId id : dynamic_) mark_[id] = 0;  // every mark is on a root, an awake body
    if (!fell || impulses.empty()) return;
    // A sleeping body's carried impulses are dropped: a woken body starts cold.
    impulses.erase(std::remove_if(impulses.begin(), impulses.end(),
                                  [&](const ContactImpulse& c) { return sleep[c.body] == kAsleep || sleep[c.other] == kAsleep; }),
                   impulses.end());
}

}  // namespace lockroll::sim
