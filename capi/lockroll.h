/* lockroll's C ABI: a networked rollback (or lockstep) session for games written in C, or in any
 * language that can call C (Python's ctypes, C#'s P/Invoke, Godot's GDExtension, Unreal, ...).
 * It wraps net::SessionBuilder and net::NetSession (the C++ API, docs/guide.md); one header, C99,
 * shipped as the shared library liblockroll.so, which exports only lockroll_* symbols.
 *
 * Contract
 *  - Errors: functions that can fail return a lockroll_status (LOCKROLL_OK = 0) or NULL; then
 *    lockroll_last_error() says what and where ("lockroll_builder_start: SessionBuilder: slot 1
 *    is named twice"). No C++ exception ever crosses this boundary: every entry point catches.
 *  - Threading: a builder or a session is used by one thread at a time (any thread, not
 *    necessarily the one that made it). lockroll_request_stop() alone may be called from any
 *    thread or a signal handler. lockroll_last_error() is per thread: it reads the last failure
 *    of a call made on the calling thread.
 *  - Ownership and lifetimes: lockroll_builder_new() / lockroll_session_free() and
 *    lockroll_builder_free() pair up; freeing NULL does nothing. A session does not keep its
 *    builder (free it right after start). Strings passed in are copied before the call returns.
 *    Strings handed out (lockroll_last_error(), an event's detail) belong to lockroll: the error
 *    until the thread's next failing call, a detail until the next lockroll_next_event() or
 *    lockroll_session_free() on that session. The game's callbacks and `user` pointer must stay
 *    valid until lockroll_session_free() returns; lockroll calls them only from inside
 *    lockroll_builder_start(), lockroll_update() and lockroll_session_free(), on the calling
 *    thread.
 *  - The game (lockroll_game): a deterministic state machine, as in rollback/simulation.h:
 *    advance() must be a pure function of (state, inputs); save(); load() of those bytes;
 *    advance() gives the same state, bit for bit. lockroll saves the state every frame, loads
 *    an older one and advances again when a late input contradicts its guess (rollback).
 *    load() may be handed a state received from a peer (a snapshot transfer): validate it and
 *    return non-zero, the state untouched, when it is not one of yours.
 *  - The game loop is the game's: call lockroll_update() once per frame of your own loop, at any
 *    rate, with the local input of this frame; it never blocks. lockroll_wait() sleeps until the
 *    next tick is due, for a loop with nothing else to do.
 *  - ABI growth: lockroll_game starts with struct_size (set it to sizeof(lockroll_game)); fields
 *    added later go at the end and are treated as absent when struct_size says the caller's
 *    struct is older. Enumerators keep their values.
 */
#ifndef LOCKROLL_LOCKROLL_H
#define LOCKROLL_LOCKROLL_H

#include <stddef.h>
#include <stdint.h>

#if defined(_WIN32) && defined(LOCKROLL_BUILDING_C_ABI)
#define LOCKROLL_API __declspec(dllexport)
#elif defined(_WIN32)
#define LOCKROLL_API __declspec(dllimport)
#elif defined(__GNUC__)
#define LOCKROLL_API __attribute__((visibility("default")))
#else
#define LOCKROLL_API
#endif

/* The enumerations are int-sized in C. In C++ they are given int32_t as their type, so that any
 * int a C caller passes where one is expected (an enumerator of a newer header, a garbled value)
 * is a value the library may read and refuse; without a fixed type, C++ may assume only the
 * enumerators' range (found by fuzz/capi_fuzz.cpp: lockroll_outcome_name(2147534418)). */
#ifdef __cplusplus
#define LOCKROLL_ENUM_TYPE : int32_t
#else
#define LOCKROLL_ENUM_TYPE
#endif

#ifdef __cplusplus
extern "C" {
#endif

typedef enum lockroll_status LOCKROLL_ENUM_TYPE {
    LOCKROLL_OK = 0,
    LOCKROLL_INVALID_ARGUMENT = 1, /* a NULL handle, a bad setting or value */
    LOCKROLL_START_FAILED = 2,     /* the settings do not make a session (slots, port in use, ...) */
    LOCKROLL_NOT_FOUND = 3,        /* no such frame (checksum) or peer (stats) yet */
    LOCKROLL_INTERNAL = 4          /* a bug or out of memory; the message says which */
} lockroll_status;

/* How a run ended (lockroll_update_result.outcome); LOCKROLL_RUNNING while it goes on. */
typedef enum lockroll_outcome LOCKROLL_ENUM_TYPE {
    LOCKROLL_RUNNING = 0,
    LOCKROLL_COMPLETED = 1,       /* every player confirmed the last frame (lockroll_builder_frames) */
    LOCKROLL_CONNECT_TIMEOUT = 2, /* not every peer connected in time */
    LOCKROLL_FINISH_TIMEOUT = 3,  /* the last frame shown, but not confirmed everywhere in time */
    LOCKROLL_RUN_TIMEOUT = 4,     /* the last frame never shown within the run timeout */
    LOCKROLL_FAILED = 5,          /* the session failed (refused, kicked): see the failed event */
    LOCKROLL_STOPPED = 6,         /* lockroll_request_stop() */
    LOCKROLL_PARTITIONED = 7,     /* ended while cut off from a majority of the players */
    LOCKROLL_SERVER_LOST = 8      /* relay: the server went silent (killed or unreachable) */
} lockroll_outcome;

/* A slot's input for one frame, as advance() is told (one byte per player). */
typedef enum lockroll_input_status LOCKROLL_ENUM_TYPE {
    LOCKROLL_INPUT_CONFIRMED = 0, /* the player's own input, final */
    LOCKROLL_INPUT_PREDICTED = 1, /* a guess: the frame runs again if the real input differs */
    LOCKROLL_INPUT_ABSENT = 2     /* nobody plays the slot: all zero bytes, final */
} lockroll_input_status;

/* What a session tells its game (rollback/events.h has each one's meaning). */
typedef enum lockroll_event_kind LOCKROLL_ENUM_TYPE {
    LOCKROLL_EVENT_SYNCHRONIZING = 0,     /* frame: round trips so far */
    LOCKROLL_EVENT_SYNCHRONIZED = 1,      /* frame 0 (or a snapshot's frame) starts */
    LOCKROLL_EVENT_REFUSED = 2,           /* a handshake failed; detail says why */
    LOCKROLL_EVENT_INTERRUPTED = 3,       /* player silent for the interrupt timeout */
    LOCKROLL_EVENT_RESUMED = 4,
    LOCKROLL_EVENT_DISCONNECTED = 5,      /* player dropped */
    LOCKROLL_EVENT_PARTITIONED = 6,
    LOCKROLL_EVENT_NEUTRAL_FROM = 7,      /* player's input is the neutral one from frame */
    LOCKROLL_EVENT_JOINED = 8,
    LOCKROLL_EVENT_SPECTATOR_JOINED = 9,
    LOCKROLL_EVENT_SNAPSHOT_LOADED = 10,
    LOCKROLL_EVENT_SNAPSHOT_REJECTED = 11,
    LOCKROLL_EVENT_DESYNC_DETECTED = 12,  /* frame: first confirmed frame that differs */
    LOCKROLL_EVENT_DESYNC_RECOVERED = 13,
    LOCKROLL_EVENT_KICKED = 14,
    LOCKROLL_EVENT_FAILED = 15,           /* the session cannot go on; detail says why */
    LOCKROLL_EVENT_SERVER_DRAINING = 16,
    LOCKROLL_EVENT_DESYNC_REPORT = 17,    /* narrowing ended: frame: first differing frame; detail
                                             names body, field and the evidence file */
    LOCKROLL_EVENT_SERVER_LOST = 18,      /* relay: the server went silent; detail: how long */
    LOCKROLL_EVENT_OTHER = 255            /* a kind newer than this header; detail names it */
} lockroll_event_kind;

typedef struct lockroll_event {
    lockroll_event_kind kind;
    int32_t player;     /* the slot or peer concerned */
    uint32_t frame;
    uint64_t at_us;     /* the session's clock */
    const char* detail; /* never NULL; valid until the next lockroll_next_event() */
} lockroll_event;

/* What one lockroll_update() did. */
typedef struct lockroll_update_result {
    int32_t frames;          /* ticks run by this call (0 when none was due) */
    uint32_t rollback_depth; /* the deepest rollback among them (frames simulated again) */
    double interpolation;    /* in [0, 1): where now lies between the last tick and the next */
    uint32_t events;         /* events this call queued (take them with lockroll_next_event) */
    lockroll_outcome outcome;
} lockroll_update_result;

/* One remote peer's link, for an overlay (GGPO's ggpo_get_network_stats). */
typedef struct lockroll_stats {
    uint64_t ping_us;        /* smoothed round trip */
    uint64_t jitter_us;
    int32_t frames_behind;   /* how far its frame is estimated behind ours */
    uint32_t send_queue;     /* our inputs it has not acknowledged (frames) */
    uint64_t bytes_sent;     /* payload to and from it since the start (peer to peer) */
    uint64_t bytes_received;
    double kbps_sent;
    double kbps_received;
    int32_t interrupted;     /* 1 while it is silent past the interrupt timeout */
} lockroll_stats;

/* The game, as callbacks on the game's own `user` pointer (rollback/simulation.h's contract). */
typedef struct lockroll_game {
    size_t struct_size; /* sizeof(lockroll_game) */
    /* The most bytes a saved state takes (fixed for the session's life). */
    size_t state_size;
    /* Required. Writes the state into out (capacity = state_size bytes); returns the bytes
     * written (at most capacity; a larger value fails the session with a message). */
    size_t (*save)(void* user, uint8_t* out, size_t capacity);
    /* Required. Restores a state save() wrote; 0 on success, else non-zero with the state
     * untouched (the bytes may have come from a peer). */
    int (*load)(void* user, const uint8_t* state, size_t size);
    /* Required. One frame: `inputs` holds players * input_size bytes, player p's at
     * [p * input_size, (p + 1) * input_size); status[p] is a lockroll_input_status. */
    void (*advance)(void* user, const uint8_t* inputs, size_t inputs_size, const uint8_t* status,
                    uint32_t players);
    /* Optional (NULL: XXH3-64 of the saved bytes). Equal states give equal checksums everywhere. */
    uint64_t (*checksum)(void* user, const uint8_t* state, size_t size);
    /* Optional, for desync reports naming body and field: body_count bodies with field_count
     * integer fields each, field_names[field_count] (copied at start), and field_value(). */
    uint32_t body_count;
    int32_t field_count;
    const char* const* field_names;
    int64_t (*field_value)(void* user, const uint8_t* state, size_t size, uint32_t body, int32_t field);
} lockroll_game;

typedef struct lockroll_builder lockroll_builder;
typedef struct lockroll_session lockroll_session;

/* "0.2.0": the library's version (the package's). */
LOCKROLL_API const char* lockroll_version(void);
/* The message of the calling thread's last failed call; "" when none failed. Never NULL. */
LOCKROLL_API const char* lockroll_last_error(void);
/* "completed", "synchronized", ...: a name for logs. Never NULL. */
LOCKROLL_API const char* lockroll_outcome_name(lockroll_outcome outcome);
LOCKROLL_API const char* lockroll_event_name(lockroll_event_kind kind);

/* ---- the builder: who plays where (net/session_builder.h's SessionBuilder) ---- */
LOCKROLL_API lockroll_builder* lockroll_builder_new(void);
LOCKROLL_API void lockroll_builder_free(lockroll_builder* builder);
LOCKROLL_API lockroll_status lockroll_builder_players(lockroll_builder* builder, int32_t players);
LOCKROLL_API lockroll_status lockroll_builder_input_size(lockroll_builder* builder, uint32_t bytes);
/* A slot played here; once per local player. */
LOCKROLL_API lockroll_status lockroll_builder_local_player(lockroll_builder* builder, int32_t slot);
/* A slot played by the process listening at host:port. */
LOCKROLL_API lockroll_status lockroll_builder_remote_player(lockroll_builder* builder, int32_t slot, const char* host,
                                                            uint16_t port);
/* Through a relay server (`lockroll server`) instead of remote players; one or more local players
 * (several play through one connection). */
LOCKROLL_API lockroll_status lockroll_builder_server(lockroll_builder* builder, const char* host, uint16_t port);
/* Where this process listens (default 127.0.0.1, an ephemeral port: lockroll_port()). */
LOCKROLL_API lockroll_status lockroll_builder_listen(lockroll_builder* builder, const char* host, uint16_t port);
LOCKROLL_API lockroll_status lockroll_builder_tick_rate(lockroll_builder* builder, int32_t hz);
LOCKROLL_API lockroll_status lockroll_builder_input_delay(lockroll_builder* builder, int32_t frames);
/* Frames of prediction; 0: lockstep. */
LOCKROLL_API lockroll_status lockroll_builder_prediction_window(lockroll_builder* builder, int32_t frames);
LOCKROLL_API lockroll_status lockroll_builder_match_id(lockroll_builder* builder, uint64_t id);
/* The run completes once frame n is confirmed by everyone; 0 (default): until stopped. */
LOCKROLL_API lockroll_status lockroll_builder_frames(lockroll_builder* builder, uint32_t frames);
/* Microseconds; 0 keeps a default. connect: until every peer is connected (30 s); finish: after
 * showing the last frame, to confirm it everywhere (15 s); run: the whole run (none). */
LOCKROLL_API lockroll_status lockroll_builder_timeouts(lockroll_builder* builder, uint64_t connect_us, uint64_t finish_us,
                                                       uint64_t run_us);
/* Microseconds of silence before a peer is reported interrupted (0.75 s) and dropped (5 s);
 * 0 keeps a default. Rounded up to whole milliseconds (the builder's interrupt_timeout and
 * disconnect_timeout). Through a server: the server's silence that fails the session (5 s). */
LOCKROLL_API lockroll_status lockroll_builder_disconnect_timeouts(lockroll_builder* builder, uint64_t interrupt_us,
                                                                  uint64_t disconnect_us);
/* Watch a peer-to-peer match without playing: no local or remote players; the player of slot 0
 * listens at host:port. This process is spectator `index` (0..count-1 of
 * lockroll_builder_spectators, which every process of the match sets the same). */
LOCKROLL_API lockroll_status lockroll_builder_spectator(lockroll_builder* builder, const char* host, uint16_t port,
                                                        int32_t index);
/* Spectators the match admits (default 0); the same on every process. Peer to peer only: a relay
 * server sets its own places per room (lockroll_builder_start fails naming both). */
LOCKROLL_API lockroll_status lockroll_builder_spectators(lockroll_builder* builder, int32_t count);
/* Watch a match played through the relay server (lockroll_builder_server) without playing: no
 * local players; the server places this process. It loads a snapshot of a running match through
 * the server and follows the confirmed frames; lockroll_update() takes an input of 0 bytes. A
 * server started with a key needs a spectator's token (lockroll_builder_connect_token). */
LOCKROLL_API lockroll_status lockroll_builder_server_spectator(lockroll_builder* builder);
/* The connect token a backend issued for this process (`lockroll token`: a player's, or with
 * --spectate a spectator's), sent in every hello to a relay server started with a key. `size`
 * bytes (1..256) are copied. Through a server only (lockroll_builder_start fails otherwise); a
 * refused token fails the session with the server's reason (a LOCKROLL_EVENT_REFUSED event). */
LOCKROLL_API lockroll_status lockroll_builder_connect_token(lockroll_builder* builder, const uint8_t* token, size_t size);
/* Enter a running match in the local slot by snapshot. Not needed after a restart, peer to peer
 * or through a server: a player process started again with its usual settings rejoins by
 * snapshot by itself (through a server it says hello again while the server still counts the
 * previous process as live, up to the connect timeout). */
LOCKROLL_API lockroll_status lockroll_builder_join(lockroll_builder* builder);
/* Write every confirmed frame's inputs and checksum to a replay file (docs/replay-format.md)
 * when the run ends; scene_text (may be NULL) is what the game is rebuilt from. The path is
 * tried at start (LOCKROLL_START_FAILED naming it); not with join or spectator. */
LOCKROLL_API lockroll_status lockroll_builder_record_replay(lockroll_builder* builder, const char* path,
                                                            const char* scene_text);
/* On a desync, write the evidence file (names body and field) into this directory, created at
 * start; a LOCKROLL_EVENT_DESYNC_REPORT event names it either way. */
LOCKROLL_API lockroll_status lockroll_builder_desync_report_dir(lockroll_builder* builder, const char* path);
/* Binds the port and builds the session on `game` (in its initial state) with `user`. NULL on a
 * configuration error (lockroll_last_error() names the setting). The builder stays usable. */
LOCKROLL_API lockroll_session* lockroll_builder_start(const lockroll_builder* builder, const lockroll_game* game,
                                                      void* user);

/* ---- the session ---- */
LOCKROLL_API void lockroll_session_free(lockroll_session* session);
/* One frame of the game's loop; never blocks. `input` holds input_size bytes per local player
 * (slot order), used for every tick this call runs. `out` (may be NULL) says what happened. An
 * input of the wrong size is LOCKROLL_INVALID_ARGUMENT and runs nothing. */
LOCKROLL_API lockroll_status lockroll_update(lockroll_session* session, const uint8_t* input, size_t input_size,
                                             lockroll_update_result* out);
/* Sleeps until the next tick is due (at most about a millisecond). */
LOCKROLL_API void lockroll_wait(const lockroll_session* session);
/* Any thread, signal handlers too: the run ends (LOCKROLL_STOPPED) at the next update. */
LOCKROLL_API void lockroll_request_stop(lockroll_session* session);
/* The oldest event not taken yet: 1 and *out filled, or 0 when there is none (the newest 1024
 * are kept). */
LOCKROLL_API int lockroll_next_event(lockroll_session* session, lockroll_event* out);
/* Why the event lockroll_next_event() last filled in happened, as a stable name: "timed_out",
 * "kick_vote_two_player_rule", "match_id", "tie_rule", ... (rollback/events.h's
 * SessionEvent::Reason and reason_name(); docs/sessions.md lists them). "none" when the kind
 * says it all, before the first event and for a NULL session. Never NULL; the string is
 * lockroll's for as long as the library is loaded. (A function, not a lockroll_event field:
 * that struct has no struct_size, so it cannot grow.) */
LOCKROLL_API const char* lockroll_event_reason(const lockroll_session* session);
LOCKROLL_API lockroll_status lockroll_network_stats(const lockroll_session* session, int32_t peer,
                                                    lockroll_stats* out);
/* The confirmed checksum of a recent frame; LOCKROLL_NOT_FOUND when not confirmed (or too old). */
LOCKROLL_API lockroll_status lockroll_confirmed_checksum(const lockroll_session* session, uint32_t frame,
                                                         uint64_t* out);
/* The confirmed checksum of the last frame (lockroll_builder_frames), once the run completed. */
LOCKROLL_API lockroll_status lockroll_final_checksum(const lockroll_session* session, uint64_t* out);
/* The frame shown now, and the newest frame every input of which is confirmed. */
LOCKROLL_API uint32_t lockroll_frame(const lockroll_session* session);
LOCKROLL_API uint32_t lockroll_confirmed_frame(const lockroll_session* session);
/* The UDP port this process listens on. */
LOCKROLL_API uint16_t lockroll_port(const lockroll_session* session);
/* The first failure writing the replay or a desync evidence file ("" when none, or for NULL).
 * Valid until the next lockroll_output_error() or lockroll_session_free() on that session. */
LOCKROLL_API const char* lockroll_output_error(const lockroll_session* session);

#ifdef __cplusplus
}
#endif

#endif /* LOCKROLL_LOCKROLL_H */
