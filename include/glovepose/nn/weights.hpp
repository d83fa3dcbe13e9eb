/// @file weights.hpp
/// @brief Reader and writer of the flat weight file (weights_format.md): safetensors-compatible,
/// u64 little-endian header length, JSON header, raw little-endian tensors. Set-up code: every
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
#include "half.hpp"
#include "json.hpp"
#include "tensor.hpp"

namespace glovepose::nn {

/// @brief Element types of the file. Models are F32; 16-bit files are widened to float at load.
enum class DType : unsigned char { F32, F16, BF16 };

/// @brief The file's name of a dtype.
inline const char* dtype_name(DType d) noexcept { return d == DType::F32 ? "F32" : (d == DType::F16 ? "F16" : "BF16"); }
/// @brief Bytes per element.
inline std::size_t dtype_size(DType d) noexcept { return d == DType::F32 ? 4 : 2; }

/// @brief Largest header the reader accepts (as safetensors: 100 MB).
inline constexpr std::uint64_t kMaxHeaderBytes = 100'000'000;

/// @brief Tensors and string metadata of one file.
struct WeightFile {
  TensorMap tensors;                            ///< By name, widened to float.
  std::map<std::string, std::string> metadata;  ///< The header's "__metadata__".

  /// @brief Reads and validates a file.
  static WeightFile read(const std::string& path) {
    std::ifstream file(path, std::ios::binary);
    if (!file) throw Error("weight file '" + path + "': cannot open");
    try {
      const std::string bytes((std::istreambuf_iterator<char>(file)), std::istreambuf_iterator<char>());
      return parse(bytes);
    } catch (const Error& e) {
      throw Error("weight file '" + path + "': " + e.what());
    } catch (const std::bad_alloc&) {
      throw Error("weight file '" + path + "': out of memory while reading it");
    }
  }

  /// @brief Parses and validates the bytes of a file.
  static WeightFile parse(const std::string& bytes) {
    if (bytes.size() < 8)
      throw Error("file is " + std::to_string(bytes.size()) + " bytes, expected at least 8 (the header length)");
    std::uint64_t header_size = 0;
    for (int i = 7; i >= 0; --i) header_size = (header_size << 8) | static_cast<unsigned char>(bytes[static_cast<std::size_t>(i)]);
    const std::uint64_t available = bytes.size() - 8;
    if (header_size < 2 || header_size > available || header_size > kMaxHeaderBytes)
      throw Error("byte 0: header length " + std::to_string(header_size) + ", expected 2.." +
                  std::to_string(std::min<std::uint64_t>(available, kMaxHeaderBytes)) + " (the file has " +
                  std::to_string(bytes.size()) + " bytes)");
    if (bytes[8] != '{') throw Error("byte 8: the header does not start with '{', expected a JSON object");
    const json::Value header = json::Parser::parse(bytes.substr(8, header_size), 8);
    if (header.kind != json::Value::Kind::Object) throw Error("byte 8: the header is not a JSON object");
    const std::size_t data_start = 8 + header_size;
    const std::uint64_t data_size = bytes.size() - data_start;

    WeightFile out;
    struct Span {
      std::uint64_t begin, end;
      std::string name;
    };
    std::vector<Span> spans;
    for (const auto& [name, entry] : header.members) {
      if (name == "__metadata__") {
        if (entry.kind != json::Value::Kind::Object) throw Error("byte " + std::to_string(entry.offset) + ": __metadata__ is not an object");
        for (const auto& [key, value] : entry.members) {
          if (value.kind != json::Value::Kind::String)
            throw Error("byte " + std::to_string(value.offset) + ": metadata '" + key + "' is not a string, expected string values");
          out.metadata[key] = value.text;
        }
        continue;
      }
      const std::string where = "tensor '" + name + "'";
      if (entry.kind != json::Value::Kind::Object) throw Error(where + ": entry is not an object");
      const json::Value* dtype = entry.find("dtype");
      const json::Value* shape = entry.find("shape");
      const json::Value* offsets = entry.find("data_offsets");
      for (const auto& member : entry.members)
        if (member.first != "dtype" && member.first != "shape" && member.first != "data_offsets")
          throw Error(where + ": unexpected key '" + member.first + "', expected only dtype, shape and data_offsets");
      if (!dtype || dtype->kind != json::Value::Kind::String) throw Error(where + ": no \"dtype\" string");
      DType type = DType::F32;
      if (dtype->text == "F32") type = DType::F32;
      else if (dtype->text == "F16") type = DType::F16;
      else if (dtype->text == "BF16") type = DType::BF16;
      else throw Error(where + ": dtype " + dtype->text + ", expected F32, F16 or BF16");
      if (!shape || shape->kind != json::Value::Kind::Array) throw Error(where + ": no \"shape\" list");
      Tensor tensor;
      std::uint64_t count = 1;
      for (const json::Value& d : shape->items) {
        if (!d.is_unsigned_integer()) throw Error(where + ": shape entry at byte " + std::to_string(d.offset) + " is not a non-negative integer");
        const std::uint64_t dim = std::stoull(d.text);
        if (dim > (std::uint64_t{1} << 40) || (dim && count > (std::uint64_t{1} << 40) / dim))
          throw Error(where + ": shape is too large");
        count *= dim;
        tensor.shape.push_back(static_cast<std::int64_t>(dim));
      }
      if (!offsets || offsets->kind != json::Value::Kind::Array || offsets->items.size() != 2 ||
          !offsets->items[0].is_unsigned_integer() || !offsets->items[1].is_unsigned_integer())
        throw Error(where + ": \"data_offsets\" is not a pair of non-negative integers");
      const std::uint64_t begin = std::stoull(offsets->items[0].text), end = std::stoull(offsets->items[1].text);
      if (begin > end) throw Error(where + ": data_offsets [" + std::to_string(begin) + ", " + std::to_string(end) + "] are reversed");
      if (end > data_size)
        throw Error(where + ": data ends at data byte " + std::to_string(end) + " (file byte " + std::to_string(data_start + end) +
                    ") but the file holds " + std::to_string(data_size) + " data bytes (truncated?)");
      if (end - begin != count * dtype_size(type))
        throw Error(where + ": " + std::to_string(end - begin) + " data bytes for shape " + shape_string(tensor.shape) + " of " +
                    dtype_name(type) + ", expected " + std::to_string(count * dtype_size(type)));
      tensor.values.resize(static_cast<std::size_t>(count));
      const char* src = bytes.data() + data_start + begin;
      for (std::size_t i = 0; i < tensor.values.size(); ++i) {
        float v = 0.0f;
        if (type == DType::F32) {
          std::uint32_t u = 0;
          for (int b = 3; b >= 0; --b) u = (u << 8) | static_cast<unsigned char>(src[4 * i + static_cast<std::size_t>(b)]);
          v = bits_float(u);
        } else {
          const std::uint16_t h = static_cast<std::uint16_t>(static_cast<unsigned char>(src[2 * i]) |
                                                             (static_cast<unsigned char>(src[2 * i + 1]) << 8));
          v = type == DType::F16 ? f16_to_float(h) : bf16_to_float(h);
        }
        if (!std::isfinite(v))
          throw Error(where + ": element " + std::to_string(i) + " (file byte " +
                      std::to_string(data_start + begin + i * dtype_size(type)) + ") is " + (std::isnan(v) ? "NaN" : "infinite") +
                      ", expected finite values");
        tensor.values[i] = v;
      }
      spans.push_back({begin, end, name});
      out.tensors[name] = std::move(tensor);
    }
    // Tensors must tile the data buffer: no overlap, no gap (safetensors' rule).
    std::sort(spans.begin(), spans.end(), [](const Span& a, const Span& b) { return a.begin < b.begin || (a.begin == b.begin && a.end < b.end); });
    std::uint64_t covered = 0;
    for (std::size_t i = 0; i < spans.size(); ++i) {
      if (spans[i].begin < covered)
        throw Error("tensor '" + spans[i].name + "' (data bytes " + std::to_string(spans[i].begin) + ".." + std::to_string(spans[i].end) +
                    ") overlaps tensor '" + spans[i - 1].name + "', expected disjoint tensors");
      if (spans[i].begin > covered)
        throw Error("data bytes " + std::to_string(covered) + ".." + std::to_string(spans[i].begin) +
                    " belong to no tensor, expected the tensors to cover the data without gaps");
      covered = spans[i].end;
    }
    if (covered != data_size)
      throw Error("data bytes " + std::to_string(covered) + ".." + std::to_string(data_size) +
                  " belong to no tensor, expected the tensors to cover the data without gaps");
    return out;
  }

  /// @brief The file's bytes, tensors stored as `dtype`, sorted by name, header padded to 8 bytes.
  std::string serialize(DType dtype = DType::F32) const {
    std::string header = "{";
    bool first = true;
    if (!metadata.empty()) {
      header += "\"__metadata__\":{";
      for (const auto& [k, v] : metadata) {
        header += (first ? "" : ",") + json::quote(k) + ":" + json::quote(v);
        first = false;
      }
      header += "}";
    }
    std::uint64_t offset = 0;
    for (const auto& [name, t] : tensors) {
      if (static_cast<std::int64_t>(t.values.size()) != t.element_count())
        throw Error("WeightFile::serialize: tensor '" + name + "' holds " + std::to_string(t.values.size()) +
                    " values for shape " + shape_string(t.shape));
      const std::uint64_t bytes = t.values.size() * dtype_size(dtype);
      header += std::string(first ? "" : ",") + json::quote(name) + ":{\"dtype\":\"" + dtype_name(dtype) +
                "\",\"shape\":" + shape_string(t.shape) + ",\"data_offsets\":[" + std::to_string(offset) + "," +
                std::to_string(offset + bytes) + "]}";
      offset += bytes;
      first = false;
    }
    header += "}";
    while ((8 + header.size()) % 8 != 0) header += ' ';
    std::string out(8, '\0');
    for (int i = 0; i < 8; ++i) out[static_cast<std::size_t>(i)] = static_cast<char>((header.size() >> (8 * i)) & 0xff);
    out += header;
    out.reserve(out.size() + offset);
    for (const auto& [name, t] : tensors)
      for (float v : t.values) {
        if (dtype == DType::F32) {
          const std::uint32_t u = float_bits(v);
          for (int b = 0; b < 4; ++b) out += static_cast<char>((u >> (8 * b)) & 0xff);
        } else {
          const std::uint16_t h = dtype == DType::F16 ? float_to_f16(v) : float_to_bf16(v);
          out += static_cast<char>(h & 0xff);
          out += static_cast<char>(h >> 8);
        }
      }
    return out;
  }

  /// @brief Writes the file. Throws glovepose::Error if it cannot be written.
  void write(const std::string& path, DType dtype = DType::F32) const {
    const std::string bytes = serialize(dtype);
    std::ofstream file(path, std::ios::binary);
    if (!file || !file.write(bytes.data(), static_cast<std::streamsize>(bytes.size())))
      throw Error("weight file '" + path + "': cannot write");
  }

  /// @brief A metadata value; throws glovepose::Error naming the missing key.
  const std::string& meta(const std::string& key) const {
    const auto it = metadata.find(key);
    if (it == metadata.end()) throw Error("metadata '" + key + "' is missing");
    return it->second;
  }

  /// @brief A metadata value holding a JSON array of numbers; throws naming the key when it is not.
  std::vector<double> meta_numbers(const std::string& key) const {
    const json::Value v = json::Parser::parse(meta(key));
    if (v.kind != json::Value::Kind::Array) throw Error("metadata '" + key + "' is not a JSON array of numbers");
    std::vector<double> out;
    for (const json::Value& item : v.items) {
      if (item.kind != json::Value::Kind::Number || !std::isfinite(item.number))
        throw Error("metadata '" + key + "' has a non-number entry, expected finite numbers");
      out.push_back(item.number);
    }
    return out;
  }

  /// @brief Numbers as a JSON array string with exact round trip (17 significant digits).
  static std::string format_numbers(const std::vector<double>& values) {
    std::string out = "[";
    char buf[32];
    for (std::size_t i = 0; i < values.size(); ++i) {
      std::snprintf(buf, sizeof buf, "%.17g", values[i]);
      out += (i ? ", " : "") + std::string(buf);
    }
    return out + "]";
  }
};

}  // namespace glovepose::nn
