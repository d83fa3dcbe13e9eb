// C# P/Invoke smoke test of the glovepose C ABI (Mono's mcs + mono; the same declarations work in
// .NET and Unity). The struct layouts must be the C header's: the sizes are checked first.
// Usage: mono capi_smoke.exe MODEL    Prints "N passed, N failed"; exit code 0 when none failed.
using System;
using System.Runtime.InteropServices;

static class GlovePose
{
    const string Lib = "glovepose_c";

    public const int Ok = 0, Solved = 1, Uncalibrated = 8;
    public const int ErrorFileNotFound = -4, ErrorStructSize = -3, ErrorCalibrationState = -7;
    public const int WeightsF32 = 0, WeightsF16 = 1;

    [StructLayout(LayoutKind.Sequential)]
    public struct EstimatorConfig
    {
        public uint StructSize;
        public int ReadoutMeanWindow, ReadoutSolveEvery, CalibrationMedianWindow;
        public double CalibrationSamplePeriod, CalibrationMinRelativeRange, CalibrationClampLimit;
        public int Smoothing, JointTransforms;
        public double SmoothingFrequency, SmoothingMinCutoff, SmoothingBeta, SmoothingDCutoff;
    }

    [StructLayout(LayoutKind.Sequential)]
    public struct Pose
    {
        public uint StructSize, Flags;
        [MarshalAs(UnmanagedType.ByValArray, SizeConst = 25)] public double[] Angles;
        [MarshalAs(UnmanagedType.ByValArray, SizeConst = 25)] public double[] RawAngles;
        public double Timestamp, OldestAge, ComputeSeconds;
        public ulong Sequence;
        public uint Rejected;
        public int Valid;
    }

    [StructLayout(LayoutKind.Sequential)]
    public struct Joint
    {
        public float Px, Py, Pz;
        public float Qx, Qy, Qz, Qw;
    }

    [StructLayout(LayoutKind.Sequential)]
    public struct CalibrationProgress
    {
        public uint StructSize;
        public int Collecting;
        public long Frames;
        public int FramesNeeded, Ready, Source, FlatCells;
    }

    // OpenXR's hand joints (XrHandJointLocationEXT / XrHandJointVelocityEXT layouts), in the wrist's frame.
    [StructLayout(LayoutKind.Sequential)]
    public struct XrJointLocation
    {
        public ulong LocationFlags;
        public float Qx, Qy, Qz, Qw;
        public float Px, Py, Pz;
        public float Radius;
    }

    [StructLayout(LayoutKind.Sequential)]
    public struct XrJointVelocity
    {
        public ulong VelocityFlags;
        public float Vx, Vy, Vz;
        public float Wx, Wy, Wz;
    }

    [StructLayout(LayoutKind.Sequential)]
    public struct XrHand
    {
        public uint StructSize;
        public int Active, Predicted, Clamped, Handedness, Reserved;
        public double Time, Horizon;
        [MarshalAs(UnmanagedType.ByValArray, SizeConst = 26)] public XrJointLocation[] Locations;
        [MarshalAs(UnmanagedType.ByValArray, SizeConst = 26)] public XrJointVelocity[] Velocities;
    }

    [StructLayout(LayoutKind.Sequential)]
    public struct HandOptions
    {
        public uint StructSize;
        public int Handedness;
        public double PredictionWindow, MaxPrediction;
    }

    public const int HandRight = 0, HandLeft = 1;
    public const ulong XrOrientationValid = 0x1, XrPositionValid = 0x2, XrOrientationTracked = 0x4, XrPositionTracked = 0x8;
    public const ulong XrLinearVelocityValid = 0x1, XrAngularVelocityValid = 0x2;

    [DllImport(Lib)] public static extern int glovepose_abi_version();
    [DllImport(Lib)] public static extern IntPtr glovepose_version();
    [DllImport(Lib)] public static extern IntPtr glovepose_last_error();
    [DllImport(Lib)] public static extern IntPtr glovepose_dof_name(int dof);
    [DllImport(Lib)] public static extern IntPtr glovepose_joint_name(int joint);
    [DllImport(Lib)] public static extern int glovepose_model_load(string modelPath, int weightStorage, string gloveDescriptionPath, out IntPtr model);
    [DllImport(Lib)] public static extern void glovepose_model_free(IntPtr model);
    [DllImport(Lib)] public static extern int glovepose_model_cell_count(IntPtr model);
    [DllImport(Lib)] public static extern int glovepose_model_row_count(IntPtr model);
    [DllImport(Lib)] public static extern IntPtr glovepose_model_glove_id(IntPtr model);
    [DllImport(Lib)] public static extern int glovepose_estimator_config_default(out EstimatorConfig config);
    [DllImport(Lib)] public static extern int glovepose_estimator_create(IntPtr model, ref EstimatorConfig config, out IntPtr estimator);
    [DllImport(Lib)] public static extern void glovepose_estimator_free(IntPtr estimator);
    [DllImport(Lib)] public static extern int glovepose_hand_options_default(out HandOptions options);
    [DllImport(Lib)] public static extern int glovepose_estimator_create_for_hand(IntPtr model, ref EstimatorConfig config, ref HandOptions options, out IntPtr estimator);
    [DllImport(Lib)] public static extern int glovepose_estimator_get_xr_joints(IntPtr estimator, double time, ref XrHand hand);
    [DllImport(Lib)] public static extern IntPtr glovepose_xr_joint_name(int joint);
    [DllImport(Lib)] public static extern int glovepose_estimator_push_row(IntPtr estimator, int row, double value, double timestamp);
    [DllImport(Lib)] public static extern int glovepose_estimator_push_measurements(IntPtr estimator, double[] values, int count, double timestamp);
    [DllImport(Lib)] public static extern int glovepose_estimator_push_cells(IntPtr estimator, double[] cells, int count, double timestamp, double oldestAge);
    [DllImport(Lib)] public static extern int glovepose_estimator_get_pose(IntPtr estimator, ref Pose pose);
    [DllImport(Lib)] public static extern int glovepose_estimator_get_joints(IntPtr estimator, [Out] Joint[] joints, int count);
    [DllImport(Lib)] public static extern int glovepose_estimator_reset(IntPtr estimator);
    [DllImport(Lib)] public static extern int glovepose_calibration_start(IntPtr estimator);
    [DllImport(Lib)] public static extern int glovepose_calibration_get_progress(IntPtr estimator, ref CalibrationProgress progress);
    [DllImport(Lib)] public static extern int glovepose_calibration_finish(IntPtr estimator);
    [DllImport(Lib)] public static extern int glovepose_calibration_cancel(IntPtr estimator);

    public static string Str(IntPtr p) { return p == IntPtr.Zero ? null : Marshal.PtrToStringAnsi(p); }

    public static XrHand NewXrHand()
    {
        return new XrHand { StructSize = 1912, Locations = new XrJointLocation[26], Velocities = new XrJointVelocity[26] };
    }

    // OpenXR (right-handed, -Z forward) to Unity (left-handed, +Z forward): mirror Z. A position
    // keeps x and y and negates z; a rotation keeps z and w and negates x and y. (capi/README.md's
    // Unity snippet does this with Vector3 and Quaternion.)
    public static void ToUnity(XrJointLocation j, out float[] position, out float[] rotation)
    {
        position = new float[] { j.Px, j.Py, -j.Pz };
        rotation = new float[] { -j.Qx, -j.Qy, j.Qz, j.Qw };
    }
}

static class Smoke
{
    static int passed, failed;

    static void Check(bool condition, string what)
    {
        if (condition) { ++passed; return; }
        ++failed;
        Console.WriteLine("FAILED: " + what + " (last error: " + GlovePose.Str(GlovePose.glovepose_last_error()) + ")");
    }

    static int Main(string[] args)
    {
        Check(Marshal.SizeOf(typeof(GlovePose.EstimatorConfig)) == 80, "sizeof config == 80");
        Check(Marshal.SizeOf(typeof(GlovePose.Pose)) == 448, "sizeof pose == 448");
        Check(Marshal.SizeOf(typeof(GlovePose.Joint)) == 28, "sizeof joint == 28");
        Check(Marshal.SizeOf(typeof(GlovePose.CalibrationProgress)) == 32, "sizeof progress == 32");
        Check(GlovePose.glovepose_abi_version() == 1, "ABI version 1");
        Check(GlovePose.Str(GlovePose.glovepose_version()) == "0.1.0", "version");
        Check(GlovePose.Str(GlovePose.glovepose_joint_name(12)) == "middle_tip", "joint name");

        IntPtr model;
        Check(GlovePose.glovepose_model_load("/nonexistent/m.safetensors", GlovePose.WeightsF32, null, out model) == GlovePose.ErrorFileNotFound,
              "missing model file");
        Check(model == IntPtr.Zero, "no handle for a missing file");
        Check(GlovePose.Str(GlovePose.glovepose_last_error()).Contains("/nonexistent/m.safetensors"), "the error names the file");
        Check(GlovePose.glovepose_model_load(args[0], GlovePose.WeightsF32, null, out model) == GlovePose.Ok, "load the model");
        Check(GlovePose.glovepose_model_cell_count(model) == 44, "44 cells");
        Check(GlovePose.glovepose_model_row_count(model) == 180, "180 rows");
        Check(GlovePose.Str(GlovePose.glovepose_model_glove_id(model)) == "glauser2019-44", "glove id");

        GlovePose.EstimatorConfig config;
        Check(GlovePose.glovepose_estimator_config_default(out config) == GlovePose.Ok, "default config");
        Check(config.StructSize == 80 && config.ReadoutSolveEvery == 16 && config.CalibrationMedianWindow == 0 && config.CalibrationMinRelativeRange == -1.0, "default values (0, -1: the glove's)");
        config.JointTransforms = 1;
        config.Smoothing = 1;
        IntPtr estimator;
        Check(GlovePose.glovepose_estimator_create(model, ref config, out estimator) == GlovePose.Ok, "create an estimator");

        // A synthetic glove of breathing cells, as solved C_c frames at 60 Hz: calibrate, then track.
        var cells = new double[44];
        Check(GlovePose.glovepose_calibration_finish(estimator) == GlovePose.ErrorCalibrationState, "finish before start is refused");
        Check(GlovePose.glovepose_calibration_start(estimator) == GlovePose.Ok, "start calibration");
        int solved = 0, uncalibrated = 0;
        for (int f = 0; f < 120; ++f)
        {
            double t = f / 60.0;
            for (int c = 0; c < 44; ++c) cells[c] = 20.0 + 5.0 * Math.Sin(2 * Math.PI * (0.7 + 0.05 * c) * t + c);
            if (f == 60)
            {
                var progress = new GlovePose.CalibrationProgress { StructSize = 32 };
                Check(GlovePose.glovepose_calibration_get_progress(estimator, ref progress) == GlovePose.Ok, "progress");
                Check(progress.Collecting == 1 && progress.Ready == 1 && progress.Frames == 60 && progress.FramesNeeded == 20, "progress values");
                Check(GlovePose.glovepose_calibration_finish(estimator) == GlovePose.Ok, "finish calibration");
            }
            int r = GlovePose.glovepose_estimator_push_cells(estimator, cells, 44, t, 0.0);
            if (r == GlovePose.Solved) ++solved;
            if (r == GlovePose.Uncalibrated) ++uncalibrated;
        }
        Check(solved == 60 && uncalibrated == 60, "60 poses after the calibration, none before");

        var pose = new GlovePose.Pose { StructSize = 448 };
        Check(GlovePose.glovepose_estimator_get_pose(estimator, ref pose) == GlovePose.Ok, "get pose");
        Check(pose.Valid == 1 && pose.Sequence == 60 && Math.Abs(pose.Timestamp - 119 / 60.0) < 1e-12, "pose header");
        bool finite = true;
        for (int d = 0; d < 25; ++d) finite &= !double.IsNaN(pose.Angles[d]) && !double.IsInfinity(pose.Angles[d]);
        Check(finite, "finite angles");
        Console.WriteLine("C#: " + GlovePose.Str(GlovePose.glovepose_dof_name(6)) + " = " + pose.Angles[6].ToString("F4") + " rad");
        var wrongSize = new GlovePose.Pose { StructSize = 100 };
        Check(GlovePose.glovepose_estimator_get_pose(estimator, ref wrongSize) == GlovePose.ErrorStructSize, "wrong struct size refused");

        var joints = new GlovePose.Joint[21];
        Check(GlovePose.glovepose_estimator_get_joints(estimator, joints, 21) == GlovePose.Ok, "get joints");
        var q = joints[12];
        Check(Math.Abs(q.Qx * q.Qx + q.Qy * q.Qy + q.Qz * q.Qz + q.Qw * q.Qw - 1.0) < 1e-5, "unit quaternion");

        // OpenXR joints of a left hand from the same stream: the right hand's mirrored (x -> -x).
        Check(Marshal.SizeOf(typeof(GlovePose.XrJointLocation)) == 40 && Marshal.SizeOf(typeof(GlovePose.XrJointVelocity)) == 32,
              "OpenXR joint structs 40 and 32 bytes");
        Check(Marshal.SizeOf(typeof(GlovePose.XrHand)) == 1912 && Marshal.SizeOf(typeof(GlovePose.HandOptions)) == 24, "sizeof xr hand, hand options");
        Check(GlovePose.Str(GlovePose.glovepose_xr_joint_name(6)) == "index_metacarpal", "OpenXR joint name");
        GlovePose.HandOptions options;
        Check(GlovePose.glovepose_hand_options_default(out options) == GlovePose.Ok && options.StructSize == 24, "default hand options");
        options.Handedness = GlovePose.HandLeft;
        IntPtr left;
        Check(GlovePose.glovepose_estimator_create_for_hand(model, ref config, ref options, out left) == GlovePose.Ok, "create a left-hand estimator");
        GlovePose.glovepose_calibration_start(left);
        for (int f = 0; f < 120; ++f)  // the right estimator's stream and calibration
        {
            double t = f / 60.0;
            for (int c = 0; c < 44; ++c) cells[c] = 20.0 + 5.0 * Math.Sin(2 * Math.PI * (0.7 + 0.05 * c) * t + c);
            if (f == 60) GlovePose.glovepose_calibration_finish(left);
            GlovePose.glovepose_estimator_push_cells(left, cells, 44, t, 0.0);
        }
        var rightHand = GlovePose.NewXrHand();
        var leftHand = GlovePose.NewXrHand();
        Check(GlovePose.glovepose_estimator_get_xr_joints(estimator, 119 / 60.0 + 0.01, ref rightHand) == GlovePose.Ok, "right OpenXR joints");
        Check(rightHand.Active == 1 && rightHand.Predicted == 1 && rightHand.Handedness == GlovePose.HandRight, "right hand header");
        Check((rightHand.Locations[15].LocationFlags & GlovePose.XrPositionValid) != 0, "position valid");
        Check(GlovePose.glovepose_estimator_get_xr_joints(left, 119 / 60.0 + 0.01, ref leftHand) == GlovePose.Ok, "left OpenXR joints");
        double mirror = 0.0;
        for (int j = 0; j < 26; ++j)
            mirror = Math.Max(mirror, Math.Abs(leftHand.Locations[j].Px + rightHand.Locations[j].Px) +
                                      Math.Abs(leftHand.Locations[j].Py - rightHand.Locations[j].Py) +
                                      Math.Abs(leftHand.Locations[j].Qy + rightHand.Locations[j].Qy));
        Check(leftHand.Handedness == GlovePose.HandLeft && mirror < 1e-6, "the left hand is the right hand mirrored");
        float[] unityPosition, unityRotation;
        GlovePose.ToUnity(rightHand.Locations[15], out unityPosition, out unityRotation);
        Check(unityPosition[2] > 0.05f && Math.Abs(unityRotation[3]) <= 1.0f, "the middle fingertip is forward (+Z) in Unity's frame");
        GlovePose.glovepose_estimator_free(left);

        Check(GlovePose.glovepose_estimator_reset(estimator) == GlovePose.Ok, "reset");
        GlovePose.glovepose_estimator_free(estimator);
        GlovePose.glovepose_model_free(model);
        Console.WriteLine(passed + " passed, " + failed + " failed");
        return failed == 0 ? 0 : 1;
    }
}
