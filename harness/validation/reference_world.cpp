#include "harness/validation/reference_world.h"

#include <cmath>
#include <stdexcept>

namespace lockroll::sim {

double NumberTraits<double>::from_fixed(Fixed f) { return std::ldexp(static_cast<double>(f.raw), -Fixed::kFracBits); }
double NumberTraits<double>::sqrt_wide(double w) { return std::sqrt(w); }

}  // namespace lockroll::sim

namespace lockroll::harness {

namespace {
const sim::SceneDesc& checked(const sim::SceneDesc& scene) {
    if (const std::string err = sim::validate(scene); !err.empty()) throw std::invalid_argument(err);
    if (sim::player_count(scene) != 0)
        throw std::invalid_argument("the double reference does not run player bodies (scene " + scene.name + ")");
    return scene;
}

// Nearest Q32.32 value, saturating: only used to find candidate pairs.
sim::Fixed to_fixed(double v) {
    const double r = std::nearbyint(std::ldexp(v, sim::Fixed::kFracBits));
    if (!(r > -9.2e18)) return sim::Fixed::min();
    if (r > 9.2e18) return sim::Fixed::max();
    return sim::Fixed::from_raw(static_cast<std::int64_t>(r));
}
sim::Vec3 to_fixed(const DVec3& v) { return {to_fixed(v.x), to_fixed(v.y), to_fixed(v.z)}; }
}  // namespace

ReferenceWorld::ReferenceWorld(const sim::SceneDesc& scene) : scene_(checked(scene)), kernel_(scene_) {
    kernel_.initial_state(scene_, pos_, vel_);
    shadow_.resize(pos_.size());
    extent_.resize(pos_.size());
    for (std::size_t i = 0; i < pos_.size(); ++i) {
        shadow_[i] = to_fixed(pos_[i]);
        extent_[i] = to_fixed(kernel_.extent()[i]);
    }
    broadphase_.configure(scene_.broadphase, kernel_.dynamic_ids(), kernel_.static_ids(), shadow_, extent_,
                          scene_.contact_margin);
}

void ReferenceWorld::step() {
    kernel_.step(
        pos_, vel_,
        [this](const std::vector<DVec3>& pos, std::vector<sim::BodyPair>& out) {
            for (std::size_t i = 0; i < pos.size(); ++i) shadow_[i] = to_fixed(pos[i]);
            broadphase_.find_pairs(shadow_, extent_, out);
        },
        [](std::vector<DVec3>&) {});
    ++frame_;
}

}  // namespace lockroll::harness
