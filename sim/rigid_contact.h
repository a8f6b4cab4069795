// Narrowphase for rotating bodies: contact manifolds with points, so impulses create torque.
//
// Contract
//  - Colliders are given in world space: centre, rotation matrix (sim/vec3.h rotation()) and
//    shape size. A capsule's core segment lies along its local y axis; a box is oriented.
//  - contact_points() fills a manifold of up to kMaxManifold points when the colliders are
//    closer than `margin` (speculative contacts: a point may have a negative depth, a gap, so
//    the solver can stop a body exactly at the surface within the step). Each point carries its
//    own unit normal from A to B, its world position and its depth (> 0 overlapping).
//  - Routines: round-round (closest points of two core segments, then spheres); sphere-box
//    (exact against the oriented box); capsule-box (exact: the core segment's closest point to
//    the box; touching a face, the segment clipped to that face gives up to two points, so a
//    capsule lying along a face has one at each end of the part over it; touching an edge or
//    corner, one point; a segment inside the box by the separating axes); box-box
//    (separating-axis test over 15 axes; a face axis gives the incident face clipped to the
//    reference face, up to 8 points, an edge axis one point between the two edges).
//  - Each point has a feature id (unique in its manifold, stable while the touching features
//    are): warm starting carries impulses by it.
//  - Deterministic: a fixed order of points, integer arithmetic only.
#pragma once

#include "sim/scene.h"
#include "sim/vec3.h"

namespace lockroll::sim {

inline constexpr int kMaxManifold = 8;

// Feature ids: what made a point, stable while the geometry is (the solver matches warm-start
// impulses by them). Round-round and sphere-box: 0. Capsule-box: 8 f + c for a face contact
// (f the box face 0..5, c the segment end 0/1 or the face's side plane 2..5 that cut the
// segment there), kFeatureEdge + 0..26 for an edge or corner of the box (rigid_contact.cpp).
// Box-box face contacts: 0..35 for the clipped incident face, plus kFeatureFlipped when B's
// face is the reference; edge-edge: kFeatureEdge + 3 i + j for edge i of A and j of B.
inline constexpr std::uint8_t kFeatureFlipped = 64, kFeatureEdge = 128;

struct ContactPoint {
    Vec3 normal;  // unit, from A to B
    Vec3 point;   // world position where the impulse acts
    Fixed depth;  // > 0 overlap; <= 0 a gap within the margin
    std::uint8_t feature = 0;  // unique within a manifold
};

struct Manifold {
    int count = 0;
    ContactPoint points[kMaxManifold];
};

struct OrientedCollider {
    Shape shape = Shape::Sphere;
    Vec3 center;
    const Mat3* rot = nullptr;  // body to world
    Fixed radius;               // sphere, capsule
    Fixed core_half;            // capsule
    Vec3 half;                  // box
};

// Fills m (m.count = 0 when apart). A and B may be any shapes; the normal always points A to B.
void contact_points(const OrientedCollider& a, const OrientedCollider& b, Fixed margin, Manifold& m);

// Two boxes as contact_points() does them, but with every edge axis of the separating-axis
// test normalised and tested (contact_points() skips them when a cheaper bound shows none can
// matter) and every clip of the incident face written out. The same manifold, bit for bit:
// for tests.
void box_box_exhaustive(const OrientedCollider& a, const OrientedCollider& b, Fixed margin, Manifold& m);

// contact_points() with every shortcut off (those of box_box_exhaustive(), and a capsule against
// an unturned box through its rotation's products). The same manifold, bit for bit: for tests.
void contact_points_general(const OrientedCollider& a, const OrientedCollider& b, Fixed margin, Manifold& m);

// A face axis's projected radius in box_box(): h.x |c0| + h.y |c1| + h.z |c2| (h the other box's
// half sizes, c its axes' cosines with the axis), each product rounded once, summed. Its shortcut
// for small sizes and cosines gives these bits without the 128-bit products: for tests.
Fixed face_axis_radius(const Vec3& h, Fixed c0, Fixed c1, Fixed c2);

// Point against an oriented box: closest point, unit normal from the point toward the box
// surface (out of the box through the nearest face when the point is inside), and the signed
// distance (negative inside). Returns false when the point is farther than `reach`.
bool point_box(const Vec3& p, const OrientedCollider& box, Fixed reach, Vec3& normal, Vec3& surface, Fixed& distance);

}  // namespace lockroll::sim
