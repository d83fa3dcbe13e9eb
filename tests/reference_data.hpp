// Locates the tests' reference data (tests/reference: public facts and vectors, with their sources).
#pragma once

#include <fstream>
#include <string>

#include <doctest/doctest.h>

namespace glovepose::test {

/// Path of a file of tests/reference; a missing one is a broken checkout and fails the test.
inline std::string reference_file(const std::string& name) {
  const std::string path = std::string(GLOVEPOSE_REFERENCE_DIR) + "/" + name;
  REQUIRE_MESSAGE(std::ifstream(path).good(), "reference file " << path << " is missing");
  return path;
}

}  // namespace glovepose::test
