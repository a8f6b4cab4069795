// A 2-player game in C# over bindings/csharp/Lockroll.cs (P/Invoke into liblockroll.so): one
// integer, as examples/c_counter.
//   CsharpCounter.exe SLOT MY_PORT PEER_PORT FRAMES
// Prints "slot S OUTCOME frame F checksum HEX value V"; exit 0 when completed with a checksum,
// 2 on a bad setting (lockroll's message).
using System;
using System.Runtime.InteropServices;
using System.Threading;
using Lockroll;

static class CsharpCounter {
    static long value;
    // Kept in fields: lockroll holds only their function pointers.
    static readonly SaveFn save = (user, outBytes, capacity) => {
        if ((ulong)capacity < 8) return UIntPtr.Zero;
        Marshal.Copy(BitConverter.GetBytes(value), 0, outBytes, 8);  // little-endian on every target we run
        return (UIntPtr)8;
    };
    static readonly LoadFn load = (user, state, size) => {
        if ((ulong)size != 8) return 1;
        var bytes = new byte[8];
        Marshal.Copy(state, bytes, 0, 8);
        value = BitConverter.ToInt64(bytes, 0);
        return 0;
    };
    static readonly AdvanceFn advance = (user, inputs, size, status, players) => {
        var bytes = new byte[(int)(ulong)size];
        Marshal.Copy(inputs, bytes, 0, bytes.Length);
        value += 1;
        for (int p = 0; p < bytes.Length; ++p) value += bytes[p] * (p + 2);
    };

    static int Fail(string what) {
        Console.Error.WriteLine("csharp_counter: " + what);
        return 2;
    }

    static int Main(string[] args) {
        if (args.Length != 4) return Fail("usage: CsharpCounter.exe SLOT MY_PORT PEER_PORT FRAMES");
        int slot;
        ushort myPort, peerPort;
        uint frames;
        if (!int.TryParse(args[0], out slot)) return Fail("SLOT must be an integer, got " + args[0]);
        if (!ushort.TryParse(args[1], out myPort)) return Fail("MY_PORT must be 0..65535, got " + args[1]);
        if (!ushort.TryParse(args[2], out peerPort)) return Fail("PEER_PORT must be 0..65535, got " + args[2]);
        if (!uint.TryParse(args[3], out frames)) return Fail("FRAMES must be a non-negative integer, got " + args[3]);
        var game = new Game {
            struct_size = (UIntPtr)Marshal.SizeOf(typeof(Game)), state_size = (UIntPtr)8,
            save = Marshal.GetFunctionPointerForDelegate(save), load = Marshal.GetFunctionPointerForDelegate(load),
            advance = Marshal.GetFunctionPointerForDelegate(advance),
        };
        IntPtr b = Native.lockroll_builder_new();
        if (Native.lockroll_builder_players(b, 2) != Status.Ok || Native.lockroll_builder_input_size(b, 1) != Status.Ok ||
            Native.lockroll_builder_local_player(b, slot) != Status.Ok ||
            Native.lockroll_builder_remote_player(b, 1 - slot, "127.0.0.1", peerPort) != Status.Ok ||
            Native.lockroll_builder_listen(b, "127.0.0.1", myPort) != Status.Ok ||
            Native.lockroll_builder_match_id(b, 0xc0117e4) != Status.Ok || Native.lockroll_builder_frames(b, frames) != Status.Ok)
            return Fail(Native.LastError());
        IntPtr s = Native.lockroll_builder_start(b, ref game, IntPtr.Zero);
        Native.lockroll_builder_free(b);
        if (s == IntPtr.Zero) return Fail(Native.LastError());
        UpdateResult r;
        var input = new byte[1];
        for (;;) {  // the game's own loop, 100 frames a second
            input[0] = (byte)(((Native.lockroll_frame(s) / 7 + (uint)slot) % 3) == 0 ? 1 : 0);
            if (Native.lockroll_update(s, input, (UIntPtr)1, out r) != Status.Ok) return Fail(Native.LastError());
            Event e;
            while (Native.lockroll_next_event(s, out e) != 0)
                Console.Error.WriteLine("event " + Native.Text(Native.lockroll_event_name(e.kind)) + " (" +
                                        Native.Text(Native.lockroll_event_reason(s)) + ") peer " + e.player +
                                        " frame " + e.frame + " " + Native.Text(e.detail));
            if (r.outcome != Outcome.Running) break;
            Thread.Sleep(10);
        }
        ulong checksum;
        bool have = Native.lockroll_final_checksum(s, out checksum) == Status.Ok;
        Console.WriteLine("slot " + slot + " " + Native.Text(Native.lockroll_outcome_name(r.outcome)) + " frame " + frames +
                          " checksum " + checksum.ToString("x16") + " value " + value);
        Native.lockroll_session_free(s);
        GC.KeepAlive(save); GC.KeepAlive(load); GC.KeepAlive(advance);
        return r.outcome == Outcome.Completed && have ? 0 : 1;
    }
}
