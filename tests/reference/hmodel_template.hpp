// Numbers of the template hand of the hand model behind the paper's angles (Tkach et al. 2017),
// carried here as facts for the tests, with their source: the public repository
// anastasia-tkach/honline-cpp-public: data/models/anastasia/I.txt (rest-pose matrices), C.txt
// (sphere centres), R.txt (sphere radii), tracker/HModel/ModelSemantics.cpp and Model.cpp
// (parameters and limits). That repository states no license; only its numbers are used, rewritten
// as these tables (the library types the same values in by hand: include/glovepose/hand/dofs.hpp,
// kinematics.hpp and openxr_joints.hpp).
#pragma once

#include <array>

namespace glovepose::test::hmodel {

/// Rest-pose transforms of the 18 phalanges (ids 0..17), each a column-major 4x4 matrix,
/// translations in millimetres (I.txt, after its leading count 18).
inline constexpr std::array<double, 18 * 16> kRestPose = {
    // phalanx 0
    1, 0, 0, 0, 0, 1, 0, 0,
    0, 0, 1, 0, 0, 0, 0, 1,
    // phalanx 1
    -0.305523, -0.766703, -0.564642, 0, 0.319439, 0.4761, -0.819321, 0,
    0.897003, -0.430691, 0.0994552, 0, 9.72575, 3.87206, -7.16046, 1,
    // phalanx 2
    0.997074, 0.0764379, 0, 0, -0.0749142, 0.977199, -0.198669, 0,
    -0.0151859, 0.198088, 0.980067, 0, 0, 37.1409, 0, 1,
    // phalanx 3
    0.998709, -0.0507922, 0, 0, 0.0497797, 0.978802, -0.198669, 0,
    0.0100908, 0.198413, 0.980067, 0, 0, 28.436, 0, 1,
    // phalanx 4
    -0.900232, -0.395267, -0.182609, 0, -0.376838, 0.917393, -0.127996, 0,
    0.218117, -0.0464125, -0.974818, 0, -18.1006, 44.8872, 6.8978, 1,
    // phalanx 5
    0.998521, 0.0543646, 0, 0, -0.0543646, 0.998521, 0, 0,
    0, 0, 1, 0, 0, 31.9997, 0, 1,
    // phalanx 6
    0.996917, 0.0784591, 0, 0, -0.0784591, 0.996917, 0, 0,
    0, 0, 1, 0, 0, 19.1319, 0, 1,
    // phalanx 7
    -0.98734, -0.15862, 0, 0, -0.158012, 0.983554, -0.0874808, 0,
    0.0138762, -0.0863733, -0.996166, 0, -5.93253, 49.1046, 10.7991, 1,
    // phalanx 8
    0.999922, 0.012492, 0, 0, -0.012492, 0.999922, 0, 0,
    0, 0, 1, 0, 0, 37.9263, 0, 1,
    // phalanx 9
    0.996917, 0.0784591, 0, 0, -0.0784591, 0.996917, 0, 0,
    0, 0, 1, 0, 0, 23.9032, 0, 1,
    // phalanx 10
    -0.992608, -0.0199468, 0.119712, 0, -0.0159037, 0.999274, 0.0346348, 0,
    -0.120316, 0.0324749, -0.992204, 0, 8.13206, 52.8925, 10.5463, 1,
    // phalanx 11
    0.996917, -0.0784591, 0, 0, 0.0784591, 0.996917, 0, 0,
    0, 0, 1, 0, 0, 40.4944, 0, 1,
    // phalanx 12
    0.999891, 0.0147668, 0, 0, -0.0147668, 0.999891, 0, 0,
    0, 0, 1, 0, 0, 23.2687, 0, 1,
    // phalanx 13
    -0.95871, 0.13524, 0.25017, 0, 0.151187, 0.987454, 0.0455744, 0,
    -0.240868, 0.081515, -0.967129, 0, 25.3963, 50.8191, 5.28707, 1,
    // phalanx 14
    0.99978, -0.0209711, 0, 0, 0.0209711, 0.99978, 0, 0,
    0, 0, 1, 0, 0, 37.0552, 0, 1,
    // phalanx 15
    0.996802, -0.0799147, 0, 0, 0.0799147, 0.996802, 0, 0,
    0, 0, 1, 0, 0, 20.5967, 0, 1,
    // phalanx 16
    1, 0, 0, 0, 0, 1, 0, 0,
    0, 0, 1, 0, 0, 0, 0, 1,
    // phalanx 17
    1, 0, 0, 0, 0, 1, 0, 0,
    0, 0, 1, 0, 0, 0, 0, 1,
};

/// The first 20 sphere centres of the template (C.txt holds 39), millimetres, x y z per centre: per
/// finger (pinky, ring, middle, index, thumb) the tip end, the tip joint, the middle joint, the base
/// joint.
inline constexpr std::array<double, 20 * 3> kSphereCentres = {
    -39.1921, 104.429, -2.03342, -36.4219, 92.1801, 0.546722,
    -30.1593, 74.2435, 2.80197, -18.1006, 44.8872, 6.8978,
    -15.8237, 123.282, 2.66812, -15.4072, 109.963, 5.39038,
    -11.9253, 86.4072, 7.48129, -5.93253, 49.1046, 10.7991,
    3.87815, 132.34, 12.6011, 5.30699, 116.501, 12.9708,
    7.48805, 93.3575, 11.9488, 8.13206, 52.8925, 10.5463,
    35.1592, 120.538, 8.59863, 33.6977, 107.802, 8.0224,
    30.9986, 87.4094, 6.97586, 25.3963, 50.8191, 5.28708,
    26.7855, 47.9654, -70.3597, 26.0498, 38.8509, -59.7168,
    21.59, 21.5548, -37.5908, 9.72575, 3.87206, -7.16046,
};

/// The radii (mm) of the same 20 spheres, in the same order (R.txt, its first 20 values).
inline constexpr std::array<double, 20> kSphereRadii = {
    4.18002, 4.77166, 6.22559, 7.84562, 4.84959, 5.01217, 6.97092, 7.26768, 5.58432, 5.67621,
    7.64302, 7.68834, 5.17427, 5.85299, 7.55251, 8.44143, 7.0311, 7.30846, 10.3118, 15.6827,
};

/// One of the 25 finger parameters the glove estimates (theta 9..33 of the model's 34).
struct FingerParameter {
  int theta;
  const char* name;
  int phalanx;      ///< Phalanx id it rotates.
  char axis;        ///< X flexion, Z abduction, Y twist.
  double min, max;  ///< Joint limits, radians.
};

/// The finger parameters, their phalanges, axes and joint limits (tracker/HModel/ModelSemantics.cpp
/// and Model.cpp of the same repository).
inline constexpr std::array<FingerParameter, 25> kFingerParameters = {{
    {9, "thumb_base_abduction", 1, 'Z', -0.1, 1.0},
    {10, "thumb_base_flexion", 1, 'X', -0.5, 1.0},
    {11, "thumb_middle_flexion", 2, 'X', -0.9, 0.9},
    {12, "thumb_tip_flexion", 3, 'X', -1.4, 0.7},
    {13, "index_base_abduction", 13, 'Z', -0.30, 0.35},
    {14, "index_base_flexion", 13, 'X', -1.3, 1.6},
    {15, "index_middle_flexion", 14, 'X', -0.1, 2.0},
    {16, "index_tip_flexion", 15, 'X', -0.1, 2.0},
    {17, "middle_base_abduction", 10, 'Z', -0.30, 0.40},
    {18, "middle_base_flexion", 10, 'X', -1.3, 1.6},
    {19, "middle_middle_flexion", 11, 'X', -0.1, 2.0},
    {20, "middle_tip_flexion", 12, 'X', -0.1, 2.0},
    {21, "ring_base_abduction", 7, 'Z', -0.10, 0.30},
    {22, "ring_base_flexion", 7, 'X', -1.3, 1.6},
    {23, "ring_middle_flexion", 8, 'X', -0.1, 2.0},
    {24, "ring_tip_flexion", 9, 'X', -0.1, 2.0},
    {25, "pinky_base_abduction", 4, 'Z', -0.20, 0.65},
    {26, "pinky_base_flexion", 4, 'X', -1.3, 1.6},
    {27, "pinky_middle_flexion", 5, 'X', -0.1, 2.0},
    {28, "pinky_tip_flexion", 6, 'X', -0.1, 2.0},
    {29, "thumb_base_twist", 1, 'Y', -0.40, 0.40},
    {30, "index_base_twist", 13, 'Y', -0.45, 0.05},
    {31, "middle_base_twist", 10, 'Y', -0.15, 0.05},
    {32, "ring_base_twist", 7, 'Y', -0.10, 0.05},
    {33, "pinky_base_twist", 4, 'Y', -0.10, 0.05},
}};

}  // namespace glovepose::test::hmodel
