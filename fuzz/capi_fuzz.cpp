// libFuzzer target: the C ABI's entry points (capi/lockroll.h) as a careless or hostile host
// program calls them. The input is a script: builders made, set and freed in any order, every
// setter with any value (NULL handles and strings, out-of-range numbers), sessions started with
// games that misbehave (a save() longer than its capacity, a load() that refuses, a struct_size
// from an older or garbled header, field names missing), then every session call with any
// argument (inputs of the wrong size, NULL outputs, any peer and frame), in any order, freed or
// not at the end of the script.
//
// Properties beyond "no crash, no sanitizer report, no leak":
//  - nothing throws through the C boundary (an escaping exception aborts: std::terminate);
//  - every status is one of lockroll_status's values; every string returned is non-NULL
//    (lockroll_last_error, the names, lockroll_output_error, an event's detail);
//  - a call refused for a NULL handle or a bad value is LOCKROLL_INVALID_ARGUMENT and says why
//    (lockroll_last_error() is not empty);
//  - lockroll_update() with an input of the wrong size runs nothing (0 frames), and an update's
//    interpolation fraction lies in [0, 1).
//
// Safety of the machine: hosts are only "127.0.0.1", "" or NULL (never a name that would be
// looked up), remote ports only 1 and 9 on loopback (nothing listens there), listen ports 0
// (ephemeral), files only under one scratch directory of this process or a path that cannot
// exist. No call waits on the network: at most one lockroll_wait() (about a millisecond) a run.
#include <fuzzer/FuzzedDataProvider.h>

#include <lockroll/lockroll.h>

#include <unistd.h>

#include <array>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

namespace {

void check(bool ok) {
    if (!ok) std::abort();
}

bool valid_status(lockroll_status s) { return s >= LOCKROLL_OK && s <= LOCKROLL_INTERNAL; }

// A refused call says why; an accepted one may leave the last message as it was.
void checked(lockroll_status s) {
    check(valid_status(s));
    const char* e = lockroll_last_error();
    check(e != nullptr);
    if (s == LOCKROLL_INVALID_ARGUMENT) check(e[0] != '\0');
}

// The game, with its misbehaviour chosen by the script.
struct Game {
    std::int64_t value = 0;
    int save_mode = 0;  // 0: honest, 1: one byte longer than its capacity, 2: writes nothing
    bool refuse_load = false;
};

std::size_t save(void* user, std::uint8_t* out, std::size_t capacity) {
    auto* g = static_cast<Game*>(user);
    if (g->save_mode == 1) return capacity + 1;  // a buggy game: the library must refuse it
    if (g->save_mode == 2 || capacity < sizeof g->value) return 0;
    std::memcpy(out, &g->value, sizeof g->value);
    return sizeof g->value;
}
int load(void* user, const std::uint8_t* state, std::size_t size) {
    auto* g = static_cast<Game*>(user);
    if (g->refuse_load || size != sizeof g->value) return 7;
    std::memcpy(&g->value, state, sizeof g->value);
    return 0;
}
void advance(void* user, const std::uint8_t* inputs, std::size_t size, const std::uint8_t*, std::uint32_t) {
    auto* g = static_cast<Game*>(user);
    g->value += 1;
    for (std::size_t i = 0; i < size; ++i) g->value += inputs[i];
}
std::uint64_t checksum(void*, const std::uint8_t* state, std::size_t size) {
    std::uint64_t h = 1469598103934665603ull;
    for (std::size_t i = 0; i < size; ++i) h = (h ^ state[i]) * 1099511628211ull;
    return h;
}
std::int64_t field_value(void*, const std::uint8_t*, std::size_t size, std::uint32_t body, std::int32_t field) {
    return static_cast<std::int64_t>(size) + body * 10 + field;
}
const char* const kFieldNames[] = {"value", "spare"};

const std::string& scratch() {
    static const std::string dir = [] {
        const auto d = std::filesystem::temp_directory_path() / ("lockroll-capi-fuzz-" + std::to_string(::getpid()));
        std::filesystem::create_directories(d);
        return d.string();
    }();
    return dir;
}

const char* host(FuzzedDataProvider& in) {
    switch (in.ConsumeIntegralInRange<int>(0, 2)) {
        case 0: return "127.0.0.1";
        case 1: return "";
        default: return nullptr;
    }
}
std::uint16_t remote_port(FuzzedDataProvider& in) { return in.ConsumeBool() ? 1 : 9; }
// A file path: under the scratch directory, one that cannot exist, empty, or NULL.
const char* path(FuzzedDataProvider& in, std::string& keep, const char* leaf) {
    switch (in.ConsumeIntegralInRange<int>(0, 3)) {
        case 0: keep = scratch() + "/" + leaf; return keep.c_str();
        case 1: return "/nonexistent-lockroll-capi-fuzz/x";
        case 2: return "";
        default: return nullptr;
    }
}
std::int32_t small_int(FuzzedDataProvider& in) {
    // Mostly near the valid ranges, sometimes anything.
    return in.ConsumeBool() ? in.ConsumeIntegralInRange<std::int32_t>(-2, 20) : in.ConsumeIntegral<std::int32_t>();
}

// One builder setter, chosen by the script, on `b` (which may be NULL).
void set(FuzzedDataProvider& in, lockroll_builder* b) {
    std::string keep;
    switch (in.ConsumeIntegralInRange<int>(0, 19)) {
        case 0: checked(lockroll_builder_players(b, small_int(in))); break;
        case 1: checked(lockroll_builder_input_size(b, in.ConsumeIntegralInRange<std::uint32_t>(0, 70))); break;
        case 2: checked(lockroll_builder_local_player(b, small_int(in))); break;
        case 3: checked(lockroll_builder_remote_player(b, small_int(in), host(in), remote_port(in))); break;
        case 4: checked(lockroll_builder_server(b, host(in), remote_port(in))); break;
        case 5: checked(lockroll_builder_listen(b, host(in), 0)); break;
        case 6: checked(lockroll_builder_tick_rate(b, in.ConsumeBool() ? in.ConsumeIntegralInRange<std::int32_t>(-1, 1000) : small_int(in))); break;
        case 7: checked(lockroll_builder_input_delay(b, small_int(in))); break;
        case 8: checked(lockroll_builder_prediction_window(b, small_int(in))); break;
        case 9: checked(lockroll_builder_match_id(b, in.ConsumeIntegral<std::uint64_t>())); break;
        case 10: checked(lockroll_builder_frames(b, in.ConsumeIntegralInRange<std::uint32_t>(0, 40))); break;
        case 11:
            checked(lockroll_builder_timeouts(b, in.ConsumeIntegralInRange<std::uint64_t>(0, 2'000'000),
                                              in.ConsumeIntegralInRange<std::uint64_t>(0, 2'000'000),
                                              in.ConsumeIntegralInRange<std::uint64_t>(0, 2'000'000)));
            break;
        case 12:
            checked(lockroll_builder_disconnect_timeouts(b, in.ConsumeIntegral<std::uint64_t>(), in.ConsumeIntegral<std::uint64_t>()));
            break;
        case 13: checked(lockroll_builder_spectator(b, host(in), remote_port(in), small_int(in))); break;
        case 14: checked(lockroll_builder_spectators(b, small_int(in))); break;
        // Join, a spectator through the server and a connect token share one case, so the
        // corpus's scripts (fuzz/corpus/capi) keep their meaning wherever they do not join.
        case 15:
            switch (in.ConsumeIntegralInRange<int>(0, 2)) {
                case 0: checked(lockroll_builder_join(b)); break;
                case 1: checked(lockroll_builder_server_spectator(b)); break;
                default: {
                    // 0..300 bytes (the limit is 256), NULL now and then; a size that says more
                    // than the buffer holds only past the limit, where it is refused unread.
                    const std::vector<std::uint8_t> token =
                        in.ConsumeBytes<std::uint8_t>(in.ConsumeIntegralInRange<std::size_t>(0, 300));
                    const std::size_t size =
                        in.ConsumeBool() ? token.size() : in.ConsumeIntegralInRange<std::size_t>(257, SIZE_MAX);
                    checked(lockroll_builder_connect_token(b, in.ConsumeBool() ? nullptr : token.data(), size));
                    break;
                }
            }
            break;
        case 16: {
            const std::string scene = in.ConsumeRandomLengthString(64);
            checked(lockroll_builder_record_replay(b, path(in, keep, "r.replay"), in.ConsumeBool() ? scene.c_str() : nullptr));
            break;
        }
        case 17: checked(lockroll_builder_desync_report_dir(b, path(in, keep, "reports"))); break;
        // The common valid case, so starts get past validation often enough.
        case 18:
            checked(lockroll_builder_players(b, 1));
            checked(lockroll_builder_input_size(b, 1));
            checked(lockroll_builder_local_player(b, 0));
            break;
        default:
            checked(lockroll_builder_players(b, 2));
            checked(lockroll_builder_input_size(b, 2));
            checked(lockroll_builder_local_player(b, in.ConsumeIntegralInRange<std::int32_t>(0, 1)));
            checked(lockroll_builder_remote_player(b, in.ConsumeIntegralInRange<std::int32_t>(0, 1), "127.0.0.1", remote_port(in)));
            break;
    }
}

lockroll_game game_from(FuzzedDataProvider& in, Game& g) {
    lockroll_game c{};
    c.struct_size = sizeof c;
    c.state_size = sizeof g.value;
    c.save = save;
    c.load = load;
    c.advance = advance;
    g.save_mode = in.ConsumeIntegralInRange<int>(0, 2);
    g.refuse_load = in.ConsumeBool();
    switch (in.ConsumeIntegralInRange<int>(0, 7)) {
        case 0: c.struct_size = offsetof(lockroll_game, checksum); break;  // an older header
        case 1: c.struct_size = in.ConsumeIntegralInRange<std::size_t>(0, sizeof c + 64); break;
        case 2: c.state_size = in.ConsumeIntegralInRange<std::size_t>(0, 64); break;
        case 3: c.save = nullptr; break;
        case 4: c.load = nullptr; break;
        case 5: c.advance = nullptr; break;
        default: break;
    }
    if (in.ConsumeBool()) c.checksum = checksum;
    if (in.ConsumeBool()) {
        c.body_count = in.ConsumeIntegralInRange<std::uint32_t>(0, 4);
        c.field_count = in.ConsumeIntegralInRange<std::int32_t>(-1, 2);
        c.field_names = in.ConsumeBool() ? kFieldNames : nullptr;
        c.field_value = in.ConsumeBool() ? field_value : nullptr;
    }
    return c;
}

// One call on a running session (which may be NULL).
void use(FuzzedDataProvider& in, lockroll_session*& s, bool& waited) {
    switch (in.ConsumeIntegralInRange<int>(0, 10)) {
        case 0:
        case 1: {
            std::vector<std::uint8_t> input = in.ConsumeBytes<std::uint8_t>(in.ConsumeIntegralInRange<std::size_t>(0, 5));
            lockroll_update_result r{};
            r.frames = -7;
            const bool null_input = in.ConsumeBool();
            const lockroll_status st =
                lockroll_update(s, null_input ? nullptr : input.data(), input.size(), in.ConsumeBool() ? &r : nullptr);
            checked(st);
            if (st == LOCKROLL_OK && r.frames != -7) check(r.interpolation >= 0 && r.interpolation < 1);
            if (st == LOCKROLL_INVALID_ARGUMENT && r.frames != -7) check(r.frames == 0);
            break;
        }
        case 2: {
            lockroll_event e{};
            for (int i = 0; i < 64 && lockroll_next_event(s, &e) == 1; ++i) {
                check(e.detail != nullptr);
                check(lockroll_event_name(e.kind) != nullptr);
                check(lockroll_event_reason(s) != nullptr);
            }
            if (in.ConsumeBool()) check(lockroll_next_event(s, nullptr) == 0);
            break;
        }
        case 3: {
            lockroll_stats st{};
            checked(lockroll_network_stats(s, small_int(in), in.ConsumeBool() ? &st : nullptr));
            break;
        }
        case 4: {
            std::uint64_t v = 0;
            checked(lockroll_confirmed_checksum(s, in.ConsumeIntegral<std::uint32_t>(), in.ConsumeBool() ? &v : nullptr));
            break;
        }
        case 5: {
            std::uint64_t v = 0;
            checked(lockroll_final_checksum(s, in.ConsumeBool() ? &v : nullptr));
            break;
        }
        case 6:
            (void)lockroll_frame(s);
            (void)lockroll_confirmed_frame(s);
            (void)lockroll_port(s);
            check(lockroll_output_error(s) != nullptr);
            break;
        case 7: lockroll_request_stop(s); break;
        case 8:
            if (!waited) lockroll_wait(s);  // about a millisecond: once a run at most
            waited = true;
            break;
        case 9:
            lockroll_session_free(s);
            s = nullptr;
            break;
        default:
            check(lockroll_outcome_name(static_cast<lockroll_outcome>(in.ConsumeIntegral<std::int32_t>())) != nullptr);
            check(lockroll_event_name(static_cast<lockroll_event_kind>(in.ConsumeIntegral<std::int32_t>())) != nullptr);
            check(lockroll_version() != nullptr);
            break;
    }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    FuzzedDataProvider in(data, size);
    std::array<lockroll_builder*, 2> builders{};
    lockroll_session* session = nullptr;
    Game game;
    bool waited = false;
    for (int op = 0; op < 48 && in.remaining_bytes() > 0; ++op) {
        lockroll_builder*& b = builders[in.ConsumeIntegralInRange<std::size_t>(0, 1)];
        switch (in.ConsumeIntegralInRange<int>(0, 7)) {
            case 0:
                if (!b) b = lockroll_builder_new();
                check(b != nullptr);
                break;
            case 1:
                lockroll_builder_free(b);  // NULL too
                b = nullptr;
                break;
            case 2:
            case 3: set(in, in.ConsumeIntegralInRange<int>(0, 15) == 0 ? nullptr : b); break;
            case 4:
                if (!session) {
                    const bool null_game = in.ConsumeIntegralInRange<int>(0, 15) == 0;
                    const lockroll_game g = game_from(in, game);
                    session = lockroll_builder_start(b, null_game ? nullptr : &g, &game);
                    check(lockroll_last_error() != nullptr);
                    if (!session) check(lockroll_last_error()[0] != '\0');  // a refused start says why
                }
                break;
            default: use(in, session, waited); break;
        }
    }
    lockroll_session_free(session);
    for (lockroll_builder* b : builders) lockroll_builder_free(b);
    return 0;
}
