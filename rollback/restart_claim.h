// RestartClaim: a hello's claim that a running slot's process restarted, and when that claim
// becomes this process's vote that the old process is gone (issue 21: a datagram is a claim,
// not a fact).
//
// Anyone can send a hello with a slot's id (ids are not authenticated), so a claim is weighed
// only against what this process hears itself: the old process's silence. admit_hello
// (rollback/session_admission.h) lets a claim in only once the old process has been silent for
// restart_quiet_us; that alone let an outsider's hello that landed during a genuine loss burst
// of that length be the vote, and in a view of two the vote is the decision: an honest player
// whose silence would have ended a moment later was dropped
// (Lifecycle.ForgedRestartHelloDuringALossBurst*). So the claim is only noted when it comes, and
// counts once
//   - the old process has not been heard since the claim began (heard again: the claim is void,
//     a later hello begins a new one), and
//   - the claim has stood for restart_confirm_us, and
//   - it is made again then (a hello arrives): a restarted process says hello every
//     hello_resend_us until it is let in, a one-off forged hello never counts.
// The window is restart_quiet_us again (interrupt_us / 2): a claim that counts has seen the old
// process silent at least that long after it, whatever came before, so an honest silence that
// ends within that window of the claim's first hello is never a drop; a genuine restart costs
// that window once more (plus a hello interval) before its predecessor is voted gone, still far
// below disconnect_us. What is left: a silence that does last that long after a forged claim
// (a forger that keeps claiming turns any silence of interrupt_us / 2 plus a hello interval
// into this process's vote). docs/sessions.md, "A restart is a claim".
//
// Contract
//  - A value per slot (SlotView::restart_claim), cleared with the slot's epoch. No clock: times
//    come in; the old process's last-heard time is the caller's (PeerLink::last_heard_us), so a
//    withdrawal needs no hook, only that time moving past the claim's start.
//  - claim(): one claiming hello, at now_us; true when the claim counts now (the caller votes).
#pragma once

#include <cstdint>

namespace lockroll::rollback {

// How long a restart claim must stand, its slot's old process unheard, before it counts.
constexpr std::uint64_t restart_confirm_us(std::uint64_t interrupt_us) { return interrupt_us / 2; }

class RestartClaim {
public:
    // A hello claims the slot's process restarted, at now_us; that process was last heard at
    // last_heard_us. Begins a claim unless one stands that the old process has not answered
    // since (heard after it began); true when the standing claim is confirm_us old.
    bool claim(std::uint64_t now_us, std::uint64_t last_heard_us, std::uint64_t confirm_us);
    // A claim stands, unanswered by the old process (as last heard at last_heard_us).
    bool stands(std::uint64_t last_heard_us) const { return pending_ && last_heard_us <= since_us_; }
    std::uint64_t since_us() const { return since_us_; }
    void clear() { pending_ = false; }

private:
    bool pending_ = false;
    std::uint64_t since_us_ = 0;
};

}  // namespace lockroll::rollback
