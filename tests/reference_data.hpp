// Locates the shared reference data (../shared/reference beside the repository).
#pragma once

#include <cstdlib>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <doctest/doctest.h>

namespace glovepose::test {

/// Path of a reference file if it exists. When it is missing the test says so plainly, and fails
/// when GLOVEPOSE_REQUIRE_REFERENCE=1 (set by CI, which always has ../shared).
inline std::optional<std::string> reference_file(const std::string& name) {
  const std::string path = std::string(GLOVEPOSE_REFERENCE_DIR) + "/" + name;
  if (std::ifstream(path).good()) return path;
  const char* required = std::getenv("GLOVEPOSE_REQUIRE_REFERENCE");
  if (required && std::string(required) == "1") {
    FAIL("reference file " << path << " is missing and GLOVEPOSE_REQUIRE_REFERENCE=1");
  } else {
    MESSAGE("NOT CHECKED: reference file " << path << " is missing, so this comparison did not run");
  }
  return std::nullopt;
}

/// All whitespace-separated numbers of a text file (commas count as whitespace).
inline std::vector<double> read_numbers(const std::string& path) {
  std::ifstream file(path);
  std::stringstream text;
  text << file.rdbuf();
  std::string s = text.str();
  for (char& c : s)
    if (c == ',') c = ' ';
  std::istringstream in(s);
  std::vector<double> numbers;
  double v = 0.0;
  while (in >> v) numbers.push_back(v);
  return numbers;
}

}  // namespace glovepose::test
