/// @file architecture.hpp
/// @brief The network kinds a model file can hold (metadata 'architecture') and their one name
/// table. Apart from model_info.hpp so that the trainable networks name their kind without reading
/// model files.
#pragma once

#include <iterator>
#include <optional>
#include <string>
#include <string_view>

#include "../config.hpp"

namespace glovepose::model {

/// @brief The network a model file holds (metadata 'architecture'): the paper's U-Net, its fully
/// connected baseline, or a linear map (evaluated by the trainer only).
enum class Architecture : unsigned char { UNet, Fcn, Linear, Count };

/// @brief The one name table: the spellings in model files and on the command line, by enum value.
inline constexpr const char* kArchitectureNames[] = {"unet", "fcn", "linear"};
static_assert(std::size(kArchitectureNames) == static_cast<std::size_t>(Architecture::Count),
              "kArchitectureNames needs one name per Architecture");

/// @brief "unet", "fcn" or "linear".
constexpr const char* to_string(Architecture a) noexcept { return kArchitectureNames[static_cast<std::size_t>(a)]; }

/// @brief The architecture `text` names, or nullopt when it names none.
inline std::optional<Architecture> parse_architecture(std::string_view text) noexcept {
  for (std::size_t i = 0; i < std::size(kArchitectureNames); ++i)
    if (text == kArchitectureNames[i]) return static_cast<Architecture>(i);
  return std::nullopt;
}

/// @brief The architecture `text` names; throws glovepose::Error naming the accepted spellings otherwise.
inline Architecture architecture(const std::string& text) {
  if (const std::optional<Architecture> a = parse_architecture(text)) return *a;
  throw Error("architecture '" + text + "', expected 'unet', 'fcn' or 'linear'");
}

}  // namespace glovepose::model
