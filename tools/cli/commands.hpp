// The glovepose tool's commands other than predict/info, each in its own file.
#pragma once

#include <glovepose/config.hpp>
#include <glovepose/train/dataset.hpp>

#include <algorithm>
#include <charconv>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <string>
#include <system_error>
#include <vector>

namespace glovepose::cli {

/// `glovepose simulate ...` (simulate.cpp); argv[1] is "simulate". Returns the exit code.
int simulate(int argc, char** argv);

/// `glovepose train | finetune | eval ...` (train.cpp); argv[1] is the command. Returns the exit code.
int train_tools(int argc, char** argv);

/// `glovepose import ...` (import.cpp); argv[1] is "import". Returns the exit code.
int import_recordings(int argc, char** argv);

/// `glovepose demo ...` (demo.cpp); argv[1] is "demo". Returns the exit code.
int demo(int argc, char** argv);

/// `glovepose soak ...` (soak.cpp); argv[1] is "soak". Returns the exit code.
int soak(int argc, char** argv);

/// `glovepose bench ...` (bench.cpp); argv[1] is "bench". Returns the exit code.
int bench(int argc, char** argv);

/// `glovepose view ...` (view.cpp); argv[1] is "view". Returns the exit code.
int view(int argc, char** argv);

/// A file shipped in models/ (a model, the calibration sequence): where `cmake --install` puts them
/// relative to the executable (GLOVEPOSE_MODELS_FROM_BIN, ../share/glovepose/models by default);
/// the build tree has the same layout (build/share/glovepose/models links to the source's
/// models/). Throws glovepose::Error naming the place tried.
inline std::string shipped_model_path(const std::string& name) {
  namespace fs = std::filesystem;
  std::error_code error;
  const fs::path executable = fs::read_symlink("/proc/self/exe", error);
  if (error) throw Error("cannot find this executable (/proc/self/exe: " + error.message() + "), expected --model FILE");
  const fs::path candidate = (executable.parent_path() / GLOVEPOSE_MODELS_FROM_BIN / name).lexically_normal();
  if (!fs::is_regular_file(candidate, error))
    throw Error("the shipped file '" + candidate.string() + "' is missing (install glovepose with cmake --install), expected it or --model FILE");
  return candidate.string();
}

/// A dataset file (train::Dataset::read); a CSV file given instead is refused with the command
/// that imports it.
inline train::Dataset read_dataset(const std::string& path) {
  try {
    return train::Dataset::read(path);
  } catch (const Error& e) {
    std::ifstream file(path, std::ios::binary);
    std::string start(256, '\0');
    file.read(start.data(), static_cast<std::streamsize>(start.size()));
    start.resize(static_cast<std::size_t>(file.gcount()));
    const bool text = !start.empty() && std::all_of(start.begin(), start.end(), [](char c) {
      return c == '\n' || c == '\r' || c == '\t' || (static_cast<unsigned char>(c) >= 0x20 && c != 0x7f);
    });
    if (!text || start.find(',') == std::string::npos) throw;
    throw Error(std::string(e.what()) + "; the file is CSV text, not a dataset file: import it first with "
                "glovepose import --rate HZ [--glove FILE] --out DATA.safetensors " + path + " (see glovepose import --help)");
  }
}

/// Whether a command-line argument asks for the usage.
inline bool asks_for_help(const std::string& argument) { return argument == "--help" || argument == "-h"; }

/// Ends the process with a command's usage: on stdout with exit code 0 when the user asked for it
/// (`problem` empty), else `problem` and the usage on stderr with exit code 2.
[[noreturn]] inline void exit_with_usage(const std::string& command, const std::string& problem, const std::string& usage) {
  if (problem.empty()) {
    std::cout << usage << std::flush;
    std::exit(0);
  }
  std::cerr << "glovepose" << (command.empty() ? "" : " " + command) << ": " << problem << "\n" << usage << std::flush;
  std::exit(2);
}

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
