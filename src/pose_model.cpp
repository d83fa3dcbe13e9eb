// PoseModel's members, compiled once for glovepose::compiled (GLOVEPOSE_COMPILED_LIB): loading,
// the model's parts and its batch path.
#include <glovepose/detail/pose_model_impl.hpp>
