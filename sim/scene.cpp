#include "sim/scene.h"

#include <set>
#include <unordered_map>

#include "sim/rng.h"

namespace lockroll::sim {

const char* shape_name(Shape s) {
    switch (s) {
        case Shape::Sphere: return "sphere";
        case Shape::Box: return "box";
        case Shape::Capsule: return "capsule";
    }
    return "?";
}

bool SolverDesc::is_default() const {
    const SolverDesc d;
    return substeps == d.substeps && integrator == d.integrator && correction == d.correction && slop == d.slop &&
           max_push_speed == d.max_push_speed && restitution_threshold == d.restitution_threshold &&
           restitution_after == d.restitution_after && position_based == d.position_based &&
           shock_propagation == d.shock_propagation &&
           continuous == d.continuous;
}

RigidDesc::RigidDesc() {
    // 0.5 for every pair: a middle value (wood on wood is 0.3..0.5, rubber on concrete ~0.8).
    for (int a = 0; a < kShapeCount; ++a)
        for (int b = 0; b < kShapeCount; ++b) friction[a][b] = static_friction[a][b] = Fixed::ratio(1, 2);
}

SceneDesc::SceneDesc() {
    // The seed paper's custom engine: box-box 0 (inelastic), sphere-sphere 1 (elastic),
    // box-sphere 0.8. Capsules (player bodies in the Quantum build) behave like boxes.
    const Fixed e08 = Fixed::ratio(4, 5);
    const auto S = static_cast<int>(Shape::Sphere), B = static_cast<int>(Shape::Box),
               C = static_cast<int>(Shape::Capsule);
    restitution[S][S] = Fixed::one();
    restitution[B][B] = restitution[C][C] = restitution[B][C] = restitution[C][B] = Fixed::zero();
    restitution[S][B] = restitution[B][S] = restitution[S][C] = restitution[C][S] = e08;
}

void add_room(SceneDesc& scene, const Vec3& lo, const Vec3& hi, Fixed t) {
    const Fixed two = Fixed::from_int(2);
    const Vec3 c{(lo.x + hi.x) / two, (lo.y + hi.y) / two, (lo.z + hi.z) / two};
    const Vec3 h{(hi.x - lo.x) / two, (hi.y - lo.y) / two, (hi.z - lo.z) / two};
    const Fixed ht = t / two;
    auto wall = [&](Vec3 center, Vec3 half) {
        BodyDesc b;
        b.shape = Shape::Box;
        b.position = center;
        b.half_extents = half;
        b.mass = Fixed::zero();
        scene.bodies.push_back(b);
    };
    // Walls overlap at the edges (each spans the full outer extent) so no corner gap exists.
    const Vec3 outer{h.x + t, h.y + t, h.z + t};
    wall({c.x, lo.y - ht, c.z}, {outer.x, ht, outer.z});  // floor
    wall({c.x, hi.y + ht, c.z}, {outer.x, ht, outer.z});  // ceiling
    wall({lo.x - ht, c.y, c.z}, {ht, outer.y, outer.z});  // -x
    wall({hi.x + ht, c.y, c.z}, {ht, outer.y, outer.z});  // +x
    wall({c.x, c.y, lo.z - ht}, {outer.x, outer.y, ht});  // -z
    wall({c.x, c.y, hi.z + ht}, {outer.x, outer.y, ht});  // +z
}

namespace {
Fixed uniform(SplitMix64& rng, Fixed lo, Fixed hi) {
    if (hi.raw <= lo.raw) return lo;
    const auto span = static_cast<std::uint64_t>(hi.raw) - static_cast<std::uint64_t>(lo.raw);
    return Fixed::from_raw(lo.raw + static_cast<std::int64_t>(rng.below(span + 1)));
}

Fixed bounding_radius(const SpawnerDesc& s) {
    switch (s.shape) {
        case Shape::Sphere: return s.radius;
        case Shape::Capsule: return s.radius + s.half_height;
        case Shape::Box: return max(max(s.half_extents.x, s.half_extents.y), s.half_extents.z);
    }
    return s.radius;
}
}  // namespace

void expand_spawner(SceneDesc& scene, const SpawnerDesc& s) {
    SplitMix64 rng(s.seed);
    const Fixed r = bounding_radius(s);
    const Fixed reach = r + r;
    const u128 reach_sq = static_cast<u128>(mul_wide(reach.raw, reach.raw));
    // Accepted positions bucketed by cells of edge >= 2r, so the overlap test looks at 27
    // cells instead of every earlier body. Whether a spot is clear is an AND over neighbours,
    // independent of the map's iteration order, so the result stays deterministic.
    int shift = 0;
    while (shift < 62 && (std::int64_t{1} << shift) < reach.raw) ++shift;
    auto cell_key = [&](std::int64_t cx, std::int64_t cy, std::int64_t cz) {
        return (static_cast<std::uint64_t>(cx) * 0x9E3779B97F4A7C15ull) ^
               (static_cast<std::uint64_t>(cy) * 0xC2B2AE3D27D4EB4Full) ^ (static_cast<std::uint64_t>(cz) * 0x165667B1ull);
    };
    std::unordered_map<std::uint64_t, std::vector<Vec3>> cells;
    if (s.count > 0) cells.reserve(static_cast<std::size_t>(s.count));
    std::int64_t crowded = 0;  // bodies so far for which every try overlapped
    scene.bodies.reserve(scene.bodies.size() + static_cast<std::size_t>(s.count > 0 ? s.count : 0));
    for (int n = 0; n < s.count; ++n) {
        BodyDesc b;
        b.shape = s.shape;
        b.radius = s.radius;
        b.half_extents = s.half_extents;
        b.half_height = s.half_height;
        b.mass = s.mass;
        b.gravity_scale = s.gravity_scale;
        b.restitution = s.restitution;
        b.friction = s.friction;
        b.static_friction = s.static_friction;
        // A full region: stop searching for free spots (see kSpawnCrowdedLimit).
        const int tries = crowded >= kSpawnCrowdedLimit ? 1 : kSpawnTries;
        for (int attempt = 0; attempt < tries; ++attempt) {
            b.position = {uniform(rng, s.region_min.x + r, s.region_max.x - r),
                          uniform(rng, s.region_min.y + r, s.region_max.y - r),
                          uniform(rng, s.region_min.z + r, s.region_max.z - r)};
            if (tries == 1) break;
            const std::int64_t cx = b.position.x.raw >> shift, cy = b.position.y.raw >> shift,
                               cz = b.position.z.raw >> shift;
            bool clear = true;
            for (int dz = -1; dz <= 1 && clear; ++dz)
                for (int dy = -1; dy <= 1 && clear; ++dy)
                    for (int dx = -1; dx <= 1 && clear; ++dx) {
                        auto it = cells.find(cell_key(cx + dx, cy + dy, cz + dz));
                        if (it == cells.end()) continue;
                        for (const Vec3& other : it->second)
                            if (length_sq_wide(other - b.position) < reach_sq) { clear = false; break; }
                    }
            if (clear || attempt + 1 == kSpawnTries) {
                if (!clear) ++crowded;
                auto& cell = cells[cell_key(cx, cy, cz)];
                if (cell.size() < kSpawnCellLimit) cell.push_back(b.position);
                break;
            }
        }
        b.velocity = {uniform(rng, -s.max_speed, s.max_speed), uniform(rng, -s.max_speed, s.max_speed),
                      uniform(rng, -s.max_speed, s.max_speed)};
        scene.bodies.push_back(b);
    }
}

int player_count(const SceneDesc& scene) {
    int n = 0;
    for (const auto& b : scene.bodies) n = b.player + 1 > n ? b.player + 1 : n;
    return n;
}

std::string validate(const SceneDesc& scene) {
    if (scene.tick_rate < 1 || scene.tick_rate > 1000) return "tick_rate must be 1..1000";
    if (scene.iterations < 1 || scene.iterations > 64) return "iterations must be 1..64";
    if (scene.contact_margin.raw < 0) return "contact_margin must be >= 0";
    const SolverDesc& sv = scene.solver;
    if (sv.substeps < 1 || sv.substeps > 64) return "solver.substeps must be 1..64";
    if (static_cast<std::int64_t>(scene.tick_rate) * sv.substeps > 100000)
        return "tick_rate * solver.substeps must be at most 100000";
    if (sv.correction.raw <= 0 || sv.correction > Fixed::one()) return "solver.correction must be within (0, 1]";
    if (sv.slop.raw < 0) return "solver.slop must be >= 0";
    if (sv.max_push_speed.raw < 0) return "solver.max_push_speed must be >= 0";
    if (sv.shock_propagation && sv.slop.raw <= 0)
        return "solver.shock_propagation needs solver.slop > 0 (resting contacts must stay touching to be ordered)";
    if (sv.restitution_threshold.raw < 0) return "solver.restitution_threshold must be >= 0";
    if (sv.continuous_min_speed.raw < 0) return "solver.continuous_min_speed must be >= 0";
    for (int a = 0; a < kShapeCount; ++a)
        for (int b = 0; b < kShapeCount; ++b)
            if (scene.restitution[a][b].raw < 0 || scene.restitution[a][b] > Fixed::one())
                return "restitution must be within [0, 1]";
    const RigidDesc& rg = scene.rigid;
    if (rg.enabled) {
        if (!sv.is_default()) return "rigid scenes use their own solver: drop the \"solver\" settings";
        for (int a = 0; a < kShapeCount; ++a)
            for (int b = 0; b < kShapeCount; ++b)
                if (rg.friction[a][b].raw < 0 || rg.static_friction[a][b].raw < 0 ||
                    rg.friction[a][b] > Fixed::from_int(10) || rg.static_friction[a][b] > Fixed::from_int(10))
                    return "rigid.friction and rigid.static_friction must be within [0, 10]";
        if (rg.linear_damping.raw < 0 || rg.angular_damping.raw < 0) return "rigid damping must be >= 0";
        if (rg.baumgarte.raw < 0 || rg.baumgarte > Fixed::one()) return "rigid.baumgarte must be within [0, 1]";
        if (rg.slop.raw < 0) return "rigid.slop must be >= 0";
        if (rg.restitution_threshold.raw < 0) return "rigid.restitution_threshold must be >= 0";
        const RigidDesc::Sleeping& sl = rg.sleeping;
        if (sl.linear_speed.raw <= 0 || sl.linear_speed > Fixed::from_int(100))
            return "rigid.sleeping.linear_speed must be within (0, 100]";
        if (sl.angular_speed.raw <= 0 || sl.angular_speed > Fixed::from_int(100))
            return "rigid.sleeping.angular_speed must be within (0, 100]";
        if (sl.time.raw <= 0 || sl.time > Fixed::from_int(60)) return "rigid.sleeping.time must be within (0, 60]";
        if (rg.spinning_friction.raw < 0 || rg.spinning_friction > Fixed::one())
            return "rigid.spinning_friction must be within [0, 1] (metres)";
        if (rg.rolling_friction.raw < 0 || rg.rolling_friction > Fixed::one())
            return "rigid.rolling_friction must be within [0, 1] (metres)";
    }
    std::set<int> slots;
    for (std::size_t i = 0; i < scene.bodies.size(); ++i) {
        const BodyDesc& b = scene.bodies[i];
        const std::string at = "body " + std::to_string(i) + ": ";
        if (b.mass.raw < 0) return at + "mass must be >= 0";
        switch (b.shape) {
            case Shape::Sphere:
                if (b.radius.raw <= 0) return at + "radius must be > 0";
                break;
            case Shape::Capsule:
                if (b.radius.raw <= 0) return at + "radius must be > 0";
                if (b.half_height.raw < 0) return at + "half_height must be >= 0";
                break;
            case Shape::Box:
                if (b.half_extents.x.raw <= 0 || b.half_extents.y.raw <= 0 || b.half_extents.z.raw <= 0)
                    return at + "half_extents must all be > 0";
                break;
        }
        if (b.restitution && (b.restitution->raw < 0 || *b.restitution > Fixed::one()))
            return at + "restitution must be within [0, 1]";
        const Quat identity;
        // (Friction and damping overrides are simply unused by the particle solver.)
        if (!rg.enabled && (b.orientation != identity || b.angular_velocity != Vec3{}))
            return at + "orientation and angular_velocity need a rigid scene (\"rigid\")";
        for (const Fixed c : {b.orientation.w, b.orientation.x, b.orientation.y, b.orientation.z})
            if (c < -Fixed::one() || c > Fixed::one()) return at + "orientation components must be within [-1, 1]";
        if (b.orientation == Quat{Fixed::zero(), Fixed::zero(), Fixed::zero(), Fixed::zero()})
            return at + "orientation must not be zero";
        for (const auto& o : {b.friction, b.static_friction})
            if (o && (o->raw < 0 || *o > Fixed::from_int(10))) return at + "friction must be within [0, 10]";
        for (const auto& o : {b.linear_damping, b.angular_damping})
            if (o && o->raw < 0) return at + "damping must be >= 0";
        if (b.player >= 0) {
            if (b.mass.raw == 0) return at + "a player body must be dynamic (mass > 0)";
            if (!slots.insert(b.player).second) return at + "player slot " + std::to_string(b.player) + " is used twice";
        } else if (b.player < -1) {
            return at + "player must be >= 0";
        }
    }
    int expect = 0;
    for (int s : slots)
        if (s != expect++) return "player slots must be numbered 0..P-1 without gaps";
    return {};
}

}  // namespace lockroll::sim
