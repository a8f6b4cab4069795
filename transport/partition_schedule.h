// When the network is partitioned: a list of cuts, each "the links between these sets of slots
// (peer ids) are cut from one time to another". A value type: the simulated network applies it
// in virtual time (transport/sim_network.h), the UDP proxy on the monotonic clock
// (net/udp_proxy.h); the CLI's frames are mapped to microseconds by the harness
// (harness/partition_flag.h). Semantics in docs/network-model.md ("Partitions").
//
// Contract
//  - A cut holds two or more non-empty, pairwise disjoint sets of slots and a window
//    [from_us, until_us) with from_us < until_us. While now is in the window, every datagram
//    from a slot in one set to a slot in another set of the same cut is cut, in both
//    directions. Links within one set, and every link of a slot named in none of the cut's sets,
//    are untouched by that cut: such a slot keeps all its links (it can bridge the sides).
//  - Several cuts combine by "or": a link is cut while any active cut separates its ends. Their
//    windows may overlap.
//  - Times are microseconds on whatever clock the user applies it to; the schedule itself never
//    reads one. An empty schedule cuts nothing.
//  - add() throws std::invalid_argument naming what is wrong with the cut; slots are checked
//    against a peer count separately (check_slots), since a schedule may be built before it.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <lockroll/transport/transport.h>

namespace lockroll::transport {

struct PartitionCut {
    std::vector<std::vector<PeerId>> sets;  // slots of each side, as given
    Micros from_us = 0;                     // first microsecond the cut is active
    Micros until_us = 0;                    // first microsecond it is healed (exclusive)

    // The index of the set holding `slot`, or -1 when no set names it.
    int side_of(PeerId slot) const;

    friend bool operator==(const PartitionCut&, const PartitionCut&) = default;
};

// Empty when the cut is usable; otherwise what is wrong (fewer than two sets, an empty set, a
// slot in two sets or twice in one, from_us >= until_us).
std::string validate(const PartitionCut& cut);

class PartitionSchedule {
public:
    PartitionSchedule() = default;

    // Throws std::invalid_argument with validate()'s message.
    void add(PartitionCut cut);

    bool empty() const { return cuts_.empty(); }
    const std::vector<PartitionCut>& cuts() const { return cuts_; }

    // Whether a datagram sent from -> to at `now` is cut (some cut active at `now` puts the two
    // slots in different sets). Symmetric in from and to.
    bool is_cut(PeerId from, PeerId to, Micros now) const;

    // The same cuts, every window moved later by offset_us (e.g. from "since frame 0" to the
    // clock the match runs on).
    PartitionSchedule shifted(Micros offset_us) const;

    // Empty when every slot named is below `peers`; otherwise names the first one that is not.
    std::string check_slots(int peers) const;

    friend bool operator==(const PartitionSchedule&, const PartitionSchedule&) = default;

private:
    std::vector<PartitionCut> cuts_;
};

}  // namespace lockroll::transport
