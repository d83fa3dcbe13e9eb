// The package's API over Native: SafeHandles that free the library's objects, an exception for
// set-up failures carrying the library's message, and Model / Estimator / LatestHand.
//
// Set-up calls (load, create, finish / load / save / set a calibration) throw GlovePoseException.
// Per-frame calls (push, get, publish, read) return a Status and never allocate: the caller
// creates the structs and arrays once (Pose.Create(), XrHand.Create(), new Joint[21]) and reuses them.
using System;
using System.Runtime.InteropServices;
using System.Text;
using Microsoft.Win32.SafeHandles;

namespace GlovePose
{
    /// <summary>A set-up call failed: Status is the library's code, Message its glovepose_last_error().</summary>
    public sealed class GlovePoseException : Exception
    {
        public Status Status { get; private set; }
        public GlovePoseException(Status status, string message) : base(message) { Status = status; }

        // Reads the thread-local message at once: it is only valid until the next failing call.
        internal static void ThrowOnError(int result)
        {
            if (result < 0) throw new GlovePoseException((Status)result, Library.LastError);
        }
    }

    /// <summary>A glovepose_model*; freed with glovepose_model_free.</summary>
    public sealed class ModelHandle : SafeHandleZeroOrMinusOneIsInvalid
    {
        public ModelHandle() : base(true) { }
        protected override bool ReleaseHandle() { Native.glovepose_model_free(handle); return true; }
    }

    /// <summary>A glovepose_estimator*; freed with glovepose_estimator_free.</summary>
    public sealed class EstimatorHandle : SafeHandleZeroOrMinusOneIsInvalid
    {
        public EstimatorHandle() : base(true) { }
        protected override bool ReleaseHandle() { Native.glovepose_estimator_free(handle); return true; }
    }

    /// <summary>A glovepose_latest*; freed with glovepose_latest_free.</summary>
    public sealed class LatestHandle : SafeHandleZeroOrMinusOneIsInvalid
    {
        public LatestHandle() : base(true) { }
        protected override bool ReleaseHandle() { Native.glovepose_latest_free(handle); return true; }
    }

    /// <summary>The library's version, names and messages.</summary>
    public static class Library
    {
        /// <summary>"major.minor.patch" of the native library.</summary>
        public static string Version { get { return Utf8(Native.glovepose_version()); } }
        /// <summary>The ABI the native library was built with; this package speaks Counts.AbiVersion.</summary>
        public static int AbiVersion { get { return Native.glovepose_abi_version(); } }
        /// <summary>The instruction set the native library's networks run in this process: "sse2",
        /// "avx2", "avx512" or "neon" (the best the CPU executes, or the environment variable
        /// GLOVEPOSE_ISA's); null when GLOVEPOSE_ISA names one it cannot run (LastError says why).</summary>
        public static string Isa { get { IntPtr isa = Native.glovepose_isa(); return isa == IntPtr.Zero ? null : Utf8(isa); } }
        /// <summary>When row `row` of a readout cycle ending at `cycleEnd` (s) was read, `rows` rows per
        /// cycle at `cycleRate` cycles/s: each row at the end of its slot (glovepose_row_time); NaN when invalid.</summary>
        public static double RowTime(double cycleEnd, int row, int rows, double cycleRate) { return Native.glovepose_row_time(cycleEnd, row, rows, cycleRate); }
        /// <summary>The calling thread's last error message ("" if none).</summary>
        public static string LastError { get { return Utf8(Native.glovepose_last_error()); } }
        public static string ResultName(Status status) { return Utf8(Native.glovepose_result_name((int)status)); }
        /// <summary>Name of angle dof (0..24), e.g. "index_base_flexion"; null out of range.</summary>
        public static string DofName(int dof) { return Utf8(Native.glovepose_dof_name(dof)); }
        public static string JointName(int joint) { return Utf8(Native.glovepose_joint_name(joint)); }
        public static int JointParent(int joint) { return Native.glovepose_joint_parent(joint); }
        /// <summary>Name of OpenXR joint 0..25, e.g. "index_tip"; null out of range.</summary>
        public static string XrJointName(int joint) { return Utf8(Native.glovepose_xr_joint_name(joint)); }
        public static int XrJointParent(int joint) { return Native.glovepose_xr_joint_parent(joint); }

        /// <summary>Copies a NUL-terminated UTF-8 string the library owns (null for NULL).</summary>
        public static unsafe string Utf8(IntPtr text)
        {
            if (text == IntPtr.Zero) return null;
            byte* p = (byte*)text;
            int n = 0;
            while (p[n] != 0) ++n;
            return Encoding.UTF8.GetString(p, n);
        }

        /// <summary>Copies a NUL-terminated UTF-8 string from a fixed buffer of `capacity` bytes.</summary>
        public static unsafe string Utf8(byte* text, int capacity)
        {
            int n = 0;
            while (n < capacity && text[n] != 0) ++n;
            return Encoding.UTF8.GetString(text, n);
        }

        internal static void RequireAbi()
        {
            int abi = Native.glovepose_abi_version();
            if (abi != Counts.AbiVersion)
                throw new GlovePoseException(Status.ErrorInvalidArgument,
                    "the native glovepose_c library speaks ABI " + abi + ", this package ABI " + Counts.AbiVersion);
        }
    }

    /// <summary>A loaded model: immutable, shared by any number of estimators on any threads.</summary>
    public sealed class Model : IDisposable
    {
        public readonly ModelHandle Handle;
        Model(ModelHandle handle) { Handle = handle; }

        /// <summary>Loads a .safetensors model; gloveDescriptionPath null: the model's own glove.</summary>
        /// <exception cref="GlovePoseException">missing or malformed file, bad storage; the message names the file.</exception>
        public static Model Load(string path, WeightStorage storage = WeightStorage.F32, string gloveDescriptionPath = null)
        {
            Library.RequireAbi();
            ModelHandle handle;
            int result = Native.glovepose_model_load(path, (int)storage, gloveDescriptionPath, out handle);
            if (result < 0)
            {
                handle.Dispose();  // a NULL handle: nothing to free
                GlovePoseException.ThrowOnError(result);
            }
            return new Model(handle);
        }

        public int CellCount { get { return Native.glovepose_model_cell_count(Handle); } }
        /// <summary>Measurement rows of the glove's wiring; 0 when the model knows none (push cells then).</summary>
        public int RowCount { get { return Native.glovepose_model_row_count(Handle); } }
        public string GloveId { get { return Library.Utf8(Native.glovepose_model_glove_id(Handle)); } }
        public string CellName(int cell) { return Library.Utf8(Native.glovepose_model_cell_name(Handle, cell)); }
        public bool HasTrainingRange { get { return Native.glovepose_model_has_training_range(Handle) == 1; } }
        /// <summary>Whether the model carries a range map: new estimators then calibrate from the wearer's free motion (no calibration step).</summary>
        public bool HasRangeMap { get { return Native.glovepose_model_has_range_map(Handle) == 1; } }
        /// <summary>Whether the model carries its own measured errors, behind GetConfidence (else 1 for a trusted pose, 0 otherwise).</summary>
        public bool HasPoseError { get { return Native.glovepose_model_has_pose_error(Handle) == 1; } }
        public int CalibrationStepCount { get { return Native.glovepose_model_calibration_step_count(Handle); } }

        /// <summary>Step `step` of the guided calibration sequence (what to show the user).</summary>
        public CalibrationStep CalibrationStep(int step)
        {
            var s = GlovePose.CalibrationStep.Create();
            GlovePoseException.ThrowOnError(Native.glovepose_model_get_calibration_step(Handle, step, ref s));
            return s;
        }

        /// <summary>Releases this reference; estimators made from the model keep it alive.</summary>
        public void Dispose() { Handle.Dispose(); }
    }

    /// <summary>One glove stream: one thread at a time.</summary>
    public sealed class Estimator : IDisposable
    {
        public readonly EstimatorHandle Handle;

        /// <summary>The library's defaults (the paper's settings), struct_size set.</summary>
        public static EstimatorConfig DefaultConfig()
        {
            EstimatorConfig config;
            GlovePoseException.ThrowOnError(Native.glovepose_estimator_config_default(out config));
            return config;
        }

        /// <summary>A right hand, the default prediction window and bound.</summary>
        public static HandOptions DefaultHandOptions()
        {
            HandOptions options;
            GlovePoseException.ThrowOnError(Native.glovepose_hand_options_default(out options));
            return options;
        }

        public Estimator(Model model) : this(model, DefaultConfig(), DefaultHandOptions()) { }
        public Estimator(Model model, EstimatorConfig config) : this(model, config, DefaultHandOptions()) { }

        /// <exception cref="GlovePoseException">bad settings (named in the message), wrong struct size.</exception>
        public Estimator(Model model, EstimatorConfig config, HandOptions options)
        {
            if (model == null) throw new ArgumentNullException("model");
            EstimatorHandle handle;
            int result = Native.glovepose_estimator_create_for_hand(model.Handle, ref config, ref options, out handle);
            if (result < 0)
            {
                handle.Dispose();
                GlovePoseException.ThrowOnError(result);
            }
            Handle = handle;
        }

        // ---- per frame: a Status, no allocation, no exception
        /// <summary>One reading of row `row` at `timestamp` (s, increasing). Solved: a new pose.</summary>
        public Status PushRow(int row, double value, double timestamp) { return (Status)Native.glovepose_estimator_push_row(Handle, row, value, timestamp); }
        public Status PushMeasurements(double[] values, double timestamp) { return (Status)Native.glovepose_estimator_push_measurements(Handle, values, values == null ? 0 : values.Length, timestamp); }
        public Status PushCells(double[] cells, double timestamp, double oldestAge) { return (Status)Native.glovepose_estimator_push_cells(Handle, cells, cells == null ? 0 : cells.Length, timestamp, oldestAge); }
        public Status GetPose(ref Pose pose) { return (Status)Native.glovepose_estimator_get_pose(Handle, ref pose); }
        /// <summary>The 21-joint list into joints[0..20] (needs JointTransforms = 1).</summary>
        public Status GetJoints(Joint[] joints) { return (Status)Native.glovepose_estimator_get_joints(Handle, joints, joints == null ? 0 : joints.Length); }
        public Status GetCells(double[] cells) { return (Status)Native.glovepose_estimator_get_cells(Handle, cells, cells == null ? 0 : cells.Length); }
        /// <summary>The latest pose's per-DoF confidence into confidence[0..24], 0..1: the probability that the angle is within 10 degrees.</summary>
        public Status GetConfidence(double[] confidence) { return (Status)Native.glovepose_estimator_get_confidence(Handle, confidence, confidence == null ? 0 : confidence.Length); }
        public Status GetPoseAt(double time, ref PredictedPose pose) { return (Status)Native.glovepose_estimator_get_pose_at(Handle, time, ref pose); }
        /// <summary>The 26 OpenXR joints at `time` (the stream's clock), in the wrist joint's frame.</summary>
        public Status GetXrJoints(double time, ref XrHand hand) { return (Status)Native.glovepose_estimator_get_xr_joints(Handle, time, ref hand); }
        public Status GetXrAim(ref XrAimState aim) { return (Status)Native.glovepose_estimator_get_xr_aim(Handle, ref aim); }
        public Status Reset() { return (Status)Native.glovepose_estimator_reset(Handle); }

        // ---- calibration
        public Status StartCalibration() { return (Status)Native.glovepose_calibration_start(Handle); }
        public Status GetCalibrationProgress(ref CalibrationProgress progress) { return (Status)Native.glovepose_calibration_get_progress(Handle, ref progress); }
        /// <summary>The guided step under way (-1: none) and the time since the sequence began.</summary>
        public Status GetCalibrationStep(out int step, out double sequenceSeconds) { return (Status)Native.glovepose_calibration_get_step(Handle, out step, out sequenceSeconds); }
        public Status CancelCalibration() { return (Status)Native.glovepose_calibration_cancel(Handle); }
        public Status GetCalibrationRange(double[] min, double[] max) { return (Status)Native.glovepose_calibration_get_range(Handle, min, max, min == null ? 0 : min.Length); }
        /// <exception cref="GlovePoseException">none running, or too few frames (ErrorCalibrationState).</exception>
        public void FinishCalibration() { GlovePoseException.ThrowOnError(Native.glovepose_calibration_finish(Handle)); }
        public void LoadCalibration(string path) { GlovePoseException.ThrowOnError(Native.glovepose_calibration_load(Handle, path)); }
        public void SaveCalibration(string path) { GlovePoseException.ThrowOnError(Native.glovepose_calibration_save(Handle, path)); }
        public void UseTrainingCalibration() { GlovePoseException.ThrowOnError(Native.glovepose_calibration_use_training(Handle)); }
        /// <summary>Calibrates from the wearer's free motion from now on (CalibrationSource.Continuous).</summary>
        /// <exception cref="GlovePoseException">the model carries no range map (ErrorCalibrationState).</exception>
        public void UseContinuousCalibration() { GlovePoseException.ThrowOnError(Native.glovepose_calibration_use_continuous(Handle)); }
        /// <summary>Forgets the calibration in use: no pose (Status.Uncalibrated) until a calibration finishes or a range is set or loaded.</summary>
        public void ClearCalibration() { GlovePoseException.ThrowOnError(Native.glovepose_calibration_clear(Handle)); }
        public void SetCalibrationRange(double[] min, double[] max)
        {
            if (min == null || max == null || min.Length != max.Length) throw new ArgumentException("min and max need one value per cell each");
            int result = Native.glovepose_calibration_set_range(Handle, min, max, min.Length);
            if (result != (int)Status.Ok)
                throw new GlovePoseException((Status)result, result < 0 ? Library.LastError : "calibration range: " + Library.ResultName((Status)result));
        }

        public void Dispose() { Handle.Dispose(); }
    }

    /// <summary>The newest hand of one estimator for other threads: the estimator's thread calls
    /// Publish after each solved push; an engine's update and render threads read, without locks
    /// and without ever seeing a torn pose.</summary>
    public sealed class LatestHand : IDisposable
    {
        public readonly LatestHandle Handle;

        public LatestHand()
        {
            LatestHandle handle;
            int result = Native.glovepose_latest_create(out handle);
            if (result < 0)
            {
                handle.Dispose();
                GlovePoseException.ThrowOnError(result);
            }
            Handle = handle;
        }

        /// <summary>Writer (the estimator's thread, one writer): makes its current hand the newest.</summary>
        public Status Publish(Estimator estimator) { return (Status)Native.glovepose_latest_publish(Handle, estimator.Handle); }

        /// <summary>Reader, any thread: the newest pose and (if joints is not null) its 21 joints;
        /// number 0 while nothing has been published (pose and joints untouched).</summary>
        public Status Read(ref Pose pose, Joint[] joints, out ulong number)
        {
            return (Status)Native.glovepose_latest_read(Handle, ref pose, joints, joints == null ? 0 : joints.Length, out number);
        }

        /// <summary>Reader, any thread: the OpenXR joints at `time`, predicted from the newest
        /// published hand with the hand model, side and bound of `estimator` (only its immutable
        /// parts are read, so this may run while the estimator's thread streams).</summary>
        public Status GetXrJoints(Estimator estimator, double time, ref XrHand hand)
        {
            return (Status)Native.glovepose_latest_get_xr_joints(Handle, estimator.Handle, time, ref hand);
        }

        /// <summary>Reader, any thread: the pinch and aim state published with the newest pose.</summary>
        public Status GetXrAim(ref XrAimState aim, out ulong sequence) { return (Status)Native.glovepose_latest_get_xr_aim(Handle, ref aim, out sequence); }

        /// <summary>Free after every thread has stopped reading.</summary>
        public void Dispose() { Handle.Dispose(); }
    }
}
