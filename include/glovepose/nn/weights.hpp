/// @file weights.hpp
/// @brief Reader and writer of the weight file (weights_format.md): the container of
/// io/tensor_file.hpp holding finite F32, F16 or BF16 tensors, widened to float. Set-up code: every
/// malformed input is a glovepose::Error naming the tensor or byte offset and what was expected.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iterator>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "../config.hpp"
#include "../io/tensor_file.hpp"
#include "../io/half.hpp"
#include "../io/json.hpp"
#include "tensor.hpp"

namespace glovepose::nn {

/// @brief Element types of the container (io::DType). A model file holds F32 (16-bit F16 and BF16
/// files are accepted and widened to float at load); the other dtypes belong to datasets.
using DType = io::DType;
/// @brief The file's name of a dtype (io::dtype_name).
using io::dtype_name;
/// @brief Bytes per element (io::dtype_size).
using io::dtype_size;
/// @brief Largest header the reader accepts (io::kMaxHeaderBytes).
using io::kMaxHeaderBytes;

/// @brief Tensors and string metadata of one weight file: the container (io::TensorFile) restricted
/// to finite F32, F16 and BF16 tensors, widened to float.
struct WeightFile {
  TensorMap tensors;                            ///< By name, widened to float.
  std::map<std::string, std::string> metadata;  ///< The header's "__metadata__".

  /// @brief Reads and validates a file; messages start with "weight file '<path>': ".
  static WeightFile read(const std::string& path) { return io::TensorFile::read_as(path, "weight file", from); }

  /// @brief Parses and validates the bytes of a file.
  static WeightFile parse(const std::string& bytes) { return from(io::TensorFile::parse(bytes)); }

  /// @brief The weights of a container: every tensor F32, F16 or BF16 and finite, else a
  /// glovepose::Error naming the tensor (and the file byte of a non-finite element).
  static WeightFile from(io::TensorFile file) {
    WeightFile out;
    out.metadata = std::move(file.metadata);
    for (auto it = file.tensors.begin(); it != file.tensors.end(); it = file.tensors.erase(it)) {
      const std::string& name = it->first;
      const io::RawTensor& raw = it->second;
      const std::string where = "tensor '" + name + "'";
      if (raw.dtype != DType::F32 && raw.dtype != DType::F16 && raw.dtype != DType::BF16)
        throw Error(where + ": dtype " + dtype_name(raw.dtype) + ", expected F32, F16 or BF16");
      Tensor tensor{raw.shape, raw.to<float>()};
      for (std::size_t i = 0; i < tensor.values.size(); ++i)
        if (!std::isfinite(tensor.values[i]))
          throw Error(where + ": element " + std::to_string(i) + " (file byte " +
                      std::to_string(raw.file_offset + i * dtype_size(raw.dtype)) + ") is " +
                      (std::isnan(tensor.values[i]) ? "NaN" : "infinite") + ", expected finite values");
      out.tensors[name] = std::move(tensor);
    }
    return out;
  }

  /// @brief The container of these weights, tensors stored as `dtype` (F32, F16 or BF16).
  io::TensorFile to_tensor_file(DType dtype = DType::F32) const {
    if (dtype != DType::F32 && dtype != DType::F16 && dtype != DType::BF16)
      throw Error(std::string("WeightFile: dtype ") + dtype_name(dtype) + ", expected F32, F16 or BF16");
    io::TensorFile file;
    file.metadata = metadata;
    for (const auto& [name, t] : tensors) {
      if (static_cast<std::int64_t>(t.values.size()) != t.element_count())
        throw Error("WeightFile::serialize: tensor '" + name + "' holds " + std::to_string(t.values.size()) + " values for shape " +
                    io::shape_string(t.shape));
      file.tensors[name] = io::RawTensor::from(t.shape, t.values, dtype);
    }
    return file;
  }

  /// @brief The file's bytes, tensors stored as `dtype`, sorted by name, header padded to 8 bytes.
  std::string serialize(DType dtype = DType::F32) const { return to_tensor_file(dtype).serialize(); }

  /// @brief Writes the file. Throws glovepose::Error if it cannot be written.
  void write(const std::string& path, DType dtype = DType::F32) const { to_tensor_file(dtype).write(path, "weight file"); }

  /// @brief A metadata value; throws glovepose::Error naming the missing key.
  const std::string& meta(const std::string& key) const {
    const auto it = metadata.find(key);
    if (it == metadata.end()) throw Error("metadata '" + key + "' is missing");
    return it->second;
  }

  /// @brief A metadata value holding a JSON array of numbers; throws naming the key when it is not.
  std::vector<double> meta_numbers(const std::string& key) const {
    io::json::Value v;
    try {
      v = io::json::parse(meta(key));
    } catch (const Error& e) {
      throw Error("metadata '" + key + "': " + e.what());
    }
    if (!v.is_array()) throw Error("metadata '" + key + "' is not a JSON array of numbers");
    std::vector<double> out;
    for (const io::json::Value& item : v) {
      if (!item.is_number()) throw Error("metadata '" + key + "' holds " + io::json::describe(item) + ", expected numbers");
      out.push_back(item.get<double>());
    }
    return out;
  }

  /// @brief Numbers as a JSON array string that reads back exactly (shortest round-trip digits).
  static std::string format_numbers(const std::vector<double>& values) { return io::json::write(values); }
};

}  // namespace glovepose::nn
