/// @file tensor_file.hpp
/// @brief The one container of weight files and datasets (weights_format.md), typed: safetensors-
/// compatible, u64 little-endian header length, JSON header, raw little-endian row-major tensors that
/// tile the data buffer. Set-up code: every malformed input is a glovepose::Error naming the tensor
/// or byte offset and what was expected. Values are kept as raw bytes (NaN and infinity pass
/// through); the users of the container (nn::WeightFile, io::Dataset) decide what they accept.
#pragma once

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <limits>
#include <map>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "../config.hpp"
#include "atomic_file.hpp"
#include "half.hpp"
#include "json.hpp"
#include "number_text.hpp"
#include "shape.hpp"

namespace glovepose::io {

/// @brief Element types of the container, named as in safetensors.
enum class DType : unsigned char { F64, F32, F16, BF16, I64, I32, U8 };

/// @brief The file's name of a dtype ("F64", "F32", "F16", "BF16", "I64", "I32", "U8").
inline const char* dtype_name(DType d) noexcept {
  constexpr const char* names[] = {"F64", "F32", "F16", "BF16", "I64", "I32", "U8"};  // in the enum's order
  return name_of(d, names, "?");
}

/// @brief Bytes per element of a dtype.
inline std::size_t dtype_size(DType d) noexcept {
  switch (d) {
    case DType::F64:
    case DType::I64:
      return 8;
    case DType::F32:
    case DType::I32:
      return 4;
    case DType::F16:
    case DType::BF16:
      return 2;
    case DType::U8:
      return 1;
  }
  return 0;
}

/// @brief Every dtype, in the order of the enum.
inline constexpr DType kDTypes[] = {DType::F64, DType::F32, DType::F16, DType::BF16, DType::I64, DType::I32, DType::U8};

/// @brief The dtype with this file name; throws glovepose::Error naming the accepted names.
inline DType dtype_from_name(const std::string& name) {
  for (DType d : kDTypes)
    if (name == dtype_name(d)) return d;
  throw Error("dtype " + name + ", expected one of F64, F32, F16, BF16, I64, I32, U8");
}

/// @brief The dtype that stores a C++ element type exactly: double F64, float F32, int64_t I64,
/// int32_t I32, uint8_t U8 (the only element types RawTensor converts to and from).
template <typename T>
constexpr DType dtype_of() noexcept {
  static_assert(std::is_same_v<T, double> || std::is_same_v<T, float> || std::is_same_v<T, std::int64_t> ||
                    std::is_same_v<T, std::int32_t> || std::is_same_v<T, std::uint8_t>,
                "RawTensor converts to and from double, float, int64_t, int32_t and uint8_t only");
  if constexpr (std::is_same_v<T, double>)
    return DType::F64;
  else if constexpr (std::is_same_v<T, float>)
    return DType::F32;
  else if constexpr (std::is_same_v<T, std::int64_t>)
    return DType::I64;
  else if constexpr (std::is_same_v<T, std::int32_t>)
    return DType::I32;
  else
    return DType::U8;
}

/// @brief Largest header the reader accepts (as safetensors: 100 MB).
inline constexpr std::uint64_t kMaxHeaderBytes = 100'000'000;

namespace detail {

/// @brief Whether this machine stores integers little-endian (folded to a constant by the compiler).
inline bool host_is_little_endian() noexcept {
  const std::uint16_t one = 1;
  unsigned char first = 0;
  std::memcpy(&first, &one, 1);
  return first == 1;
}

/// @brief Copies n elements of `size` bytes between host order and little-endian order (the same
/// operation both ways): a memcpy on little-endian hosts, a byte reversal per element otherwise.
inline void copy_le(const void* src, void* dst, std::size_t n, std::size_t size) noexcept {
  if (n == 0) return;
  if (host_is_little_endian()) {
    std::memcpy(dst, src, n * size);
    return;
  }
  const auto* from = static_cast<const unsigned char*>(src);
  auto* to = static_cast<unsigned char*>(dst);
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t k = 0; k < size; ++k) to[i * size + k] = from[i * size + size - 1 - k];
}

/// @brief The error of a value that a conversion would not keep exactly.
template <typename From>
Error inexact_error(From v, std::size_t index, DType from, DType to) {
  const bool integer_target = to == DType::I64 || to == DType::I32 || to == DType::U8;
  return Error("element " + std::to_string(index) + ": " + number_text(v) + " (" + dtype_name(from) + ") cannot be stored exactly as " +
               dtype_name(to) + ", expected " + (integer_target ? "an integer within the range of " : "a value held exactly by ") +
               dtype_name(to));
}

/// @brief One element converted from From to To; floating types convert among themselves freely,
/// integer <-> floating and integer <-> integer only when the value is kept exactly.
template <typename To, typename From>
To convert_element(From v, std::size_t index, DType from, DType to) {
  const auto inexact = [&]() { return inexact_error(v, index, from, to); };
  if constexpr (std::is_floating_point_v<To> && std::is_floating_point_v<From>) {
    return static_cast<To>(v);
  } else if constexpr (std::is_floating_point_v<From>) {  // floating -> integer
    const double d = static_cast<double>(v);
    const double lowest = static_cast<double>(std::numeric_limits<To>::lowest());  // 0 or -2^k: exact
    const double limit = std::ldexp(1.0, std::numeric_limits<To>::digits);         // 2^k: exact
    if (!(d == std::trunc(d)) || d < lowest || d >= limit) throw inexact();
    return static_cast<To>(d);
  } else if constexpr (std::is_floating_point_v<To>) {  // integer -> floating
    const To r = static_cast<To>(v);
    if (static_cast<double>(r) >= std::ldexp(1.0, std::numeric_limits<From>::digits) || static_cast<From>(r) != v) throw inexact();
    return r;
  } else {  // integer -> integer (all fit in int64)
    const auto w = static_cast<std::int64_t>(v);
    if (w < static_cast<std::int64_t>(std::numeric_limits<To>::lowest()) || w > static_cast<std::int64_t>(std::numeric_limits<To>::max()))
      throw inexact();
    return static_cast<To>(v);
  }
}

/// @brief Decodes n stored elements (type Stored, little-endian) through `widen` into out, converted to T.
template <typename T, typename Stored, typename Widen>
void decode_all(const char* src, T* out, std::size_t n, DType from, Widen widen) {
  constexpr std::size_t kChunk = 1024;  // bounded scratch, cache-friendly
  Stored buf[kChunk];
  for (std::size_t start = 0; start < n; start += kChunk) {
    const std::size_t m = std::min(kChunk, n - start);
    copy_le(src + start * sizeof(Stored), buf, m, sizeof(Stored));
    for (std::size_t i = 0; i < m; ++i) out[start + i] = convert_element<T>(widen(buf[i]), start + i, from, dtype_of<T>());
  }
}

/// @brief Encodes n values of T as dtype `to` (Stored little-endian) through `narrow` (value -> Stored).
template <typename Stored, typename T, typename Narrow>
void encode_all(const T* values, char* dst, std::size_t n, Narrow narrow) {
  constexpr std::size_t kChunk = 1024;
  Stored buf[kChunk];
  for (std::size_t start = 0; start < n; start += kChunk) {
    const std::size_t m = std::min(kChunk, n - start);
    for (std::size_t i = 0; i < m; ++i) buf[i] = narrow(values[start + i], start + i);
    copy_le(buf, dst + start * sizeof(Stored), m, sizeof(Stored));
  }
}

}  // namespace detail

/// @brief One tensor of the container: dtype, shape and its raw little-endian row-major bytes.
struct RawTensor {
  DType dtype = DType::F32;         ///< Element type.
  std::vector<std::int64_t> shape;  ///< Dimensions, outermost first (empty: a scalar).
  std::string bytes;                ///< product(shape) * dtype_size(dtype) bytes, little-endian.
  /// @brief File byte of the first element when read from a file (for messages), 0 otherwise;
  /// not part of the tensor's value (ignored by operator== and by the writer).
  std::uint64_t file_offset = 0;

  /// @brief Number of elements implied by the shape; throws glovepose::Error for a negative dimension.
  std::size_t element_count() const {
    std::size_t n = 1;
    for (std::int64_t d : shape) {
      if (d < 0) throw Error("shape " + shape_string(shape) + " has a negative dimension, expected sizes >= 0");
      n *= static_cast<std::size_t>(d);
    }
    return n;
  }

  /// @brief Throws glovepose::Error unless bytes holds exactly product(shape) elements of dtype.
  void check_size() const {
    const std::size_t expected = element_count() * dtype_size(dtype);
    if (bytes.size() != expected)
      throw Error(std::to_string(bytes.size()) + " bytes for shape " + shape_string(shape) + " of " + dtype_name(dtype) + ", expected " +
                  std::to_string(expected));
  }

  /// @brief A tensor of `dtype` holding `values` (row-major, product(shape) of them). Floating values
  /// convert among the floating dtypes (rounding to nearest even); integer targets and integer sources
  /// need exact values. Throws glovepose::Error naming the count or the first element that does not fit.
  template <typename T>
  static RawTensor from(std::vector<std::int64_t> shape, const std::vector<T>& values, DType dtype = dtype_of<T>()) {
    RawTensor t;
    t.dtype = dtype;
    t.shape = std::move(shape);
    const std::size_t n = t.element_count();
    if (values.size() != n)
      throw Error(std::to_string(values.size()) + " values for shape " + shape_string(t.shape) + ", expected " + std::to_string(n));
    t.bytes.resize(n * dtype_size(dtype));
    char* dst = t.bytes.data();
    const T* src = values.data();
    const DType own = dtype_of<T>();
    const auto as = [&](auto target) {  // T -> the C++ type of the target dtype
      using Target = decltype(target);
      return [&](T v, std::size_t i) { return detail::convert_element<Target>(v, i, own, dtype); };
    };
    const auto half = [&](std::uint16_t (*narrow)(float), float (*widen)(std::uint16_t)) {
      return [&, narrow, widen](T v, std::size_t i) {
        const float f = detail::convert_element<float>(v, i, own, DType::F32);
        const std::uint16_t h = narrow(f);
        if (std::is_integral_v<T> && widen(h) != f) throw detail::inexact_error(v, i, own, dtype);
        return h;
      };
    };
    switch (dtype) {
      case DType::F64:
        detail::encode_all<double>(src, dst, n, as(double{}));
        break;
      case DType::F32:
        detail::encode_all<float>(src, dst, n, as(float{}));
        break;
      case DType::I64:
        detail::encode_all<std::int64_t>(src, dst, n, as(std::int64_t{}));
        break;
      case DType::I32:
        detail::encode_all<std::int32_t>(src, dst, n, as(std::int32_t{}));
        break;
      case DType::U8:
        detail::encode_all<std::uint8_t>(src, dst, n, as(std::uint8_t{}));
        break;
      case DType::F16:
        detail::encode_all<std::uint16_t>(src, dst, n, half(float_to_f16, f16_to_float));
        break;
      case DType::BF16:
        detail::encode_all<std::uint16_t>(src, dst, n, half(float_to_bf16, bf16_to_float));
        break;
    }
    return t;
  }

  /// @brief The values converted to T (same rules as from()); a memcpy when dtype is T's own.
  /// Throws glovepose::Error for a size that does not fit the shape or a value T cannot hold exactly.
  template <typename T>
  std::vector<T> to() const {
    check_size();
    const std::size_t n = element_count();
    std::vector<T> out(n);
    const char* src = bytes.data();
    const auto same = [](auto v) { return v; };
    switch (dtype) {
      case DType::F64:
        detail::decode_all<T, double>(src, out.data(), n, dtype, same);
        break;
      case DType::F32:
        detail::decode_all<T, float>(src, out.data(), n, dtype, same);
        break;
      case DType::F16:
        detail::decode_all<T, std::uint16_t>(src, out.data(), n, dtype, f16_to_float);
        break;
      case DType::BF16:
        detail::decode_all<T, std::uint16_t>(src, out.data(), n, dtype, bf16_to_float);
        break;
      case DType::I64:
        detail::decode_all<T, std::int64_t>(src, out.data(), n, dtype, same);
        break;
      case DType::I32:
        detail::decode_all<T, std::int32_t>(src, out.data(), n, dtype, same);
        break;
      case DType::U8:
        detail::decode_all<T, std::uint8_t>(src, out.data(), n, dtype, same);
        break;
    }
    return out;
  }

  /// @brief Same dtype, shape and bytes (NaN payloads compare bitwise).
  friend bool operator==(const RawTensor& a, const RawTensor& b) noexcept {
    return a.dtype == b.dtype && a.shape == b.shape && a.bytes == b.bytes;
  }
  /// @brief Negation of operator==.
  friend bool operator!=(const RawTensor& a, const RawTensor& b) noexcept { return !(a == b); }
};

/// @brief Tensors and string metadata of one container file.
struct TensorFile {
  std::map<std::string, RawTensor> tensors;     ///< By name; written sorted by name.
  std::map<std::string, std::string> metadata;  ///< The header's "__metadata__" (strings only).

  /// @brief Parses and checks the bytes of a whole file.
  static TensorFile parse(const std::string& bytes) {
    return assemble(bytes.size(), [&](std::uint64_t offset, std::uint64_t n) { return bytes.substr(offset, n); });
  }

  /// @brief Reads and checks a file, tensor by tensor (no copy of the whole file in memory).
  /// Messages start with "<kind> '<path>': ".
  static TensorFile read(const std::string& path, const std::string& kind = "tensor file") {
    std::ifstream file(path, std::ios::binary);
    if (!file) throw Error(kind + " '" + path + "': cannot open");
    try {
      file.seekg(0, std::ios::end);
      const std::streamoff size = file.tellg();
      if (!file || size < 0) throw Error("cannot determine the file size");
      return assemble(static_cast<std::uint64_t>(size), [&](std::uint64_t offset, std::uint64_t n) {
        std::string out(n, '\0');
        file.seekg(static_cast<std::streamoff>(offset));
        if (n && !file.read(out.data(), static_cast<std::streamsize>(n)))
          throw Error("cannot read file bytes " + std::to_string(offset) + ".." + std::to_string(offset + n));
        return out;
      });
    } catch (const Error& e) {
      throw Error(kind + " '" + path + "': " + e.what());
    } catch (const std::bad_alloc&) {
      throw Error(kind + " '" + path + "': out of memory while reading it");
    }
  }

  /// @brief Reads a file and converts it with `convert(TensorFile)` (e.g. nn::WeightFile::from);
  /// the errors of both start with "<kind> '<path>': ".
  template <typename Convert>
  static auto read_as(const std::string& path, const std::string& kind, Convert convert) {
    TensorFile file = read(path, kind);
    try {
      return convert(std::move(file));
    } catch (const Error& e) {
      throw Error(kind + " '" + path + "': " + e.what());
    }
  }

  /// @brief The file's bytes: tensors sorted by name and contiguous, header padded with spaces so
  /// that the data buffer starts 8-byte aligned. Throws glovepose::Error for a tensor whose bytes do
  /// not fit its shape.
  std::string serialize() const {
    std::string out = header_bytes();
    for (const auto& entry : tensors) out += entry.second.bytes;
    return out;
  }

  /// @brief Writes serialize()'s bytes to `path`, streaming the tensors, whole or not at all
  /// (io::AtomicFile). Throws glovepose::Error ("<kind> '<path>': ...") naming the cause if it
  /// cannot be written; the file at `path` then keeps its previous contents.
  void write(const std::string& path, const std::string& kind = "tensor file") const {
    const std::string header = header_bytes();
    AtomicFile file(path, kind);
    file.write(header.data(), header.size());
    for (const auto& entry : tensors) file.write(entry.second.bytes.data(), entry.second.bytes.size());
    file.commit();
  }

 private:
  // The length prefix and the JSON header, padded; checks every tensor's size.
  std::string header_bytes() const {
    json::Value header = json::Value::object();
    if (!metadata.empty()) header["__metadata__"] = metadata;
    std::uint64_t offset = 0;
    for (const auto& [name, t] : tensors) {
      if (name == "__metadata__") throw Error("TensorFile: '__metadata__' is reserved, expected another tensor name");
      try {
        t.check_size();
      } catch (const Error& e) {
        throw Error("TensorFile: tensor '" + name + "': " + e.what());
      }
      header[name] = {{"dtype", dtype_name(t.dtype)}, {"shape", t.shape}, {"data_offsets", {offset, offset + t.bytes.size()}}};
      offset += t.bytes.size();
    }
    std::string text = json::write(header);
    while ((8 + text.size()) % 8 != 0) text += ' ';
    std::string out(8, '\0');
    for (int i = 0; i < 8; ++i) out[static_cast<std::size_t>(i)] = static_cast<char>((text.size() >> (8 * i)) & 0xff);
    return out + text;
  }

  // Checks the container's structure and fills the tensors; fetch(file_offset, n) returns n file bytes.
  template <typename Fetch>
  static TensorFile assemble(std::uint64_t file_size, Fetch fetch) {
    if (file_size < 8) throw Error("file is " + std::to_string(file_size) + " bytes, expected at least 8 (the header length)");
    const std::string prefix = fetch(0, 8);
    std::uint64_t header_size = 0;
    for (int i = 7; i >= 0; --i) header_size = (header_size << 8) | static_cast<unsigned char>(prefix[static_cast<std::size_t>(i)]);
    const std::uint64_t available = file_size - 8;
    if (header_size < 2 || header_size > available || header_size > kMaxHeaderBytes)
      throw Error("byte 0: header length " + std::to_string(header_size) + ", expected 2.." +
                  std::to_string(std::min<std::uint64_t>(available, kMaxHeaderBytes)) + " (the file has " + std::to_string(file_size) +
                  " bytes)");
    const std::string header_text = fetch(8, header_size);
    if (header_text[0] != '{') throw Error("byte 8: the header does not start with '{', expected a JSON object");
    json::Value header;
    try {
      header = json::parse(header_text, 8);
    } catch (const Error& e) {
      throw Error(std::string("JSON header: ") + e.what());
    }
    if (!header.is_object()) throw Error("byte 8: the header is not a JSON object");
    const std::uint64_t data_start = 8 + header_size;
    const std::uint64_t data_size = file_size - data_start;

    TensorFile out;
    struct Span {
      std::uint64_t begin, end;
      std::string name;
    };
    std::vector<Span> spans;
    for (const auto& [name, entry] : header.items()) {
      if (name == "__metadata__") {
        if (!entry.is_object()) throw Error("__metadata__ is " + json::describe(entry) + ", expected an object");
        for (const auto& [key, value] : entry.items()) {
          if (!value.is_string())
            throw Error("metadata '" + key + "' is not a string (" + json::describe(value) + "), expected string values");
          out.metadata[key] = value.template get<std::string>();
        }
        continue;
      }
      const std::string where = "tensor '" + name + "'";
      if (!entry.is_object()) throw Error(where + ": entry is not an object");
      for (const auto& member : entry.items())
        if (member.key() != "dtype" && member.key() != "shape" && member.key() != "data_offsets")
          throw Error(where + ": unexpected key '" + member.key() + "', expected only dtype, shape and data_offsets");
      const json::Value* dtype = json::Fields::find(entry, "dtype");
      const json::Value* shape = json::Fields::find(entry, "shape");
      const json::Value* offsets = json::Fields::find(entry, "data_offsets");
      if (!dtype || !dtype->is_string()) throw Error(where + ": no \"dtype\" string");
      RawTensor tensor;
      try {
        tensor.dtype = dtype_from_name(dtype->get<std::string>());
      } catch (const Error& e) {
        throw Error(where + ": " + e.what());
      }
      if (!shape || !shape->is_array()) throw Error(where + ": no \"shape\" list");
      std::uint64_t count = 1;
      for (const json::Value& d : *shape) {
        if (!d.is_number_unsigned()) throw Error(where + ": shape entry " + json::describe(d) + " is not a non-negative integer");
        const std::uint64_t dim = d.get<std::uint64_t>();
        if (dim > (std::uint64_t{1} << 40) || (dim && count > (std::uint64_t{1} << 40) / dim)) throw Error(where + ": shape is too large");
        count *= dim;
        tensor.shape.push_back(static_cast<std::int64_t>(dim));
      }
      if (!offsets || !offsets->is_array() || offsets->size() != 2 || !(*offsets)[0].is_number_unsigned() ||
          !(*offsets)[1].is_number_unsigned())
        throw Error(where + ": \"data_offsets\" is not a pair of non-negative integers");
      const std::uint64_t begin = (*offsets)[0].get<std::uint64_t>(), end = (*offsets)[1].get<std::uint64_t>();
      if (begin > end) throw Error(where + ": data_offsets [" + std::to_string(begin) + ", " + std::to_string(end) + "] are reversed");
      if (end > data_size)
        throw Error(where + ": data ends at data byte " + std::to_string(end) + " (file byte " + std::to_string(data_start + end) +
                    ") but the file holds " + std::to_string(data_size) + " data bytes (truncated?)");
      const std::uint64_t expected = count * dtype_size(tensor.dtype);
      if (end - begin != expected)
        throw Error(where + ": " + std::to_string(end - begin) + " data bytes for shape " + shape_string(tensor.shape) + " of " +
                    dtype_name(tensor.dtype) + ", expected " + std::to_string(expected));
      tensor.file_offset = data_start + begin;
      spans.push_back({begin, end, name});
      out.tensors[name] = std::move(tensor);
    }
    // Tensors must tile the data buffer: no overlap, no gap (safetensors' rule).
    std::sort(spans.begin(), spans.end(),
              [](const Span& a, const Span& b) { return a.begin < b.begin || (a.begin == b.begin && a.end < b.end); });
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
    // In file order, so that a stream is read front to back.
    for (const Span& s : spans) out.tensors[s.name].bytes = fetch(data_start + s.begin, s.end - s.begin);
    return out;
  }
};

}  // namespace glovepose::io
