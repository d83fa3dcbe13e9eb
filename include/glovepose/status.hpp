/// @file status.hpp
/// @brief The status values with which per-frame calls answer bad or unusual input.
#pragma once

#include <cstdint>

#include "config.hpp"

namespace glovepose {

/// @brief Outcome of a per-frame call. Per-frame calls never throw; they return one of these.
///
/// Anything other than `Ok` and `Solved` means the offered value was not used (it was not mixed
/// into any filter or state), or that no result is available yet; the next good input is used
/// normally.
enum class Status : std::uint8_t {
  Ok = 0,              ///< Accepted; nothing new to report.
  Solved,              ///< Accepted, and a new result (e.g. a solved capacitance frame) is available.
  NotReady,            ///< Accepted, but not enough data has arrived yet to produce a result.
  NonFinite,           ///< Rejected: the value (or one of the values) is NaN or infinite.
  Negative,            ///< Rejected: a capacitance reading below zero is physically impossible.
  UnknownIndex,        ///< Rejected: a row/sensor index outside the configured layout.
  TimestampBackwards,  ///< Rejected: the timestamp is earlier than the last accepted one.
  SizeMismatch,        ///< Rejected: a frame with the wrong number of values.
  Uncalibrated,        ///< No calibration range is available for the requested operation.
};

/// @brief A short, stable, human-readable name of a status (for logs and error strings).
constexpr const char* to_string(Status status) noexcept {
  constexpr const char* names[] = {"ok",
                                   "solved",
                                   "not ready",
                                   "non-finite value",
                                   "negative value",
                                   "unknown index",
                                   "timestamp went backwards",
                                   "size mismatch",
                                   "uncalibrated"};  // in the enum's order
  return name_of(status, names, "unknown status");
}

/// @brief True when the status means the offered input was taken into the state.
constexpr bool accepted(Status status) noexcept { return status == Status::Ok || status == Status::Solved || status == Status::NotReady; }

}  // namespace glovepose
