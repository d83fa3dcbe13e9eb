/// @file glovepose.hpp
/// @brief Umbrella header: everything of the real-time path.
#pragma once

#include "config.hpp"
#include "status.hpp"
#include "hand/dofs.hpp"
#include "hand/kinematics.hpp"
#include "hand/collision.hpp"
#include "sensor/layout.hpp"
#include "sensor/solver.hpp"
#include "sensor/readout.hpp"
#include "sensor/calibration.hpp"
#include "grid/grid_map.hpp"
#include "filter/one_euro.hpp"
#include "filter/trend.hpp"
#include "hand/joint_list.hpp"
#include "hand/openxr_joints.hpp"
#include "hand/xr_hand.hpp"
#include "estimator.hpp"
