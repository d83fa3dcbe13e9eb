// Prints the poses of glovepose serve's engine stream, one line each: the sequence, the stream time
// and the 25 angles ("R" formatting: each double as it is), comma-separated. The sample of
// Runtime/PoseStream.cs; needs no native library.
// Build and run (Mono): mcs -unsafe -out:StreamPrint.exe Runtime/*.cs Samples~/StreamPrint.cs
//                      mono StreamPrint.exe HOST PORT [COUNT]
using System;
using System.Globalization;
using System.Text;
using GlovePose;

public static class StreamPrint
{
    public static int Main(string[] args)
    {
        int port;
        if (args.Length < 2 || !int.TryParse(args[1], out port) || port < 1 || port > 65535)
        {
            Console.Error.WriteLine("usage: StreamPrint.exe HOST PORT [COUNT]");
            return 2;
        }
        long count = args.Length > 2 ? long.Parse(args[2], CultureInfo.InvariantCulture) : -1, printed = 0;
        var pose = StreamPose.Create();
        var line = new StringBuilder();
        using (var stream = new PoseStream(args[0], port))
        {
            StreamStatus status = StreamStatus.Pose;
            while ((count < 0 || printed < count) && (status = stream.Read(ref pose, 5000)) == StreamStatus.Pose)
            {
                line.Clear();
                line.Append(pose.Sequence.ToString(CultureInfo.InvariantCulture)).Append(',').Append(pose.StreamTime.ToString("R", CultureInfo.InvariantCulture));
                foreach (double a in pose.Angles) line.Append(',').Append(a.ToString("R", CultureInfo.InvariantCulture));
                Console.WriteLine(line.ToString());
                ++printed;
            }
            if (status != StreamStatus.Pose) Console.Error.WriteLine("StreamPrint: the stream ended: {0}", status);
        }
        if (printed == 0) Console.Error.WriteLine("StreamPrint: no pose from {0}:{1}", args[0], port);
        return printed > 0 ? 0 : 1;
    }
}
