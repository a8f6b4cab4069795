// Snapshots and checksums of a World's mutable state.
//
// Contract
//  - What is stored: the frame number, the overflow counter, and position and velocity of every
//    dynamic body in ascending id order; in a rigid scene (SceneDesc::rigid) also each body's
//    orientation and angular velocity. Nothing else changes during a step, so nothing else is
//    stored: static bodies, shapes, masses, materials and the scene are the World's immutable
//    part and must match between saver and loader (same scene => same dynamic count).
//  - Layout (canonical, identical on every platform; docs/snapshot-format.md):
//      u32 magic "LRS1" | u32 dynamic_count | u32 frame | u32 layout | u64 overflow_count
//      then per dynamic body: i64 pos.x, pos.y, pos.z, vel.x, vel.y, vel.z
//      and, when layout is 1 (rigid): i32 orientation w, x, y, z (units of 2^-30: the grid
//      sim/vec3.h renormalised() keeps them on), i64 angular_velocity.x, y, z
//    and, when layout is 2 (rigid with rigid.warm_starting): the layout-1 bodies, then
//      u32 impulse_count, then per carried contact impulse (sim/rigid_solver.h ContactImpulse,
//      in key order): u32 body, u32 other, u8 feature, i64 pn, pt1, pt2 (33 bytes)
//    all little-endian, no padding: 24 + 48 (layout 0) or 88 (layouts 1, 2) bytes * dynamic_count
//    (+ 4 + 33 * impulse_count in layout 2: the only variable-size layout; its capacity is
//    snapshot_capacity(), with at most kImpulsesPerBody impulses per dynamic body).
//    Layout 0 is exactly the format before rigid bodies (the word was reserved, always 0), so
//    particle scenes keep their bytes and checksums.
//    A rigid scene with rigid.sleeping sets kLayoutSleeping (0x100) in the layout word (257 or
//    258), and each body's bytes end with one more word: u32 sleep (World::sleep_state(): the
//    frames it has been still, at most the scene's frames to sleep, or 0xFFFFFFFF asleep), 92
//    bytes per body. Scenes without sleeping keep their bytes and checksums.
//    Loading rejects a sleep word above the frames to sleep that is not asleep, a sleeping
//    player body, and a sleeping body with a non-zero velocity or angular velocity.
//  - When: between steps, at any time; saving never changes the world.
//  - Size: snapshot_size(world) bytes now, at most snapshot_capacity(world) (layout 2 grows and
//    shrinks with the carried impulses); the caller owns the buffer (a rollback ring buffer
//    allocates the capacity once and reuses it).
//  - Fields: 6 per body (position, velocity), 13 in a rigid scene (+ orientation w/x/y/z and
//    angular_velocity x/y/z); snapshot_field() gives orientation as its Q32.32 raw value.
//  - Loading validates size, magic and body count before touching the world: on any failure
//    the world is unchanged and the error says what was wrong. Any int64 is a valid Fixed, so
//    there is nothing else to reject.
//  - Guarantee: save at frame f, load, step N frames == step N frames without saving, bit for
//    bit (the broadphase keeps only a sort-order cache whose result never depends on history).
//  - checksum(): XXH3-64 of exactly the snapshot bytes. body_hash(): XXH3-64 of one body's 48
//    (88) bytes, seeded with its id, for narrowing a desync to one body; in layout 2 the hash
//    then continues over the body's carried impulses (the entries whose `body` it is), so a
//    difference there names the body too.
#pragma once

#include <cstdint>
#include <span>
#include <string>

#include "sim/world.h"

namespace lockroll::sim {

inline constexpr std::uint32_t kSnapshotMagic = 0x3153524Cu;  // "LRS1" little-endian
inline constexpr std::size_t kSnapshotHeaderBytes = 24;
inline constexpr std::size_t kSnapshotBodyBytes = 48;
inline constexpr std::size_t kSnapshotRigidBodyBytes = 88;
inline constexpr std::size_t kSnapshotSleepBodyBytes = 92;  // rigid + the sleep word
inline constexpr std::size_t kSnapshotImpulseBytes = 33;
inline constexpr std::uint32_t kLayoutParticle = 0, kLayoutRigid = 1, kLayoutRigidWarm = 2;
inline constexpr std::uint32_t kLayoutSleeping = 0x100;  // a flag on layouts 1 and 2

// The state words of a body, in snapshot order; names for desync reports. Particle scenes have
// the first kParticleFields, rigid scenes kRigidFields, rigid scenes with sleeping all
// kSleepFields (field 13, "sleep", is the sleep word as an unsigned value).
inline constexpr int kParticleFields = 6, kRigidFields = 13, kSleepFields = 14;
inline constexpr const char* kBodyFieldNames[kSleepFields] = {
    "position.x",    "position.y",    "position.z",    "velocity.x",         "velocity.y",
    "velocity.z",    "orientation.w", "orientation.x", "orientation.y",      "orientation.z",
    "angular_velocity.x", "angular_velocity.y", "angular_velocity.z", "sleep"};

// Bytes and fields per body in this world's snapshots.
std::size_t snapshot_body_bytes(const World& world);
int body_field_count(const World& world);
// Bytes per body of a snapshot, from its header's layout word (48 when too short to say).
std::size_t snapshot_body_bytes(std::span<const std::uint8_t> snapshot);

// Bytes of this world's snapshot now, and the most it can take (equal unless the layout is 2).
std::size_t snapshot_size(const World& world);
std::size_t snapshot_capacity(const World& world);

// Writes exactly snapshot_size(world) bytes; `out` must be at least that large (checked: a
// short buffer throws std::length_error and writes nothing).
void save(const World& world, std::span<std::uint8_t> out);

// Empty string on success; otherwise what was wrong, and the world is unchanged.
std::string load(World& world, std::span<const std::uint8_t> in);

std::uint64_t checksum(const World& world);
std::uint64_t body_hash(const World& world, BodyId id);
// body_hash() of the body at `index` (dynamic-id order) of a saved snapshot of `world`'s scene.
std::uint64_t snapshot_body_hash(const World& world, std::span<const std::uint8_t> snapshot, std::size_t index);

// Reads body `index` (position in dynamic-id order) field `field` (0..5, or 0..12 in a rigid
// snapshot) out of a snapshot
// buffer; used to name the first differing field between two snapshots.
std::int64_t snapshot_field(std::span<const std::uint8_t> snapshot, std::size_t index, int field);

// Compares two snapshots of the same scene. Returns -1 when identical; otherwise the index (in
// dynamic-id order) of the first differing body, with its first differing field in *field
// (-1 when the difference is in the header, or past the bodies in layout 2's carried impulses:
// then the index is dynamic_count).
long first_difference(std::span<const std::uint8_t> a, std::span<const std::uint8_t> b, int* field);

}  // namespace lockroll::sim
