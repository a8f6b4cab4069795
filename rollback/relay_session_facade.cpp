// rollback::RelaySession, the installed facade: every call goes to the RelaySessionImpl it owns
// (relay_session_impl.h; its code is in relay_session.cpp), so relay_session.h names no
// internal type.
#include "rollback/relay_session.h"

#include "rollback/relay_session_impl.h"

namespace lockroll::rollback {

RelaySession::RelaySession(const RelaySessionConfig& config, Simulation& simulation, SessionObserver* observer,
                           Predictor* predictor)
    : impl_(std::make_unique<RelaySessionImpl>(config, simulation, observer, predictor)) {
    core_ = impl_.get();
}

RelaySession::~RelaySession() = default;

void RelaySession::receive(std::span<const std::uint8_t> datagram, std::uint64_t now_us) noexcept { impl_->receive(datagram, now_us); }
AdvanceResult RelaySession::advance(std::span<const std::uint8_t> local_input, std::uint64_t now_us) noexcept { return impl_->advance(local_input, now_us); }
void RelaySession::poll(std::uint64_t now_us, std::vector<Datagram>& out) noexcept { impl_->poll(now_us, out); }
int RelaySession::catch_up(std::uint64_t now_us, int max_frames) noexcept { return impl_->catch_up(now_us, max_frames); }
void RelaySession::set_last_frame(std::uint32_t frame) { impl_->set_last_frame(frame); }
std::int32_t RelaySession::behind(std::uint64_t now_us) const { return impl_->behind(now_us); }
void RelaySession::transport_reconnected(std::uint64_t now_us) { impl_->transport_reconnected(now_us); }
const RelaySessionConfig& RelaySession::config() const { return impl_->config(); }
const std::vector<PlayerId>& RelaySession::local_slots() const { return impl_->local_slots(); }
std::size_t RelaySession::local_input_size() const { return impl_->local_input_size(); }
std::uint32_t RelaySession::server_input_ack() const { return impl_->server_input_ack(); }
bool RelaySession::server_lost() const { return impl_->server_lost(); }
int RelaySession::room_id_slot() const { return impl_->room_id_slot(); }
std::uint64_t RelaySession::rtt_us() const { return impl_->rtt_us(); }
std::uint64_t RelaySession::jitter_us() const { return impl_->jitter_us(); }
const RelayStats& RelaySession::relay_stats() const { return impl_->relay_stats(); }
std::optional<std::uint64_t> RelaySession::confirmed_checksum(std::uint32_t frame) const { return impl_->confirmed_checksum(frame); }

}  // namespace lockroll::rollback
