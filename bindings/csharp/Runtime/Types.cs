// The C ABI's codes, flags and structs (capi/glovepose_c.h), as blittable C# types with the
// header's layout: the package test compares every size and field offset with the C compiler's.
// Arrays inside structs are fixed buffers, so a struct is passed to the library by reference
// (pinned, no copy) and reading a pose allocates nothing.
using System;
using System.Runtime.InteropServices;

namespace GlovePose
{
    /// <summary>A call's result (glovepose_result): 0 and positive are per-frame statuses, negative are errors.</summary>
    public enum Status : int
    {
        Ok = 0,
        Solved = 1,
        NotReady = 2,
        NonFinite = 3,
        Negative = 4,
        UnknownIndex = 5,
        TimestampBackwards = 6,
        SizeMismatch = 7,
        Uncalibrated = 8,
        ErrorInvalidArgument = -1,
        ErrorInvalidHandle = -2,
        ErrorStructSize = -3,
        ErrorFileNotFound = -4,
        ErrorInvalidFile = -5,
        ErrorIo = -6,
        ErrorCalibrationState = -7,
        ErrorDisabled = -8,
        ErrorOutOfMemory = -9,
        ErrorInternal = -10,
    }

    /// <summary>In-memory weight precision of a loaded model (GLOVEPOSE_WEIGHTS_*). Realtime: the
    /// fastest within 0.1 degree of F32 for the instruction set the library runs (Library.Isa).</summary>
    public enum WeightStorage : int { F32 = 0, F16 = 1, Bf16 = 2, Fixed16 = 3, Realtime = 4 }

    /// <summary>The hand the glove is on (GLOVEPOSE_HAND_*).</summary>
    public enum Hand : int { Right = 0, Left = 1 }

    /// <summary>Where the calibration range in use comes from (GLOVEPOSE_CALIBRATION_*).</summary>
    public enum CalibrationSource : int { None = 0, OnTheFly = 1, User = 2, Training = 3, Continuous = 4 }

    /// <summary>GLOVEPOSE_POSE_* bits. New bits may appear: test bits, do not compare the value.</summary>
    [Flags]
    public enum PoseFlags : uint
    {
        ReadingsRejected = 0x1,
        InputClamped = 0x2,
        TrainingCalibration = 0x4,
        Calibrating = 0x8,
        StaleReadings = 0x10,
        Recovering = 0x20,
        StuckRows = 0x40,
        DisconnectedRows = 0x80,
        OutlierRows = 0x100,
        /// <summary>Cells stopped being measured (a torn trace) and were stood in for from the others; not a fault.</summary>
        MaskedCells = 0x200,
        /// <summary>The cells look like the glove lying off the hand: no hand to estimate.</summary>
        GloveOff = 0x400,
        /// <summary>Any of these: the pose cannot be trusted.</summary>
        FaultFlags = 0x5F0,
    }

    /// <summary>OpenXR location flags (XrSpaceLocationFlags, GLOVEPOSE_XR_*).</summary>
    [Flags]
    public enum XrLocationFlags : ulong
    {
        OrientationValid = 0x1,
        PositionValid = 0x2,
        OrientationTracked = 0x4,
        PositionTracked = 0x8,
    }

    /// <summary>OpenXR velocity flags (XrSpaceVelocityFlags, GLOVEPOSE_XR_*_VELOCITY_VALID).</summary>
    [Flags]
    public enum XrVelocityFlags : ulong
    {
        LinearVelocityValid = 0x1,
        AngularVelocityValid = 0x2,
    }

    /// <summary>XR_FB_hand_tracking_aim status bits (XrHandTrackingAimFlagsFB, GLOVEPOSE_XR_AIM_*).</summary>
    [Flags]
    public enum XrAimFlags : ulong
    {
        Computed = 0x1,
        Valid = 0x2,
        IndexPinching = 0x4,
        MiddlePinching = 0x8,
        RingPinching = 0x10,
        LittlePinching = 0x20,
        SystemGesture = 0x40,
        DominantHand = 0x80,
        MenuPressed = 0x100,
    }

    /// <summary>Counts of the ABI (GLOVEPOSE_*_COUNT) and its version.</summary>
    public static class Counts
    {
        public const int AbiVersion = 1;
        public const int Dof = 25;
        public const int Joints = 21;
        public const int XrJoints = 26;
        /// <summary>XR_TYPE_HAND_TRACKING_AIM_STATE_FB, the type (and version) of XrAimState.</summary>
        public const int XrTypeHandTrackingAimStateFB = 1000111001;
    }

    /// <summary>A 3-vector of floats (XrVector3f): metres, m/s or rad/s.</summary>
    [StructLayout(LayoutKind.Sequential)]
    public struct Vector3f
    {
        public float X, Y, Z;
        public Vector3f(float x, float y, float z) { X = x; Y = y; Z = z; }
        public override string ToString() { return "(" + X + ", " + Y + ", " + Z + ")"; }
    }

    /// <summary>A unit quaternion x, y, z, w (XrQuaternionf).</summary>
    [StructLayout(LayoutKind.Sequential)]
    public struct Quaternionf
    {
        public float X, Y, Z, W;
        public Quaternionf(float x, float y, float z, float w) { X = x; Y = y; Z = z; W = w; }
        public static readonly Quaternionf Identity = new Quaternionf(0, 0, 0, 1);
        public override string ToString() { return "(" + X + ", " + Y + ", " + Z + ", " + W + ")"; }
    }

    /// <summary>A rigid pose (XrPosef's fields): rotate by Orientation, then move by Position.</summary>
    [StructLayout(LayoutKind.Sequential)]
    public struct Posef
    {
        public Quaternionf Orientation;
        public Vector3f Position;
        public Posef(Quaternionf orientation, Vector3f position) { Orientation = orientation; Position = position; }
        public static readonly Posef Identity = new Posef(Quaternionf.Identity, new Vector3f(0, 0, 0));
    }

    /// <summary>glovepose_estimator_config. Start from Estimator.DefaultConfig().</summary>
    [StructLayout(LayoutKind.Sequential)]
    public struct EstimatorConfig
    {
        public uint StructSize;
        public int ReadoutMeanWindow;
        public int ReadoutSolveEvery;
        public int CalibrationMedianWindow;
        public double CalibrationSamplePeriod;
        public double CalibrationMinRelativeRange;
        public double CalibrationClampLimit;
        /// <summary>1: 1-euro smoothing of the angles.</summary>
        public int Smoothing;
        /// <summary>1: the 21-joint list with every pose (needed for joints and the latest reader's joints).</summary>
        public int JointTransforms;
        public double SmoothingFrequency;
        public double SmoothingMinCutoff;
        public double SmoothingBeta;
        public double SmoothingDCutoff;
    }

    /// <summary>glovepose_hand_options. Start from Estimator.DefaultHandOptions().</summary>
    [StructLayout(LayoutKind.Sequential)]
    public struct HandOptions
    {
        public uint StructSize;
        public Hand Handedness;
        public double PredictionWindow;
        public double MaxPrediction;
    }

    /// <summary>glovepose_pose: one estimated pose. Make one with Pose.Create() and reuse it.</summary>
    [StructLayout(LayoutKind.Sequential)]
    public unsafe struct Pose
    {
        public uint StructSize;
        public PoseFlags Flags;
        /// <summary>Radians, Library.DofName order (smoothed when smoothing is on).</summary>
        public fixed double Angles[Counts.Dof];
        public fixed double RawAngles[Counts.Dof];
        public double Timestamp;
        public double OldestAge;
        public double ComputeSeconds;
        public ulong Sequence;
        public uint Rejected;
        public int Valid;

        public static Pose Create() { var p = new Pose(); p.StructSize = (uint)sizeof(Pose); return p; }
        public double Angle(int dof) { Check(dof); fixed (double* a = Angles) return a[dof]; }
        public double RawAngle(int dof) { Check(dof); fixed (double* a = RawAngles) return a[dof]; }
        public bool Trusted { get { return Valid != 0 && (Flags & PoseFlags.FaultFlags) == 0; } }
        static void Check(int dof) { if ((uint)dof >= Counts.Dof) throw new ArgumentOutOfRangeException("dof"); }
    }

    /// <summary>glovepose_joint: one joint of the 21-joint list, in the hand's root frame.</summary>
    [StructLayout(LayoutKind.Sequential)]
    public struct Joint
    {
        public Vector3f Position;
        public Quaternionf Rotation;
    }

    /// <summary>glovepose_xr_joint_location, laid out as XrHandJointLocationEXT; pose in the wrist joint's frame.</summary>
    [StructLayout(LayoutKind.Sequential)]
    public struct XrJointLocation
    {
        public XrLocationFlags LocationFlags;
        public Quaternionf Orientation;
        public Vector3f Position;
        public float Radius;
        /// <summary>The joint's pose in the wrist joint's frame.</summary>
        public Posef Pose { get { return new Posef(Orientation, Position); } }
    }

    /// <summary>glovepose_xr_joint_velocity, laid out as XrHandJointVelocityEXT (wrist frame).</summary>
    [StructLayout(LayoutKind.Sequential)]
    public struct XrJointVelocity
    {
        public XrVelocityFlags VelocityFlags;
        public Vector3f LinearVelocity;
        public Vector3f AngularVelocity;
    }

    /// <summary>glovepose_xr_hand: one hand's 26 OpenXR joints at one time. Make one with
    /// XrHand.Create() and reuse it; Location(j) and Velocity(j) read joint j (XrHandJointEXT order).</summary>
    [StructLayout(LayoutKind.Sequential)]
    public unsafe struct XrHand
    {
        const int LocationSize = 40, VelocitySize = 32;
        public uint StructSize;
        public int Active;
        public int Predicted;
        public int Clamped;
        public Hand Handedness;
        /// <summary>XrHandTrackingDataSourceEXT (XR_EXT_hand_tracking_data_source): 1, unobstructed (a data glove).</summary>
        public int DataSource;
        public double Time;
        public double Horizon;
        // The C arrays of structs, as bytes (C# has no fixed buffers of structs); Location(j) reads them.
        public fixed byte Locations[Counts.XrJoints * LocationSize];
        public fixed byte Velocities[Counts.XrJoints * VelocitySize];

        public static XrHand Create() { var h = new XrHand(); h.StructSize = (uint)sizeof(XrHand); return h; }

        public XrJointLocation Location(int joint)
        {
            if ((uint)joint >= Counts.XrJoints) throw new ArgumentOutOfRangeException("joint");
            fixed (byte* p = Locations) return ((XrJointLocation*)p)[joint];
        }

        public XrJointVelocity Velocity(int joint)
        {
            if ((uint)joint >= Counts.XrJoints) throw new ArgumentOutOfRangeException("joint");
            fixed (byte* p = Velocities) return ((XrJointVelocity*)p)[joint];
        }
    }

    /// <summary>glovepose_xr_aim_state, laid out as XrHandTrackingAimStateFB. Make one with XrAimState.Create().</summary>
    [StructLayout(LayoutKind.Sequential)]
    public struct XrAimState
    {
        public int Type;
        public IntPtr Next;
        public XrAimFlags Status;
        /// <summary>The aim pose in the wrist joint's frame: compose it with the wrist's (HandSpace.ToSession).</summary>
        public Quaternionf AimOrientation;
        public Vector3f AimPosition;
        public float PinchStrengthIndex;
        public float PinchStrengthMiddle;
        public float PinchStrengthRing;
        public float PinchStrengthLittle;

        public static XrAimState Create() { var s = new XrAimState(); s.Type = Counts.XrTypeHandTrackingAimStateFB; return s; }
        public Posef AimPose { get { return new Posef(AimOrientation, AimPosition); } }
    }

    /// <summary>glovepose_predicted_pose: the hand at a requested time. Make one with PredictedPose.Create().</summary>
    [StructLayout(LayoutKind.Sequential)]
    public unsafe struct PredictedPose
    {
        public uint StructSize;
        public PoseFlags Flags;
        public fixed double Angles[Counts.Dof];
        public fixed double Rate[Counts.Dof];
        public double Time;
        public double Horizon;
        public int Predicted;
        public int Clamped;
        public int HasRate;
        public int Trusted;

        public static PredictedPose Create() { var p = new PredictedPose(); p.StructSize = (uint)sizeof(PredictedPose); return p; }
        public double Angle(int dof) { Check(dof); fixed (double* a = Angles) return a[dof]; }
        /// <summary>Rate of change of angle dof, rad/s.</summary>
        public double AngleRate(int dof) { Check(dof); fixed (double* a = Rate) return a[dof]; }
        static void Check(int dof) { if ((uint)dof >= Counts.Dof) throw new ArgumentOutOfRangeException("dof"); }
    }

    /// <summary>glovepose_calibration_progress. Make one with CalibrationProgress.Create().</summary>
    [StructLayout(LayoutKind.Sequential)]
    public struct CalibrationProgress
    {
        public uint StructSize;
        public int Collecting;
        public long Frames;
        public int FramesNeeded;
        public int Ready;
        public CalibrationSource Source;
        public int FlatCells;

        public static CalibrationProgress Create() { var p = new CalibrationProgress(); p.StructSize = (uint)Marshal.SizeOf(typeof(CalibrationProgress)); return p; }
    }

    /// <summary>glovepose_calibration_step: one step of the model's guided calibration (Model.CalibrationStep).</summary>
    [StructLayout(LayoutKind.Sequential)]
    public unsafe struct CalibrationStep
    {
        public uint StructSize;
        public int Step;
        public int StepCount;
        /// <summary>The pose to copy, radians, Library.DofName order.</summary>
        public fixed float Pose[Counts.Dof];
        public double StartSeconds;
        public double Seconds;
        public fixed byte Name[32];
        public fixed byte Instruction[1024];

        public static CalibrationStep Create() { var s = new CalibrationStep(); s.StructSize = (uint)sizeof(CalibrationStep); return s; }
        /// <summary>Angle dof of the pose to copy, radians.</summary>
        public float PoseAngle(int dof) { if ((uint)dof >= Counts.Dof) throw new ArgumentOutOfRangeException("dof"); fixed (float* a = Pose) return a[dof]; }
        /// <summary>Short id, e.g. "flat_on_table" (allocates: set-up use).</summary>
        public string NameText { get { fixed (byte* p = Name) return Library.Utf8(p, 32); } }
        /// <summary>What to tell the user (allocates: set-up use).</summary>
        public string InstructionText { get { fixed (byte* p = Instruction) return Library.Utf8(p, 1024); } }
    }
}
