// One physics step, written once over the number type (sim/number_traits.h).
//
// World (sim/world.h) instantiates it with Fixed and owns the state that snapshots store; the
// harness instantiates it with a floating type as the work-precision reference
// (harness/validation/reference_world.h). Both therefore run the same algorithm, operation for operation.
//
// The default step is the seed paper's solver: semi-implicit Euler (gravity into velocity,
// player input, velocity into position), candidate pairs once per step, then `iterations`
// passes over the candidates of narrowphase + full mass-weighted positional correction +
// impulse J = -(1 + e) v_n / (1/m_a + 1/m_b) while approaching. A scene whose SolverDesc is not
// the default runs the extended step instead (substeps, ballistic integration, partial
// correction with slop and a cap, restitution threshold, restitution after the iterations,
// continuous collision against static bodies). The two are separate code paths chosen once per
// step, so scenes that do not opt in run exactly the code they always ran.
#pragma once

#include <algorithm>
#include <cstdint>
#include <map>
#include <tuple>
#include <vector>

#include "sim/broadphase.h"
#include "sim/contact.h"
#include "sim/islands.h"
#include "sim/parallel_tasks.h"
#include "sim/scene.h"

namespace lockroll::sim {

template <class N>
class StepKernel {
public:
    using T = NumberTraits<N>;
    using Vec = typename T::Vec;

    // The scene must be valid (validate()); per-body constants are taken from it once.
    explicit StepKernel(const SceneDesc& scene);

    // Positions of every body and velocities (zero for static bodies) as the scene gives them.
    void initial_state(const SceneDesc& scene, std::vector<Vec>& pos, std::vector<Vec>& vel) const;

    // Advances pos/vel (indexed by body id) by one frame. find_pairs(pos, out) fills the
    // candidate pairs for the current positions (called once per physics step);
    // control(vel) applies the frame's player input (called once per frame).
    // tasks: how the default step's parallel phases run (the extended step is sequential);
    // the same bits either way (docs/physics.md, "Parallel step"): integration per body range,
    // and the iterations island by island over the candidate pairs (sim/islands.h), each
    // island's pairs in their global relative order.
    template <class FindPairs, class Control>
    void step(std::vector<Vec>& pos, std::vector<Vec>& vel, FindPairs&& find_pairs, Control&& control,
              const ParallelTasks& tasks = ParallelTasks()) {
        if (extended_)
            step_extended(pos, vel, find_pairs, control);
        else
            step_default(pos, vel, find_pairs, control, tasks);
    }

    N dt() const { return dt_; }
    bool extended() const { return extended_; }
    Shape shape(BodyId id) const { return shape_[id]; }
    N inv_mass(BodyId id) const { return inv_mass_[id]; }
    N radius(BodyId id) const { return radius_[id]; }
    N core_half(BodyId id) const { return core_half_[id]; }
    const Vec& half_extents(BodyId id) const { return half_extents_[id]; }
    const std::vector<Vec>& extent() const { return extent_; }
    const std::vector<BodyId>& dynamic_ids() const { return dynamic_; }
    const std::vector<BodyId>& static_ids() const { return static_; }
    // Events handled by continuous collision since construction (diagnostics, not state).
    std::uint64_t continuous_events() const { return continuous_events_; }

private:
    static Vec vec(const Vec3& v) { return {T::from_fixed(v.x), T::from_fixed(v.y), T::from_fixed(v.z)}; }

    template <class FindPairs, class Control>
    void step_default(std::vector<Vec>& pos, std::vector<Vec>& vel, FindPairs& find_pairs, Control& control,
                      const ParallelTasks& tasks) {
        if (tasks.parallel()) {
            step_default_parallel(pos, vel, find_pairs, control, tasks);
            return;
        }
        for (BodyId id : dynamic_) vel[id] += body_class(id).gravity_dv;
        control(vel);
        for (BodyId id : dynamic_) pos[id] += vel[id] * dt_;
        find_pairs(static_cast<const std::vector<Vec>&>(pos), pairs_);
        prepare_pairs();
        solve_default(pos, vel);
    }

    // step_default() in parallel phases (a separate path: the sequential one stays the plain
    // loops, whose code the paper scene's cost depends on).
    static constexpr std::size_t kBodyGrain = 512;  // dynamic bodies per range, at least
    static constexpr std::size_t kPairGrain = 256;  // candidate pairs per island piece, at least
    template <class FindPairs, class Control>
    void step_default_parallel(std::vector<Vec>& pos, std::vector<Vec>& vel, FindPairs& find_pairs, Control& control,
                               const ParallelTasks& tasks) {
        tasks.for_ranges(dynamic_.size(), kBodyGrain, [&](std::size_t begin, std::size_t end) {
            for (std::size_t i = begin; i < end; ++i) vel[dynamic_[i]] += body_class(dynamic_[i]).gravity_dv;
        });
        control(vel);
        tasks.for_ranges(dynamic_.size(), kBodyGrain, [&](std::size_t begin, std::size_t end) {
            for (std::size_t i = begin; i < end; ++i) pos[dynamic_[i]] += vel[dynamic_[i]] * dt_;
        });
        find_pairs(static_cast<const std::vector<Vec>&>(pos), pairs_);
        prepare_pairs_and_links(tasks);
        solve_default_islands(pos, vel, tasks);
    }

    template <class FindPairs, class Control>
    void step_extended(std::vector<Vec>& pos, std::vector<Vec>& vel, FindPairs& find_pairs, Control& control) {
        const bool euler = settings_.integrator == Integrator::Euler;
        for (int s = 0; s < settings_.substeps; ++s) {
            if (euler) {
                for (BodyId id : dynamic_) vel[id] += sub_gravity_dv_[id];
                if (s == 0) control(vel);
                if (settings_.continuous)
                    for (BodyId id : dynamic_) advance_continuous(id, pos, vel, false);
                else
                    for (BodyId id : dynamic_) pos[id] += vel[id] * sub_dt_;
            } else {
                if (s == 0) control(vel);
                if (settings_.continuous) {
                    for (BodyId id : dynamic_) advance_continuous(id, pos, vel, true);
                } else {
                    for (BodyId id : dynamic_) {
                        pos[id] += (vel[id] + half_sub_gravity_dv_[id]) * sub_dt_;
                        vel[id] += sub_gravity_dv_[id];
                    }
                }
            }
            find_pairs(static_cast<const std::vector<Vec>&>(pos), pairs_);
            prepare_pairs();
            solve_extended(pos, vel);
        }
    }

    // What the default step's hot loops read per body besides its state, by class: bodies
    // that agree on every field share one entry. The integration, the pair preparation and
    // the solver read a 4-byte class per body instead of up to 8 + 8 + 24 + 8 + 8 + 1 bytes
    // (radius_, core_half_, gravity_dv, inv_mass_, restitution_, shape_): at 10,000 bodies 40 KB
    // instead of 570 KB among the arrays they read by id, in pair (cell) order, which with the
    // state do not fit a 512 KB L2 (docs/performance.md, "Grid and walk memory, third pass").
    // The same values, so the same bits. Scenes have a handful of classes (bodies_10k: 2); a
    // scene of all-different bodies has one per body and costs one more load per access.
    struct BodyClass {
        N core_half, radius;  // as core_half_ and radius_
        Vec gravity_dv;       // gravity * gravity_scale * dt (zero for static bodies)
        N inv_mass, restitution;  // as inv_mass_ and restitution_
        Shape shape;
    };

    // A candidate pair prepared once per step: ordered (round before box), its narrowphase
    // routine, and the mass terms the solver would otherwise divide for in every iteration.
    enum class PairKind : std::uint8_t { RoundRound, RoundBox, BoxBox };
    // 16 bytes: the mass and restitution terms live apart, in terms_ (the solver sweeps the
    // pairs four times a step; 32-byte pairs were 2 of every 3 bytes it streamed).
    struct SolverPair {
        BodyId a, b;
        PairKind kind;
        bool b_static;        // then the whole correction and impulse go to a (no division)
        std::uint32_t terms;  // index into terms_
    };
    struct PairTerms {
        N one_plus_e;     // 1 + restitution
        N inv_sum_recip;  // 1 / (1/m_a + 1/m_b), when both are dynamic
    };
    // A pair's terms from its two classes in solver roles (a, b): what prepare_each stored.
    PairTerms pair_terms(const BodyClass& a, const BodyClass& b) const {
        return {T::one() + pair_restitution(a, b), b.inv_mass == T::zero() || a.inv_mass == T::zero()
                                                       ? T::zero()
                                                       : T::reciprocal(a.inv_mass + b.inv_mass)};
    }
    const PairTerms& terms(const SolverPair& p) const { return terms_[p.terms]; }

    N pair_restitution(BodyId a, BodyId b) const { return pair_restitution(body_class(a), body_class(b)); }
    N pair_restitution(const BodyClass& a, const BodyClass& b) const {
        return (a.restitution >= T::zero() || b.restitution >= T::zero())
                   ? T::max(a.restitution, b.restitution)  // explicit materials combine by max
                   : table_[static_cast<int>(a.shape)][static_cast<int>(b.shape)];
    }

    // Out of line, as it was before prepare_each() was split out of it (inlined into the step,
    // the paper scene's step ran 0.3 % more instructions).
    [[gnu::noinline]] void prepare_pairs() {
        solver_pairs_.clear();
        if (!terms_by_class_) terms_.resize(pairs_.size());
        prepare_each(pairs_.data(), pairs_.data() + pairs_.size(),
                     [this](const BodyPair*, const SolverPair& p) { solver_pairs_.push_back(p); });
    }

    // prepare_pairs() per range of pairs, with the islands' links (solve_default_islands).
    void prepare_pairs_and_links(const ParallelTasks& tasks) {
        solver_pairs_.resize(pairs_.size());
        if (!terms_by_class_) terms_.resize(pairs_.size());
        links_.resize(pairs_.size());
        tasks.for_ranges(pairs_.size(), kPairGrain, [&](std::size_t begin, std::size_t end) {
            prepare_each(pairs_.data() + begin, pairs_.data() + end, [this](const BodyPair* pair,
                                                                            const SolverPair& p) {
                const auto k = static_cast<std::size_t>(pair - pairs_.data());
                solver_pairs_[k] = p;
                links_[k] = {inv_mass_[p.a] == T::zero() ? Islands::kStatic : p.a,
                             inv_mass_[p.b] == T::zero() ? Islands::kStatic : p.b};
            });
        });
    }

    // Prepares the pairs [first, last) of pairs_ for the solver and hands each to
    // emit(&pair, prepared). A loop
    // with a callback rather than a function per pair: the sequential loop compiles as it did
    // before the parallel path shared it (a per-pair function returning the pair, inlined or
    // not, cost the paper scene's step 0.3-1.7 % more instructions).
    template <class Emit>
    void prepare_each(const BodyPair* first, const BodyPair* last, Emit&& emit) {
        for (const BodyPair* pair = first; pair != last; ++pair) {
            BodyId a = pair->a, b = pair->b;
            const BodyClass* ka = &body_class(a);
            const BodyClass* kb = &body_class(b);
            // Canonical roles: a round shape before a box (each routine sees (round, box)); within
            // the same class, a static body second. Only a static round body against a dynamic box
            // leaves the static body first, which the solver mirrors.
            const bool a_round = ka->shape != Shape::Box, b_round = kb->shape != Shape::Box;
            if (a_round != b_round ? !a_round : ka->inv_mass == T::zero()) {
                std::swap(a, b);
                std::swap(ka, kb);
            }
            SolverPair p;
            p.a = a;
            p.b = b;
            p.kind = ka->shape == Shape::Box   ? PairKind::BoxBox
                     : kb->shape == Shape::Box ? PairKind::RoundBox
                                               : PairKind::RoundRound;
            p.b_static = kb->inv_mass == T::zero();
            if (terms_by_class_) {  // precomputed for every (class, class): no division here
                p.terms = static_cast<std::uint32_t>((ka - classes_.data()) * classes_.size() + (kb - classes_.data()));
            } else {
                p.terms = static_cast<std::uint32_t>(pair - pairs_.data());
                terms_[p.terms] = pair_terms(*ka, *kb);
            }
            emit(pair, p);
        }
    }

    const BodyClass& body_class(BodyId id) const { return classes_[class_[id]]; }
    // A round body's collider from its class (the values of core_half_ and radius_).
    BasicRoundCollider<N> round_collider(BodyId id, const std::vector<Vec>& pos) const {
        const BodyClass& k = body_class(id);
        return {pos[id], k.core_half, k.radius};
    }

    bool narrow(const SolverPair& p, const std::vector<Vec>& pos, BasicContact<N>& c) const {
        const BodyId a = p.a, b = p.b;
        switch (p.kind) {
            case PairKind::RoundRound:
                return collide(round_collider(a, pos), round_collider(b, pos), c);
            case PairKind::RoundBox:
                if (p.b_static)  // static boxes never move: bounds computed once
                    return collide_with_bounds(round_collider(a, pos), static_lo_[b], static_hi_[b], c);
                return collide(round_collider(a, pos),
                               BasicBoxCollider<N>{pos[b], half_extents_[b]}, c);
            default:
                return collide(BasicBoxCollider<N>{pos[a], half_extents_[a]}, BasicBoxCollider<N>{pos[b], half_extents_[b]},
                               c);
        }
    }

    // A contact normal with two zero components is exactly +-1 on the third: face contacts of
    // balls on floors and walls, and every box-box contact. For those the solver works on that
    // one component. The bits are the same as the general path's: x*0 and x*1 are exact, the
    // zero components never change (v - 0 cannot overflow), negation saturates exactly as the
    // multiply by -1 does, and the sign is applied where the multiply by the normal was, before
    // any later multiply. These multiplies were a quarter of the paper scene's instructions.
    static int normal_axis(const Vec& n) {
        const bool zx = n.x == T::zero(), zy = n.y == T::zero(), zz = n.z == T::zero();
        if (zx + zy + zz != 2) return -1;
        return !zx ? 0 : !zy ? 1 : 2;
    }
    static N& component(Vec& v, int k) { return k == 0 ? v.x : k == 1 ? v.y : v.z; }
    static const N& component(const Vec& v, int k) { return k == 0 ? v.x : k == 1 ? v.y : v.z; }

    void solve_default(std::vector<Vec>& pos, std::vector<Vec>& vel) const {
        solve_pairs(solver_pairs_, [](const SolverPair& p) -> const SolverPair& { return p; }, pos, vel);
    }

    // `iterations` passes over the pairs of `order` (get(item) names the pair): narrowphase,
    // then resolution, which writes only the pair's dynamic bodies. One body for the whole
    // list and for an island's (two instantiations, each optimised as the one loop was).
    template <class Order, class Get>
    void solve_pairs(const Order& order, Get&& get, std::vector<Vec>& pos, std::vector<Vec>& vel) const {
        for (int iteration = 0; iteration < iterations_; ++iteration) {
            for (const auto& item : order) {
                const SolverPair& p = get(item);
                BasicContact<N> c;
                if (!narrow(p, pos, c)) continue;
                const int axis = normal_axis(c.normal);
                if (axis >= 0)
                    resolve_on_axis(p, pos, vel, c, axis, component(c.normal, axis) < T::zero());
                else
                    resolve(p, pos, vel, c);
            }
        }
    }

    // solve_default() island by island: the pairs of other islands write none of an island's
    // bodies (static bodies are never written), so each island's iterations over its pairs in
    // their global relative order give the bits of the global sweep. Needs links_ from
    // prepare_pairs_and_links().
    void solve_default_islands(std::vector<Vec>& pos, std::vector<Vec>& vel, const ParallelTasks& tasks) {
        islands_.build(pos.size(), links_, tasks);
        // At least kPairGrain pairs a piece: a small scene is not worth waking a thread for.
        const std::size_t pieces = std::min(tasks.piece_count(solver_pairs_.size(), kPairGrain), islands_.count());
        tasks.run(pieces, [&](std::size_t k) {
            for (std::size_t i = islands_.first(pieces, k), e = islands_.first(pieces, k + 1); i < e; ++i) {
                solve_pairs(islands_.links(i), [this](std::uint32_t j) -> const SolverPair& { return solver_pairs_[j]; },
                            pos, vel);
            }
        });
    }

    // The seed paper's resolution: full positional correction split by inverse mass, then the
    // impulse J = -(1+e)(v_rel . n) / (1/m_a + 1/m_b), only while approaching.
    void resolve(const SolverPair& p, std::vector<Vec>& pos, std::vector<Vec>& vel, const BasicContact<N>& c) const {
        const BodyId a = p.a, b = p.b;
        if (p.b_static) {
            // All of the correction and impulse goes to a: J/m_a = -(1+e) v_n exactly.
            pos[a] -= c.normal * c.depth;
            const N vn = -T::dot(vel[a], c.normal);
            if (vn < T::zero()) vel[a] += c.normal * (terms(p).one_plus_e * vn);
            return;
        }
        const N ia = body_class(a).inv_mass, ib = body_class(b).inv_mass;
        if (ia == T::zero()) {
            // Static round body against a dynamic box: mirror of the case above.
            pos[b] += c.normal * c.depth;
            const N vn = T::dot(vel[b], c.normal);
            if (vn < T::zero()) vel[b] -= c.normal * (terms(p).one_plus_e * vn);
            return;
        }
        const Vec push = c.normal * (c.depth * terms(p).inv_sum_recip);
        pos[a] -= push * ia;
        pos[b] += push * ib;
        const N vn = T::dot(vel[b] - vel[a], c.normal);
        if (vn >= T::zero()) return;
        const Vec impulse = c.normal * (-(terms(p).one_plus_e * vn) * terms(p).inv_sum_recip);
        vel[a] -= impulse * ia;
        vel[b] += impulse * ib;
    }

    // resolve() for a normal of +-1 on `axis` (see normal_axis), step for step.
    void resolve_on_axis(const SolverPair& p, std::vector<Vec>& pos, std::vector<Vec>& vel, const BasicContact<N>& c,
                         int axis, bool negative) const {
        const auto along = [negative](N s) { return negative ? -s : s; };  // the axis component of n * s
        const BodyId a = p.a, b = p.b;
        if (p.b_static) {
            component(pos[a], axis) -= along(c.depth);
            const N vn = -along(component(vel[a], axis));
            if (vn < T::zero()) component(vel[a], axis) += along(terms(p).one_plus_e * vn);
            return;
        }
        const N ia = body_class(a).inv_mass, ib = body_class(b).inv_mass;
        if (ia == T::zero()) {
            component(pos[b], axis) += along(c.depth);
            const N vn = along(component(vel[b], axis));
            if (vn < T::zero()) component(vel[b], axis) -= along(terms(p).one_plus_e * vn);
            return;
        }
        const N push = along(c.depth * terms(p).inv_sum_recip);
        component(pos[a], axis) -= push * ia;
        component(pos[b], axis) += push * ib;
        // The general path subtracts all three components (each may saturate and count).
        const Vec rel = vel[b] - vel[a];
        const N vn = along(component(rel, axis));
        if (vn >= T::zero()) return;
        const N impulse = along(-(terms(p).one_plus_e * vn) * terms(p).inv_sum_recip);
        component(vel[a], axis) -= impulse * ia;
        component(vel[b], axis) += impulse * ib;
    }

    // Relative normal velocity of a pair, negative while approaching.
    N normal_speed(const SolverPair& p, const std::vector<Vec>& vel, const Vec& n) const {
        if (p.b_static) return -T::dot(vel[p.a], n);
        if (inv_mass_[p.a] == T::zero()) return T::dot(vel[p.b], n);
        return T::dot(vel[p.b] - vel[p.a], n);
    }

    // Changes the pair's relative normal velocity by dv (> 0 separates), split by inverse mass.
    void add_normal_speed(const SolverPair& p, std::vector<Vec>& vel, const Vec& n, N dv) const {
        if (p.b_static) {
            vel[p.a] -= n * dv;
        } else if (inv_mass_[p.a] == T::zero()) {
            vel[p.b] += n * dv;
        } else {
            const Vec impulse = n * (dv * terms(p).inv_sum_recip);
            vel[p.a] -= impulse * inv_mass_[p.a];
            vel[p.b] += impulse * inv_mass_[p.b];
        }
    }

    void solve_extended(std::vector<Vec>& pos, std::vector<Vec>& vel) {
        const N zero = T::zero(), one = T::one();
        const bool position_based = settings_.position_based;
        const bool after = settings_.restitution_after || position_based;
        const bool capped = max_push_ > zero;
        if (position_based || capped)
            for (BodyId id : dynamic_) predicted_[id] = pos[id];
        if (after) {
            pre_.resize(solver_pairs_.size());
            for (std::size_t k = 0; k < solver_pairs_.size(); ++k) {
                BasicContact<N> c;
                pre_[k].touching = narrow(solver_pairs_[k], pos, c);
                if (!pre_[k].touching) continue;
                pre_[k].normal = c.normal;
                pre_[k].vn = normal_speed(solver_pairs_[k], vel, c.normal);
            }
        }
        for (int iteration = 0; iteration < iterations_; ++iteration) {
            for (const SolverPair& p : solver_pairs_) {
                BasicContact<N> c;
                if (!narrow(p, pos, c)) continue;
                correct(p, c, pos, Mover::Both);
                if (position_based) continue;
                const N vn = normal_speed(p, vel, c.normal);
                if (vn >= zero) continue;
                const N one_plus_e = (after || -vn < threshold_) ? one : terms(p).one_plus_e;
                add_normal_speed(p, vel, c.normal, -(one_plus_e * vn));
            }
        }
        if (settings_.shock_propagation) shock_pass(pos);
        if (capped) cap_push(pos);
        // Position-based: what the iterations moved a body is what its velocity changes by.
        if (position_based)
            for (BodyId id : dynamic_) vel[id] += (pos[id] - predicted_[id]) * inv_sub_dt_;
        if (!after) return;
        for (std::size_t k = 0; k < solver_pairs_.size(); ++k) {
            const SolverPair& p = solver_pairs_[k];
            const N e = terms(p).one_plus_e - one;
            if (!pre_[k].touching || e == zero || -pre_[k].vn < threshold_ || pre_[k].vn >= zero) continue;
            const N target = -(e * pre_[k].vn);
            const N vn = normal_speed(p, vel, pre_[k].normal);
            if (vn < target) add_normal_speed(p, vel, pre_[k].normal, target - vn);
        }
    }

    // Removes the part of the overlap beyond slop (times correction), split by inverse
    // mass, or all of it on one side when the other is to be held still.
    enum class Mover : std::uint8_t { Both, OnlyA, OnlyB };
    void correct(const SolverPair& p, const BasicContact<N>& c, std::vector<Vec>& pos, Mover mover) const {
        const N zero = T::zero();
        N depth = c.depth - slop_;
        if (depth <= zero) return;
        if (correction_ != T::one()) depth = depth * correction_;
        if (p.b_static || mover == Mover::OnlyA) {
            pos[p.a] -= c.normal * depth;
        } else if (inv_mass_[p.a] == zero || mover == Mover::OnlyB) {
            pos[p.b] += c.normal * depth;
        } else {
            const Vec push = c.normal * (depth * terms(p).inv_sum_recip);
            pos[p.a] -= push * inv_mass_[p.a];
            pos[p.b] += push * inv_mass_[p.b];
        }
    }

    // Limits how far the iterations moved each body this step to max_push_speed * dt, so deeply
    // overlapping bodies separate over several steps instead of being flung apart.
    void cap_push(std::vector<Vec>& pos) const {
        const typename T::Wide limit_sq = T::square(max_push_);
        for (BodyId id : dynamic_) {
            const Vec d = pos[id] - predicted_[id];
            const typename T::Wide d_sq = T::length_sq(d);
            if (!(limit_sq < d_sq)) continue;
            pos[id] = predicted_[id] + d * (max_push_ / T::sqrt_wide(d_sq));
        }
    }

    // Shock propagation (Guendelman, Bridson and Fedkiw 2003): one more pass over the touching
    // contacts, lowest first by their distance in the contact graph from a static body, in
    // which each pair moves only its upper body. A stack's weight then cannot push its lower
    // bodies into whatever holds them up, whatever the mass ratio.
    void shock_pass(std::vector<Vec>& pos) {
        constexpr std::uint32_t kUnreached = ~std::uint32_t{0};
        const std::size_t n = pos.size();
        touching_.clear();
        for (std::size_t k = 0; k < solver_pairs_.size(); ++k) {
            BasicContact<N> c;
            if (narrow(solver_pairs_[k], pos, c)) touching_.push_back(static_cast<std::uint32_t>(k));
        }
        adj_start_.assign(n + 1, 0);
        for (std::uint32_t k : touching_) {
            ++adj_start_[solver_pairs_[k].a + 1];
            ++adj_start_[solver_pairs_[k].b + 1];
        }
        for (std::size_t i = 1; i <= n; ++i) adj_start_[i] += adj_start_[i - 1];
        adj_.resize(2 * touching_.size());
        cursor_.assign(adj_start_.begin(), adj_start_.end() - 1);
        for (std::uint32_t k : touching_) {
            adj_[cursor_[solver_pairs_[k].a]++] = solver_pairs_[k].b;
            adj_[cursor_[solver_pairs_[k].b]++] = solver_pairs_[k].a;
        }
        level_.assign(n, kUnreached);
        queue_.clear();
        for (BodyId s : static_) {
            level_[s] = 0;
            queue_.push_back(s);
        }
        for (std::size_t q = 0; q < queue_.size(); ++q) {  // breadth first: levels are distances
            const BodyId u = queue_[q];
            for (std::uint32_t j = adj_start_[u]; j < adj_start_[u + 1]; ++j) {
                const BodyId v = adj_[j];
                if (level_[v] != kUnreached) continue;
                level_[v] = level_[u] + 1;
                queue_.push_back(v);
            }
        }
        auto low = [&](std::uint32_t k) { return std::min(level_[solver_pairs_[k].a], level_[solver_pairs_[k].b]); };
        std::stable_sort(touching_.begin(), touching_.end(), [&](std::uint32_t x, std::uint32_t y) { return low(x) < low(y); });
        for (std::uint32_t k : touching_) {
            const SolverPair& p = solver_pairs_[k];
            BasicContact<N> c;
            if (!narrow(p, pos, c)) continue;
            const std::uint32_t la = level_[p.a], lb = level_[p.b];
            correct(p, c, pos, la < lb ? Mover::OnlyB : lb < la ? Mover::OnlyA : Mover::Both);
        }
    }

    // Signed distance from dynamic body m at x to static body s, and the unit normal from m to s.
    N separation_to(BodyId m, const Vec& x, BodyId s, const Vec& xs, Vec& n) const {
        const bool m_round = shape_[m] != Shape::Box, s_round = shape_[s] != Shape::Box;
        const BasicRoundCollider<N> mr{x, core_half_[m], radius_[m]}, sr{xs, core_half_[s], radius_[s]};
        const BasicBoxCollider<N> mb{x, half_extents_[m]}, sb{xs, half_extents_[s]};
        if (m_round) return s_round ? separation(mr, sr, n) : separation(mr, sb, n);
        return s_round ? separation(mb, sr, n) : separation(mb, sb, n);
    }

    // Conservative advancement of body m (at x with velocity v, acceleration a, half_a = a/2)
    // toward static s over [0, rem]: the first time the gap closes to tol_ while approaching at
    // continuous_min_speed or faster.
    //
    // Why each advance is safe: the distance between a translating convex body and a fixed one
    // is a convex function of the translation, so it never falls below its tangent plane: after
    // moving by D it is at least gap - n.D. Over the rest of the step n.D grows no faster than
    // max(n.v, 0) + |a| (rem - tau), so advancing by gap over that rate cannot step past a
    // contact, whatever the speed; and it converges fast head-on and leaves at once when the
    // body is not closing in.
    bool sweep(BodyId m, const Vec& x, const Vec& v, const Vec& a, const Vec& half_a, N rem, BodyId s, const Vec& xs,
               N& hit, Vec& n) const {
        const N zero = T::zero();
        const N accel_bound = T::abs(a.x) + T::abs(a.y) + T::abs(a.z);
        N tau = zero;
        for (int it = 0; it < kSweepIterations; ++it) {
            const Vec xt = x + v * tau + half_a * (tau * tau);
            const Vec vt = v + a * tau;
            const N speed_bound = T::abs(vt.x) + T::abs(vt.y) + T::abs(vt.z) + accel_bound * (rem - tau);
            // No speed this fast in the rest of the step: no event is possible (resting and slow
            // bodies cost one distance query).
            if (speed_bound < min_speed_) return false;
            const N gap = separation_to(m, xt, s, xs, n);
            const N vn = T::dot(vt, n);  // closing speed along the separation direction
            if (gap <= tol_) {
                if (vn <= zero || vn < min_speed_) return false;  // resting, leaving or slow: the solver's
                hit = tau;
                return true;
            }
            const N closing = T::max(vn, zero) + accel_bound * (rem - tau);
            if (closing <= zero) return false;  // not closing in for the rest of the step
            const N advance = gap / closing;
            if (advance == zero) {  // within rounding of the contact
                if (vn < min_speed_) return false;
                hit = tau;
                return true;
            }
            tau = tau + advance;
            if (tau >= rem) return false;
        }
        return false;
    }

    // Moves dynamic body id through one physics step, stopping at each impact with a static
    // body, reflecting the normal velocity with the pair's restitution and travelling on.
    void advance_continuous(BodyId id, std::vector<Vec>& pos, std::vector<Vec>& vel, bool ballistic) {
        const Vec zero_vec{T::zero(), T::zero(), T::zero()};
        const Vec a = ballistic ? accel_[id] : zero_vec;
        const Vec half_a = ballistic ? half_accel_[id] : zero_vec;
        Vec x = pos[id], v = vel[id];
        N rem = sub_dt_;
        const Vec& ext = extent_[id];
        for (int event = 0; event < kMaxEvents; ++event) {
            // Swept box of the body over the rest of the step (the parabola stays within the
            // chord's box widened by |a| rem^2 / 2 on each axis).
            const Vec x1 = x + v * rem + half_a * (rem * rem);
            const N bend[3] = {T::abs(half_a.x) * (rem * rem), T::abs(half_a.y) * (rem * rem),
                               T::abs(half_a.z) * (rem * rem)};
            const N c0[3] = {x.x, x.y, x.z}, c1[3] = {x1.x, x1.y, x1.z}, e[3] = {ext.x, ext.y, ext.z};
            bool found = false;
            N best = rem;
            Vec best_n{};
            BodyId best_s = 0;
            for (BodyId s : static_) {
                const Vec& xs = pos[s];
                const Vec& es = extent_[s];
                const N sc[3] = {xs.x, xs.y, xs.z}, se[3] = {es.x, es.y, es.z};
                bool overlap = true;
                for (int k = 0; k < 3 && overlap; ++k) {
                    const N lo = T::min(c0[k], c1[k]) - e[k] - bend[k], hi = T::max(c0[k], c1[k]) + e[k] + bend[k];
                    overlap = lo <= sc[k] + se[k] && sc[k] - se[k] <= hi;
                }
                if (!overlap) continue;
                N hit;
                Vec n;
                if (sweep(id, x, v, a, half_a, rem, s, xs, hit, n) && (!found || hit < best)) {
                    found = true;
                    best = hit;
                    best_n = n;
                    best_s = s;
                }
            }
            if (!found) break;
            x = x + v * best + half_a * (best * best);
            v = v + a * best;
            // An impact fast enough to be an event bounces with the pair's full restitution
            // (restitution_threshold is for the solver's slower contacts).
            const N vn = T::dot(v, best_n);  // > 0: approaching the static body
            v = v - best_n * ((T::one() + pair_restitution(id, best_s)) * vn);
            rem = rem - best;
            ++continuous_events_;
        }
        if (ballistic) {  // without events: the same operations as the ballistic step without sweeps
            x += (v + half_a * rem) * rem;
            v += a * rem;
        } else {
            x += v * rem;
        }
        pos[id] = x;
        vel[id] = v;
    }

    static constexpr int kSweepIterations = 64;
    static constexpr int kMaxEvents = 8;

    SolverDesc settings_;
    int iterations_ = 4;
    bool extended_ = false;
    N dt_;
    N table_[kShapeCount][kShapeCount];

    // Immutable per-body data, by body id.
    std::vector<Shape> shape_;
    std::vector<Vec> extent_;        // AABB half size of the body (core + radius)
    std::vector<N> radius_;          // sweep radius (0 for boxes)
    std::vector<N> core_half_;       // capsule core half-height (0 otherwise)
    std::vector<std::uint32_t> class_;  // by body id
    std::vector<BodyClass> classes_;    // by class, in order of first appearance by id
    std::vector<Vec> half_extents_;  // boxes
    std::vector<Vec> static_lo_, static_hi_;  // static boxes: center -+ half, fixed for life
    std::vector<N> inv_mass_;
    std::vector<N> restitution_;     // per-body override, or negative for "use the table"
    std::vector<BodyId> dynamic_;    // ids of dynamic bodies, ascending
    std::vector<BodyId> static_;     // ids of static bodies, ascending

    // Extended step only.
    N sub_dt_, inv_sub_dt_, slop_, correction_, max_push_, threshold_, min_speed_, tol_;
    std::vector<Vec> sub_gravity_dv_, half_sub_gravity_dv_, accel_, half_accel_;
    std::vector<Vec> predicted_;  // position-based: positions before the iterations
    std::vector<std::uint32_t> touching_, adj_start_, adj_, cursor_, level_;  // shock propagation
    std::vector<BodyId> queue_;
    struct PreSolve {
        bool touching = false;
        Vec normal{};
        N vn{};
    };
    std::vector<PreSolve> pre_;
    std::uint64_t continuous_events_ = 0;

    std::vector<BodyPair> pairs_;
    std::vector<SolverPair> solver_pairs_;
    // Up to kTermClasses body classes: terms_ holds every (class a, class b) pair's terms,
    // computed once, at a * classes + b. Beyond: one entry per candidate pair, by its index.
    static constexpr std::size_t kTermClasses = 16;
    bool terms_by_class_ = false;
    std::vector<PairTerms> terms_;
    // Parallel default step only: islands over solver_pairs_.
    Islands islands_;
    std::vector<Islands::Link> links_;
};

template <class N>
StepKernel<N>::StepKernel(const SceneDesc& scene)
    : settings_(scene.solver), iterations_(scene.iterations), extended_(!scene.solver.is_default()) {
    dt_ = T::ratio(1, scene.tick_rate);
    for (int a = 0; a < kShapeCount; ++a)
        for (int b = 0; b < kShapeCount; ++b) table_[a][b] = T::from_fixed(scene.restitution[a][b]);
    const std::size_t n = scene.bodies.size();
    shape_.resize(n);
    extent_.resize(n);
    radius_.resize(n);
    core_half_.resize(n);
    half_extents_.resize(n);
    static_lo_.resize(n);
    static_hi_.resize(n);
    inv_mass_.resize(n);
    restitution_.resize(n);
    class_.resize(n);
    std::map<std::tuple<N, N, N, N, N, N, N, Shape>, std::uint32_t> classes;  // BodyClass's fields -> class
    for (std::size_t i = 0; i < n; ++i) {
        const BodyDesc& b = scene.bodies[i];
        const auto id = static_cast<BodyId>(i);
        shape_[i] = b.shape;
        switch (b.shape) {
            case Shape::Sphere: {
                const N r = T::from_fixed(b.radius);
                radius_[i] = r;
                extent_[i] = {r, r, r};
                break;
            }
            case Shape::Capsule: {
                const N r = T::from_fixed(b.radius);
                radius_[i] = r;
                core_half_[i] = T::from_fixed(b.half_height);
                extent_[i] = {r, r + core_half_[i], r};
                break;
            }
            case Shape::Box:
                half_extents_[i] = vec(b.half_extents);
                if (b.mass == Fixed::zero()) {
                    static_lo_[i] = vec(b.position) - half_extents_[i];
                    static_hi_[i] = vec(b.position) + half_extents_[i];
                }
                extent_[i] = half_extents_[i];
                break;
        }
        restitution_[i] = b.restitution ? T::from_fixed(*b.restitution) : -T::one();
        const bool is_static = b.mass == Fixed::zero();
        const Vec gravity_dv = is_static ? Vec{} : vec(scene.gravity) * (T::from_fixed(b.gravity_scale) * dt_);
        if (!is_static) inv_mass_[i] = T::reciprocal(T::from_fixed(b.mass));
        const auto [cls, added] =
            classes.try_emplace(std::tuple{core_half_[i], radius_[i], gravity_dv.x, gravity_dv.y, gravity_dv.z,
                                           inv_mass_[i], restitution_[i], shape_[i]},
                                static_cast<std::uint32_t>(classes_.size()));
        if (added) classes_.push_back({core_half_[i], radius_[i], gravity_dv, inv_mass_[i], restitution_[i], shape_[i]});
        class_[i] = cls->second;
        if (is_static) {
            static_.push_back(id);
            continue;
        }
        dynamic_.push_back(id);
    }
    terms_by_class_ = classes_.size() <= kTermClasses;
    if (terms_by_class_)
        for (const BodyClass& a : classes_)
            for (const BodyClass& b : classes_) terms_.push_back(pair_terms(a, b));
    if (!extended_) return;

    const SolverDesc& sv = scene.solver;
    sub_dt_ = T::ratio(1, static_cast<std::int64_t>(scene.tick_rate) * sv.substeps);
    inv_sub_dt_ = T::ratio(static_cast<std::int64_t>(scene.tick_rate) * sv.substeps, 1);
    predicted_.resize(n);
    slop_ = T::from_fixed(sv.slop);
    correction_ = T::from_fixed(sv.correction);
    max_push_ = T::from_fixed(sv.max_push_speed) * sub_dt_;  // per physics step
    threshold_ = T::from_fixed(sv.restitution_threshold);
    min_speed_ = T::from_fixed(sv.continuous_min_speed);
    tol_ = T::from_fixed(Fixed::from_raw(256));  // 2^-24 m: far below any size, far above rounding
    sub_gravity_dv_.resize(n);
    half_sub_gravity_dv_.resize(n);
    accel_.resize(n);
    half_accel_.resize(n);
    const N half = T::ratio(1, 2);
    for (BodyId id : dynamic_) {
        const BodyDesc& b = scene.bodies[id];
        accel_[id] = vec(scene.gravity) * T::from_fixed(b.gravity_scale);
        half_accel_[id] = accel_[id] * half;
        if (sv.integrator == Integrator::Euler) {
            sub_gravity_dv_[id] = vec(scene.gravity) * (T::from_fixed(b.gravity_scale) * sub_dt_);
        } else {
            sub_gravity_dv_[id] = accel_[id] * sub_dt_;
            half_sub_gravity_dv_[id] = half_accel_[id] * sub_dt_;
        }
    }
}

template <class N>
void StepKernel<N>::initial_state(const SceneDesc& scene, std::vector<Vec>& pos, std::vector<Vec>& vel) const {
    const std::size_t n = scene.bodies.size();
    pos.assign(n, Vec{});
    vel.assign(n, Vec{});
    for (std::size_t i = 0; i < n; ++i) pos[i] = vec(scene.bodies[i].position);
    for (BodyId id : dynamic_) vel[id] = vec(scene.bodies[id].velocity);
}

}  // namespace lockroll::sim
