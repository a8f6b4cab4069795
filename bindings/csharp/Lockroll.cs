// lockroll from C#: P/Invoke declarations of the C ABI (<lockroll/lockroll.h>, liblockroll.so),
// one to one. Handles are IntPtr; the game's callbacks are delegates, which the caller must keep
// alive (a field, not a local) for as long as the session runs, since lockroll holds only their
// function pointers. lockroll copies the Game struct at start. The header's contract applies:
// one thread per session, strings handed out valid until the next call that replaces them.
// Mono and .NET find "lockroll" as liblockroll.so on the library path (LD_LIBRARY_PATH).
using System;
using System.Runtime.InteropServices;

namespace Lockroll {

public enum Status { Ok = 0, InvalidArgument = 1, StartFailed = 2, NotFound = 3, Internal = 4 }
public enum Outcome { Running = 0, Completed = 1, ConnectTimeout = 2, FinishTimeout = 3, RunTimeout = 4, Failed = 5,
                      Stopped = 6, Partitioned = 7, ServerLost = 8 }

[UnmanagedFunctionPointer(CallingConvention.Cdecl)]
public delegate UIntPtr SaveFn(IntPtr user, IntPtr outBytes, UIntPtr capacity);
[UnmanagedFunctionPointer(CallingConvention.Cdecl)]
public delegate int LoadFn(IntPtr user, IntPtr state, UIntPtr size);
[UnmanagedFunctionPointer(CallingConvention.Cdecl)]
public delegate void AdvanceFn(IntPtr user, IntPtr inputs, UIntPtr size, IntPtr status, uint players);

[StructLayout(LayoutKind.Sequential)]
public struct Game {  // lockroll_game
    public UIntPtr struct_size, state_size;
    public IntPtr save, load, advance, checksum;  // Marshal.GetFunctionPointerForDelegate; checksum may be zero
    public uint body_count;
    public int field_count;
    public IntPtr field_names, field_value;
}

[StructLayout(LayoutKind.Sequential)]
public struct UpdateResult {  // lockroll_update_result
    public int frames;
    public uint rollback_depth;
    public double interpolation;
    public uint events;
    public Outcome outcome;
}

[StructLayout(LayoutKind.Sequential)]
public struct Event {  // lockroll_event
    public int kind, player;
    public uint frame;
    public ulong at_us;
    public IntPtr detail;  // Marshal.PtrToStringAnsi
}

public static class Native {
    const string Lib = "lockroll";
    [DllImport(Lib)] public static extern IntPtr lockroll_version();
    [DllImport(Lib)] public static extern IntPtr lockroll_last_error();
    [DllImport(Lib)] public static extern IntPtr lockroll_outcome_name(Outcome outcome);
    [DllImport(Lib)] public static extern IntPtr lockroll_event_name(int kind);
    [DllImport(Lib)] public static extern IntPtr lockroll_builder_new();
    [DllImport(Lib)] public static extern void lockroll_builder_free(IntPtr b);
    [DllImport(Lib)] public static extern Status lockroll_builder_players(IntPtr b, int players);
    [DllImport(Lib)] public static extern Status lockroll_builder_input_size(IntPtr b, uint bytes);
    [DllImport(Lib)] public static extern Status lockroll_builder_local_player(IntPtr b, int slot);
    [DllImport(Lib)] public static extern Status lockroll_builder_remote_player(IntPtr b, int slot, string host, ushort port);
    [DllImport(Lib)] public static extern Status lockroll_builder_server(IntPtr b, string host, ushort port);
    [DllImport(Lib)] public static extern Status lockroll_builder_listen(IntPtr b, string host, ushort port);
    [DllImport(Lib)] public static extern Status lockroll_builder_tick_rate(IntPtr b, int hz);
    [DllImport(Lib)] public static extern Status lockroll_builder_input_delay(IntPtr b, int frames);
    [DllImport(Lib)] public static extern Status lockroll_builder_prediction_window(IntPtr b, int frames);
    [DllImport(Lib)] public static extern Status lockroll_builder_match_id(IntPtr b, ulong id);
    [DllImport(Lib)] public static extern Status lockroll_builder_frames(IntPtr b, uint frames);
    [DllImport(Lib)] public static extern Status lockroll_builder_timeouts(IntPtr b, ulong connectUs, ulong finishUs, ulong runUs);
    [DllImport(Lib)] public static extern Status lockroll_builder_disconnect_timeouts(IntPtr b, ulong interruptUs, ulong disconnectUs);
    [DllImport(Lib)] public static extern Status lockroll_builder_spectator(IntPtr b, string host, ushort port, int index);
    [DllImport(Lib)] public static extern Status lockroll_builder_spectators(IntPtr b, int count);
    [DllImport(Lib)] public static extern Status lockroll_builder_server_spectator(IntPtr b);
    [DllImport(Lib)] public static extern Status lockroll_builder_connect_token(IntPtr b, byte[] token, UIntPtr size);
    [DllImport(Lib)] public static extern Status lockroll_builder_join(IntPtr b);
    [DllImport(Lib)] public static extern Status lockroll_builder_record_replay(IntPtr b, string path, string sceneText);
    [DllImport(Lib)] public static extern Status lockroll_builder_desync_report_dir(IntPtr b, string path);
    [DllImport(Lib)] public static extern IntPtr lockroll_builder_start(IntPtr b, ref Game game, IntPtr user);
    [DllImport(Lib)] public static extern void lockroll_session_free(IntPtr s);
    [DllImport(Lib)] public static extern Status lockroll_update(IntPtr s, byte[] input, UIntPtr size, out UpdateResult result);
    [DllImport(Lib)] public static extern void lockroll_wait(IntPtr s);
    [DllImport(Lib)] public static extern void lockroll_request_stop(IntPtr s);
    [DllImport(Lib)] public static extern int lockroll_next_event(IntPtr s, out Event e);
    // Why the event just taken happened: a stable name ("timed_out", "tie_rule", "none", ...).
    [DllImport(Lib)] public static extern IntPtr lockroll_event_reason(IntPtr s);
    [DllImport(Lib)] public static extern Status lockroll_confirmed_checksum(IntPtr s, uint frame, out ulong checksum);
    [DllImport(Lib)] public static extern Status lockroll_final_checksum(IntPtr s, out ulong checksum);
    [DllImport(Lib)] public static extern uint lockroll_frame(IntPtr s);
    [DllImport(Lib)] public static extern uint lockroll_confirmed_frame(IntPtr s);
    [DllImport(Lib)] public static extern ushort lockroll_port(IntPtr s);
    [DllImport(Lib)] public static extern IntPtr lockroll_output_error(IntPtr s);

    public static string LastError() { return Marshal.PtrToStringAnsi(lockroll_last_error()); }
    public static string Text(IntPtr p) { return p == IntPtr.Zero ? "" : Marshal.PtrToStringAnsi(p); }
}

}  // namespace Lockroll
