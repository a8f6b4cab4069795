// An allocator whose resize() leaves new elements uninitialised, for buffers that are written
// whole right after they grow (the rigid solver's contact points: sim/rigid_solver.h).
//
// Why: std::vector::resize value-initialises, and a type with default member initialisers
// (Fixed's raw = 0) is then zero-filled. The parallel contact generation sizes the whole
// points buffer (thousands of points of about 470 bytes each in a 10,000-body pile, several
// MB) on the stepping thread before the tasks write it, so every step paid a sequential
// memset of the lot (docs/performance.md, "Parallel step, third pass").
//
// Contract: T is an implicit-lifetime type (trivially copyable and destructible), so the
// storage operator new returns already holds its objects (C++20, P0593) and construct() with
// no arguments may leave their values indeterminate. The owner writes every member of an
// element before reading it. Construction with arguments (push_back, copies) is the ordinary
// placement new.
#pragma once

#include <memory>
#include <type_traits>
#include <utility>

namespace lockroll::sim {

template <class T>
class UninitializedAllocator : public std::allocator<T> {
public:
    using value_type = T;
    template <class U>
    struct rebind {
        using other = UninitializedAllocator<U>;
    };

    UninitializedAllocator() noexcept = default;
    template <class U>
    UninitializedAllocator(const UninitializedAllocator<U>&) noexcept {}

    template <class U>
    void construct(U*) noexcept {
        static_assert(std::is_trivially_copyable_v<U> && std::is_trivially_destructible_v<U>,
                      "UninitializedAllocator: only for implicit-lifetime types");
    }
    template <class U, class... Args>
    void construct(U* p, Args&&... args) {
        ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
    }
};

template <class T, class U>
bool operator==(const UninitializedAllocator<T>&, const UninitializedAllocator<U>&) noexcept {
    return true;
}

}  // namespace lockroll::sim
