/// @file glovepose.hpp
/// @brief Umbrella header: everything of the real-time path.
///
/// Against the compiled library (glovepose::compiled, which defines GLOVEPOSE_COMPILED_LIB) it
/// declares the estimator, the model and what they take and return, nothing else, so a unit that
/// includes it compiles in about a second; include a stage's own header to use the stage itself.
/// Header-only (glovepose::glovepose) it also brings every stage.
#pragma once

#include "config.hpp"
#include "estimator.hpp"
#include "estimator_config.hpp"
#include "pose.hpp"
#include "pose_model.hpp"
#include "status.hpp"

#ifndef GLOVEPOSE_COMPILED_LIB
#include "filter/one_euro.hpp"
#include "filter/trend.hpp"
#include "grid/grid_map.hpp"
#include "hand/collision.hpp"
#include "hand/dofs.hpp"
#include "hand/finger_curls.hpp"
#include "hand/joint_list.hpp"
#include "hand/kinematics.hpp"
#include "hand/openxr_joints.hpp"
#include "hand/xr_hand.hpp"
#include "pose_model_options.hpp"
#include "pose_prediction.hpp"
#include "sensor/calibration.hpp"
#include "sensor/layout.hpp"
#include "sensor/readout.hpp"
#include "sensor/solver.hpp"
#endif
