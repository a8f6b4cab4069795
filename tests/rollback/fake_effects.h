// The rest of a P2P session, faked and recorded, for the tests that drive MembershipChanges
// (membership_changes_test) and AuthoredStreams (authored_streams_test) by hand: FakeEffects
// implements MembershipEffects and AuthoringEffects over hand-built streams, as
// SessionImpl::Effects does over the session, and EffectsFixture is the state both parts borrow.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "rollback/authored_streams.h"
#include "rollback/membership.h"
#include "rollback/membership_changes.h"
#include "rollback/peer_link.h"
#include "rollback/slot_view.h"
#include "tests/rollback/peer_links.h"

namespace lockroll::rollback::testing {

struct FakeEffects final : MembershipEffects, AuthoringEffects {
    using Kind = SessionEvent::Kind;
    using Reason = SessionEvent::Reason;
    struct Event {
        Kind kind;
        PlayerId peer;
        std::uint32_t frame;
        std::string detail;
        Reason reason;
    };
    std::vector<Event> events;
    bool failed = false;  // fail_dropped was called
    std::vector<PlayerId> changed_hands, failed_peers, replaced_peers;
    int floor_moves = 0;  // live_peers_changed calls
    std::uint32_t shown = 10, confirmed = 7;  // frame(), confirmed_frame()
    const Membership* view = nullptr;
    const std::vector<PeerLink>* links = nullptr;
    std::vector<InputQueue> queues;  // one stream per peer id

    // PartEffects
    void emit(Kind kind, Reason reason, PlayerId peer, std::uint32_t frame, std::uint64_t, std::string detail) override {
        events.push_back({kind, peer, frame, std::move(detail), reason});
    }
    // The session's rule (SessionImpl::live_peer), over the view and the links.
    bool live_peer(PlayerId p) const override {
        const PeerLink& l = (*links)[p];
        if (p == view->local() || !l.welcomed || l.error()) return false;
        return p < static_cast<PlayerId>(view->players()) ? view->running(p) : l.role == Role::Spectator;
    }
    const InputQueue& stream(PlayerId slot) const override { return queues[slot]; }
    // MembershipEffects
    void fail_dropped(std::uint64_t) override { failed = true; }
    void slot_changed_hands(PlayerId slot) override { changed_hands.push_back(slot); }
    void peer_failed(PlayerId peer) override { failed_peers.push_back(peer); }
    void peer_replaced(PlayerId peer) override { replaced_peers.push_back(peer); }
    void live_peers_changed() override { ++floor_moves; }
    std::uint32_t frame() const override { return shown; }
    std::uint32_t confirmed_frame() const override { return confirmed; }
    // AuthoringEffects
    InputQueue::Add write(PlayerId slot, std::uint32_t frame, std::span<const std::uint8_t> input, bool absent) override {
        return queues[slot].add_confirmed(frame, input, absent);
    }

    // The events of one kind, in order.
    std::vector<Event> of(Kind k) const {
        std::vector<Event> out;
        for (const Event& e : events)
            if (e.kind == k) out.push_back(e);
        return out;
    }
};

// `players` slots (this session plays `local`), then `spectators` spectator peers; every link
// welcomed, one 1-byte stream per peer id, the fake reading this view and these links.
struct EffectsFixture {
    SessionConfig config;
    Membership view;
    std::vector<SlotView> slots;
    std::vector<PeerLink> links;
    FakeEffects fake;

    EffectsFixture(int players, PlayerId local, std::vector<PlayerId> hosts, TwoPlayerRule rule, int spectators)
        : view(players, local, rule, hosts), slots(static_cast<std::size_t>(players)),
          links(fresh_links(players + spectators, static_cast<std::size_t>(players))) {
        config.players = players;
        config.local_player = local;
        config.max_spectators = spectators;
        config.input_size = 1;
        config.slot_hosts = std::move(hosts);
        config.two_player_rule = rule;
        for (std::size_t p = 0; p < links.size(); ++p) {
            links[p].welcomed = true;
            if (p >= static_cast<std::size_t>(players)) links[p].role = Role::Spectator;
            fake.queues.emplace_back(1, 64);
        }
        fake.view = &view;
        fake.links = &links;
    }
};

}  // namespace lockroll::rollback::testing
