// PartEffects: the hooks that the parts of a P2P session acting on the view and the streams --
// MembershipChanges (rollback/membership_changes.h) and AuthoredStreams
// (rollback/authored_streams.h) -- need alike from the rest of the session, declared once: an
// event, whether a peer is live, a slot's stream. MembershipEffects and AuthoringEffects extend it
// with the hooks that only one of them has. SessionImpl::Effects (rollback/session_effects.h)
// implements them all, and tests/rollback/fake_effects.h fakes them.
//
// Contract
//  - emit(): one event into the session's queue (SessionImpl::emit), with its typed reason.
//  - live_peer(): welcomed, not in error, and a running slot or a spectator; never this
//    session's own slot or its guests (SessionImpl::live_peer).
//  - stream(): a slot's stream as Sync holds it (its confirmed inputs and count).
//  - A virtual base: a class that implements several interfaces that extend it implements each
//    of these hooks once. Not deleted through (protected destructor).
#pragma once

#include <cstdint>
#include <string>

#include "rollback/events.h"
#include "rollback/input_queue.h"

namespace lockroll::rollback {

class PartEffects {
public:
    virtual void emit(SessionEvent::Kind kind, SessionEvent::Reason reason, PlayerId peer, std::uint32_t frame, std::uint64_t now_us,
                      std::string detail) = 0;
    virtual bool live_peer(PlayerId peer) const = 0;
    virtual const InputQueue& stream(PlayerId slot) const = 0;

protected:
    ~PartEffects() = default;
};

}  // namespace lockroll::rollback
