// GlovePoseEstimator's members, compiled once for glovepose::compiled (GLOVEPOSE_COMPILED_LIB):
// the units that link the library compile estimator.hpp's declarations only.
#include <glovepose/detail/estimator_impl.hpp>
