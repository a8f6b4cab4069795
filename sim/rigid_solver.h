// The rigid-body step, for scenes that opt in (SceneDesc::rigid.enabled; docs/physics.md).
//
// Order of operations per frame (dt = 1 / tick_rate):
//  1. velocities: v += g dt; the frame's player input; damping v *= 1/(1 + c dt), w likewise.
//  2. world-space inverse inertia R diag(I^-1) R^T of every dynamic body, once; each body's
//     closing bound (|v|_1 + |w|_1 r) dt.
//  3. candidate pairs (the world's broadphase, each body's AABB its bounding sphere's,
//     fattened by contact_margin); contact manifolds with points (sim/rigid_contact.h),
//     speculative within the pair's margin: 1 cm plus both closing bounds, at most
//     contact_margin.
//  3b. (rigid.reduce_manifold) a box-box face manifold keeps at most its four corner points.
//  4. per contact point: lever arms (a sphere's taken exactly along the normal, so its normal
//     impulse never spins it), each row's Jacobian products (Row) and effective mass along the
//     normal and two tangents, the target normal speed (Baumgarte feedback beyond slop, the gap
//     / dt of a speculative point, restitution: e times the approach speed before this step's
//     gravity, when that is above the threshold and the point touches or its gap closes
//     within the step). The bodies with points are copied into a compact solver array
//     (SolverBody) in the order the points first name them, and copied back after step 5b.
//  5. `iterations` passes of sequential impulses over the points in a fixed order: normal
//     impulse (accumulated, >= 0), then friction (accumulated, on the tangent plane): while the
//     friction needed stays within mu_s times the normal impulse the contact sticks; beyond it,
//     the friction impulse is mu_k times the normal impulse against the slip (the cone).
//     With rigid.warm_starting each point first gets the impulses its key (body, other body,
//     feature id) ended the last step with (ContactImpulse: state, in the snapshot), and
//     the iterations refine them, so a stack's impulses converge over frames; each pass then
//     solves every normal row before every friction row, odd passes in reverse order.
//     With rigid.block_solver (either way, rows ordered as with warm starting) each manifold's
//     normal rows are swept forward and back until they stop changing before the next manifold.
//      With rigid.spinning_friction or rigid.rolling_friction each pass is followed, over the
//      same points, by their angular rows: about n, |impulse| <= mu_spin pn; about t1, t2, on
//      the disc of radius mu_roll pn (sim/rigid_solver_angular_friction.cpp; no warm start).
//  5a. (rigid.split_impulse) the overlap beyond slop is not in the targets of step 4 (a
//     pressing point's target is 0): `iterations` passes over the normal rows solve it on
//     separate pseudo velocities, which move the bodies in step 6 and are then dropped.
//  5b. (rigid.shock_propagation) one more pass from the ground up, in which each contact moves only
//     its upper body (the lower one counts as immovable): no contact of a stack is left
//     approaching, whatever the iteration count (Guendelman, Bridson and Fedkiw 2003).
//  6. positions x += v dt; orientations by the exponential map. A body whose inertia is not
//     isotropic keeps its angular momentum L = I w exact: the rotation uses w at the half step
//     (from L and the half-turned orientation), and w is recomputed from L after the turn, so
//     free bodies precess (and flip about their intermediate axis) as Euler's equations say.
//
// State lives in the World (position, velocity, orientation, angular velocity); this class
// holds only per-body constants and per-step scratch, so a step depends on nothing else and
// snapshots stay exactly the state. Never allocates after the first steps.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "sim/broadphase.h"
#include "sim/graph_colouring.h"
#include "sim/islands.h"
#include "sim/union_find.h"
#include "sim/parallel_tasks.h"
#include "sim/rigid_contact.h"
#include "sim/step_kernel.h"
#include "sim/uninitialized_allocator.h"

namespace lockroll::sim {

// The impulses a contact point ended a step with, for warm starting the next one. `body` is
// the pair's dynamic body (the solver's first body unless that one is static), `other` the
// other one, `feature` the point's feature id (sim/rigid_contact.h). Kept sorted by
// (body, other, feature), so one body's entries are contiguous (desync narrowing hashes them
// with the body).
struct ContactImpulse {
    BodyId body = 0, other = 0;
    std::uint8_t feature = 0;
    Fixed pn, pt1, pt2;  // normal and two tangent impulses (N s)
};
inline bool key_less(const ContactImpulse& x, const ContactImpulse& y) {
    if (x.body != y.body) return x.body < y.body;
    if (x.other != y.other) return x.other < y.other;
    return x.feature < y.feature;
}
// At most this many carried impulses per dynamic body (a box resting on two others has 8
// points); beyond, the last ones in key order are dropped, so the state has a fixed capacity.
inline constexpr std::size_t kImpulsesPerBody = 8;

namespace rigid_detail {
class ReciprocalMemo;

// A pair's manifold (pairs_' index), found in the parallel step's phase 1.
struct Found {
    std::uint32_t pair;
    Manifold m;
};

// One range's found manifolds (RigidSolver::find_manifolds()). fill() makes each manifold in
// place, in the storage's next element: a Manifold is 520 bytes, and building it aside and
// copying it in cost bodies_1k_rigid ~32 M instructions over 360 steps. Contract: begin() to
// end() are exactly the manifolds with points of the last fill(), in the order made. The
// storage past them (the last manifold made without points, earlier fills' manifolds) is
// scratch the next fill() makes manifolds in, never read. It only grows (value-initialised
// past its longest fill), so a steady step allocates nothing.
class FoundList {
public:
    // make(i, m) makes pair i's manifold in m (whatever m held before), for i in [begin, end).
    // The count of kept manifolds is a local, not kept_: make()'s stores could alias it.
    // [[unlikely]]: without it gcc compiled build_contacts() (sim/rigid_solver.cpp) ~0.1 % worse
    // on paper_rigid (docs/performance.md, "Contact generation and pair walk, same bits").
    template <class Make>
    void fill(std::size_t begin, std::size_t end, Make&& make) {
        std::size_t kept = 0;
        for (std::size_t i = begin; i < end; ++i) {
            if (kept == slots_.size()) [[unlikely]] slots_.emplace_back();
            Found& f = slots_[kept];
            make(i, f.m);
            if (f.m.count == 0) continue;
            f.pair = static_cast<std::uint32_t>(i);
            ++kept;
        }
        kept_ = kept;
    }
    const Found* begin() const { return slots_.data(); }
    const Found* end() const { return slots_.data() + kept_; }
    std::size_t size() const { return kept_; }

private:
    std::vector<Found> slots_;
    std::size_t kept_ = 0;
};
}  // namespace rigid_detail

class RigidSolver {
public:
    // The speculative margin every pair gets whatever its speed (pair_margin()): 1 cm, for the
    // velocity the iterations add within a step (0.6 m/s at 60 Hz); a pair closing faster gets
    // more, up to the scene's contact_margin.
    static constexpr Fixed kSpeculativeBase = Fixed::from_raw(Fixed::kOne / 100);

    // How far a body's surface can move within the step: (|v|_1 + |w|_1 reach) dt, or `margin`
    // when |v|_1 + |w|_1 reach > cap_speed (= margin / dt). Exact in 128 bits, so any speed,
    // however absurd, takes the cap without a sum or product saturating (which would count as
    // an overflow event, sim/fixed.h); below the cap, the same bits as the Fixed expression.
    // Contract: cap_speed, margin, dt >= 0 and reach >= 0.
    static Fixed closing_bound(const Vec3& v, const Vec3& w, Fixed reach, Fixed cap_speed, Fixed margin, Fixed dt);

    // Only for a scene with rigid.enabled; kernel supplies the shapes, sizes and masses.
    void configure(const SceneDesc& scene, const StepKernel<Fixed>& kernel);
    bool enabled() const { return enabled_; }
    bool warm_starting() const { return warm_; }
    // rigid.sleeping, and its time to sleep in frames: ceil(time * tick_rate), >= 1.
    bool sleeping() const { return sleep_; }
    std::uint32_t sleep_frames() const { return sleep_frames_; }

    // The scene's orientations (normalised) and angular velocities (zero for static bodies).
    void initial_state(const SceneDesc& scene, std::vector<Quat>& orient, std::vector<Vec3>& angvel) const;

    // AABB half sizes for the broadphase: a dynamic body's bounding sphere (it may turn), a
    // static body's exact box.
    const std::vector<Vec3>& extent() const { return extent_; }

    // impulses: the warm-starting state (ContactImpulse), read and rewritten when
    // warm_starting(), untouched otherwise. tasks: how the parallel phases run (sequential
    // by default); the bits are the same either way (docs/physics.md, "Parallel step"):
    //  - per body (gravity, damping, inertia, integration): each body's own operations;
    //  - contact generation per pair range into per-range manifold lists, concatenated in pair
    //    order, then solver slots numbered in that order (sequential), the solver bodies
    //    copied in per range of slots, then the points built per range into their places;
    //  - warm start and the iterations island by island (sim/islands.h), each island's rows
    //    in their global relative order; the split passes likewise;
    //  - with rigid.graph_colouring, at any worker count (one included): the contact setup
    //    above, which colours the manifolds (sim/graph_colouring.h) after numbering the slots
    //    and lays the points out colour by colour; then warm start, the iterations and the
    //    split passes colour by colour, each colour's manifolds cut into ranges over the
    //    workers, then the overflow group on the stepping thread;
    //  - sequential, as they are global: keeping the impulses (a sort by key), the shock pass
    //    (levels over the whole graph, one global order); the scatter runs per range of slots.
    //  - with rigid.sleeping (sim/rigid_solver_sleeping.cpp), sequential: the awake set at the
    //    start, waking after the candidate pairs, and the still counts and falling asleep at
    //    the end. `sleep` is the sleep state (World::sleep_state(); empty without sleeping).
    template <class FindPairs, class Control>
    void step(std::vector<Vec3>& pos, std::vector<Vec3>& vel, std::vector<Quat>& orient, std::vector<Vec3>& angvel,
              std::vector<ContactImpulse>& impulses, std::vector<std::uint32_t>& sleep, FindPairs&& find_pairs,
              Control&& control, const ParallelTasks& tasks) {
        // With sleeping, dynamic_ is the awake bodies from here on (every per-body phase below
        // runs over them only).
        if (sleep_) awake_set(sleep);
        // A coloured scene runs the second branch at any worker count (its contact setup lays
        // the points out colour by colour; its per-body phases give the same bits either way).
        if (!tasks.parallel() && !colour_) {
            for (BodyId id : dynamic_) vel[id] += gravity_dv_[id];
            control(vel);
            if (damped_) damp(vel, angvel, 0, dynamic_.size());
            update_inertia(orient, 0, dynamic_.size());
            closing_reach(vel, angvel, 0, dynamic_.size());
            find_pairs(static_cast<const std::vector<Vec3>&>(pos), pairs_);
            if (sleep_) wake(vel, orient, angvel, sleep);
            build_contacts(pos, vel, angvel);
            solve(impulses);
        } else {
            const auto per_body = [&](auto&& phase) { tasks.for_ranges(dynamic_.size(), kBodyGrain, phase); };
            per_body([&](std::size_t begin, std::size_t end) {
                for (std::size_t i = begin; i < end; ++i) vel[dynamic_[i]] += gravity_dv_[dynamic_[i]];
            });
            control(vel);
            if (damped_) per_body([&](std::size_t begin, std::size_t end) { damp(vel, angvel, begin, end); });
            per_body([&](std::size_t begin, std::size_t end) { update_inertia(orient, begin, end); });
            per_body([&](std::size_t begin, std::size_t end) { closing_reach(vel, angvel, begin, end); });
            find_pairs(static_cast<const std::vector<Vec3>&>(pos), pairs_);
            if (sleep_) wake(vel, orient, angvel, sleep);
            build_contacts_parallel(pos, vel, angvel, tasks);
            if (colour_)
                solve_coloured(impulses, tasks);
            else
                solve_islands(impulses, tasks);
        }
        if (warm_) keep_impulses(impulses);
        if (shock_) shock_pass();
        if (!tasks.parallel())
            scatter(vel, angvel);
        else
            scatter_parallel(vel, angvel, tasks);
        if (split_) split_passes(tasks);
        if (!tasks.parallel())
            integrate(pos, vel, orient, angvel, 0, dynamic_.size());
        else
            tasks.for_ranges(dynamic_.size(), kBodyGrain, [&](std::size_t begin, std::size_t end) {
                integrate(pos, vel, orient, angvel, begin, end);
            });
        if (sleep_) fall_asleep(vel, angvel, impulses, sleep);
    }

    // Most ContactImpulse entries a step keeps (kImpulsesPerBody per dynamic body; 0 without
    // warm starting).
    std::size_t impulse_capacity() const { return impulse_capacity_; }

    // Contact points of the last step (diagnostics and tests).
    std::size_t contact_count() const { return points_.size(); }

private:
    // One contact point's three constraint rows (normal n, tangents t1, t2), each written as
    // its Jacobian: the row's speed is d.(v_b - v_a) + cb.w_b - ca.w_a with ca = ra x d and
    // cb = rb x d (ra, rb: the point from each body's centre), and an impulse L on it changes
    // v_a by -d L / m_a, w_a by -ia L with ia = I_a^-1 ca (and body b the other way). The
    // products are made once when the point is built (the effective masses need them anyway),
    // so an iteration costs 9 products per row speed, rounded once, and 3 or 4 per body moved.
    struct Row {
        Vec3 ca, cb;  // ra x d, rb x d
        Vec3 ia, ib;  // world inverse inertia times those (zero for a static body)
        Fixed mass;   // 1 / (1/m_a + 1/m_b + ca.ia + cb.ib), or 0
    };
    struct Point {
        BodyId a, b;
        std::uint32_t sa, sb;  // a's and b's places in bodies_
        std::uint8_t feature;  // ContactPoint::feature
        // +-(k + 1) when n (t1, t2) is exactly +-e_k (a room wall's face), else 0: see axis_code().
        std::int8_t axis_n, axis_t1, axis_t2;
        // Which Jacobian products are not exactly zero, decided once when the point is built
        // (kArmA << k: row[k].ca, kArmB << k: row[k].cb, kInertiaA << k: row[k].ia,
        // kInertiaB << k: row[k].ib), so the passes test a bit instead of three components.
        // A zero term adds exactly zero to a row speed or a velocity: skipping it (or not)
        // changes no bit, so the bits only save work.
        std::uint16_t nonzero;
        Vec3 n, t1, t2;
        Row row[3];          // along n, t1, t2
        Fixed target;        // normal speed the impulse drives toward (>= -gap/dt)
        Fixed bias;          // split impulses: pseudo normal speed pushing overlap out
        Fixed pb;            // split impulses: accumulated pseudo impulse
        Fixed mu_k, mu_s;
        Fixed pn, pt1, pt2;  // accumulated impulses
    };
    static constexpr std::uint16_t kArmA = 1, kArmB = 1 << 3, kInertiaA = 1 << 6, kInertiaB = 1 << 9;
    // A turning sphere's arms on a point whose n, t1, t2 are all exact axes (arms() took them
    // as single components): row[1]'s arm and inertia product lie on t2's axis alone, row[2]'s
    // on t1's, so each of their dot products and friction sums is one product.
    static constexpr std::uint16_t kAxisArmsA = 1 << 12, kAxisArmsB = 1 << 13;
    // n, t1 and t2 are all exact axes (axis_n, axis_t1, axis_t2 non-zero).
    static constexpr std::uint16_t kAxisRows = 1 << 14;

    // Per-body phases cut into ranges of at least this many dynamic bodies.
    static constexpr std::size_t kBodyGrain = 256;
    // Candidate pairs per contact-generation range, and manifolds per piece of islands, at
    // least (a small scene is not worth waking a thread for).
    static constexpr std::size_t kPairGrain = 128, kManifoldGrain = 64;
    // The per-body phases, over dynamic_[begin, end).
    void damp(std::vector<Vec3>& vel, std::vector<Vec3>& angvel, std::size_t begin, std::size_t end) const;
    void update_inertia(const std::vector<Quat>& orient, std::size_t begin, std::size_t end);
    // rigid.reduce_manifold: keeps of a box-box face manifold the point farthest along each of
    // the four diagonals of the contact plane's tangent basis (a point extreme along two of
    // them is kept once), renamed kFeatureReduced + diagonal so warm starting finds it again.
    static void reduce(Manifold& m);
    // A body as the contact solver sees it: linear and angular velocity, inverse mass and (when
    // isotropic) inverse inertia in one cache line, so a contact row touches one line per body. bodies_ holds the bodies that
    // have a contact point this step, in the order the points first name them (so the points,
    // which follow the broadphase's cells, walk bodies_ nearly in order instead of jumping
    // about the whole world); build_contacts() copies them in, scatter() copies the
    // velocities back before integration. The pseudo velocities of split impulses live in
    // pseudo_, at the same places.
    struct alignas(64) SolverBody {
        Vec3 v, w;
        Fixed inv_mass;
        Fixed iso_inv_inertia;  // an isotropic body's scalar inverse inertia (0 static); < 0: not isotropic
    };
    using Bodies = std::vector<SolverBody>;
    static constexpr std::uint32_t kNoSlot = ~std::uint32_t{0};
    std::uint32_t slot_of(BodyId id, const std::vector<Vec3>& vel, const std::vector<Vec3>& angvel);
    void scatter(std::vector<Vec3>& vel, std::vector<Vec3>& angvel) const;
    // scatter() per range of places (each place is another body: the ranges write disjoint
    // velocities).
    void scatter_parallel(std::vector<Vec3>& vel, std::vector<Vec3>& angvel, const ParallelTasks& tasks) const;
    void build_contacts(const std::vector<Vec3>& pos, const std::vector<Vec3>& vel, const std::vector<Vec3>& angvel);
    // The pair's manifold (a, b: the pair in the roles contact_points() gets), reduced when
    // the scene asks; m.count == 0 when apart.
    inline void manifold_of(const BodyPair& pair, const std::vector<Vec3>& pos, BodyId& a, BodyId& b, Manifold& m) const;
    // The speculative margin of the pair (a, b) this step: kSpeculativeBase plus how far each
    // body's surface can move within the step, capped at the scene's contact_margin
    // (docs/physics.md, "Speculative margin per pair").
    Fixed pair_margin(BodyId a, BodyId b) const {
        const Fixed m = kSpeculativeBase + closing_[a] + closing_[b];
        return m < margin_ ? m : margin_;
    }
    // closing_ of dynamic_[begin, end) from this step's velocities (after gravity, control and
    // damping, before the iterations).
    void closing_reach(const std::vector<Vec3>& vel, const std::vector<Vec3>& angvel, std::size_t begin, std::size_t end);
    // Builds the m.count points of a manifold between a and b (whose slots exist) at out.
    // manifold_of() and build_points() are inline, defined and used in rigid_solver.cpp only
    // (build_contacts()'s loop, as before the parallel step); rigid_solver_parallel.cpp reaches
    // them through the per-range phases find_manifolds() and build_found().
    // memo: the effective masses' reciprocals already taken by this loop (one per thread).
    inline void build_points(BodyId a, BodyId b, const Manifold& m, const std::vector<Vec3>& pos, Point* out,
                             rigid_detail::ReciprocalMemo& memo) const;
    // build_contacts() in three phases (RigidSolver::step), the same points in the same places.
    void build_contacts_parallel(const std::vector<Vec3>& pos, const std::vector<Vec3>& vel,
                                 const std::vector<Vec3>& angvel, const ParallelTasks& tasks);
    // Phase 1 for pairs_[begin, end): their manifolds into list. Phase 3 for found_[k]: its
    // points into their places, from manifold index first on.
    using Found = rigid_detail::Found;
    void find_manifolds(std::size_t begin, std::size_t end, const std::vector<Vec3>& pos, rigid_detail::FoundList& list) const;
    // place: by manifold (pair order), its first point's index in points_.
    void build_found(const rigid_detail::FoundList& list, std::uint32_t first, const std::vector<std::uint32_t>& place,
                     const std::vector<Vec3>& pos);
    // rigid.graph_colouring, after phase 2 (manifold_start_ and links_ in pair order): colours
    // the manifolds and renumbers them colour by colour (each colour's manifolds ascending in
    // pair order, the overflow last): manifold_start_ in the new numbering, placed_ by pair
    // order, group_start_ each group's first manifold.
    void lay_out_colours();
    // Warm start and the iterations: over every point (solve(), the sequential step), or
    // island by island (solve_islands(), islands_ over the manifolds).
    void solve(const std::vector<ContactImpulse>& impulses);
    void solve_islands(const std::vector<ContactImpulse>& impulses, const ParallelTasks& tasks);
    // Which points a pass visits: every one (AllPoints: the sequential step), or one island's
    // (ManifoldSet: manifold indexes into manifold_start_, ascending). The passes are templates
    // over it, defined in sim/rigid_solver_passes.h: rigid_solver.cpp instantiates them for
    // AllPoints only, rigid_solver_parallel.cpp for ManifoldSet only, so the sequential
    // step's code is what it was before the parallel step (docs/performance.md).
    // ManifoldRange: the manifolds [begin, end), contiguous in points_ (a coloured scene's
    // colour, or part of one).
    struct AllPoints {};
    using ManifoldSet = std::span<const std::uint32_t>;
    struct ManifoldRange {
        std::size_t begin, end;
    };
    template <class F>
    void each_point(AllPoints, bool backwards, F&& f);
    template <class F>
    void each_point(ManifoldSet set, bool backwards, F&& f);
    template <class F>
    void each_point(ManifoldRange range, bool backwards, F&& f);
    // f(begin, end) for runs of contiguous points: together each_point(points, false)'s visits
    // in its order (one run for AllPoints and ManifoldRange, one per manifold for ManifoldSet).
    template <class F>
    void each_run(AllPoints, F&& f);
    template <class F>
    void each_run(ManifoldSet set, F&& f);
    template <class F>
    void each_run(ManifoldRange range, F&& f);
    std::size_t manifold_count(AllPoints) const { return manifold_start_.size() - 1; }
    static std::size_t manifold_count(ManifoldSet set) { return set.size(); }
    static std::size_t manifold_at(AllPoints, std::size_t k) { return k; }
    static std::size_t manifold_at(ManifoldSet set, std::size_t k) { return set[k]; }
    static std::size_t manifold_count(ManifoldRange range) { return range.end - range.begin; }
    static std::size_t manifold_at(ManifoldRange range, std::size_t k) { return range.begin + k; }
    template <class Points>
    void solve_pass(Bodies& bodies, int pass, Points points);
    // Gives each point (of points) its carried impulses and applies them;
    // keep_impulses() stores the iterations' result (before the shock pass, which is not a
    // physical impulse).
    template <class Points>
    void warm_start(const std::vector<ContactImpulse>& impulses, Points points);
    void keep_impulses(std::vector<ContactImpulse>& impulses) const;
    ContactImpulse key_of(const Point& p) const;
    void shock_pass();
    // rigid.split_impulse: `iterations` passes over the normal rows on the pseudo velocities
    // (pseudo_), driving each point's pseudo normal speed to its bias (overlap beyond slop
    // times baumgarte per step), accumulated >= 0. They move the bodies in integrate() and
    // are dropped: the real velocities never see the push-out.
    void split_passes(const ParallelTasks& tasks);
    void split_islands(const ParallelTasks& tasks);  // split_passes' iterations, island by island
    // rigid.graph_colouring (sim/rigid_solver_coloured.cpp): warm start and the iterations, and
    // split_passes' iterations, colour by colour over colouring_, each colour cut into ranges
    // of at least kColourGrain manifolds over the workers (a smaller colour runs inline), then
    // the overflow group in manifold order. Odd passes of a warm-started or block-solved scene
    // visit the groups in reverse order (the order within a colour changes no bit). Any
    // ParallelTasks, sequential included, gives the same bits.
    static constexpr std::size_t kColourGrain = 64;
    void solve_coloured(const std::vector<ContactImpulse>& impulses, const ParallelTasks& tasks);
    void split_coloured(const ParallelTasks& tasks);
    // Calls f(range) for each group of the coloured numbering (forward, or backwards), each
    // colour's manifolds cut into ranges over tasks, the overflow group whole.
    template <class F>
    void each_colour(const ParallelTasks& tasks, bool backwards, F&& f);
    std::vector<std::uint32_t> placed_;  // by manifold in pair order: its first point
    std::array<std::uint32_t, GraphColouring::kGroups + 1> group_start_{};
    template <class Points>
    void split_iterations(Points points);
    // rigid.block_solver: manifold m's normal rows (real, or pseudo with split impulses) swept
    // forward and back until no impulse changes, at most kBlockSweeps times.
    static constexpr int kBlockSweeps = 8;
    void solve_block(std::size_t m, Bodies& bodies, bool pseudo);
    void solve_pseudo(Point& p);
    // Solves point p's normal and friction rows once (or only one kind); with `only` set, as if
    // only that body moved.
    enum class Rows : std::uint8_t { Both, Normal, Friction };
    void solve_point(Point& p, Bodies& bodies, BodyId only, bool shock,
                     Rows rows = Rows::Both);
    // solve_point()'s body, inline in rigid_solver.cpp's callers only (as row_speed()).
    void solve_one(Point& p, Bodies& bodies, BodyId only, bool shock, Rows rows);
    // solve_point(p, bodies, kEveryBody, false) for each point of [begin, end) in order: the
    // passes' common case, with the point's solve inline.
    void solve_run(Point* begin, Point* end, Bodies& bodies);
    void integrate(std::vector<Vec3>& pos, const std::vector<Vec3>& vel, std::vector<Quat>& orient,
                   std::vector<Vec3>& angvel, std::size_t begin, std::size_t end) const;
    // rigid.sleeping (sim/rigid_solver_sleeping.cpp; docs/physics.md, "Sleeping").
    // awake_set: dynamic_ = the bodies of every_dynamic_ not asleep, in id order.
    void awake_set(const std::vector<std::uint32_t>& sleep);
    // After the candidate pairs: wakes, whole, every component of sleeping bodies (joined by
    // this step's pairs between sleeping bodies) that has a pair with an awake dynamic body
    // (a function of the pair set, not of its order); a woken body gets this step's gravity,
    // world inertia and closing reach, and dynamic_ takes it in. Then drops the pairs with no
    // awake dynamic end (both asleep, or asleep and static).
    void wake(std::vector<Vec3>& vel, const std::vector<Quat>& orient, const std::vector<Vec3>& angvel,
              std::vector<std::uint32_t>& sleep);
    // After integration: each awake body's still count (+1, saturating at sleep_frames_, when
    // |v| < linear and |w| < angular; else 0; always 0 for a player), then every island of
    // this step's pairs (static ends excluded; a body in none is its own) whose bodies all
    // reached sleep_frames_ falls asleep: v = w = 0, kAsleep, its carried impulses dropped.
    void fall_asleep(std::vector<Vec3>& vel, std::vector<Vec3>& angvel, std::vector<ContactImpulse>& impulses,
                     std::vector<std::uint32_t>& sleep);
    // rigid.spinning_friction and rigid.rolling_friction (sim/rigid_solver_angular_friction.cpp;
    // docs/physics.md, "Spinning and rolling friction"). Each point's angular rows: about n
    // (spin) and about t1, t2 (rolling), on the relative angular velocity w_b - w_a alone.
    // They start from zero each step (scene constants, no warm start: nothing in the snapshot).
    struct AngularRows {
        Vec3 ia[3], ib[3];  // I_a^-1 d, I_b^-1 d for d = n, t1, t2 (zero for a static body)
        Fixed mass[3];      // 1 / (d.ia + d.ib), or 0
        Fixed acc[3];       // accumulated angular impulses (N m s)
    };
    // Sizes angular_rows_ to the step's points (before the iterations; sequential).
    void prepare_angular();
    // solve() with the angular rows: each pass's angular_sweep() after its solve_pass(). Kept
    // out of rigid_solver.cpp, so the sequential step's loop is what it was (one branch a step).
    void solve_with_angular(const std::vector<ContactImpulse>& impulses);
    // One sweep of the angular rows over `points`, right after solve_pass() over the same
    // points (its callers: solve(), solve_islands(), solve_coloured()), in the direction of the
    // pass's friction sweep; pass 0 builds each point's rows first. Called only when
    // spin_roll_ (one branch a pass when off: solve_pass() itself is unchanged).
    template <class Points>
    void angular_sweep(Bodies& bodies, int pass, Points points);
    // Point p's spin row (|impulse| <= spin_mu_ pn), then its rolling pair (the impulse on the
    // tangent plane clamped to the disc of radius roll_mu_ pn), Gauss-Seidel, rows `r`.
    void solve_angular(const Point& p, AngularRows& r, Bodies& bodies, bool build) const;
    static constexpr BodyId kEveryBody = ~BodyId{0};
    // Applies impulses l0, l1, l2 along p's rows n, t1, t2 (to `only` alone when set).
    static void apply(const Point& p, Fixed l0, Fixed l1, Fixed l2, Bodies& bodies, BodyId only = kEveryBody);
    static bool moves(const SolverBody& body, BodyId id, BodyId only);
    // apply() for a normal impulse alone, and for friction alone (l1, l2 not both zero). Inline
    // in their callers (rigid_solver.cpp only): in solve_run()'s loop the calls cost 2.2 % of
    // bodies_1k_rigid's step (docs/performance.md, "Rigid solver iterations, fifth pass").
    static void apply_normal(const Point& p, Fixed l, Bodies& bodies, BodyId only);
    static void apply_friction(const Point& p, Fixed l1, Fixed l2, Bodies& bodies, BodyId only);
    static void turn_axes(Vec3& w, const Point& p, const Vec3& u1, Fixed l1, const Vec3& u2, Fixed l2, int sign);
    // The speed along row k of p (> 0 separates for the normal), rounded once. Inline in
    // every caller (rigid_solver.cpp only): out of line it cost 5.7 M of paper_rigid's 180 M.
    static Fixed row_speed(const Point& p, int k, const Vec3& dv, const Bodies& bodies);
    // p.row[k].*arm = r x (p's row k direction) for body id's arm r (arm: &Row::ca or &Row::cb;
    // exact zeros for a sphere's normal).
    void arms(BodyId id, const Vec3& r, Point& p, Vec3 Row::*arm) const;
    // Fills a row from its arms row.ca, row.cb: the inverse inertia products and the effective
    // mass (same_mass's when given: a row known to have the same one; else 1/k through memo).
    void make_row(const Point& p, Row& row, rigid_detail::ReciprocalMemo& memo, const Row* same_mass = nullptr) const;
    Fixed pair_restitution(BodyId a, BodyId b) const;
    void pair_friction(BodyId a, BodyId b, Fixed& mu_k, Fixed& mu_s) const;
    OrientedCollider collider(BodyId id, const std::vector<Vec3>& pos) const;
    // w from angular momentum L at orientation q: R (I^-1 (R^T L)).
    Vec3 omega_from(BodyId id, const Quat& q, const Vec3& l) const;

    bool enabled_ = false, damped_ = false, shock_ = false, warm_ = false, split_ = false, reduce_ = false, block_ = false;
    bool colour_ = false;
    bool sleep_ = false;
    bool spin_roll_ = false;  // spin_mu_ or roll_mu_ > 0
    Fixed spin_mu_, roll_mu_;  // metres (torque per unit normal force)
    std::uint32_t sleep_frames_ = 0;
    u128 sleep_lin_sq_{}, sleep_ang_sq_{};  // the thresholds' squares, as length_sq_wide gives them
    std::size_t impulse_capacity_ = 0;
    int iterations_ = 4;
    Fixed dt_, inv_dt_, baumgarte_rate_, slop_, threshold_, margin_, cap_speed_;
    Fixed kin_[kShapeCount][kShapeCount], stat_[kShapeCount][kShapeCount], rest_[kShapeCount][kShapeCount];

    // Per body, by id.
    std::vector<Shape> shape_;
    std::vector<Fixed> radius_, core_half_, inv_mass_;
    // How far a surface point can be from the centre's axis of turning, for closing_reach():
    // a box's half diagonal, a capsule's core half length, 0 for a sphere (turning never moves
    // its surface) and for static bodies (they never turn).
    std::vector<Fixed> turn_reach_;
    // This step's bound on how far the body's surface moves: (|v|_1 + |w|_1 turn_reach_) dt,
    // at most margin_ (so sums of two never overflow); 0 for static bodies.
    std::vector<Fixed> closing_;
    std::vector<Vec3> half_, extent_, gravity_dv_;
    std::vector<Vec3> inertia_, inv_inertia_;  // body frame, diagonal
    std::vector<std::uint8_t> isotropic_;
    std::vector<Fixed> restitution_;           // override or negative
    std::vector<Fixed> friction_, static_friction_;  // override or negative
    std::vector<Fixed> lin_damp_, ang_damp_;   // 1 / (1 + c dt)
    // Every dynamic body in id order; with rigid.sleeping, the awake ones during a step.
    std::vector<BodyId> dynamic_;
    // rigid.sleeping: every dynamic body (dynamic_ is then the awake set), whether each body
    // is a player's, and the sleep bookkeeping's scratch (by id, and the islands' links).
    std::vector<BodyId> every_dynamic_;
    std::vector<std::uint8_t> player_, mark_;
    UnionFind components_;  // wake's and fall_asleep's union-find, by id
    std::vector<BodyPair> sleep_links_;
    std::vector<BodyId> woken_;

    // Per step.
    std::vector<Mat3> rot_;          // body to world; static bodies set once
    std::vector<Mat3> inv_i_world_;  // zero for static bodies
    std::vector<BodyPair> pairs_;
    // Grown without zero-filling: build_points() writes every member of a point before any
    // pass reads it (sim/uninitialized_allocator.h).
    std::vector<Point, UninitializedAllocator<Point>> points_;
    // By point (points_' index): spinning and rolling rows, only when spin_roll_.
    std::vector<AngularRows, UninitializedAllocator<AngularRows>> angular_rows_;
    // rigid.block_solver, or a parallel (or coloured) step: first point of each manifold, then
    // points_.size() (empty otherwise); a coloured step numbers the manifolds colour by colour
    // (lay_out_colours()).
    std::vector<std::uint32_t> manifold_start_;
    // Parallel step only: each contact range's manifolds (pair index, manifold), the solver's
    // islands over the manifolds, and their links (solver slots, Islands::kStatic for static).
    std::vector<rigid_detail::FoundList> found_;
    std::vector<std::uint32_t> found_first_;  // by range: its first manifold's index
    // With rigid.graph_colouring, colouring_ over links_ (lay_out_colours()).
    Islands islands_;
    std::vector<Islands::Link> links_;
    GraphColouring colouring_;
    Bodies bodies_;
    std::vector<std::uint32_t> slot_;  // by body id: its place in bodies_, or kNoSlot
    std::vector<BodyId> slot_ids_;     // by place: the body id
    Bodies pseudo_;  // split impulses: pseudo velocities, zero outside a step's solve
    // Shock propagation scratch.
    std::vector<std::uint32_t> level_, order_, adj_start_, adj_, cursor_;
    std::vector<BodyId> queue_;
    // rotation() of one quaternion per dynamic box or capsule (the bodies whose rotation
    // update_inertia() builds), at rot_memo_at_[id] (kNoSlot for every other body; both made by
    // configure(), so 104 bytes only for the bodies that use them): integrate() builds the
    // rotation of a turning box's new orientation (for its w) and keeps it here; the next
    // update_inertia() takes it when orient[id] is that quaternion, bit for bit, instead of
    // building it again. Not state (no snapshot holds it): keyed by the quaternion. Contract:
    // m == rotation(q) for every entry at all times (a new entry holds the identity's), so a hit has
    // rotation()'s bits whatever wrote the orientations in between (the split impulses' pseudo
    // motion, a snapshot load, flip_bit): those only make the comparison miss. Mutable as
    // integrate() is const; each body's entry is written only by the range holding the body.
    struct RotationMemo {
        Quat q;
        Mat3 m = rotation(Quat{});
    };
    mutable std::vector<RotationMemo> rot_memo_;
    std::vector<std::uint32_t> rot_memo_at_;
};

// Pieces of the contact setup, exposed for the test that compares them with the general
// arithmetic (tests/sim/rigid_solver_test.cpp).
namespace rigid_detail {
// A tangent basis of unit n, a fixed function of n (the general arithmetic).
void tangents(const Vec3& n, Vec3& t1, Vec3& t2);
// +-(k + 1) when d is exactly +-e_k, else 0.
std::int8_t axis_code(const Vec3& d);
// e * s for the axis e with axis code `code` != 0 (s or -s on its axis, exactly 0 elsewhere),
// and dot(e, v): what the rounded products give, saturation and overflow count included.
Vec3 scaled_axis(std::int8_t code, Fixed s);
Fixed dot_axis(std::int8_t code, const Vec3& v);
// cross(r, e) for the axis e with axis code `code` != 0, without the products (the same bits
// and overflow count).
Vec3 cross_axis(const Vec3& r, std::int8_t code);
// tangents(e) and their axis codes for the axis e with axis code `code` != 0, from a table.
void axis_tangents(std::int8_t code, Vec3& t1, Vec3& t2, std::int8_t& code1, std::int8_t& code2);
// 1/k for the effective masses, remembered for the last two k a loop met: reciprocal() is a pure
// function of k, so a remembered value has its bits. Between 1 kg bodies most rows with no
// turning arm (a ball's normal row: k = 1/m_a + 1/m_b) share a handful of k. Only
// k >= 2^-16 is remembered: 1/k <= 2^16 then, so reciprocal() never saturates and counts no
// overflow that a hit would leave uncounted. One per loop (and thread).
class ReciprocalMemo {
public:
    static constexpr std::int64_t kLeast = std::int64_t{1} << (Fixed::kFracBits - 16);
    // reciprocal(x) for x > 0.
    Fixed reciprocal_of(Fixed x) {
        if (x.raw == k_[0]) return inv_[0];
        if (x.raw == k_[1]) return inv_[1];
        const Fixed r = reciprocal(x);
        if (x.raw >= kLeast) {
            k_[next_] = x.raw;
            inv_[next_] = r;
            next_ ^= 1;
        }
        return r;
    }

private:
    std::int64_t k_[2] = {0, 0};  // raw k; 0 is never asked for (k > 0)
    Fixed inv_[2];
    int next_ = 0;
};

// f() (a velocity change both bodies of a contact get, equal masses), with any overflow events
// it noted noted once more: what computing it for each body gives, once (apply_normal(),
// apply_friction()).
template <class F>
[[gnu::always_inline]] inline Vec3 shared_change(F&& f) {
    const std::uint64_t before = overflow_events();
    const Vec3 v = f();
    const std::uint64_t noted = overflow_events() - before;
    if (noted != 0) note_overflows(noted);
    return v;
}

// Friction (t1, t2) clamped to the cone of normal impulse pn >= 0 (solve_one()): kept when
// |t| <= mu_s pn, else scaled to mu_k pn / |t| (|t| correctly rounded, each step rounded once).
// A zero cone (the contact let go) is set to zero without the square root and the division: the
// limit mu_s 0 is 0, so any non-zero (t1, t2) is outside; |t|^2 >= 1 in Q64.64 gives |t| != 0
// (its raw value may wrap negative only for |t| >= 2^31, still non-zero), so the scale is
// (mu_k 0) / |t| = 0 / |t| = 0 and t1 0 = t2 0 = 0, none of it noting an overflow; a zero
// (t1, t2) stays zero. The same bits and count as the general clamp, clamp_to_cone_general()
// (tests/sim/rigid_solver_test.cpp compares them).
[[gnu::always_inline]] inline void clamp_to_cone_general(Fixed& t1, Fixed& t2, Fixed pn, Fixed mu_s, Fixed mu_k) {
    const Fixed limit_s = mu_s * pn;
    const u128 mag_sq = static_cast<u128>(mul_wide(t1.raw, t1.raw)) + static_cast<u128>(mul_wide(t2.raw, t2.raw));
    if (mag_sq > static_cast<u128>(mul_wide(limit_s.raw, limit_s.raw))) {
        const Fixed mag = sqrt_wide(mag_sq);
        const Fixed scale = mu_k * pn / mag;
        t1 = t1 * scale;
        t2 = t2 * scale;
    }
}
[[gnu::always_inline]] inline void clamp_to_cone(Fixed& t1, Fixed& t2, Fixed pn, Fixed mu_s, Fixed mu_k) {
    if (pn.raw == 0) {
        t1 = Fixed::zero();
        t2 = Fixed::zero();
        return;
    }
    clamp_to_cone_general(t1, t2, pn, mu_s, mu_k);
}
}  // namespace rigid_detail

}  // namespace lockroll::sim
