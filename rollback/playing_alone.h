// Playing alone (issue 21, "the survivor plays on alone, and its outcome says 'alone since frame
// F'"): whether this process is the only running voter of its session's view, and since which
// frame -- the frame of the drop that left it so. Under TwoPlayerRule::PlayOnAlone a view of two
// running processes drops the other on one vote (rollback/membership.h). That view is a match of
// two, or a match of three or more that has shrunk to two by drops; either way the survivor
// agreed with nobody from then on, and its outcome must say so rather than a plain "completed"
// (two survivors cut apart each play on alone, on finals of their own).
//
// Contract
//  - running_voters(s): the processes running in s's view, by their slot (a slot no other slot
//    hosts, config.slot_hosts), ascending; the local one included while it runs.
//  - AloneSince follows one session through its drained events: saw() each event as it is drained
//    (with the match's player count: a spectator's Disconnected is no drop), settle() once after
//    each drain with running_voters() of the session then and its local slot. A Disconnected of a
//    slot seen since the last settle() that leaves the view to the local process alone sets
//    since() to that drop's frame (the newest such drop: two drops in one drain, a majority's then
//    the two-player rule's, give the latter). Nothing sets it without a drop (a process alone from
//    the start, every other slot absent, agreed with nobody but dropped nobody either). Once the
//    view holds another voter again (a rejoin; a kicked session's view, which still holds those
//    who dropped it), since() is reset. A spectator is never alone: it is no voter. One rule for
//    net::PeerRunner (`lockroll peer`'s outcome and summary.json) and the virtual-time match
//    (ClientResult::alone_since_frame).
//  - No clock, no I/O: running_voters() reads the Session; AloneSince is a pure value type.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "rollback/events.h"
#include "rollback/session.h"

namespace lockroll::rollback {

std::vector<PlayerId> running_voters(const Session& s);

class AloneSince {
public:
    void saw(const SessionEvent& e, int players);
    void settle(std::span<const PlayerId> voters, PlayerId local);
    std::optional<std::uint32_t> since() const { return since_; }

private:
    std::optional<std::uint32_t> since_, last_drop_;
};

}  // namespace lockroll::rollback
