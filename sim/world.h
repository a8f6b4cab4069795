// The deterministic physics world: fixed-point bodies in a structure of arrays, stepped at a
// fixed dt. Bit-exact: the same scene and the same inputs give the same bytes on every
// compiler and CPU (see tests/sim/golden_test.cpp and scripts/cross-check.sh).
//
// Body ids are indices into SceneDesc::bodies, stable for the world's life; they are what
// desync reports, snapshots and the harness name. Static bodies (mass 0) never move and are
// not part of the snapshot.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "sim/broadphase.h"
#include "sim/controller.h"
#include "sim/input.h"
#include "sim/scene.h"

namespace lockroll::sim {

class World {
public:
    // The scene must pass validate(); throws std::invalid_argument with validate()'s message
    // otherwise (a programming error: loaders validate and report first).
    explicit World(const SceneDesc& scene);

    // Advances one frame. inputs[p] drives player slot p; slots beyond inputs.size() get a
    // neutral input. Never allocates after the first step.
    void step(std::span<const PlayerInput> inputs);

    std::uint32_t frame() const { return frame_; }
    // Operations that saturated since the world was created (part of state and checksum).
    std::uint64_t overflow_count() const { return overflow_count_; }

    std::size_t body_count() const { return pos_.size(); }
    std::size_t dynamic_count() const { return dynamic_.size(); }
    int player_count() const { return static_cast<int>(player_body_.size()); }
    BodyId player_body(int slot) const { return player_body_[static_cast<std::size_t>(slot)]; }
    bool is_static(BodyId id) const { return inv_mass_[id].raw == 0; }
    Shape shape(BodyId id) const { return shape_[id]; }
    const Vec3& position(BodyId id) const { return pos_[id]; }
    const Vec3& velocity(BodyId id) const { return vel_[id]; }
    Fixed inv_mass(BodyId id) const { return inv_mass_[id]; }
    Fixed dt() const { return dt_; }
    const std::vector<BodyId>& dynamic_ids() const { return dynamic_; }
    const SceneDesc& scene() const { return scene_; }

    // Fault injection for desync tests: flips one bit of one state word of a dynamic body.
    // field: 0..2 position x/y/z, 3..5 velocity x/y/z.
    void flip_bit(BodyId id, int field, int bit);

private:
    friend class SnapshotAccess;

    void apply_controller(std::span<const PlayerInput> inputs);
    void solve_contacts();

    SceneDesc scene_;
    Fixed dt_;

    // Mutable state (exactly what a snapshot stores).
    std::uint32_t frame_ = 0;
    std::uint64_t overflow_count_ = 0;
    std::vector<Vec3> pos_, vel_;

    // Immutable per-body data (never snapshotted).
    std::vector<Shape> shape_;
    std::vector<Vec3> extent_;       // AABB half size of the body (core + radius)
    std::vector<Fixed> radius_;      // sweep radius (0 for boxes)
    std::vector<Fixed> core_half_;   // capsule core half-height (0 otherwise)
    std::vector<Vec3> half_extents_; // boxes
    std::vector<Fixed> inv_mass_;
    std::vector<Vec3> gravity_dv_;   // gravity * gravity_scale * dt, precomputed
    std::vector<Fixed> restitution_; // per-body override, or -1 for "use the table"
    std::vector<BodyId> dynamic_;    // ids of dynamic bodies, ascending
    std::vector<BodyId> static_;     // ids of static bodies, ascending
    std::vector<BodyId> player_body_;  // by player slot

    ControllerFactors controller_;  // used only when the scene has players

    // A candidate pair prepared once per step: ordered (round before box), its narrowphase
    // routine, and the mass terms the solver would otherwise divide for in every iteration.
    enum class PairKind : std::uint8_t { RoundRound, RoundBox, BoxBox };
    struct SolverPair {
        BodyId a, b;
        PairKind kind;
        bool b_static;       // then the whole correction and impulse go to a (no division)
        Fixed one_plus_e;    // 1 + restitution
        Fixed inv_sum_recip; // 1 / (1/m_a + 1/m_b), when both are dynamic
    };
    void prepare_pairs();

    Broadphase broadphase_;
    std::vector<BodyPair> pairs_;
    std::vector<SolverPair> solver_pairs_;
};

}  // namespace lockroll::sim
