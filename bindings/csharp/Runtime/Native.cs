// The P/Invoke declarations of capi/glovepose_c.h: every exported function, one line each, in the
// header's order. The only place in the package that names the native library.
//
// Handles are SafeHandles (the marshaller keeps them alive during a call and releases them once);
// structs are blittable and passed by ref (pinned, never copied); strings the library returns are
// IntPtr (it owns them: Library.Utf8 copies them); paths are marshalled as the platform's narrow
// strings (UTF-8 on Linux and Android), which is what the library's fopen takes.
using System;
using System.Runtime.InteropServices;

namespace GlovePose
{
    public static class Native
    {
        /// <summary>glovepose_c.dll on Windows, libglovepose_c.so on Linux and Android.</summary>
        public const string Library = "glovepose_c";
        const CallingConvention Cdecl = CallingConvention.Cdecl;

        // ---- library
        [DllImport(Library, CallingConvention = Cdecl)] public static extern IntPtr glovepose_version();
        [DllImport(Library, CallingConvention = Cdecl)] public static extern int glovepose_abi_version();
        [DllImport(Library, CallingConvention = Cdecl)] public static extern IntPtr glovepose_isa();
        [DllImport(Library, CallingConvention = Cdecl)] public static extern double glovepose_row_time(double cycleEnd, int row, int rows, double cycleRate);
        [DllImport(Library, CallingConvention = Cdecl)] public static extern IntPtr glovepose_last_error();
        [DllImport(Library, CallingConvention = Cdecl)] public static extern IntPtr glovepose_result_name(int result);
        [DllImport(Library, CallingConvention = Cdecl)] public static extern IntPtr glovepose_dof_name(int dof);
        [DllImport(Library, CallingConvention = Cdecl)] public static extern IntPtr glovepose_joint_name(int joint);
        [DllImport(Library, CallingConvention = Cdecl)] public static extern int glovepose_joint_parent(int joint);
        [DllImport(Library, CallingConvention = Cdecl)] public static extern IntPtr glovepose_xr_joint_name(int joint);
        [DllImport(Library, CallingConvention = Cdecl)] public static extern int glovepose_xr_joint_parent(int joint);

        // ---- model
        [DllImport(Library, CallingConvention = Cdecl)] public static extern int glovepose_model_load(string modelPath, int weightStorage, string gloveDescriptionPath, out ModelHandle model);
        [DllImport(Library, CallingConvention = Cdecl)] public static extern void glovepose_model_free(IntPtr model);
        [DllImport(Library, CallingConvention = Cdecl)] public static extern int glovepose_model_cell_count(ModelHandle model);
        [DllImport(Library, CallingConvention = Cdecl)] public static extern int glovepose_model_row_count(ModelHandle model);
        [DllImport(Library, CallingConvention = Cdecl)] public static extern IntPtr glovepose_model_glove_id(ModelHandle model);
        [DllImport(Library, CallingConvention = Cdecl)] public static extern IntPtr glovepose_model_cell_name(ModelHandle model, int cell);
        [DllImport(Library, CallingConvention = Cdecl)] public static extern int glovepose_model_has_training_range(ModelHandle model);
        [DllImport(Library, CallingConvention = Cdecl)] public static extern int glovepose_model_has_range_map(ModelHandle model);
        [DllImport(Library, CallingConvention = Cdecl)] public static extern int glovepose_model_has_pose_error(ModelHandle model);
        [DllImport(Library, CallingConvention = Cdecl)] public static extern int glovepose_model_calibration_step_count(ModelHandle model);
        [DllImport(Library, CallingConvention = Cdecl)] public static extern int glovepose_model_get_calibration_step(ModelHandle model, int step, ref CalibrationStep output);

        // ---- estimator
        [DllImport(Library, CallingConvention = Cdecl)] public static extern int glovepose_estimator_config_default(out EstimatorConfig config);
        [DllImport(Library, CallingConvention = Cdecl)] public static extern int glovepose_estimator_create(ModelHandle model, ref EstimatorConfig config, out EstimatorHandle estimator);
        [DllImport(Library, CallingConvention = Cdecl)] public static extern int glovepose_hand_options_default(out HandOptions options);
        [DllImport(Library, CallingConvention = Cdecl)] public static extern int glovepose_estimator_create_for_hand(ModelHandle model, ref EstimatorConfig config, ref HandOptions options, out EstimatorHandle estimator);
        [DllImport(Library, CallingConvention = Cdecl)] public static extern void glovepose_estimator_free(IntPtr estimator);
        [DllImport(Library, CallingConvention = Cdecl)] public static extern int glovepose_estimator_push_row(EstimatorHandle estimator, int row, double value, double timestamp);
        [DllImport(Library, CallingConvention = Cdecl)] public static extern int glovepose_estimator_push_measurements(EstimatorHandle estimator, double[] values, int count, double timestamp);
        [DllImport(Library, CallingConvention = Cdecl)] public static extern int glovepose_estimator_push_cells(EstimatorHandle estimator, double[] cells, int count, double timestamp, double oldestAge);
        [DllImport(Library, CallingConvention = Cdecl)] public static extern int glovepose_estimator_get_pose(EstimatorHandle estimator, ref Pose output);
        [DllImport(Library, CallingConvention = Cdecl)] public static extern int glovepose_estimator_get_joints(EstimatorHandle estimator, [Out] Joint[] output, int count);
        [DllImport(Library, CallingConvention = Cdecl)] public static extern int glovepose_estimator_get_pose_at(EstimatorHandle estimator, double time, ref PredictedPose output);
        [DllImport(Library, CallingConvention = Cdecl)] public static extern int glovepose_estimator_get_xr_joints(EstimatorHandle estimator, double time, ref XrHand output);
        [DllImport(Library, CallingConvention = Cdecl)] public static extern int glovepose_estimator_get_cells(EstimatorHandle estimator, [Out] double[] output, int count);
        [DllImport(Library, CallingConvention = Cdecl)] public static extern int glovepose_estimator_get_confidence(EstimatorHandle estimator, [Out] double[] output, int count);
        [DllImport(Library, CallingConvention = Cdecl)] public static extern int glovepose_estimator_get_xr_aim(EstimatorHandle estimator, ref XrAimState output);
        [DllImport(Library, CallingConvention = Cdecl)] public static extern int glovepose_estimator_reset(EstimatorHandle estimator);

        // ---- the latest hand, for other threads
        [DllImport(Library, CallingConvention = Cdecl)] public static extern int glovepose_latest_create(out LatestHandle latest);
        [DllImport(Library, CallingConvention = Cdecl)] public static extern void glovepose_latest_free(IntPtr latest);
        [DllImport(Library, CallingConvention = Cdecl)] public static extern int glovepose_latest_publish(LatestHandle latest, EstimatorHandle estimator);
        [DllImport(Library, CallingConvention = Cdecl)] public static extern int glovepose_latest_read(LatestHandle latest, ref Pose pose, [Out] Joint[] joints, int jointCount, out ulong number);

        // ---- calibration
        [DllImport(Library, CallingConvention = Cdecl)] public static extern int glovepose_calibration_start(EstimatorHandle estimator);
        [DllImport(Library, CallingConvention = Cdecl)] public static extern int glovepose_calibration_get_progress(EstimatorHandle estimator, ref CalibrationProgress output);
        [DllImport(Library, CallingConvention = Cdecl)] public static extern int glovepose_calibration_get_step(EstimatorHandle estimator, out int step, out double sequenceSeconds);
        [DllImport(Library, CallingConvention = Cdecl)] public static extern int glovepose_calibration_finish(EstimatorHandle estimator);
        [DllImport(Library, CallingConvention = Cdecl)] public static extern int glovepose_calibration_cancel(EstimatorHandle estimator);
        [DllImport(Library, CallingConvention = Cdecl)] public static extern int glovepose_calibration_load(EstimatorHandle estimator, string path);
        [DllImport(Library, CallingConvention = Cdecl)] public static extern int glovepose_calibration_save(EstimatorHandle estimator, string path);
        [DllImport(Library, CallingConvention = Cdecl)] public static extern int glovepose_calibration_use_training(EstimatorHandle estimator);
        [DllImport(Library, CallingConvention = Cdecl)] public static extern int glovepose_calibration_use_continuous(EstimatorHandle estimator);
        [DllImport(Library, CallingConvention = Cdecl)] public static extern int glovepose_calibration_clear(EstimatorHandle estimator);
        [DllImport(Library, CallingConvention = Cdecl)] public static extern int glovepose_calibration_set_range(EstimatorHandle estimator, double[] min, double[] max, int count);
        [DllImport(Library, CallingConvention = Cdecl)] public static extern int glovepose_calibration_get_range(EstimatorHandle estimator, [Out] double[] min, [Out] double[] max, int count);
        [DllImport(Library, CallingConvention = Cdecl)] public static extern int glovepose_latest_get_xr_joints(LatestHandle latest, EstimatorHandle estimator, double time, ref XrHand output);
        [DllImport(Library, CallingConvention = Cdecl)] public static extern int glovepose_latest_get_xr_aim(LatestHandle latest, ref XrAimState output, out ulong sequence);

        // ---- struct helpers
        [DllImport(Library, CallingConvention = Cdecl)] public static extern void glovepose_pose_init(ref Pose pose);
        [DllImport(Library, CallingConvention = Cdecl)] public static extern void glovepose_calibration_progress_init(ref CalibrationProgress progress);
        [DllImport(Library, CallingConvention = Cdecl)] public static extern void glovepose_calibration_step_init(ref CalibrationStep step);
        [DllImport(Library, CallingConvention = Cdecl)] public static extern void glovepose_xr_hand_init(ref XrHand hand);
        [DllImport(Library, CallingConvention = Cdecl)] public static extern void glovepose_predicted_pose_init(ref PredictedPose pose);
        [DllImport(Library, CallingConvention = Cdecl)] public static extern void glovepose_xr_aim_state_init(ref XrAimState state);
    }
}
