// The glovepose tool's commands other than predict/info, each in its own file.
#pragma once

#include <glovepose/config.hpp>

#include <charconv>
#include <string>

namespace glovepose::cli {

/// `glovepose simulate ...` (simulate.cpp); argv[1] is "simulate". Returns the exit code.
int simulate(int argc, char** argv);

/// `glovepose train | finetune | eval ...` (train.cpp); argv[1] is the command. Returns the exit code.
int train_tools(int argc, char** argv);

/// `glovepose demo ...` (demo.cpp); argv[1] is "demo". Returns the exit code.
int demo(int argc, char** argv);

/// `glovepose soak ...` (soak.cpp); argv[1] is "soak". Returns the exit code.
int soak(int argc, char** argv);

/// The value `text` of command-line option `option` as a number of type T (locale-independent).
/// Throws glovepose::Error naming the option and the text when it is not one.
template <typename T>
T parse_number(const std::string& option, const std::string& text) {
  T value{};
  const auto result = std::from_chars(text.data(), text.data() + text.size(), value);
  if (text.empty() || result.ec != std::errc() || result.ptr != text.data() + text.size())
    throw Error(option + " '" + text + "' is not a number, expected one such as 2026 or 1.5");
  return value;
}

}  // namespace glovepose::cli
