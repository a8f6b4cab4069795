// rollback::Session, the installed facade: every call goes to the SessionImpl it owns
// (session_impl.h; its code is in session.cpp), so session.h names no internal type.
#include "rollback/session.h"

#include "rollback/rejoin.h"
#include "rollback/session_impl.h"

namespace lockroll::rollback {

Session::Session(const SessionConfig& config, Simulation& simulation, SessionObserver* observer, Predictor* predictor)
    : impl_(std::make_unique<SessionImpl>(config, simulation, observer, predictor)),
      simulation_(&simulation),
      observer_(observer),
      predictor_(predictor) {
    core_ = impl_.get();
}

Session::~Session() = default;

void Session::receive(PlayerId from, std::span<const std::uint8_t> datagram, std::uint64_t now_us) noexcept { impl_->receive(from, datagram, now_us); }
AdvanceResult Session::advance(std::span<const std::uint8_t> local_input, std::uint64_t now_us) noexcept { return impl_->advance(local_input, now_us); }
void Session::poll(std::uint64_t now_us, std::vector<Datagram>& out) noexcept { impl_->poll(now_us, out); }
void Session::set_input_delay(int frames) { impl_->set_input_delay(frames); }
void Session::set_prediction_window(int frames) { impl_->set_prediction_window(frames); }
int Session::prediction_window() const { return impl_->prediction_window(); }
void Session::disconnect_player(PlayerId slot, std::uint64_t now_us) { impl_->disconnect_player(slot, now_us); }
int Session::catch_up(std::uint64_t now_us, int max_frames) noexcept { return impl_->catch_up(now_us, max_frames); }
void Session::set_last_frame(std::uint32_t frame) { impl_->set_last_frame(frame); }
std::int32_t Session::behind(std::uint64_t now_us) const { return impl_->behind(now_us); }
void Session::damage_outgoing_chunks(int count, ChunkDamage how) { impl_->damage_outgoing_chunks(count, how); }
std::uint64_t Session::damaged_chunks() const { return impl_->damaged_chunks(); }
const SessionConfig& Session::config() const { return impl_->config(); }
std::span<const PlayerId> Session::local_slots() const { return impl_->local_slots(); }
PlayerId Session::host_of(PlayerId slot) const { return impl_->host_of(slot); }
SlotState Session::slot_state(PlayerId slot) const { return impl_->slot_state(slot); }
bool Session::partitioned() const { return impl_->partitioned(); }
bool Session::interrupted(PlayerId peer) const { return impl_->interrupted(peer); }
std::uint64_t Session::foreign_packets() const { return impl_->foreign_packets(); }
std::optional<std::uint64_t> Session::confirmed_checksum(std::uint32_t frame) const { return impl_->confirmed_checksum(frame); }
bool Session::peer_error(PlayerId p) const { return impl_->peer_error(p); }
std::uint64_t Session::rtt_us(PlayerId p) const { return impl_->rtt_us(p); }
std::uint32_t Session::peer_ack(PlayerId p) const { return impl_->peer_ack(p); }
NetworkStats Session::network_stats(PlayerId p, std::uint64_t now_us) const { return impl_->network_stats(p, now_us); }
bool Session::desynced(PlayerId p) const { return impl_->desynced(p); }
std::int32_t Session::frames_ahead_x100() const { return impl_->frames_ahead_x100(); }

// The rule and the config are rollback/rejoin.h's; here only the swap of the state machine.
bool Session::can_rejoin() const { return rollback::can_rejoin(impl_->config(), impl_->kicked()); }
bool Session::restart_as_joiner() {
    if (!can_rejoin()) return false;
    auto next = std::make_unique<SessionImpl>(rejoin_config(impl_->config(), impl_->scene_checksum()), *simulation_,
                                              observer_, predictor_);
    next->continue_from(*impl_);
    impl_ = std::move(next);
    core_ = impl_.get();
    return true;
}

}  // namespace lockroll::rollback
