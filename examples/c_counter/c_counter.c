/* examples/counter's game in C99 over lockroll's C ABI: one integer, two players. Each frame
 * every player may press (one byte of input); the counter grows by 1 and by each press times
 * the player's weight (slot + 2).
 *
 *   c_counter SLOT MY_PORT PEER_PORT [FRAMES]   e.g.  c_counter 0 7000 7001  &  c_counter 1 7001 7000
 *
 * Both processes play FRAMES frames (default 300) on 127.0.0.1 and print the confirmed checksum
 * of the last frame, which must be the same on both. The game owns its loop: one
 * lockroll_update() per 10 ms frame of its own, with this frame's input (used for every tick
 * the call runs). Bad arguments: a message naming the argument, exit 2, nothing bound.
 */
#define _POSIX_C_SOURCE 199309L /* nanosleep */

#include <lockroll/lockroll.h>

#include <errno.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

/* The game: its whole state is one integer, saved as 8 little-endian bytes. */
typedef struct counter {
    int64_t value;
} counter;

static size_t counter_save(void* user, uint8_t* out, size_t capacity) {
    const uint64_t v = (uint64_t)((counter*)user)->value;
    int i;
    if (capacity < 8) return 0;
    for (i = 0; i < 8; ++i) out[i] = (uint8_t)(v >> (8 * i));
    return 8;
}

static int counter_load(void* user, const uint8_t* state, size_t size) {
    uint64_t v = 0;
    int i;
    if (size != 8) return 1; /* not one of ours: the state stays as it is */
    for (i = 0; i < 8; ++i) v |= (uint64_t)state[i] << (8 * i);
    ((counter*)user)->value = (int64_t)v;
    return 0;
}

static void counter_advance(void* user, const uint8_t* inputs, size_t inputs_size, const uint8_t* status,
                            uint32_t players) {
    counter* c = (counter*)user;
    size_t p;
    (void)status;
    (void)players;
    c->value += 1;
    for (p = 0; p < inputs_size; ++p) c->value += (int64_t)inputs[p] * (int64_t)(p + 2);
}

/* Parses a whole decimal number in [lo, hi]; 0 on anything else. */
static int parse(const char* text, long lo, long hi, long* out) {
    char* end = NULL;
    long v;
    errno = 0;
    v = strtol(text, &end, 10);
    if (errno != 0 || end == text || *end != '\0' || v < lo || v > hi) return 0;
    *out = v;
    return 1;
}

static int usage(const char* what, const char* got) {
    fprintf(stderr, "c_counter: %s: %s\nusage: c_counter SLOT(0|1) MY_PORT PEER_PORT [FRAMES]\n", what, got);
    return 2;
}

int main(int argc, char** argv) {
    long slot, my_port, peer_port, frames = 300;
    counter game = {0};
    lockroll_game callbacks;
    lockroll_builder* builder;
    lockroll_session* session;
    lockroll_update_result r;
    lockroll_event e;
    uint64_t checksum = 0;
    int have_checksum;
    struct timespec frame_time = {0, 10 * 1000 * 1000};

    if (argc < 4 || argc > 5) return usage("wrong number of arguments", argc > 1 ? argv[1] : "none");
    if (!parse(argv[1], 0, 1, &slot)) return usage("SLOT must be 0 or 1", argv[1]);
    if (!parse(argv[2], 1, 65535, &my_port)) return usage("MY_PORT must be 1..65535", argv[2]);
    if (!parse(argv[3], 1, 65535, &peer_port)) return usage("PEER_PORT must be 1..65535", argv[3]);
    if (argc == 5 && !parse(argv[4], 1, 1000000, &frames)) return usage("FRAMES must be 1..1000000", argv[4]);

    memset(&callbacks, 0, sizeof callbacks);
    callbacks.struct_size = sizeof callbacks;
    callbacks.state_size = 8;
    callbacks.save = counter_save;
    callbacks.load = counter_load;
    callbacks.advance = counter_advance;

    builder = lockroll_builder_new();
    if (!builder || lockroll_builder_players(builder, 2) || lockroll_builder_input_size(builder, 1) ||
        lockroll_builder_local_player(builder, (int32_t)slot) ||
        lockroll_builder_remote_player(builder, (int32_t)(1 - slot), "127.0.0.1", (uint16_t)peer_port) ||
        lockroll_builder_listen(builder, "127.0.0.1", (uint16_t)my_port) || lockroll_builder_match_id(builder, 0xc0117e4) ||
        lockroll_builder_frames(builder, (uint32_t)frames)) {
        fprintf(stderr, "c_counter: %s\n", lockroll_last_error());
        lockroll_builder_free(builder);
        return 2;
    }
    session = lockroll_builder_start(builder, &callbacks, &game);
    lockroll_builder_free(builder); /* the session does not keep it */
    if (!session) {
        fprintf(stderr, "c_counter: %s\n", lockroll_last_error());
        return 2;
    }

    /* The game's own loop, 100 frames a second against the match's 60 ticks. */
    for (;;) {
        /* A scripted player: presses now and then, differently per slot. */
        const uint32_t f = lockroll_frame(session);
        const uint8_t press = (uint8_t)(((f / 7 + (uint32_t)slot) % 3) == 0 ? 1 : 0);
        if (lockroll_update(session, &press, 1, &r) != LOCKROLL_OK) {
            fprintf(stderr, "c_counter: %s\n", lockroll_last_error());
            lockroll_session_free(session);
            return 1;
        }
        while (lockroll_next_event(session, &e))
            fprintf(stderr, "event %s peer %d frame %u %s\n", lockroll_event_name(e.kind), (int)e.player,
                    (unsigned)e.frame, e.detail);
        if (r.outcome != LOCKROLL_RUNNING) break;
        nanosleep(&frame_time, NULL);
    }

    have_checksum = lockroll_final_checksum(session, &checksum) == LOCKROLL_OK;
    printf("slot %ld %s frame %ld checksum %016llx\n", slot, lockroll_outcome_name(r.outcome), frames,
           (unsigned long long)checksum);
    lockroll_session_free(session);
    return r.outcome == LOCKROLL_COMPLETED && have_checksum ? 0 : 1;
}
