// Files the tests read and write: the build's scratch directory, a file's bytes, the shipped model.
#pragma once

#include <fstream>
#include <iterator>
#include <string>

namespace glovepose::test {

/// A path in this test build's scratch directory.
inline std::string temp_path(const std::string& name) { return std::string(GLOVEPOSE_TEST_TMP_DIR) + "/" + name; }

/// A file's bytes ("" when it cannot be read).
inline std::string slurp(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
}

/// The shipped default model.
inline const std::string kShippedModel = std::string(GLOVEPOSE_SOURCE_DIR) + "/models/glovepose_fcn512.safetensors";

}  // namespace glovepose::test
