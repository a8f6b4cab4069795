#include "sim/rigid_solver.h"

#include <algorithm>
#include <array>

#include "sim/inertia.h"
#include "sim/rigid_solver_passes.h"

namespace lockroll::sim {

namespace {
Vec3 unit(const Vec3& v) {
    const u128 sq = length_sq_wide(v);
    if (sq == (u128{1} << 64)) return v;  // already unit (an axis-aligned normal): v / 1 is v
    // One division, not three: within 2 ulp of unit length, which a tangent basis tolerates.
    return v * reciprocal(sqrt_wide(sq));
}

// v -= d * s for d with axis code `code` != 0: only the axis component changes (v - 0 = v).
void subtract_along(Vec3& v, std::int8_t code, Fixed s) {
    Fixed& c = component(v, code > 0 ? code - 1 : -code - 1);
    c -= code > 0 ? s : -s;
}
void add_along(Vec3& v, std::int8_t code, Fixed s) {
    Fixed& c = component(v, code > 0 ? code - 1 : -code - 1);
    c += code > 0 ? s : -s;
}

using rigid_detail::shared_change;

Fixed damping_factor(Fixed c, Fixed dt) { return reciprocal(Fixed::one() + c * dt); }

// m v for a box's world inverse inertia m (an isotropic body's is its scalar times v, each
// component one product rounded once: the same bits as the full product, at a third of the cost).
// Out of line, so make_row stays small enough to inline its short path.
Vec3 full_times(const Mat3& m, const Vec3& v) { return m * v; }

// A sum of exact Q64.64 terms rounded once at the end. If a partial sum leaves the i128 range
// the result saturates with its sign and counts one overflow (the total is then far beyond
// Fixed's range whatever follows, as in dot_wide_checked).
class WideSum {
public:
    void add(i128 v) {
        if (saturated_ != 0) return;
        i128 t;
        if (add_overflow(sum_, v, &t)) {
            saturated_ = sum_ > 0 ? 1 : -1;
            return;
        }
        sum_ = t;
    }
    Fixed rounded() const {
        if (saturated_ != 0) {
            note_overflow();
            return saturated_ > 0 ? Fixed::max() : Fixed::min();
        }
        return round_wide(sum_);
    }

private:
    i128 sum_ = 0;
    int saturated_ = 0;
};

// a x + b y rounded once (what WideSum gives for two terms, without its bookkeeping). The sum
// of two products leaves the i128 range only when both have the same sign.
Fixed mul_add(Fixed a, Fixed x, Fixed b, Fixed y) {
    i128 s;
    if (add_overflow(mul_wide(a.raw, x.raw), mul_wide(b.raw, y.raw), &s)) {
        note_overflow();
        return (a.raw < 0) == (x.raw < 0) ? Fixed::max() : Fixed::min();
    }
    return round_wide(s);
}

// u0 l0 + u1 l1 + u2 l2, each component rounded once; a zero weight's term is exactly zero
// and skipped.
Vec3 combine3(const Vec3& u0, Fixed l0, const Vec3& u1, Fixed l1, const Vec3& u2, Fixed l2) {
    // One weight (a normal row's impulse): each component is one product rounded once, which
    // is what u * l computes, without the sums.
    if (l1.raw == 0 && l2.raw == 0) return u0 * l0;
    if (l0.raw == 0 && l2.raw == 0) return u1 * l1;
    if (l0.raw == 0 && l1.raw == 0) return u2 * l2;
    // Two weights (a friction step): the same sums, term by term.
    if (l0.raw == 0) return {mul_add(u1.x, l1, u2.x, l2), mul_add(u1.y, l1, u2.y, l2), mul_add(u1.z, l1, u2.z, l2)};
    WideSum x, y, z;
    const auto term = [&](const Vec3& u, Fixed l) {
        if (l.raw == 0) return;
        x.add(mul_wide(u.x.raw, l.raw));
        y.add(mul_wide(u.y.raw, l.raw));
        z.add(mul_wide(u.z.raw, l.raw));
    };
    term(u0, l0);
    term(u1, l1);
    term(u2, l2);
    return {x.rounded(), y.rounded(), z.rounded()};
}
}  // namespace

namespace rigid_detail {
// A tangent basis of unit n, a fixed function of n.
void tangents(const Vec3& n, Vec3& t1, Vec3& t2) {
    const Fixed k = Fixed::from_raw(2479700525);  // 1/sqrt(3): one of |n.x|, |n.y|, |n.z| is at least this
    t1 = abs(n.x) >= k ? unit({n.y, -n.x, Fixed::zero()}) : unit({Fixed::zero(), n.z, -n.y});
    t2 = cross(n, t1);
}

// A row direction that is exactly a signed unit axis +-e_k (a contact on a room wall's face:
// its normal and tangent basis are axes) gives +-(k + 1), anything else 0. For such a d the
// product d * s is s or -s on axis k and exactly 0 elsewhere, bit for bit as the three rounded
// products give it (1 * s = s, -1 * s = -s, and for s = Fixed::min() both saturate to max and
// count one overflow, as unary minus does), and a sum u x + w y over two different axes is x
// on one and y on the other: the impulse's velocity change needs no products at all.
std::int8_t axis_code(const Vec3& d) {
    const Fixed zero = Fixed::zero(), one = Fixed::one(), neg = -Fixed::one();
    const Fixed c[3] = {d.x, d.y, d.z};
    for (int k = 0; k < 3; ++k) {
        const Fixed o1 = c[(k + 1) % 3], o2 = c[(k + 2) % 3];
        if (o1 != zero || o2 != zero) continue;
        if (c[k] == one) return static_cast<std::int8_t>(k + 1);
        if (c[k] == neg) return static_cast<std::int8_t>(-(k + 1));
    }
    return 0;
}
Vec3 scaled_axis(std::int8_t code, Fixed s) {
    Vec3 v;
    component(v, code > 0 ? code - 1 : -code - 1) = code > 0 ? s : -s;
    return v;
}

Vec3 cross_axis(const Vec3& r, std::int8_t code) {
    // r x e_x = (0, r.z, -r.y), r x e_y = (-r.z, 0, r.x), r x e_z = (r.y, -r.x, 0); for -e_k every
    // sign flips. Each non-zero component is one exact product by +-1 rounded once: the
    // component or its negation (-INT64_MIN saturating and counting, as the rounding does).
    const bool flip = code < 0;
    const auto pos = [flip](Fixed x) { return flip ? -x : x; };
    const auto neg = [flip](Fixed x) { return flip ? x : -x; };
    const Fixed z = Fixed::zero();
    switch (code > 0 ? code : -code) {
    case 1: return {z, pos(r.z), neg(r.y)};
    case 2: return {neg(r.z), z, pos(r.x)};
    default: return {pos(r.y), neg(r.x), z};
    }
}

Fixed dot_axis(std::int8_t code, const Vec3& v) {
    const Fixed c = code == 1 || code == -1 ? v.x : code == 2 || code == -2 ? v.y : v.z;
    return code > 0 ? c : -c;
}

void axis_tangents(std::int8_t code, Vec3& t1, Vec3& t2, std::int8_t& code1, std::int8_t& code2) {
    // Built once by the general functions themselves, for the six axes (index code + 3).
    struct Basis {
        Vec3 t1, t2;
        std::int8_t code1, code2;
    };
    static const auto table = [] {
        std::array<Basis, 7> b{};
        for (int c = -3; c <= 3; ++c) {
            if (c == 0) continue;
            const Fixed one = c > 0 ? Fixed::one() : -Fixed::one(), z = Fixed::zero();
            const int k = c > 0 ? c - 1 : -c - 1;
            const Vec3 n{k == 0 ? one : z, k == 1 ? one : z, k == 2 ? one : z};
            Basis& e = b[static_cast<std::size_t>(c + 3)];
            tangents(n, e.t1, e.t2);
            e.code1 = axis_code(e.t1);
            e.code2 = axis_code(e.t2);
        }
        return b;
    }();
    const Basis& e = table[static_cast<std::size_t>(code + 3)];
    t1 = e.t1;
    t2 = e.t2;
    code1 = e.code1;
    code2 = e.code2;
}
}  // namespace rigid_detail

using rigid_detail::axis_code;
using rigid_detail::tangents;

void RigidSolver::configure(const SceneDesc& scene, const StepKernel<Fixed>& k) {
    enabled_ = scene.rigid.enabled;
    if (!enabled_) return;
    const RigidDesc& rg = scene.rigid;
    shock_ = rg.shock_propagation;
    warm_ = rg.warm_starting;
    split_ = rg.split_impulse;
    reduce_ = rg.reduce_manifold;
    block_ = rg.block_solver;
    colour_ = rg.graph_colouring;
    iterations_ = scene.iterations;
    dt_ = k.dt();
    inv_dt_ = Fixed::from_int(scene.tick_rate);
    baumgarte_rate_ = rg.baumgarte * inv_dt_;
    slop_ = rg.slop;
    threshold_ = rg.restitution_threshold;
    margin_ = scene.contact_margin;
    cap_speed_ = margin_ * inv_dt_;
    for (int a = 0; a < kShapeCount; ++a)
        for (int b = 0; b < kShapeCount; ++b) {
            kin_[a][b] = rg.friction[a][b];
            stat_[a][b] = max(rg.static_friction[a][b], rg.friction[a][b]);
            rest_[a][b] = scene.restitution[a][b];
        }
    const std::size_t n = scene.bodies.size();
    shape_.resize(n);
    radius_.resize(n);
    turn_reach_.assign(n, Fixed::zero());
    closing_.assign(n, Fixed::zero());
    core_half_.resize(n);
    inv_mass_.resize(n);
    half_.resize(n);
    extent_.resize(n);
    gravity_dv_.resize(n);
    inertia_.resize(n);
    inv_inertia_.resize(n);
    isotropic_.resize(n);
    restitution_.resize(n);
    friction_.resize(n);
    static_friction_.resize(n);
    lin_damp_.assign(n, Fixed::one());
    ang_damp_.assign(n, Fixed::one());
    rot_.resize(n);
    rot_memo_.clear();
    rot_memo_at_.assign(n, kNoSlot);
    slot_.assign(n, kNoSlot);
    slot_ids_.clear();
    bodies_.clear();
    inv_i_world_.assign(n, Mat3{});
    if (split_) {
        pseudo_.reserve(n);
    }
    dynamic_ = k.dynamic_ids();
    impulse_capacity_ = warm_ ? kImpulsesPerBody * dynamic_.size() : 0;
    spin_mu_ = rg.spinning_friction;
    roll_mu_ = rg.rolling_friction;
    spin_roll_ = spin_mu_.raw > 0 || roll_mu_.raw > 0;
    sleep_ = rg.sleeping.enabled;
    if (sleep_) {
        every_dynamic_ = dynamic_;
        player_.assign(n, 0);
        for (std::size_t i = 0; i < n; ++i) player_[i] = scene.bodies[i].player >= 0;
        mark_.assign(n, 0);
        components_.reset(n);
        // ceil(time * tick_rate): time is Q32.32, so the product's raw value over 2^32, up.
        const i128 t = mul_wide(rg.sleeping.time.raw, scene.tick_rate);
        const auto whole = static_cast<std::uint64_t>(static_cast<u128>(t) >> Fixed::kFracBits);
        const bool part = (static_cast<std::uint64_t>(static_cast<u128>(t)) & ((std::uint64_t{1} << Fixed::kFracBits) - 1)) != 0;
        sleep_frames_ = static_cast<std::uint32_t>(whole + (part ? 1 : 0));
        const auto square = [](Fixed f) {
            return mul_wide_unsigned(static_cast<std::uint64_t>(f.raw), static_cast<std::uint64_t>(f.raw));
        };
        sleep_lin_sq_ = square(rg.sleeping.linear_speed);
        sleep_ang_sq_ = square(rg.sleeping.angular_speed);
    }
    const Fixed neg = -Fixed::one();
    for (std::size_t i = 0; i < n; ++i) {
        const BodyDesc& b = scene.bodies[i];
        const auto id = static_cast<BodyId>(i);
        shape_[i] = b.shape;
        radius_[i] = k.radius(id);
        core_half_[i] = k.core_half(id);
        half_[i] = k.half_extents(id);
        inv_mass_[i] = k.inv_mass(id);
        restitution_[i] = b.restitution ? *b.restitution : neg;
        friction_[i] = b.friction ? *b.friction : neg;
        static_friction_[i] = b.static_friction ? *b.static_friction : b.friction ? *b.friction : neg;
        rot_[i] = rotation(normalised(b.orientation));
        if (b.mass.raw == 0) {
            // A static body never turns: its exact AABB, |R| h (+ radius for round shapes).
            const Mat3& r = rot_[i];
            const Vec3 h = b.shape == Shape::Box ? half_[i] : Vec3{Fixed::zero(), core_half_[i], Fixed::zero()};
            Vec3 e;
            for (int row = 0; row < 3; ++row) {
                const Vec3& rr = r.row[row];
                const Fixed v = abs(rr.x) * h.x + abs(rr.y) * h.y + abs(rr.z) * h.z + radius_[i];
                (row == 0 ? e.x : row == 1 ? e.y : e.z) = v;
            }
            extent_[i] = e;
            isotropic_[i] = 1;  // inverse inertia diag(0, 0, 0): make_row() may take the short way
            continue;
        }
        // A dynamic body may turn any way: its bounding sphere.
        const Fixed bound = b.shape == Shape::Box ? sqrt_wide(length_sq_wide(half_[i])) : radius_[i] + core_half_[i];
        extent_[i] = {bound, bound, bound};
        turn_reach_[i] = b.shape == Shape::Box ? bound : b.shape == Shape::Capsule ? core_half_[i] : Fixed::zero();
        gravity_dv_[i] = scene.gravity * (b.gravity_scale * dt_);
        inertia_[i] = inertia(b.shape, b.radius, b.half_extents, b.half_height, b.mass);
        inv_inertia_[i] = inverse_inertia(b);
        isotropic_[i] = inv_inertia_[i].x == inv_inertia_[i].y && inv_inertia_[i].y == inv_inertia_[i].z;
        // A kept rotation for each body update_inertia() builds a rotation of (a box or a
        // capsule) or integrate() keeps one of (a non-isotropic body, which is one of those).
        if (b.shape == Shape::Box || core_half_[i].raw != 0 || !isotropic_[i]) {
            rot_memo_at_[i] = static_cast<std::uint32_t>(rot_memo_.size());
            rot_memo_.emplace_back();
        }
        const Fixed lc = b.linear_damping ? *b.linear_damping : rg.linear_damping;
        const Fixed ac = b.angular_damping ? *b.angular_damping : rg.angular_damping;
        if (lc.raw > 0) lin_damp_[i] = damping_factor(lc, dt_);
        if (ac.raw > 0) ang_damp_[i] = damping_factor(ac, dt_);
        damped_ = damped_ || lc.raw > 0 || ac.raw > 0;
    }
}

void RigidSolver::initial_state(const SceneDesc& scene, std::vector<Quat>& orient, std::vector<Vec3>& angvel) const {
    const std::size_t n = scene.bodies.size();
    orient.resize(n);
    angvel.assign(n, Vec3{});
    for (std::size_t i = 0; i < n; ++i) orient[i] = normalised(scene.bodies[i].orientation);
    for (BodyId id : sleep_ ? every_dynamic_ : dynamic_) angvel[id] = scene.bodies[id].angular_velocity;
}

OrientedCollider RigidSolver::collider(BodyId id, const std::vector<Vec3>& pos) const {
    return {shape_[id], pos[id], &rot_[id], radius_[id], core_half_[id], half_[id]};
}

// Inline in build_points(), their one caller (out of line: a call per manifold).
[[gnu::always_inline]] inline Fixed RigidSolver::pair_restitution(BodyId a, BodyId b) const {
    const Fixed ea = restitution_[a], eb = restitution_[b];
    if (ea.raw >= 0 || eb.raw >= 0) return max(ea, eb);
    return rest_[static_cast<int>(shape_[a])][static_cast<int>(shape_[b])];
}

[[gnu::always_inline]] inline void RigidSolver::pair_friction(BodyId a, BodyId b, Fixed& mu_k, Fixed& mu_s) const {
    const auto combine = [](Fixed x, Fixed y, Fixed table) {
        if (x.raw >= 0 && y.raw >= 0) return sqrt(x * y);
        if (x.raw >= 0) return x;
        if (y.raw >= 0) return y;
        return table;
    };
    const int sa = static_cast<int>(shape_[a]), sb = static_cast<int>(shape_[b]);
    mu_k = combine(friction_[a], friction_[b], kin_[sa][sb]);
    mu_s = max(mu_k, combine(static_friction_[a], static_friction_[b], stat_[sa][sb]));
}

void RigidSolver::arms(BodyId id, const Vec3& r, Point& p, Vec3 Row::*arm) const {
    // Written where the rows keep them (make_row() reads them there): no copy of 9 values.
    Vec3& c0 = p.row[0].*arm;
    Vec3& c1 = p.row[1].*arm;
    Vec3& c2 = p.row[2].*arm;
    if (inv_mass_[id].raw == 0) {
        // A static body's arms are never read for a result: its angular velocity is zero (every
        // row speed skips its term), its inverse inertia is zero (so are its Jacobian products
        // and its share of the effective masses), and no pass moves it. Zeros change no bits
        // and save the room's walls three cross products per point.
        c0 = c1 = c2 = Vec3{};
        return;
    }
    if (shape_[id] == Shape::Sphere) {
        // A sphere's contact point lies on its normal through the centre: r = L n, so r x n is
        // exactly zero (its normal impulse never spins it), r x t1 = L t2 and r x t2 = -L t1.
        // Taken exactly, so rounding does not give the sphere a spurious twist.
        // On a wall (normal and tangents exact axes) the products by exact 0 and +-1 are taken
        // as what they give (rigid_detail::scaled_axis, dot_axis).
        c0 = Vec3{};
        if (p.axis_n != 0 && p.axis_t1 != 0 && p.axis_t2 != 0) {
            const Fixed len = rigid_detail::dot_axis(p.axis_n, r);
            c1 = rigid_detail::scaled_axis(p.axis_t2, len);
            c2 = -rigid_detail::scaled_axis(p.axis_t1, len);
            return;
        }
        const Fixed len = dot(r, p.n);
        c1 = p.t2 * len;
        c2 = -(p.t1 * len);
        return;
    }
    if (p.axis_n != 0 && p.axis_t1 != 0 && p.axis_t2 != 0) {
        // A box (or capsule) on a wall, the floor or an unturned box's face: r x an axis is a
        // permutation of r's components with signs, no products (rigid_detail::cross_axis).
        c0 = rigid_detail::cross_axis(r, p.axis_n);
        c1 = rigid_detail::cross_axis(r, p.axis_t1);
        c2 = rigid_detail::cross_axis(r, p.axis_t2);
        return;
    }
    c0 = cross(r, p.n);
    c1 = cross(r, p.t1);
    c2 = cross(r, p.t2);
}

[[gnu::always_inline]] inline void RigidSolver::make_row(const Point& p, Row& row, rigid_detail::ReciprocalMemo& memo, const Row* same_mass) const {
    const Vec3& ca = row.ca;
    const Vec3& cb = row.cb;
    const SolverBody& a = bodies_[p.sa];
    const SolverBody& b = bodies_[p.sb];
    // A static body has zero inverse inertia, and a zero arm turns nothing: ia (ib) is then
    // zero and its term is left out of the effective mass (adding an exact zero changes no bits).
    // An isotropic body's scalar rides in its SolverBody, so only a box reads its world matrix.
    const auto inertia_arm = [&](const SolverBody& body, BodyId id, const Vec3& c) {
        if (c == Vec3{} || body.iso_inv_inertia.raw == 0) return Vec3{};
        if (body.iso_inv_inertia.raw < 0) return full_times(inv_i_world_[id], c);
        // A zero component's product is exactly 0 (an arm on a wall has two): not taken.
        const Fixed s = body.iso_inv_inertia;
        const auto times = [s](Fixed x) { return x.raw == 0 ? Fixed::zero() : s * x; };
        return Vec3{times(c.x), times(c.y), times(c.z)};
    };
    row.ia = inertia_arm(a, p.a, ca);
    row.ib = inertia_arm(b, p.b, cb);
    if (same_mass != nullptr) {
        row.mass = same_mass->mass;
        return;
    }
    Fixed k = a.inv_mass + b.inv_mass;
    if (row.ia != Vec3{}) k = k + dot(ca, row.ia);
    if (row.ib != Vec3{}) k = k + dot(cb, row.ib);
    row.mass = k.raw > 0 ? memo.reciprocal_of(k) : Fixed::zero();
}

[[gnu::always_inline]] inline Fixed RigidSolver::row_speed(const Point& p, int k, const Vec3& dv, const Bodies& bodies) {
    const Vec3& d = k == 0 ? p.n : k == 1 ? p.t1 : p.t2;
    const Row& r = p.row[k];
    WideSum s;
    // An axis row (kAxisRows): d.dv is its one non-zero product, the others exact zeros.
    if ((p.nonzero & kAxisRows) != 0) {
        const std::int8_t code = k == 0 ? p.axis_n : k == 1 ? p.axis_t1 : p.axis_t2;
        const int j = std::abs(code) - 1;
        s.add(mul_wide(component(d, j).raw, component(dv, j).raw));
    } else {
        s.add(dot_wide(d, dv));
    }
    // A body at rest adds dot_wide(c, 0) = 0, exactly and with nothing noted: its term is taken
    // anyway (testing w for zero cost more than the three products it saved, a dynamic body of
    // a pile almost always turning). A static body's arms are skipped by their mask bits.
    const Vec3& wa = bodies[p.sa].w;
    const Vec3& wb = bodies[p.sb].w;
    // A tangent row's axis arm (kAxisArmsA/B) has one non-zero component, on the other
    // tangent's axis: its dot product is that one product (the others are exact zeros).
    const auto arm_dot = [&](const Vec3& c, const Vec3& w, std::uint16_t axis_bit) {
        if (k != 0 && (p.nonzero & axis_bit) != 0) {
            const int axis = std::abs(k == 1 ? p.axis_t2 : p.axis_t1) - 1;
            return mul_wide(component(c, axis).raw, component(w, axis).raw);
        }
        return dot_wide(c, w);
    };
    if ((p.nonzero & (kArmB << k)) != 0) s.add(arm_dot(r.cb, wb, kAxisArmsB));
    if ((p.nonzero & (kArmA << k)) != 0) s.add(-arm_dot(r.ca, wa, kAxisArmsA));  // |dot_wide| < 2^127: no overflow
    return s.rounded();
}

// Whether an impulse moves this body: every dynamic body, or `only` alone (shock pass). Static
// bodies have zero inverse mass and inertia: skipping them changes no bits.
bool RigidSolver::moves(const SolverBody& body, BodyId id, BodyId only) {
    return only == kEveryBody ? body.inv_mass.raw != 0 : only == id;
}

void RigidSolver::apply(const Point& p, Fixed l0, Fixed l1, Fixed l2, Bodies& bodies, BodyId only) {
    SolverBody& a = bodies[p.sa];
    SolverBody& b = bodies[p.sb];
    const bool move_a = moves(a, p.a, only);
    const bool move_b = moves(b, p.b, only);
    // A normal impulse alone does not turn a body whose normal arm is zero (a sphere).
    const bool tangential = l1.raw != 0 || l2.raw != 0;
    if (move_a) {
        const Fixed m = a.inv_mass;
        a.v -= combine3(p.n, l0 * m, p.t1, l1 * m, p.t2, l2 * m);
        if (tangential || p.row[0].ia != Vec3{}) a.w -= combine3(p.row[0].ia, l0, p.row[1].ia, l1, p.row[2].ia, l2);
    }
    if (move_b) {
        const Fixed m = b.inv_mass;
        b.v += combine3(p.n, l0 * m, p.t1, l1 * m, p.t2, l2 * m);
        if (tangential || p.row[0].ib != Vec3{}) b.w += combine3(p.row[0].ib, l0, p.row[1].ib, l1, p.row[2].ib, l2);
    }
}

// The two common cases of apply(), with the same bits: a normal impulse alone (each component
// one product, as combine3 gives for one weight), and friction alone (two weights: each
// component a x + b y rounded once, which is also what combine3 gives when one of them is zero).
[[gnu::always_inline]] inline void RigidSolver::apply_normal(const Point& p, Fixed l, Bodies& bodies, BodyId only) {
    SolverBody& a = bodies[p.sa];
    SolverBody& b = bodies[p.sb];
    const bool move_a = moves(a, p.a, only);
    const bool move_b = moves(b, p.b, only);
    if (move_a && move_b && p.axis_n == 0 && a.inv_mass == b.inv_mass) {
        // Equal masses (every dynamic pair of the piles): both bodies' velocity changes are the
        // same products of the same numbers, taken once (shared_change() repeats any overflow
        // events they noted, so the count is what two computations give).
        const Vec3 dv = shared_change([&] { return p.n * (l * a.inv_mass); });
        a.v -= dv;
        b.v += dv;
        if ((p.nonzero & kInertiaA) != 0) a.w -= p.row[0].ia * l;
        if ((p.nonzero & kInertiaB) != 0) b.w += p.row[0].ib * l;
        return;
    }
    if (move_a) {
        if (p.axis_n != 0)
            subtract_along(a.v, p.axis_n, l * a.inv_mass);
        else
            a.v -= p.n * (l * a.inv_mass);
        if ((p.nonzero & kInertiaA) != 0) a.w -= p.row[0].ia * l;
    }
    if (move_b) {
        if (p.axis_n != 0)
            add_along(b.v, p.axis_n, l * b.inv_mass);
        else
            b.v += p.n * (l * b.inv_mass);
        if ((p.nonzero & kInertiaB) != 0) b.w += p.row[0].ib * l;
    }
}

// w -+= u1 l1 + u2 l2 for a sphere's axis arms (kAxisArmsA/B): u1 lies on t2's axis, u2 on
// t1's (a different one), so each sum has one non-zero product (x l + 0, rounded once, is x l)
// and the third component subtracts an exact zero: two products instead of six.
[[gnu::always_inline]] inline void RigidSolver::turn_axes(Vec3& w, const Point& p, const Vec3& u1, Fixed l1, const Vec3& u2, Fixed l2, int sign) {
    const int k2 = std::abs(p.axis_t2) - 1, k1 = std::abs(p.axis_t1) - 1;
    const Fixed d2 = component(u1, k2) * l1, d1 = component(u2, k1) * l2;
    if (sign < 0) {
        component(w, k2) -= d2;
        component(w, k1) -= d1;
    } else {
        component(w, k2) += d2;
        component(w, k1) += d1;
    }
}

[[gnu::always_inline]] inline void RigidSolver::apply_friction(const Point& p, Fixed l1, Fixed l2, Bodies& bodies, BodyId only) {
    SolverBody& a = bodies[p.sa];
    SolverBody& b = bodies[p.sb];
    const bool move_a = moves(a, p.a, only);
    const bool move_b = moves(b, p.b, only);
    const auto sum = [](const Vec3& u, Fixed x, const Vec3& w, Fixed y) {
        return Vec3{mul_add(u.x, x, w.x, y), mul_add(u.y, x, w.y, y), mul_add(u.z, x, w.z, y)};
    };
    const auto turn_a = [&] {
        if ((p.nonzero & kAxisArmsA) != 0)
            turn_axes(a.w, p, p.row[1].ia, l1, p.row[2].ia, l2, -1);
        else
            a.w -= sum(p.row[1].ia, l1, p.row[2].ia, l2);
    };
    const auto turn_b = [&] {
        if ((p.nonzero & kAxisArmsB) != 0)
            turn_axes(b.w, p, p.row[1].ib, l1, p.row[2].ib, l2, 1);
        else
            b.w += sum(p.row[1].ib, l1, p.row[2].ib, l2);
    };
    // Both tangents axes (then different ones, being orthogonal): x on one, y on the other.
    const bool axes = p.axis_t1 != 0 && p.axis_t2 != 0;
    if (move_a && move_b && !axes && a.inv_mass == b.inv_mass) {
        // Equal masses: one velocity change for both (as in apply_normal()).
        const Fixed m = a.inv_mass;
        const Vec3 dv = shared_change([&] { return sum(p.t1, l1 * m, p.t2, l2 * m); });
        a.v -= dv;
        b.v += dv;
        turn_a();
        turn_b();
        return;
    }
    if (move_a) {
        const Fixed m = a.inv_mass;
        if (axes) {
            subtract_along(a.v, p.axis_t1, l1 * m);
            subtract_along(a.v, p.axis_t2, l2 * m);
        } else {
            a.v -= sum(p.t1, l1 * m, p.t2, l2 * m);
        }
        turn_a();
    }
    if (move_b) {
        const Fixed m = b.inv_mass;
        if (axes) {
            add_along(b.v, p.axis_t1, l1 * m);
            add_along(b.v, p.axis_t2, l2 * m);
        } else {
            b.v += sum(p.t1, l1 * m, p.t2, l2 * m);
        }
        turn_b();
    }
}

std::uint32_t RigidSolver::slot_of(BodyId id, const std::vector<Vec3>& vel, const std::vector<Vec3>& angvel) {
    std::uint32_t& slot = slot_[id];
    if (slot == kNoSlot) {
        slot = static_cast<std::uint32_t>(bodies_.size());
        // isotropic_: a sphere's (or a static body's) scalar inverse inertia; -1 marks a full matrix.
        const Fixed iso = isotropic_[id] ? inv_inertia_[id].x : -Fixed::one();
        bodies_.push_back({vel[id], angvel[id], inv_mass_[id], iso});
        slot_ids_.push_back(id);
    }
    return slot;
}

void RigidSolver::scatter(std::vector<Vec3>& vel, std::vector<Vec3>& angvel) const {
    // Only dynamic bodies' velocities change (a static body is never moved by a row).
    for (std::size_t k = 0; k < bodies_.size(); ++k) {
        if (bodies_[k].inv_mass.raw == 0) continue;
        vel[slot_ids_[k]] = bodies_[k].v;
        angvel[slot_ids_[k]] = bodies_[k].w;
    }
}

[[gnu::always_inline]] inline void RigidSolver::manifold_of(const BodyPair& pair, const std::vector<Vec3>& pos, BodyId& a, BodyId& b,
                              Manifold& m) const {
    // A round body first, so every routine sees (round, box); otherwise the broadphase's order.
    a = pair.a;
    b = pair.b;
    if (shape_[a] == Shape::Box && shape_[b] != Shape::Box) std::swap(a, b);
    contact_points(collider(a, pos), collider(b, pos), pair_margin(a, b), m);
    if (m.count == 0) return;
    if (reduce_ && shape_[a] == Shape::Box && shape_[b] == Shape::Box && m.points[0].feature < kFeatureEdge) reduce(m);
}

void RigidSolver::build_contacts(const std::vector<Vec3>& pos, const std::vector<Vec3>& vel,
                                 const std::vector<Vec3>& angvel) {
    for (BodyId id : slot_ids_) slot_[id] = kNoSlot;
    slot_ids_.clear();
    bodies_.clear();
    points_.clear();
    manifold_start_.clear();
    Manifold m;
    rigid_detail::ReciprocalMemo memo;
    for (const BodyPair& pair : pairs_) {
        BodyId a, b;
        manifold_of(pair, pos, a, b, m);
        if (m.count == 0) continue;
        if (block_) manifold_start_.push_back(static_cast<std::uint32_t>(points_.size()));
        slot_of(a, vel, angvel);
        slot_of(b, vel, angvel);
        const std::size_t first = points_.size();
        points_.resize(first + static_cast<std::size_t>(m.count));
        build_points(a, b, m, pos, points_.data() + first, memo);
    }
    if (block_) manifold_start_.push_back(static_cast<std::uint32_t>(points_.size()));
}

[[gnu::always_inline]] inline void RigidSolver::build_points(BodyId a, BodyId b, const Manifold& m, const std::vector<Vec3>& pos, Point* out,
                                                          rigid_detail::ReciprocalMemo& memo) const {
    const Fixed e = pair_restitution(a, b);
    Fixed mu_k, mu_s;
    pair_friction(a, b, mu_k, mu_s);
    const std::uint32_t sa = slot_[a], sb = slot_[b];
    const auto sphere_or_static = [&](BodyId id) { return shape_[id] == Shape::Sphere || inv_mass_[id].raw == 0; };
    const bool sphere_pair = sphere_or_static(a) && sphere_or_static(b);
    // Which products may be non-zero, from what arms() and make_row() leave exactly zero: a
    // static body's arms (and inertia products), a sphere's normal arm, and the inertia
    // products of a body with zero inverse inertia. A bit may be set for a product that turns
    // out zero (it is then added as zero): only a clear bit skips work.
    const auto may_turn = [&](BodyId id, std::uint32_t slot, std::uint16_t arm, std::uint16_t inertia) {
        if (inv_mass_[id].raw == 0) return std::uint16_t{0};
        const std::uint16_t rows = shape_[id] == Shape::Sphere ? 6 : 7;  // rows 1, 2 (or 0, 1, 2)
        const std::uint16_t arms = static_cast<std::uint16_t>(rows * arm);
        return bodies_[slot].iso_inv_inertia.raw == 0 ? arms : static_cast<std::uint16_t>(arms | rows * inertia);
    };
    const auto nonzero = static_cast<std::uint16_t>(may_turn(a, sa, kArmA, kInertiaA) | may_turn(b, sb, kArmB, kInertiaB));
    // A dynamic sphere's arms on an all-axes point (arms()'s wall case), with a scalar inverse
    // inertia (its products keep the zero components zero).
    const auto axis_arms = [&](BodyId id, std::uint32_t slot, std::uint16_t bit) {
        return shape_[id] == Shape::Sphere && inv_mass_[id].raw != 0 && bodies_[slot].iso_inv_inertia.raw >= 0 ? bit : 0;
    };
    const auto axis_arms_ab = static_cast<std::uint16_t>(axis_arms(a, sa, kAxisArmsA) | axis_arms(b, sb, kAxisArmsB));
    for (int i = 0; i < m.count; ++i) {
        const ContactPoint& c = m.points[i];
        Point& p = out[i];
        p.a = a;
        p.b = b;
        p.sa = sa;
        p.sb = sb;
        p.feature = c.feature;
        p.n = c.normal;
        // The tangent basis is a function of n alone: an axis's comes from a table the general
        // arithmetic made, and a manifold's points that share a normal (box faces) share it and
        // its axis codes (the previous point's are copied: no test of n at all).
        if (i > 0 && p.n == out[i - 1].n) {
            p.axis_n = out[i - 1].axis_n;
            p.t1 = out[i - 1].t1;
            p.t2 = out[i - 1].t2;
            p.axis_t1 = out[i - 1].axis_t1;
            p.axis_t2 = out[i - 1].axis_t2;
        } else if ((p.axis_n = axis_code(p.n)) != 0) {
            rigid_detail::axis_tangents(p.axis_n, p.t1, p.t2, p.axis_t1, p.axis_t2);
        } else {
            tangents(p.n, p.t1, p.t2);
            p.axis_t1 = axis_code(p.t1);
            p.axis_t2 = axis_code(p.t2);
        }
        arms(a, c.point - pos[a], p, &Row::ca);
        arms(b, c.point - pos[b], p, &Row::cb);
        make_row(p, p.row[0], memo);
        make_row(p, p.row[1], memo);
        // Between spheres (or a sphere and a static body) the two tangent rows' effective
        // masses are equal (each turning body's arm is L n, so |r x t1| = |r x t2| = |L|):
        // one division serves both.
        make_row(p, p.row[2], memo, sphere_pair ? &p.row[1] : nullptr);
        p.nonzero = p.axis_n != 0 && p.axis_t1 != 0 && p.axis_t2 != 0 ? static_cast<std::uint16_t>(nonzero | axis_arms_ab | kAxisRows) : nonzero;
        p.mu_k = mu_k;
        p.mu_s = mu_s;
        p.pn = p.pt1 = p.pt2 = p.pb = p.bias = Fixed::zero();
        // Target normal speed (> 0 separates): close a gap within this step and no faster;
        // push out overlap beyond slop at baumgarte per step; bounce fast approaches.
        // With split impulses the push-out is the pseudo velocities' bias instead.
        Fixed target = c.depth * inv_dt_;
        if (c.depth.raw > 0) {
            const Fixed push = max(c.depth - slop_, Fixed::zero()) * baumgarte_rate_;
            target = split_ ? Fixed::zero() : push;
            p.bias = split_ ? push : Fixed::zero();
        }
        if (e.raw > 0) {
            const Fixed vn = row_speed(p, 0, bodies_[sb].v - bodies_[sa].v, bodies_);
            // The bounce is e times the approach speed the bodies came in with, before this
            // step's gravity (as Box2D and Bullet measure it): bouncing the g dt added this
            // step too gave every bounce e g dt more than it brought, so a ball on e = 0.8
            // kept hopping at ~0.9 m/s, above the threshold, forever (docs/physics.md).
            const Vec3 dg = gravity_dv_[b] - gravity_dv_[a];
            const Fixed vn_before = vn - (p.axis_n != 0 ? rigid_detail::dot_axis(p.axis_n, dg) : dot(p.n, dg));
            // Only when the approach closes the gap within this step: the gap is -depth, so
            // it closes when -vn dt >= -depth, i.e. vn dt <= depth. (This read vn dt + depth
            // < 0, true for every approaching gap: a ball bounced off the floor up to the
            // whole contact margin above it.)
            if (-vn_before > threshold_ && (c.depth.raw > 0 || vn * dt_ <= c.depth))
                target = max(target, -(e * vn_before));
        }
        p.target = target;
    }
}

void RigidSolver::find_manifolds(std::size_t begin, std::size_t end, const std::vector<Vec3>& pos,
                                 rigid_detail::FoundList& list) const {
    list.fill(begin, end, [&](std::size_t i, Manifold& m) {
        BodyId a, b;
        manifold_of(pairs_[i], pos, a, b, m);
    });
}

void RigidSolver::build_found(const rigid_detail::FoundList& list, std::uint32_t first, const std::vector<std::uint32_t>& place,
                              const std::vector<Vec3>& pos) {
    rigid_detail::ReciprocalMemo memo;
    for (const Found& f : list) {
        const BodyPair& pair = pairs_[f.pair];
        const bool swapped = shape_[pair.a] == Shape::Box && shape_[pair.b] != Shape::Box;
        build_points(swapped ? pair.b : pair.a, swapped ? pair.a : pair.b, f.m, pos, points_.data() + place[first++], memo);
    }
}

void RigidSolver::solve(const std::vector<ContactImpulse>& impulses) {
    // One branch a step when off (sim/rigid_solver_angular_friction.cpp has the other loop).
    if (spin_roll_) {
        solve_with_angular(impulses);
        return;
    }
    if (warm_) warm_start(impulses, AllPoints{});
    for (int i = 0; i < iterations_; ++i) solve_pass(bodies_, i, AllPoints{});
}

void RigidSolver::solve_point(Point& p, Bodies& bodies, BodyId only, bool shock, Rows rows) {
    solve_one(p, bodies, only, shock, rows);
}

// The iterations' common case (no warm start, no block solver): each point's normal and
// friction rows with every body moving, solve_one() inlined into the loop, so the call and the
// tests of `only`, `shock` and `rows` are gone (the same operations in the same order).
void RigidSolver::solve_run(Point* begin, Point* end, Bodies& bodies) {
    for (Point* p = begin; p != end; ++p) solve_one(*p, bodies, kEveryBody, false, Rows::Both);
}

[[gnu::always_inline]] inline void RigidSolver::solve_one(Point& p, Bodies& bodies, BodyId only, bool shock, Rows rows) {
    // Effective masses as if only `only` moved (shock pass), else the pair's.
    Fixed mn = p.row[0].mass, m1 = p.row[1].mass, m2 = p.row[2].mass;
    if (only != kEveryBody) {
        const auto single = [&](const Row& r) {
            const Fixed k = inv_mass_[only] + (only == p.a ? dot(r.ca, r.ia) : dot(r.cb, r.ib));
            return k.raw > 0 ? reciprocal(k) : Fixed::zero();
        };
        mn = single(p.row[0]);
        m1 = single(p.row[1]);
        m2 = single(p.row[2]);
    }
    // Normal: accumulated impulse stays >= 0 (contacts push, never pull). The shock pass only
    // adds impulse (it never takes back what the iterations gave).
    // The relative velocity, taken again for friction only when the normal impulse changed it
    // or a component saturated (so the overflow count is what two subtractions give).
    bool dv_exact = true;
    const auto relative = [&] {
        const Vec3& vb = bodies[p.sb].v;
        const Vec3& va = bodies[p.sa].v;
        const auto sub = [&](Fixed x, Fixed y) {
            std::int64_t r;
            if (sub_overflow(x.raw, y.raw, &r)) {
                dv_exact = false;
                return x - y;
            }
            return Fixed::from_raw(r);
        };
        return Vec3{sub(vb.x, va.x), sub(vb.y, va.y), sub(vb.z, va.z)};
    };
    Vec3 dv = relative();
    bool dv_stale = false;
    if (rows != Rows::Friction) {
        const Fixed vn = row_speed(p, 0, dv, bodies);
        const Fixed floor = shock ? p.pn : Fixed::zero();
        const Fixed pn = max(p.pn + mn * (p.target - vn), floor);
        const Fixed dpn = pn - p.pn;
        p.pn = pn;
        if (dpn.raw != 0) {
            apply_normal(p, dpn, bodies, only);
            dv_stale = true;
        }
    }
    if (rows == Rows::Normal) return;
    if (p.pn.raw == 0 && p.pt1.raw == 0 && p.pt2.raw == 0) return;
    if (rows != Rows::Friction && (dv_stale || !dv_exact)) {
        const Vec3& vb = bodies[p.sb].v;
        const Vec3& va = bodies[p.sa].v;
        dv = {vb.x - va.x, vb.y - va.y, vb.z - va.z};
    }
    // Friction on the tangent plane, clamped to the cone: stick within mu_s pn, slide at mu_k pn.
    Fixed t1 = p.pt1 - m1 * row_speed(p, 1, dv, bodies);
    Fixed t2 = p.pt2 - m2 * row_speed(p, 2, dv, bodies);
    rigid_detail::clamp_to_cone(t1, t2, p.pn, p.mu_s, p.mu_k);
    const Fixed d1 = t1 - p.pt1, d2 = t2 - p.pt2;
    p.pt1 = t1;
    p.pt2 = t2;
    if (d1.raw != 0 || d2.raw != 0) apply_friction(p, d1, d2, bodies, only);
}

ContactImpulse RigidSolver::key_of(const Point& p) const {
    ContactImpulse k;
    const bool a_moves = inv_mass_[p.a].raw != 0;
    k.body = a_moves ? p.a : p.b;
    k.other = a_moves ? p.b : p.a;
    k.feature = p.feature;
    return k;
}

void RigidSolver::keep_impulses(std::vector<ContactImpulse>& impulses) const {
    impulses.clear();
    for (const Point& p : points_) {
        if (p.pn.raw == 0 && p.pt1.raw == 0 && p.pt2.raw == 0) continue;
        ContactImpulse k = key_of(p);
        k.pn = p.pn;
        k.pt1 = p.pt1;
        k.pt2 = p.pt2;
        impulses.push_back(k);
    }
    // Keys are unique (one manifold per pair, feature ids unique in it); a stable sort keeps the
    // result a function of the points' order even if two ever were not, on every library.
    if (!std::is_sorted(impulses.begin(), impulses.end(), key_less))
        std::stable_sort(impulses.begin(), impulses.end(), key_less);
    if (impulses.size() > impulse_capacity_) impulses.resize(impulse_capacity_);
}

void RigidSolver::solve_block(std::size_t m, Bodies& bodies, bool pseudo) {
    const std::uint32_t begin = manifold_start_[m], end = manifold_start_[m + 1];
    for (int sweep = 0; sweep < kBlockSweeps; ++sweep) {
        bool changed = false;
        for (std::uint32_t j = 0; j < end - begin; ++j) {
            Point& p = points_[sweep & 1 ? end - 1 - j : begin + j];
            const Fixed before = pseudo ? p.pb : p.pn;
            if (pseudo)
                solve_pseudo(p);
            else
                solve_point(p, bodies, kEveryBody, false, Rows::Normal);
            changed = changed || (pseudo ? p.pb : p.pn) != before;
        }
        if (!changed || end - begin == 1) return;
    }
}

void RigidSolver::shock_pass() {
    // Levels: distance in the contact graph (touching points) from a static body.
    constexpr std::uint32_t kUnreached = ~std::uint32_t{0};
    const std::size_t n = shape_.size();
    adj_start_.assign(n + 1, 0);
    order_.clear();
    for (std::uint32_t k = 0; k < points_.size(); ++k) {
        if (points_[k].pn.raw == 0) continue;  // not pressing: no support to propagate
        order_.push_back(k);
        ++adj_start_[points_[k].a + 1];
        ++adj_start_[points_[k].b + 1];
    }
    for (std::size_t i = 1; i <= n; ++i) adj_start_[i] += adj_start_[i - 1];
    adj_.resize(adj_start_[n]);
    cursor_.assign(adj_start_.begin(), adj_start_.end() - 1);
    for (std::uint32_t k : order_) {
        adj_[cursor_[points_[k].a]++] = points_[k].b;
        adj_[cursor_[points_[k].b]++] = points_[k].a;
    }
    level_.assign(n, kUnreached);
    queue_.clear();
    for (std::size_t id = 0; id < n; ++id)
        if (inv_mass_[id].raw == 0) {
            level_[id] = 0;
            queue_.push_back(static_cast<BodyId>(id));
        }
    for (std::size_t q = 0; q < queue_.size(); ++q) {
        const BodyId u = queue_[q];
        for (std::uint32_t j = adj_start_[u]; j < adj_start_[u + 1]; ++j) {
            const BodyId v = adj_[j];
            if (level_[v] != kUnreached) continue;
            level_[v] = level_[u] + 1;
            queue_.push_back(v);
        }
    }
    const auto low = [&](std::uint32_t k) { return std::min(level_[points_[k].a], level_[points_[k].b]); };
    std::stable_sort(order_.begin(), order_.end(), [&](std::uint32_t x, std::uint32_t y) { return low(x) < low(y); });
    for (std::uint32_t k : order_) {
        Point& p = points_[k];
        const std::uint32_t la = level_[p.a], lb = level_[p.b];
        if (la == lb) continue;  // same level (or both unreached): no up and down
        solve_point(p, bodies_, la < lb ? p.b : p.a, true);
    }
}

void RigidSolver::solve_pseudo(Point& p) {
    const Fixed pb = max(p.pb + p.row[0].mass * (p.bias - row_speed(p, 0, pseudo_[p.sb].v - pseudo_[p.sa].v, pseudo_)), Fixed::zero());
    const Fixed d = pb - p.pb;
    if (d.raw == 0) return;
    p.pb = pb;
    apply_normal(p, d, pseudo_, kEveryBody);
}

void RigidSolver::split_passes(const ParallelTasks& tasks) {
    pseudo_.resize(bodies_.size());
    for (std::size_t k = 0; k < bodies_.size(); ++k) pseudo_[k] = {Vec3{}, Vec3{}, bodies_[k].inv_mass, bodies_[k].iso_inv_inertia};
    // Nothing overlaps beyond slop: no pseudo motion.
    if (std::none_of(points_.begin(), points_.end(), [](const Point& p) { return p.bias.raw > 0; })) return;
    if (colour_)
        split_coloured(tasks);
    else if (tasks.parallel())
        split_islands(tasks);
    else
        split_iterations(AllPoints{});
}

}  // namespace lockroll::sim
