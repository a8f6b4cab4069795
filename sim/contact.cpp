// The narrowphase is a set of templates (sim/contact.h); sim/ instantiates them for Fixed here
// once, so a mistake in them fails the core's own build, not only its users'.
#include "sim/contact.h"

namespace lockroll::sim {

template bool collide<Fixed>(const RoundCollider&, const RoundCollider&, Contact&);
template bool collide<Fixed>(const RoundCollider&, const BoxCollider&, Contact&);
template bool collide<Fixed>(const BoxCollider&, const BoxCollider&, Contact&);
template Fixed separation<Fixed>(const RoundCollider&, const RoundCollider&, Vec3&);
template Fixed separation<Fixed>(const RoundCollider&, const BoxCollider&, Vec3&);
template Fixed separation<Fixed>(const BoxCollider&, const BoxCollider&, Vec3&);
template Fixed separation<Fixed>(const BoxCollider&, const RoundCollider&, Vec3&);

}  // namespace lockroll::sim
