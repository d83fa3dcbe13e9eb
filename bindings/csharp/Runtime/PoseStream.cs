// A client of glovepose serve's engine stream (docs/pose_stream.md, version 1): poses from the
// service over TCP on loopback, for an engine that runs the service instead of loading the
// library. Needs no native library. One connection is read by one thread; reading waits at most
// the time it is given and allocates nothing.
using System;
using System.Net.Sockets;

namespace GlovePose
{
    /// <summary>One pose of the engine stream, as the service sent it.</summary>
    public struct StreamPose
    {
        /// <summary>The hand the glove is on.</summary>
        public Hand Hand;
        /// <summary>The pose's PoseFlag bits (include/glovepose/pose.hpp).</summary>
        public uint Flags;
        /// <summary>Poses the estimator has made, this one included: a gap is poses this client missed.</summary>
        public ulong Sequence;
        /// <summary>The pose's time on the glove's clock, seconds.</summary>
        public double StreamTime;
        /// <summary>That moment on the host's monotonic clock, seconds.</summary>
        public double HostTime;
        /// <summary>When the service sent it, on the same clock, seconds.</summary>
        public double Published;
        /// <summary>The 25 joint angles, radians, in the order of the library's DoFs (Pose.Angle).</summary>
        public double[] Angles;

        /// <summary>A pose with its angle array made: reuse it for every read.</summary>
        public static StreamPose Create() { return new StreamPose { Angles = new double[PoseStream.AngleCount] }; }
    }

    /// <summary>What a read gave.</summary>
    public enum StreamStatus
    {
        /// <summary>A pose was read.</summary>
        Pose = 0,
        /// <summary>No whole pose arrived within the wait.</summary>
        None = 1,
        /// <summary>The service closed the connection.</summary>
        Closed = 2,
        /// <summary>A message's magic, version, count or CRC is wrong: the client lost its place; reconnect.</summary>
        BadMessage = 3,
        /// <summary>The socket failed.</summary>
        Error = 4,
    }

    /// <summary>A connection to the engine stream.</summary>
    public sealed class PoseStream : IDisposable
    {
        /// <summary>Bytes of one message.</summary>
        public const int MessageBytes = 248;
        /// <summary>Joint angles per pose.</summary>
        public const int AngleCount = 25;

        readonly Socket socket;
        readonly byte[] buffer = new byte[MessageBytes];
        int have;
        static readonly uint[] CrcTable = MakeCrcTable();

        /// <summary>Connects to the service at host:port (set-up: may block; throws SocketException).</summary>
        public PoseStream(string host, int port)
        {
            var client = new TcpClient();
            client.NoDelay = true;
            client.Connect(host, port);
            socket = client.Client;
        }

        /// <summary>The next pose into <paramref name="pose"/> (made by StreamPose.Create()), waiting at
        /// most <paramref name="waitMilliseconds"/> (0: only what has arrived; -1: until one comes).</summary>
        public StreamStatus Read(ref StreamPose pose, int waitMilliseconds)
        {
            try
            {
                while (have < MessageBytes)
                {
                    int micro = waitMilliseconds < 0 ? -1 : waitMilliseconds * 1000;
                    if (!socket.Poll(micro, SelectMode.SelectRead)) return StreamStatus.None;
                    int got = socket.Receive(buffer, have, MessageBytes - have, SocketFlags.None);
                    if (got == 0) return StreamStatus.Closed;
                    have += got;
                }
            }
            catch (SocketException)
            {
                return StreamStatus.Error;
            }
            catch (ObjectDisposedException)
            {
                return StreamStatus.Closed;
            }
            have = 0;
            return Decode(buffer, 0, ref pose);
        }

        /// <summary>The newest pose that has arrived, without waiting: every whole message waiting is
        /// read and the last kept (a game loop's call once per frame). None when none has arrived.</summary>
        public StreamStatus ReadLatest(ref StreamPose pose)
        {
            StreamStatus newest = StreamStatus.None;
            for (;;)
            {
                StreamStatus s = Read(ref pose, 0);
                if (s == StreamStatus.None) return newest;
                if (s != StreamStatus.Pose) return s;
                newest = StreamStatus.Pose;
            }
        }

        /// <summary>Decodes one message at <paramref name="offset"/>: Pose, or BadMessage.</summary>
        public static StreamStatus Decode(byte[] m, int offset, ref StreamPose pose)
        {
            if (m[offset] != (byte)'G' || m[offset + 1] != (byte)'H' || m[offset + 2] != 1 || m[offset + 3] > 1 || Little(m, offset + 40, 2) != AngleCount)
                return StreamStatus.BadMessage;
            if ((uint)Little(m, offset + 244, 4) != Crc32(m, offset, 244)) return StreamStatus.BadMessage;
            if (pose.Angles == null || pose.Angles.Length != AngleCount) pose.Angles = new double[AngleCount];
            pose.Hand = m[offset + 3] == 0 ? Hand.Right : Hand.Left;
            pose.Flags = (uint)Little(m, offset + 4, 4);
            pose.Sequence = Little(m, offset + 8, 8);
            pose.StreamTime = BitConverter.Int64BitsToDouble((long)Little(m, offset + 16, 8));
            pose.HostTime = BitConverter.Int64BitsToDouble((long)Little(m, offset + 24, 8));
            pose.Published = BitConverter.Int64BitsToDouble((long)Little(m, offset + 32, 8));
            for (int d = 0; d < AngleCount; ++d) pose.Angles[d] = BitConverter.Int64BitsToDouble((long)Little(m, offset + 44 + 8 * d, 8));
            return StreamStatus.Pose;
        }

        /// <summary>Closes the connection.</summary>
        public void Dispose() { socket.Close(); }

        static ulong Little(byte[] m, int at, int bytes)
        {
            ulong v = 0;
            for (int i = bytes - 1; i >= 0; --i) v = (v << 8) | m[at + i];
            return v;
        }

        // CRC-32 as zlib computes it (reflected polynomial 0xEDB88320, all ones in and out).
        static uint Crc32(byte[] m, int at, int size)
        {
            uint crc = 0xFFFFFFFFu;
            for (int i = 0; i < size; ++i) crc = CrcTable[(crc ^ m[at + i]) & 0xFF] ^ (crc >> 8);
            return ~crc;
        }

        static uint[] MakeCrcTable()
        {
            var table = new uint[256];
            for (uint n = 0; n < 256; ++n)
            {
                uint c = n;
                for (int k = 0; k < 8; ++k) c = (c & 1) != 0 ? 0xEDB88320u ^ (c >> 1) : c >> 1;
                table[n] = c;
            }
            return table;
        }
    }
}
