// The C# package's test, a console program (Mono's mcs + mono; no NUnit), compiled with the
// package's Runtime/*.cs and run against the native library (CTest `capi_csharp`).
//
// Usage: mono PackageTest.exe MODEL REFERENCE MALFORMED_FILE HEADER PACKAGE_JSON RANGE_FILE
// Compiled with Runtime/*.cs, EngineStandIns.cs and the ```csharp blocks of capi/README.md.
// REFERENCE is what capi/tests/csharp_reference.c (C, the C compiler's view) wrote: struct sizes and
// field offsets, the header's constants, the message of loading MALFORMED_FILE, and a session of
// rows pushed through the C ABI with every pose, joint list, OpenXR hand and aim state as the bits
// of their floats, then its other reads (predicted pose, cells, calibration state, range, steps),
// and RANGE_FILE, the calibration C saved. This test replays the same rows through the package and compares bit for bit.
// Prints each failed check and, last, "N passed, N failed"; exit code 0 when none failed.
using System;
using System.Collections.Generic;
using System.IO;
using System.Reflection;
using System.Runtime.InteropServices;
using System.Text;
using System.Text.RegularExpressions;
using System.Threading;
using GlovePose;

static class PackageTest
{
    static int passed, failed;

    static void Check(bool condition, string what)
    {
        if (condition) { ++passed; return; }
        ++failed;
        Console.WriteLine("FAILED: " + what);
    }

    static string Pascal(string snake)
    {
        var b = new StringBuilder();
        foreach (string part in snake.Split('_')) b.Append(char.ToUpperInvariant(part[0])).Append(part.Substring(1));
        return b.ToString();
    }

    static readonly Dictionary<string, Type> Structs = new Dictionary<string, Type>
    {
        { "glovepose_estimator_config", typeof(EstimatorConfig) }, { "glovepose_hand_options", typeof(HandOptions) },
        { "glovepose_pose", typeof(Pose) }, { "glovepose_joint", typeof(Joint) },
        { "glovepose_xr_joint_location", typeof(XrJointLocation) }, { "glovepose_xr_joint_velocity", typeof(XrJointVelocity) },
        { "glovepose_xr_hand", typeof(XrHand) }, { "glovepose_xr_aim_state", typeof(XrAimState) },
        { "glovepose_predicted_pose", typeof(PredictedPose) }, { "glovepose_calibration_progress", typeof(CalibrationProgress) },
        { "glovepose_calibration_step", typeof(CalibrationStep) },
    };

    // Every struct's size and every field's offset are the C compiler's; the C# struct has no
    // other field, and is blittable (pinning a non-blittable struct throws).
    static void TestLayout(string[] reference)
    {
        var fieldsSeen = new Dictionary<Type, int>();
        int sizes = 0;
        foreach (string line in reference)
        {
            string[] w = line.Split(' ');
            if (w[0] == "size")
            {
                Type t = Structs[w[1]];
                Check(Marshal.SizeOf(t) == int.Parse(w[2]), "sizeof " + w[1] + " = " + w[2] + " (C#: " + Marshal.SizeOf(t) + ")");
                GCHandle pin = default(GCHandle);
                bool blittable = true;
                try { pin = GCHandle.Alloc(Activator.CreateInstance(t), GCHandleType.Pinned); }
                catch (ArgumentException) { blittable = false; }
                if (pin.IsAllocated) pin.Free();
                Check(blittable, t.Name + " is blittable");
                fieldsSeen[t] = 0;
                ++sizes;
            }
            else if (w[0] == "offset")
            {
                Type t = Structs[w[1]];
                string field = Pascal(w[2]);
                long offset = -1;
                try { offset = Marshal.OffsetOf(t, field).ToInt64(); }
                catch (ArgumentException) { }
                Check(offset == long.Parse(w[3]), "offsetof(" + w[1] + ", " + w[2] + ") = " + w[3] + " (C# " + t.Name + "." + field + ": " + offset + ")");
                fieldsSeen[t] = fieldsSeen[t] + 1;
            }
        }
        Check(sizes == Structs.Count, "the reference lists every struct (" + sizes + ")");
        foreach (var entry in fieldsSeen)
        {
            int count = entry.Key.GetFields(BindingFlags.Instance | BindingFlags.Public | BindingFlags.NonPublic).Length;
            Check(count == entry.Value, entry.Key.Name + " has the C struct's " + entry.Value + " fields (C#: " + count + ")");
        }
    }

    // Every header constant has the C# enum member (or Counts field) of that name and value, and
    // every member of those enums is in the header.
    static void TestConstants(string[] reference)
    {
        var perGroup = new Dictionary<string, int>();
        foreach (string line in reference)
        {
            string[] w = line.Split(' ');
            if (w[0] != "const") continue;
            Type t = typeof(Status).Assembly.GetType("GlovePose." + w[1]);
            long value = long.MinValue;
            if (t.IsEnum)
            {
                if (Enum.IsDefined(t, w[2]))
                {
                    object member = Enum.Parse(t, w[2]);
                    value = Type.GetTypeCode(t) == TypeCode.UInt64 ? (long)(ulong)Convert.ChangeType(member, typeof(ulong))
                                                                    : Convert.ToInt64(Convert.ChangeType(member, Enum.GetUnderlyingType(t)));
                }
            }
            else
            {
                FieldInfo f = t.GetField(w[2]);
                if (f != null) value = Convert.ToInt64(f.GetValue(null));
            }
            Check(value == long.Parse(w[3]), w[1] + "." + w[2] + " = " + w[3] + " (C#: " + value + ")");
            int n;
            perGroup.TryGetValue(w[1], out n);
            perGroup[w[1]] = n + 1;
        }
        foreach (var entry in perGroup)
        {
            Type t = typeof(Status).Assembly.GetType("GlovePose." + entry.Key);
            int members = t.IsEnum ? Enum.GetNames(t).Length : t.GetFields(BindingFlags.Public | BindingFlags.Static).Length;
            Check(members == entry.Value, entry.Key + " has no member the header lacks (" + members + " vs " + entry.Value + ")");
        }
        Check(perGroup.Count == 9, "the reference lists 9 groups of constants");
    }

    // Native declares exactly the header's functions.
    static void TestDeclarations(string headerPath)
    {
        var header = new SortedSet<string>();
        foreach (Match m in Regex.Matches(File.ReadAllText(headerPath), @"GLOVEPOSE_C_API[^;(]*?\b(glovepose_\w+)\s*\("))
            header.Add(m.Groups[1].Value);
        var declared = new SortedSet<string>();
        foreach (MethodInfo m in typeof(Native).GetMethods(BindingFlags.Public | BindingFlags.Static)) declared.Add(m.Name);
        Check(header.Count > 50, "the header declares its functions (" + header.Count + ")");
        Check(header.SetEquals(declared), "Native declares the header's " + header.Count + " functions (C#: " + declared.Count + ")");
        foreach (string f in header) if (!declared.Contains(f)) Console.WriteLine("  not declared: " + f);
        foreach (string f in declared) if (!header.Contains(f)) Console.WriteLine("  not in the header: " + f);
    }

    static void TestLibrary(string packageJson)
    {
        Match version = Regex.Match(File.ReadAllText(packageJson), "\"version\"\\s*:\\s*\"([^\"]+)\"");
        Check(version.Success && version.Groups[1].Value == Library.Version,
              "package.json's version is the native library's (" + version.Groups[1].Value + " vs " + Library.Version + ")");
        Check(Library.AbiVersion == Counts.AbiVersion, "ABI version");
        Check(Library.ResultName(Status.Solved) == "solved" && Library.ResultName(Status.ErrorFileNotFound) == "file not found", "result names");
        Check(Library.XrJointName(10) == "index_tip" && Library.XrJointParent(10) == 9 && Library.DofName(25) == null, "names and parents");
    }

    static GlovePoseException Catch(Action action)
    {
        try { action(); }
        catch (GlovePoseException e) { return e; }
        return null;
    }

    // Set-up failures raise GlovePoseException with the library's own message and code.
    static void TestErrors(string[] reference, string modelPath, string malformed)
    {
        string[] expected = null;
        foreach (string line in reference) if (line.StartsWith("error ")) expected = line.Split(new[] { ' ' }, 3);
        GlovePoseException e = Catch(() => Model.Load(malformed));
        Check(e != null && e.Status == (Status)int.Parse(expected[1]) && e.Status == Status.ErrorInvalidFile,
              "a malformed model file: GlovePoseException with ErrorInvalidFile (got " + (e == null ? "none" : e.Status.ToString()) + ")");
        Check(e != null && e.Message == expected[2], "its message is the library's: '" + (e == null ? "" : e.Message) + "' vs '" + expected[2] + "'");
        Check(e != null && e.Message.Contains(malformed), "the message names the file");
        e = Catch(() => Model.Load("/nonexistent/glovepose.safetensors"));
        Check(e != null && e.Status == Status.ErrorFileNotFound && e.Message.Contains("/nonexistent/glovepose.safetensors"), "a missing model file");

        using (Model model = Model.Load(modelPath))
        {
            Check(model.CellCount == 44 && model.RowCount == 180 && model.GloveId == "glauser2019-44", "the shipped model's glove");
            EstimatorConfig bad = Estimator.DefaultConfig();
            bad.ReadoutSolveEvery = 0;
            e = Catch(() => new Estimator(model, bad).Dispose());
            Check(e != null && e.Status == Status.ErrorInvalidArgument && e.Message.Contains("solve_every"),
                  "bad settings: ErrorInvalidArgument naming the field (" + (e == null ? "none" : e.Message) + ")");
            using (var estimator = new Estimator(model))
            {
                var progress = CalibrationProgress.Create();
                Check(model.HasRangeMap && estimator.GetCalibrationProgress(ref progress) == Status.Ok && progress.Source == CalibrationSource.Continuous,
                      "the shipped model carries a range map: a new estimator calibrates from the wearer's motion");
                var confidence = new double[25];
                Check(model.HasPoseError && estimator.GetConfidence(confidence) == Status.Ok && confidence[0] == 0.0 &&
                      estimator.GetConfidence(new double[24]) == Status.SizeMismatch,
                      "the shipped model measured its own errors; no pose yet: confidence 0; 24 values: SizeMismatch");
                estimator.ClearCalibration();
                Check(estimator.GetCalibrationProgress(ref progress) == Status.Ok && progress.Source == CalibrationSource.None, "cleared: no range");
                estimator.UseContinuousCalibration();
                Check(estimator.GetCalibrationProgress(ref progress) == Status.Ok && progress.Source == CalibrationSource.Continuous, "continuous again");
                estimator.ClearCalibration();
                e = Catch(() => estimator.FinishCalibration());
                Check(e != null && e.Status == Status.ErrorCalibrationState, "finish before start: ErrorCalibrationState");
                e = Catch(() => estimator.UseTrainingCalibration());
                Check(!model.HasTrainingRange && e != null && e.Status == Status.ErrorCalibrationState, "no training range in the shipped model: ErrorCalibrationState");
                Check(estimator.PushMeasurements(new double[179], 0.0) == Status.SizeMismatch, "a frame of 179 measurements: SizeMismatch");
                var frame = new double[180];
                for (int r = 0; r < frame.Length; ++r) frame[r] = 40.0 + 0.05 * r;
                Check((int)estimator.PushMeasurements(frame, 0.0) >= 0, "a frame of 180 measurements is accepted");
                var pose = Pose.Create();
                Check(estimator.GetPose(ref pose) == Status.Ok && pose.Valid == 0, "no pose yet");
                pose.StructSize = 100;
                Check(estimator.GetPose(ref pose) == Status.ErrorStructSize, "a wrong struct_size is refused, not misread");
                estimator.Dispose();
                Check(estimator.Handle.IsClosed, "Dispose frees the estimator");
                bool disposed = false;
                try { estimator.PushRow(0, 1.0, 0.0); }
                catch (ObjectDisposedException) { disposed = true; }
                Check(disposed, "a call on a disposed estimator throws ObjectDisposedException (never reaches the library)");
            }
        }
    }

    static string H(double v) { return BitConverter.DoubleToInt64Bits(v).ToString("x16"); }
    static string H(float v) { return BitConverter.ToUInt32(BitConverter.GetBytes(v), 0).ToString("x8"); }
    static double D(string hex) { return BitConverter.Int64BitsToDouble(Convert.ToInt64(hex, 16)); }
    static string H(Vector3f v) { return " " + H(v.X) + " " + H(v.Y) + " " + H(v.Z); }
    static string H(Quaternionf q) { return " " + H(q.X) + " " + H(q.Y) + " " + H(q.Z) + " " + H(q.W); }
    static string Hex(double[] v) { var b = new StringBuilder(); foreach (double x in v) b.Append(" " + H(x)); return b.ToString(); }

    // The lines of csharp_reference.c's writers, from the package's structs.
    static string PoseLine(string tag, Pose p)
    {
        var b = new StringBuilder(tag);
        b.Append(" " + p.Sequence + " " + (uint)p.Flags + " " + p.Rejected + " " + p.Valid + " " + H(p.Timestamp) + " " + H(p.OldestAge));
        for (int d = 0; d < Counts.Dof; ++d) b.Append(" " + H(p.Angle(d)));
        for (int d = 0; d < Counts.Dof; ++d) b.Append(" " + H(p.RawAngle(d)));
        return b.ToString();
    }

    static string JointsLine(string tag, Joint[] joints)
    {
        var b = new StringBuilder(tag);
        foreach (Joint j in joints) b.Append(H(j.Position)).Append(H(j.Rotation));
        return b.ToString();
    }

    static string XrLine(string tag, double time, Status result, XrHand h)
    {
        var b = new StringBuilder(tag);
        b.Append(" " + H(time) + " " + (int)result + " " + h.Active + " " + h.Predicted + " " + h.Clamped + " " + (int)h.Handedness + " " + H(h.Time) + " " + H(h.Horizon));
        for (int j = 0; j < Counts.XrJoints; ++j)
        {
            XrJointLocation x = h.Location(j);
            b.Append(" " + (ulong)x.LocationFlags).Append(H(x.Orientation)).Append(H(x.Position)).Append(" " + H(x.Radius));
        }
        for (int j = 0; j < Counts.XrJoints; ++j)
        {
            XrJointVelocity v = h.Velocity(j);
            b.Append(" " + (ulong)v.VelocityFlags).Append(H(v.LinearVelocity)).Append(H(v.AngularVelocity));
        }
        return b.ToString();
    }

    static string AimLine(string tag, Status result, XrAimState a)
    {
        return tag + " " + (int)result + " " + (ulong)a.Status + H(a.AimOrientation) + H(a.AimPosition) + " " + H(a.PinchStrengthIndex) + " " +
               H(a.PinchStrengthMiddle) + " " + H(a.PinchStrengthRing) + " " + H(a.PinchStrengthLittle);
    }

    // The reference session's rows through the package: every result code, pose, joint list,
    // OpenXR hand and aim state equal to the C ABI's, bit for bit; a reader thread's view too.
    static void TestSession(string[] reference, string modelPath, string rangePath, out Estimator estimatorOut, out double lastTimestamp)
    {
        Model model = Model.Load(modelPath);
        EstimatorConfig config = Estimator.DefaultConfig();
        config.ReadoutSolveEvery = 60;  // csharp_reference.c's session_config
        config.Smoothing = 1;
        config.JointTransforms = 1;
        var estimator = new Estimator(model, config);
        model.Dispose();  // the estimator keeps the model alive
        var latest = new LatestHand();
        var pose = Pose.Create();
        var joints = new Joint[Counts.Joints];
        var hand = XrHand.Create();
        var aim = XrAimState.Create();
        int pushes = 0, pushMismatches = 0, compared = 0, mismatches = 0, poses = 0, expectedPoses = -1;
        double firstAngle = double.NaN, angleRange = 0.0;
        lastTimestamp = 0.0;
        string instruction = null;
        string readerPose = null, readerJoints = null, readerXr = null, readerAim = null, readerHeader = null, readerSequence = null;
        foreach (string line in reference)
        {
            string[] w = line.Split(' ');
            string got = null;
            switch (w[0])
            {
                case "start": Check((int)estimator.StartCalibration() == int.Parse(w[1]), "start the calibration"); break;
                case "finish":
                    estimator.FinishCalibration();
                    Check(w[1] == "0", "finish the calibration");
                    break;
                case "push":
                {
                    double t = D(w[3]);
                    Status s = estimator.PushRow(int.Parse(w[1]), D(w[2]), t);
                    ++pushes;
                    if ((int)s != int.Parse(w[4])) ++pushMismatches;
                    if (s == Status.Solved)
                    {
                        estimator.GetPose(ref pose);
                        estimator.GetJoints(joints);
                        latest.Publish(estimator);
                        lastTimestamp = t;
                        ++poses;
                        if (double.IsNaN(firstAngle)) firstAngle = pose.Angle(6);
                        angleRange = Math.Max(angleRange, Math.Abs(pose.Angle(6) - firstAngle));
                    }
                    break;
                }
                case "pose": got = PoseLine("pose", pose); break;
                case "joints": got = JointsLine("joints", joints); break;
                case "xr":
                {
                    double time = D(w[1]);
                    got = XrLine("xr", time, estimator.GetXrJoints(time, ref hand), hand);
                    break;
                }
                case "aim": got = AimLine("aim", estimator.GetXrAim(ref aim), aim); break;
                case "latest_read":
                {
                    // A render thread's view of the newest published hand.
                    double time = lastTimestamp + 0.02;
                    var reader = new Thread(() =>
                    {
                        var p = Pose.Create();
                        var js = new Joint[Counts.Joints];
                        var xr = XrHand.Create();
                        var a = XrAimState.Create();
                        ulong number, sequence;
                        Status s = latest.Read(ref p, js, out number);
                        readerHeader = "latest_read " + (int)s + " " + number;
                        readerPose = PoseLine("latest_pose", p);
                        readerJoints = JointsLine("latest_joints", js);
                        readerXr = XrLine("latest_xr", time, latest.GetXrJoints(estimator, time, ref xr), xr);
                        Status aimStatus = latest.GetXrAim(ref a, out sequence);
                        readerSequence = "latest_sequence " + sequence;
                        readerAim = AimLine("latest_aim", aimStatus, a);
                    });
                    reader.Start();
                    reader.Join();
                    got = readerHeader;
                    break;
                }
                case "latest_pose": got = readerPose; break;
                case "latest_joints": got = readerJoints; break;
                case "latest_xr": got = readerXr; break;
                case "latest_sequence": got = readerSequence; break;
                case "latest_aim": got = readerAim; break;
                case "calibration_step":
                {
                    int step;
                    double seconds;
                    Status status = estimator.GetCalibrationStep(out step, out seconds);
                    got = "calibration_step " + (int)status + " " + step + " " + H(seconds);
                    break;
                }
                case "pose_at":
                {
                    double time = D(w[1]);
                    var at = PredictedPose.Create();
                    Status status = estimator.GetPoseAt(time, ref at);
                    var b = new StringBuilder("pose_at " + H(time) + " " + (int)status + " " + (uint)at.Flags + " " + at.Predicted + " " + at.Clamped + " " +
                                              at.HasRate + " " + at.Trusted + " " + H(at.Time) + " " + H(at.Horizon));
                    for (int d = 0; d < Counts.Dof; ++d) b.Append(" " + H(at.Angle(d)));
                    for (int d = 0; d < Counts.Dof; ++d) b.Append(" " + H(at.AngleRate(d)));
                    got = b.ToString();
                    break;
                }
                case "cells":
                {
                    var cells = new double[44];
                    got = "cells " + (int)estimator.GetCells(cells) + Hex(cells);
                    break;
                }
                case "progress":
                {
                    var p = CalibrationProgress.Create();
                    Status status = estimator.GetCalibrationProgress(ref p);
                    got = "progress " + (int)status + " " + p.Collecting + " " + p.Frames + " " + p.FramesNeeded + " " + p.Ready + " " + (int)p.Source + " " + p.FlatCells;
                    break;
                }
                case "range":
                {
                    var lo = new double[44];
                    var hi = new double[44];
                    got = "range " + (int)estimator.GetCalibrationRange(lo, hi) + Hex(lo) + Hex(hi);
                    break;
                }
                case "save":
                {
                    // The same range saved from C# is the same file; loaded, or set, it is the same range.
                    string mine = rangePath + ".cs";
                    estimator.SaveCalibration(mine);
                    got = "save 0";
                    Check(File.ReadAllText(mine) == File.ReadAllText(rangePath), "the calibration saved through C# is the file C saved");
                    var lo = new double[44];
                    var hi = new double[44];
                    var lo2 = new double[44];
                    var hi2 = new double[44];
                    estimator.GetCalibrationRange(lo, hi);
                    using (Model m = Model.Load(modelPath))
                    using (var loaded = new Estimator(m))
                    using (var set = new Estimator(m))
                    {
                        loaded.LoadCalibration(rangePath);
                        Check(loaded.GetCalibrationRange(lo2, hi2) == Status.Ok && Hex(lo2) == Hex(lo) && Hex(hi2) == Hex(hi), "C's saved calibration loads into C#, the same range");
                        set.SetCalibrationRange(lo, hi);
                        Check(set.GetCalibrationRange(lo2, hi2) == Status.Ok && Hex(lo2) == Hex(lo) && Hex(hi2) == Hex(hi), "a range set from C# reads back");
                        GlovePoseException e = Catch(() => loaded.LoadCalibration(modelPath));
                        Check(e != null && e.Status == Status.ErrorInvalidFile && e.Message.Contains(modelPath), "a model file is no calibration: ErrorInvalidFile naming it");
                        e = Catch(() => set.SetCalibrationRange(hi, lo));
                        Check(e != null && e.Status == Status.ErrorInvalidArgument, "min > max refused with the library's message: " + (e == null ? "none" : e.Message));
                    }
                    break;
                }
                case "model":
                    using (Model m = Model.Load(modelPath))
                        got = "model " + m.CellCount + " " + m.RowCount + " " + (m.HasTrainingRange ? 1 : 0) + " " + m.CalibrationStepCount + " " + m.GloveId + " " +
                              m.CellName(0) + " " + m.CellName(43);
                    break;
                case "step":
                    using (Model m = Model.Load(modelPath))
                    {
                        CalibrationStep step = m.CalibrationStep(int.Parse(w[1]));
                        var b = new StringBuilder("step " + w[1] + " 0 " + step.Step + " " + step.StepCount);
                        for (int d = 0; d < Counts.Dof; ++d) b.Append(" " + H(step.PoseAngle(d)));
                        b.Append(" " + H(step.StartSeconds) + " " + H(step.Seconds) + " " + step.NameText);
                        got = b.ToString();
                        instruction = "instruction " + step.InstructionText;
                    }
                    break;
                case "instruction": got = instruction; break;
                case "end": expectedPoses = int.Parse(w[1]); break;
            }
            if (got == null) continue;
            ++compared;
            if (got != line)
            {
                if (++mismatches <= 3) Console.WriteLine("  C:  " + line.Substring(0, Math.Min(line.Length, 300)) + "\n  C#: " + got.Substring(0, Math.Min(got.Length, 300)));
            }
        }
        Check(pushes > 10000 && pushMismatches == 0, pushes + " pushes, each with the C ABI's result (" + pushMismatches + " differ)");
        Check(poses == expectedPoses && poses >= 30, poses + " poses, as many as through C (" + expectedPoses + ")");
        Check(compared == 4 * poses + 2 + 6 + 6 + 2 * 10 && mismatches == 0,
              compared + " poses, joint lists, OpenXR hands, aim states, a reader thread's view, the calibration's state and steps, predicted pose and cells equal to the C ABI's, bit for bit (" + mismatches + " differ)");
        Check(angleRange > 0.01, "the poses move (index flexion spans " + angleRange.ToString("F3") + " rad): the comparison is not vacuous");
        latest.Dispose();
        estimatorOut = estimator;
    }

    static float Distance(Vector3f a, Vector3f b)
    {
        float x = a.X - b.X, y = a.Y - b.Y, z = a.Z - b.Z;
        return (float)Math.Sqrt(x * x + y * y + z * z);
    }

    static float Dot(Vector3f a, Vector3f b) { return a.X * b.X + a.Y * b.Y + a.Z * b.Z; }
    static Vector3f Minus(Vector3f a, Vector3f b) { return new Vector3f(a.X - b.X, a.Y - b.Y, a.Z - b.Z); }

    static Quaternionf AxisAngle(double x, double y, double z, double angle)
    {
        double n = Math.Sqrt(x * x + y * y + z * z), s = Math.Sin(angle / 2) / n;
        return new Quaternionf((float)(x * s), (float)(y * s), (float)(z * s), (float)Math.Cos(angle / 2));
    }

    // HandSpace against hand-worked numbers, and the transform order checked geometrically on the
    // session's last hand with the wrist rotated and moved in session space.
    static void TestHandSpace(Estimator estimator, double lastTimestamp)
    {
        // A quarter turn about +Y takes -Z to -X: a joint 0.1 m along -Z of a wrist at (1, 2, 3) is at (0.9, 2, 3).
        var wrist = new Posef(AxisAngle(0, 1, 0, Math.PI / 2), new Vector3f(1, 2, 3));
        Posef j = HandSpace.ToSession(wrist, new Posef(Quaternionf.Identity, new Vector3f(0, 0, -0.1f)));
        Check(Distance(j.Position, new Vector3f(0.9f, 2, 3)) < 1e-6f, "a quarter turn about +Y: (0, 0, -0.1) at (1, 2, 3) lands at (0.9, 2, 3), got " + j.Position);

        const int WristJoint = 1, IndexProximal = 7, IndexTip = 10;
        var hand = XrHand.Create();
        double time = lastTimestamp + 0.01;
        Check(estimator.GetXrJoints(time, ref hand) == Status.Ok && hand.Active == 1, "the session's last hand");
        Vector3f forward = new Vector3f(0, 0, -1);  // OpenXR: the fingers point along the wrist's -Z
        Posef w0 = hand.Location(WristJoint).Pose, p0 = hand.Location(IndexProximal).Pose, t0 = hand.Location(IndexTip).Pose;
        Check(Dot(Minus(t0.Position, w0.Position), forward) > Dot(Minus(p0.Position, w0.Position), forward) &&
              Dot(Minus(p0.Position, w0.Position), forward) > 0.05f, "in the wrist's frame the index tip is beyond the proximal joint, which is beyond the wrist");

        var tracker = new Posef(AxisAngle(1, 1, 1, 2.0), new Vector3f(0.3f, 1.4f, -0.5f));
        Posef ws = HandSpace.ToSession(tracker, w0), ps = HandSpace.ToSession(tracker, p0), ts = HandSpace.ToSession(tracker, t0);
        Vector3f sessionForward = HandSpace.Rotate(tracker.Orientation, forward);
        float tipAlong = Dot(Minus(ts.Position, ws.Position), sessionForward), proximalAlong = Dot(Minus(ps.Position, ws.Position), sessionForward);
        Check(Distance(ws.Position, tracker.Position) < 1e-5f, "the wrist joint lands on the tracker's wrist");
        Check(tipAlong > proximalAlong && proximalAlong > 0.05f,
              "in session space the index tip lands beyond its wrist: " + tipAlong.ToString("F4") + " m along the finger vs the proximal joint's " + proximalAlong.ToString("F4"));
        Check(Math.Abs(Distance(ts.Position, ws.Position) - Distance(t0.Position, w0.Position)) < 1e-5f, "the wrist-to-tip distance is kept");
        // The order the old Unity snippet used (the wrist inside the joint's frame) fails these checks.
        Posef wrong = HandSpace.Compose(t0, tracker), wrongWrist = HandSpace.Compose(w0, tracker);
        Check(Math.Abs(Distance(wrong.Position, wrongWrist.Position) - Distance(t0.Position, w0.Position)) > 0.01f ||
              Dot(Minus(wrong.Position, wrongWrist.Position), sessionForward) <= proximalAlong,
              "the reversed order (wrist inside the joint's frame) does not pass: the check can fail");

        // Unity's frame: mirroring Z commutes with composing, and the fingers point along Unity's +Z.
        Posef unityWrist = HandSpace.MirrorZ(tracker);
        Posef unityTip = HandSpace.ToSession(unityWrist, HandSpace.MirrorZ(t0));
        Check(Distance(unityTip.Position, HandSpace.MirrorZ(ts).Position) < 1e-5f, "compose in Unity's frame = mirror of the OpenXR composition");
        Quaternionf a = unityTip.Orientation, b = HandSpace.MirrorZ(ts.Orientation);
        Check(Math.Abs(Math.Abs(a.X * b.X + a.Y * b.Y + a.Z * b.Z + a.W * b.W) - 1f) < 1e-5f, "and the same orientation");
        Posef unityTipAtOrigin = HandSpace.ToSession(Posef.Identity, HandSpace.MirrorZ(t0));
        Check(unityTipAtOrigin.Position.Z > 0.05f, "with the wrist at Unity's origin the index tip is forward (+Z): " + unityTipAtOrigin.Position.Z.ToString("F3"));

        // Velocities: the composed velocity of the tip is the time derivative of its composed
        // position, with the wrist itself moving and turning (a 2 ms central difference).
        var wristLinear = new Vector3f(0.2f, -0.1f, 0.3f);
        var wristAngular = new Vector3f(0.5f, 1.0f, -0.7f);
        const double h = 0.001;
        Func<double, Posef> tipAt = dt =>
        {
            var later = XrHand.Create();
            estimator.GetXrJoints(time + dt, ref later);
            double rate = Math.Sqrt(Dot(wristAngular, wristAngular));
            var moved = new Posef(HandSpace.Multiply(AxisAngle(wristAngular.X, wristAngular.Y, wristAngular.Z, rate * dt), tracker.Orientation),
                                  new Vector3f(tracker.Position.X + (float)(wristLinear.X * dt), tracker.Position.Y + (float)(wristLinear.Y * dt),
                                               tracker.Position.Z + (float)(wristLinear.Z * dt)));
            return HandSpace.ToSession(moved, later.Location(IndexTip).Pose);
        };
        XrJointVelocity v = hand.Velocity(IndexTip);
        Check((v.VelocityFlags & XrVelocityFlags.LinearVelocityValid) != 0 && (v.VelocityFlags & XrVelocityFlags.AngularVelocityValid) != 0, "the tip's velocity flags");
        Vector3f linear, angular;
        HandSpace.VelocityToSession(tracker, wristLinear, wristAngular, t0.Position, v, out linear, out angular);
        Posef before = tipAt(-h), after = tipAt(h);
        var numeric = new Vector3f((float)((after.Position.X - before.Position.X) / (2 * h)), (float)((after.Position.Y - before.Position.Y) / (2 * h)),
                                   (float)((after.Position.Z - before.Position.Z) / (2 * h)));
        float error = Distance(numeric, linear), speed = (float)Math.Sqrt(Dot(linear, linear));
        Check(error < 0.01f + 0.01f * speed, "linear velocity in session space = d/dt of the composed position: " + linear + " vs " + numeric);
        // Angular: q(t+h) q(t-h)^-1 = exp(w 2h).
        Quaternionf dq = HandSpace.Multiply(after.Orientation, new Quaternionf(-before.Orientation.X, -before.Orientation.Y, -before.Orientation.Z, before.Orientation.W));
        float sign = dq.W < 0 ? -1f : 1f;
        var numericAngular = new Vector3f(sign * dq.X / (float)h, sign * dq.Y / (float)h, sign * dq.Z / (float)h);
        Check(Distance(numericAngular, angular) < 0.02f + 0.01f * (float)Math.Sqrt(Dot(angular, angular)),
              "angular velocity in session space = the composed orientation's rate: " + angular + " vs " + numericAngular);
    }

    static Vector3f V(UnityEngine.Vector3 v) { return new Vector3f(v.x, v.y, v.z); }
    static Vector3f V(Godot.Vector3 v) { return new Vector3f(v.X, v.Y, v.Z); }

    static unsafe void ClearVelocityFlags(ref XrHand hand, int joint)
    {
        fixed (byte* p = hand.Velocities) ((XrJointVelocity*)p)[joint].VelocityFlags = 0;
    }

    // The engine code of capi/README.md (its ```csharp blocks, compiled into this test with the
    // stand-ins of Tests~/EngineStandIns.cs): the Glove class streams the reference rows, then the
    // Unity and Godot code place the hand at a wrist rotated and moved in session space.
    static void TestReadmeEngineCode(string[] reference, string modelPath)
    {
        var glove = new Glove(modelPath, GlovePose.Hand.Right);
        var hand = XrHand.Create();
        var godotIdle = new GloveHandTracker(GlovePose.Hand.Left);
        godotIdle.Update(glove, 0.0, new Godot.Quaternion(0, 0, 0, 1), new Godot.Vector3(0, 0, 0), new Godot.Vector3(0, 0, 0), new Godot.Vector3(0, 0, 0));
        Check(!glove.ReadXrHand(0.0, ref hand) && !godotIdle.Tracker.HasTrackingData && !godotIdle.Tracker.Poses.ContainsKey("default"),
              "README Godot: no tracking data before the first pose");
        double last = 0.0;
        int solved = 0;
        foreach (string line in reference)
        {
            string[] w = line.Split(' ');
            if (w[0] == "start") glove.Estimator.StartCalibration();
            else if (w[0] == "finish") glove.Estimator.FinishCalibration();
            else if (w[0] == "push" && glove.OnReading(int.Parse(w[1]), D(w[2]), D(w[3])) == Status.Solved) { last = D(w[3]); ++solved; }
        }
        double time = last + 0.01;
        Check(solved > 0 && glove.ReadXrHand(time, ref hand), "README Glove: " + solved + " poses streamed, the hand read back");

        // The wrist in session space, OpenXR's frame; the finger's direction there.
        var tracker = new Posef(AxisAngle(-0.3, 1, 0.2, 2.5), new Vector3f(-0.4f, 1.2f, 0.7f));
        Vector3f forward = HandSpace.Rotate(tracker.Orientation, new Vector3f(0, 0, -1));
        float wristToTip = Distance(hand.Location(10).Position, hand.Location(1).Position);

        // Unity: the wrist given in Unity's frame; the joints come back in it.
        Posef uw = HandSpace.MirrorZ(tracker);
        var unityWrist = new UnityEngine.Pose(new UnityEngine.Vector3(uw.Position.X, uw.Position.Y, uw.Position.Z),
                                              new UnityEngine.Quaternion(uw.Orientation.X, uw.Orientation.Y, uw.Orientation.Z, uw.Orientation.W));
        var joints = new Unity.Collections.NativeArray<UnityEngine.XR.Hands.XRHandJoint>(26);
        GloveXRHandJoints.Fill(ref hand, unityWrist, new UnityEngine.Vector3(0, 0, 0), new UnityEngine.Vector3(0, 0, 0), joints);
        Func<UnityEngine.XR.Hands.XRHandJointID, Vector3f> at = id =>
            HandSpace.MirrorZ(V(joints[UnityEngine.XR.Hands.XRHandJointIDUtility.ToIndex(id)].pose.position));  // back to OpenXR's frame
        Vector3f uWrist = at(UnityEngine.XR.Hands.XRHandJointID.Wrist), uProximal = at(UnityEngine.XR.Hands.XRHandJointID.IndexProximal),
                 uTip = at(UnityEngine.XR.Hands.XRHandJointID.IndexTip);
        Check(Distance(uWrist, tracker.Position) < 1e-5f, "README Unity: the wrist joint lands on the tracker's wrist");
        float tipAlong = Dot(Minus(uTip, uWrist), forward), proximalAlong = Dot(Minus(uProximal, uWrist), forward);
        Check(tipAlong > proximalAlong && proximalAlong > 0.05f && Math.Abs(Distance(uTip, uWrist) - wristToTip) < 1e-5f,
              "README Unity: the index tip lands beyond the proximal joint along the finger, " + tipAlong.ToString("F4") + " > " + proximalAlong.ToString("F4") + " m, at its distance from the wrist");
        var all = UnityEngine.XR.Hands.XRHandJointTrackingState.Pose | UnityEngine.XR.Hands.XRHandJointTrackingState.Radius |
                  UnityEngine.XR.Hands.XRHandJointTrackingState.LinearVelocity | UnityEngine.XR.Hands.XRHandJointTrackingState.AngularVelocity;
        int tipIndex = UnityEngine.XR.Hands.XRHandJointIDUtility.ToIndex(UnityEngine.XR.Hands.XRHandJointID.IndexTip);
        Check((joints[tipIndex].trackingState & all) == all && joints[tipIndex].handedness == UnityEngine.XR.Hands.Handedness.Right,
              "README Unity: pose, radius and velocities flagged for a located joint (" + joints[tipIndex].trackingState + ")");
        ClearVelocityFlags(ref hand, 10);
        GloveXRHandJoints.Fill(ref hand, unityWrist, new UnityEngine.Vector3(0, 0, 0), new UnityEngine.Vector3(0, 0, 0), joints);
        Check((joints[tipIndex].trackingState & (UnityEngine.XR.Hands.XRHandJointTrackingState.LinearVelocity | UnityEngine.XR.Hands.XRHandJointTrackingState.AngularVelocity)) == 0 &&
              (joints[tipIndex].trackingState & UnityEngine.XR.Hands.XRHandJointTrackingState.Pose) != 0,
              "README Unity: velocities not flagged when the library does not flag them");

        // Godot: the tracker XRHandModifier3D looks up, the joints in the origin's space (right-handed).
        var godot = new GloveHandTracker(GlovePose.Hand.Right);
        Check(Godot.XRServer.Trackers.Contains(godot.Tracker) && godot.Tracker.Name.ToString() == "/user/hand_tracker/right" &&
              godot.Tracker.Hand == Godot.XRPositionalTracker.TrackerHand.Right && godotIdle.Tracker.Name.ToString() == "/user/hand_tracker/left",
              "README Godot: trackers registered as /user/hand_tracker/right and /left");
        godot.Update(glove, time, new Godot.Quaternion(tracker.Orientation.X, tracker.Orientation.Y, tracker.Orientation.Z, tracker.Orientation.W),
                     new Godot.Vector3(tracker.Position.X, tracker.Position.Y, tracker.Position.Z), new Godot.Vector3(0, 0, 0), new Godot.Vector3(0, 0, 0));
        Vector3f gWrist = V(godot.Tracker.Transforms[1].Origin), gProximal = V(godot.Tracker.Transforms[7].Origin), gTip = V(godot.Tracker.Transforms[10].Origin);
        tipAlong = Dot(Minus(gTip, gWrist), forward);
        proximalAlong = Dot(Minus(gProximal, gWrist), forward);
        Check(godot.Tracker.HasTrackingData && Distance(gWrist, tracker.Position) < 1e-5f && tipAlong > proximalAlong && proximalAlong > 0.05f &&
              Math.Abs(Distance(gTip, gWrist) - wristToTip) < 1e-5f,
              "README Godot: the wrist on the tracker's wrist, the index tip beyond the proximal joint (" + tipAlong.ToString("F4") + " > " + proximalAlong.ToString("F4") + ")");
        var located = Godot.XRHandTracker.HandJointFlags.OrientationValid | Godot.XRHandTracker.HandJointFlags.PositionValid |
                      Godot.XRHandTracker.HandJointFlags.LinearVelocityValid | Godot.XRHandTracker.HandJointFlags.AngularVelocityValid;
        Check((godot.Tracker.Flags[10] & located) == located && godot.Tracker.Radii[10] > 0f && godot.Tracker.Poses.ContainsKey("default"),
              "README Godot: flags, radius and the default pose set");
        glove.Dispose();
    }

    // The per-frame calls allocate no managed memory (the structs are reused, passed by reference).
    static void TestNoAllocation(string modelPath)
    {
        using (Model model = Model.Load(modelPath))
        using (var estimator = new Estimator(model, Estimator.DefaultConfig()))
        using (var latest = new LatestHand())
        {
            var pose = Pose.Create();
            var joints = new Joint[Counts.Joints];
            var hand = XrHand.Create();
            var aim = XrAimState.Create();
            var cells = new double[44];
            estimator.StartCalibration();
            Action<int> frame = f =>
            {
                double t = f / 60.0;
                for (int c = 0; c < cells.Length; ++c) cells[c] = 20.0 + 5.0 * Math.Sin(0.3 * f + c);
                if (estimator.PushCells(cells, t, 0.0) == Status.Solved) latest.Publish(estimator);
                estimator.GetPose(ref pose);
                estimator.GetJoints(joints);
                estimator.GetXrJoints(t, ref hand);
                estimator.GetXrAim(ref aim);
                ulong number;
                latest.Read(ref pose, joints, out number);
                latest.GetXrJoints(estimator, t, ref hand);
            };
            for (int f = 0; f < 60; ++f) frame(f);
            estimator.FinishCalibration();
            for (int f = 60; f < 120; ++f) frame(f);  // warm: every path JIT-compiled
            long before = GC.GetAllocatedBytesForCurrentThread();
            for (int f = 120; f < 720; ++f) frame(f);
            long allocated = GC.GetAllocatedBytesForCurrentThread() - before;
            Check(pose.Valid == 1 && hand.Active == 1, "the allocation loop made poses");
            Check(allocated == 0, "600 frames of push, get pose / joints / OpenXR hand / aim, publish and read allocate " + allocated + " managed bytes (expected 0)");
        }
    }

    static int Main(string[] args)
    {
        if (args.Length != 6)
        {
            Console.WriteLine("usage: mono PackageTest.exe MODEL REFERENCE MALFORMED_FILE HEADER PACKAGE_JSON RANGE_FILE");
            return 2;
        }
        string[] reference = File.ReadAllLines(args[1]);
        TestLayout(reference);
        TestConstants(reference);
        TestDeclarations(args[3]);
        TestLibrary(args[4]);
        TestErrors(reference, args[0], args[2]);
        Estimator estimator;
        double lastTimestamp;
        TestSession(reference, args[0], args[5], out estimator, out lastTimestamp);
        TestHandSpace(estimator, lastTimestamp);
        estimator.Dispose();
        TestReadmeEngineCode(reference, args[0]);
        TestNoAllocation(args[0]);
        Console.WriteLine(passed + " passed, " + failed + " failed");
        return failed == 0 ? 0 : 1;
    }
}
