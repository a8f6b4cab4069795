"""lockroll from Python: a ctypes binding of the C ABI (<lockroll/lockroll.h>, liblockroll.so).

Standard library only. The game is a Python object with save() -> bytes, load(bytes) -> bool and
advance(inputs: bytes, status: bytes); lockroll calls them from inside Session.update() (and
start()), on the calling thread. Contract, as the C header's:
  - Errors raise LockrollError with lockroll's message (naming the setting); nothing else of
    lockroll raises. An exception inside a game callback cannot cross the C boundary: it is kept,
    the callback returns as if refused (load) or did nothing, and update() re-raises it.
  - One thread at a time per session; request_stop() from anywhere.
  - The library: LOCKROLL_LIBRARY (a path) if set, else ctypes.util.find_library("lockroll").

    game = MyGame()
    s = lockroll.Builder().players(2).input_size(1).local_player(0) \\
            .remote_player(1, "127.0.0.1", 7001).listen("127.0.0.1", 7000).frames(300).start(game)
    while True:
        r = s.update(bytes([button]))          # never blocks
        for e in s.events(): print(e)
        if r.outcome != lockroll.RUNNING: break
        time.sleep(0.01)
    print(hex(s.final_checksum()))
"""
import ctypes
import ctypes.util
import os

__all__ = ["Builder", "Session", "LockrollError", "Event", "UpdateResult", "Stats", "library"]

OK, INVALID_ARGUMENT, START_FAILED, NOT_FOUND, INTERNAL = range(5)
RUNNING, COMPLETED, CONNECT_TIMEOUT, FINISH_TIMEOUT, RUN_TIMEOUT, FAILED, STOPPED, PARTITIONED, SERVER_LOST = range(9)
INPUT_CONFIRMED, INPUT_PREDICTED, INPUT_ABSENT = range(3)


class LockrollError(Exception):
    """A lockroll call failed; str() is lockroll's message, .status its lockroll_status."""

    def __init__(self, status, message):
        super().__init__(message)
        self.status = status


_SAVE = ctypes.CFUNCTYPE(ctypes.c_size_t, ctypes.c_void_p, ctypes.POINTER(ctypes.c_uint8), ctypes.c_size_t)
_LOAD = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.c_void_p, ctypes.POINTER(ctypes.c_uint8), ctypes.c_size_t)
_ADVANCE = ctypes.CFUNCTYPE(None, ctypes.c_void_p, ctypes.POINTER(ctypes.c_uint8), ctypes.c_size_t,
                            ctypes.POINTER(ctypes.c_uint8), ctypes.c_uint32)
_CHECKSUM = ctypes.CFUNCTYPE(ctypes.c_uint64, ctypes.c_void_p, ctypes.POINTER(ctypes.c_uint8), ctypes.c_size_t)
_FIELD_VALUE = ctypes.CFUNCTYPE(ctypes.c_int64, ctypes.c_void_p, ctypes.POINTER(ctypes.c_uint8), ctypes.c_size_t,
                                ctypes.c_uint32, ctypes.c_int32)


class _Game(ctypes.Structure):
    _fields_ = [("struct_size", ctypes.c_size_t), ("state_size", ctypes.c_size_t), ("save", _SAVE),
                ("load", _LOAD), ("advance", _ADVANCE), ("checksum", _CHECKSUM), ("body_count", ctypes.c_uint32),
                ("field_count", ctypes.c_int32), ("field_names", ctypes.POINTER(ctypes.c_char_p)),
                ("field_value", _FIELD_VALUE)]


class _Event(ctypes.Structure):
    _fields_ = [("kind", ctypes.c_int), ("player", ctypes.c_int32), ("frame", ctypes.c_uint32),
                ("at_us", ctypes.c_uint64), ("detail", ctypes.c_char_p)]


class _UpdateResult(ctypes.Structure):
    _fields_ = [("frames", ctypes.c_int32), ("rollback_depth", ctypes.c_uint32), ("interpolation", ctypes.c_double),
                ("events", ctypes.c_uint32), ("outcome", ctypes.c_int)]


class _Stats(ctypes.Structure):
    _fields_ = [("ping_us", ctypes.c_uint64), ("jitter_us", ctypes.c_uint64), ("frames_behind", ctypes.c_int32),
                ("send_queue", ctypes.c_uint32), ("bytes_sent", ctypes.c_uint64), ("bytes_received", ctypes.c_uint64),
                ("kbps_sent", ctypes.c_double), ("kbps_received", ctypes.c_double), ("interrupted", ctypes.c_int32)]


def _load_library():
    path = os.environ.get("LOCKROLL_LIBRARY") or ctypes.util.find_library("lockroll")
    if not path:
        raise OSError("liblockroll.so not found: set LOCKROLL_LIBRARY to its path")
    lib = ctypes.CDLL(path)
    P, u8p = ctypes.c_void_p, ctypes.POINTER(ctypes.c_uint8)
    sig = {
        "lockroll_version": (ctypes.c_char_p, []),
        "lockroll_last_error": (ctypes.c_char_p, []),
        "lockroll_outcome_name": (ctypes.c_char_p, [ctypes.c_int]),
        "lockroll_event_name": (ctypes.c_char_p, [ctypes.c_int]),
        "lockroll_builder_new": (P, []),
        "lockroll_builder_free": (None, [P]),
        "lockroll_builder_players": (ctypes.c_int, [P, ctypes.c_int32]),
        "lockroll_builder_input_size": (ctypes.c_int, [P, ctypes.c_uint32]),
        "lockroll_builder_local_player": (ctypes.c_int, [P, ctypes.c_int32]),
        "lockroll_builder_remote_player": (ctypes.c_int, [P, ctypes.c_int32, ctypes.c_char_p, ctypes.c_uint16]),
        "lockroll_builder_server": (ctypes.c_int, [P, ctypes.c_char_p, ctypes.c_uint16]),
        "lockroll_builder_listen": (ctypes.c_int, [P, ctypes.c_char_p, ctypes.c_uint16]),
        "lockroll_builder_tick_rate": (ctypes.c_int, [P, ctypes.c_int32]),
        "lockroll_builder_input_delay": (ctypes.c_int, [P, ctypes.c_int32]),
        "lockroll_builder_prediction_window": (ctypes.c_int, [P, ctypes.c_int32]),
        "lockroll_builder_match_id": (ctypes.c_int, [P, ctypes.c_uint64]),
        "lockroll_builder_frames": (ctypes.c_int, [P, ctypes.c_uint32]),
        "lockroll_builder_timeouts": (ctypes.c_int, [P, ctypes.c_uint64, ctypes.c_uint64, ctypes.c_uint64]),
        "lockroll_builder_disconnect_timeouts": (ctypes.c_int, [P, ctypes.c_uint64, ctypes.c_uint64]),
        "lockroll_builder_spectator": (ctypes.c_int, [P, ctypes.c_char_p, ctypes.c_uint16, ctypes.c_int32]),
        "lockroll_builder_spectators": (ctypes.c_int, [P, ctypes.c_int32]),
        "lockroll_builder_server_spectator": (ctypes.c_int, [P]),
        "lockroll_builder_connect_token": (ctypes.c_int, [P, ctypes.POINTER(ctypes.c_uint8), ctypes.c_size_t]),
        "lockroll_builder_join": (ctypes.c_int, [P]),
        "lockroll_builder_record_replay": (ctypes.c_int, [P, ctypes.c_char_p, ctypes.c_char_p]),
        "lockroll_builder_desync_report_dir": (ctypes.c_int, [P, ctypes.c_char_p]),
        "lockroll_builder_start": (P, [P, ctypes.POINTER(_Game), P]),
        "lockroll_session_free": (None, [P]),
        "lockroll_update": (ctypes.c_int, [P, u8p, ctypes.c_size_t, ctypes.POINTER(_UpdateResult)]),
        "lockroll_wait": (None, [P]),
        "lockroll_request_stop": (None, [P]),
        "lockroll_next_event": (ctypes.c_int, [P, ctypes.POINTER(_Event)]),
        "lockroll_event_reason": (ctypes.c_char_p, [P]),
        "lockroll_network_stats": (ctypes.c_int, [P, ctypes.c_int32, ctypes.POINTER(_Stats)]),
        "lockroll_confirmed_checksum": (ctypes.c_int, [P, ctypes.c_uint32, ctypes.POINTER(ctypes.c_uint64)]),
        "lockroll_final_checksum": (ctypes.c_int, [P, ctypes.POINTER(ctypes.c_uint64)]),
        "lockroll_frame": (ctypes.c_uint32, [P]),
        "lockroll_confirmed_frame": (ctypes.c_uint32, [P]),
        "lockroll_port": (ctypes.c_uint16, [P]),
        "lockroll_output_error": (ctypes.c_char_p, [P]),
    }
    for name, (restype, argtypes) in sig.items():
        f = getattr(lib, name)
        f.restype, f.argtypes = restype, argtypes
    return lib


_lib = None


def library():
    """The loaded liblockroll.so (loaded on first use)."""
    global _lib
    if _lib is None:
        _lib = _load_library()
    return _lib


def _check(status):
    if status != OK:
        raise LockrollError(status, library().lockroll_last_error().decode())


def version():
    return library().lockroll_version().decode()


def outcome_name(outcome):
    return library().lockroll_outcome_name(outcome).decode()


class Event:
    """One session event: kind (LOCKROLL_EVENT_* value), name, player, frame, at_us, detail, and
    reason: why, as a stable name ("timed_out", "tie_rule", ...; "none" when the kind says it all)."""

    def __init__(self, e, reason="none"):
        self.kind, self.player, self.frame, self.at_us = e.kind, e.player, e.frame, e.at_us
        self.name = library().lockroll_event_name(e.kind).decode()
        self.detail = e.detail.decode(errors="replace") if e.detail else ""
        self.reason = reason

    def __repr__(self):
        return f"event {self.name} ({self.reason}) peer {self.player} frame {self.frame} {self.detail}"


class UpdateResult:
    def __init__(self, r):
        self.frames, self.rollback_depth, self.interpolation = r.frames, r.rollback_depth, r.interpolation
        self.events, self.outcome = r.events, r.outcome


class Stats:
    def __init__(self, s):
        for name, _ in _Stats._fields_:
            setattr(self, name, getattr(s, name))


class Builder:
    """lockroll_builder: each setter returns self; errors raise LockrollError."""

    def __init__(self):
        self._lib = library()
        self._b = self._lib.lockroll_builder_new()
        if not self._b:
            raise LockrollError(INTERNAL, self._lib.lockroll_last_error().decode())

    def __del__(self):
        if getattr(self, "_b", None):
            self._lib.lockroll_builder_free(self._b)
            self._b = None

    def _set(self, fn, *args):
        _check(getattr(self._lib, "lockroll_builder_" + fn)(self._b, *args))
        return self

    def players(self, n): return self._set("players", n)
    def input_size(self, n): return self._set("input_size", n)
    def local_player(self, slot): return self._set("local_player", slot)
    def remote_player(self, slot, host, port): return self._set("remote_player", slot, host.encode(), port)
    def server(self, host, port): return self._set("server", host.encode(), port)
    def listen(self, host, port): return self._set("listen", host.encode(), port)
    def tick_rate(self, hz): return self._set("tick_rate", hz)
    def input_delay(self, frames): return self._set("input_delay", frames)
    def prediction_window(self, frames): return self._set("prediction_window", frames)
    def match_id(self, i): return self._set("match_id", i)
    def frames(self, n): return self._set("frames", n)
    def timeouts(self, connect_us=0, finish_us=0, run_us=0): return self._set("timeouts", connect_us, finish_us, run_us)
    def disconnect_timeouts(self, interrupt_us=0, disconnect_us=0):
        return self._set("disconnect_timeouts", interrupt_us, disconnect_us)
    def spectator(self, host, port, index=0): return self._set("spectator", host.encode(), port, index)
    def spectators(self, n): return self._set("spectators", n)
    # Watch a match played through server(host, port); the server places this process.
    def server_spectator(self): return self._set("server_spectator")
    # The connect token (bytes) for a server started with a key: a player's or a spectator's.
    def connect_token(self, token):
        token = bytes(token)
        return self._set("connect_token", (ctypes.c_uint8 * len(token)).from_buffer_copy(token), len(token))
    def join(self): return self._set("join")
    def record_replay(self, path, scene_text=None):
        return self._set("record_replay", path.encode(), None if scene_text is None else scene_text.encode())
    def desync_report_dir(self, path): return self._set("desync_report_dir", path.encode())

    def start(self, game, state_size):
        """Starts a session on `game` (save/load/advance, see the module doc); state_size: the
        most bytes save() returns."""
        return Session(self, game, state_size)


class Session:
    def __init__(self, builder, game, state_size):
        self._lib = library()
        self._game = game
        self._error = None  # an exception a callback raised, re-raised by update()
        self._callbacks = _Game(ctypes.sizeof(_Game), state_size, _SAVE(self._save), _LOAD(self._load),
                                _ADVANCE(self._advance), _CHECKSUM(0), 0, 0, None, _FIELD_VALUE(0))
        self._s = self._lib.lockroll_builder_start(builder._b, ctypes.byref(self._callbacks), None)
        if not self._s:
            raise LockrollError(START_FAILED, self._lib.lockroll_last_error().decode())
        self._raise_pending()

    def _raise_pending(self):
        if self._error is not None:
            e, self._error = self._error, None
            raise e

    # The callbacks: exceptions stop here (they cannot unwind through C) and resurface in update().
    def _save(self, _user, out, capacity):
        try:
            data = bytes(self._game.save())
            if len(data) > capacity:  # lockroll fails the session, naming the sizes
                return len(data)
            ctypes.memmove(out, data, len(data))
            return len(data)
        except BaseException as e:  # noqa: BLE001 -- kept and re-raised by update()
            self._error = self._error or e
            return 0

    def _load(self, _user, state, size):
        try:
            return 0 if self._game.load(ctypes.string_at(state, size)) else 1
        except BaseException as e:  # noqa: BLE001
            self._error = self._error or e
            return 1

    def _advance(self, _user, inputs, size, status, players):
        try:
            self._game.advance(ctypes.string_at(inputs, size), ctypes.string_at(status, players))
        except BaseException as e:  # noqa: BLE001
            self._error = self._error or e

    def close(self):
        if getattr(self, "_s", None):
            self._lib.lockroll_session_free(self._s)
            self._s = None

    def __del__(self):
        self.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def update(self, local_input):
        """One frame of your loop with this frame's input bytes (input_size per local player);
        never blocks. Returns an UpdateResult (outcome RUNNING while the run goes on)."""
        data = bytes(local_input)
        buf = (ctypes.c_uint8 * max(1, len(data))).from_buffer_copy(data or b"\0")
        r = _UpdateResult()
        _check(self._lib.lockroll_update(self._s, buf, len(data), ctypes.byref(r)))
        self._raise_pending()
        return UpdateResult(r)

    def wait(self):
        self._lib.lockroll_wait(self._s)

    def request_stop(self):
        self._lib.lockroll_request_stop(self._s)

    def events(self):
        """The events not taken yet, oldest first."""
        out, e = [], _Event()
        while self._lib.lockroll_next_event(self._s, ctypes.byref(e)):
            out.append(Event(e, self._lib.lockroll_event_reason(self._s).decode()))
        return out

    def network_stats(self, peer):
        s = _Stats()
        _check(self._lib.lockroll_network_stats(self._s, peer, ctypes.byref(s)))
        return Stats(s)

    def confirmed_checksum(self, frame):
        """The confirmed checksum of `frame`, or None when it is not confirmed (or too old)."""
        c = ctypes.c_uint64()
        status = self._lib.lockroll_confirmed_checksum(self._s, frame, ctypes.byref(c))
        if status == NOT_FOUND:
            return None
        _check(status)
        return c.value

    def final_checksum(self):
        """The confirmed checksum of the last frame (Builder.frames), or None."""
        c = ctypes.c_uint64()
        status = self._lib.lockroll_final_checksum(self._s, ctypes.byref(c))
        if status == NOT_FOUND:
            return None
        _check(status)
        return c.value

    def frame(self):
        return self._lib.lockroll_frame(self._s)

    def confirmed_frame(self):
        return self._lib.lockroll_confirmed_frame(self._s)

    def port(self):
        return self._lib.lockroll_port(self._s)

    def output_error(self):
        """The first failure writing the replay or a desync evidence file; "" when none."""
        return self._lib.lockroll_output_error(self._s).decode()
