/// @file json.hpp
/// @brief JSON for the file formats (set-up code): nlohmann-json with the limits a hostile file
/// must not get past, and the field readers the formats share. Errors are glovepose::Error.
#pragma once

#include <nlohmann/json.hpp>

#include <cstddef>
#include <cstdint>
#include <initializer_list>
#include <set>
#include <string>
#include <vector>

#include "../config.hpp"

namespace glovepose::io::json {

/// @brief A parsed JSON value; objects keep their members in file order.
using Value = nlohmann::ordered_json;

/// @brief Deepest nesting a file may have (containers around a value).
inline constexpr int kMaxDepth = 64;
/// @brief Most values a file may hold: bounds the memory a hostile file can ask for.
inline constexpr std::size_t kMaxValues = 1'000'000;

/// @brief An nlohmann-json message without its "[json.exception.name.id] " tag.
inline std::string message(const nlohmann::json::exception& e) {
  const std::string what = e.what();
  const std::size_t tag_end = what.rfind("] ", what.find(' '));
  return what.front() == '[' && tag_end != std::string::npos ? what.substr(tag_end + 2) : what;
}

/// @brief Parses `text` as one JSON value (whitespace around it allowed). Refuses, besides what is
/// not JSON: nesting deeper than kMaxDepth, more than kMaxValues values, a key given twice in one
/// object, and numbers too large for a double. Syntax errors name the byte, counting the text's
/// first byte as `base_offset` (its place in the file). Numbers are read in the C locale's format
/// whatever locale the process has set.
inline Value parse(const std::string& text, std::size_t base_offset = 0) {
  std::vector<std::set<std::string>> keys;  // of each object being read, innermost last
  std::size_t values = 0;
  const auto limits = [&](int depth, nlohmann::detail::parse_event_t event, Value& parsed) {
    using Event = nlohmann::detail::parse_event_t;
    if (event == Event::object_start || event == Event::array_start || event == Event::value) {
      if (depth > kMaxDepth) throw Error("nesting deeper than " + std::to_string(kMaxDepth) + " levels");
      if (++values > kMaxValues) throw Error("more than " + std::to_string(kMaxValues) + " JSON values");
    }
    if (event == Event::object_start) keys.emplace_back();
    if (event == Event::object_end) keys.pop_back();
    if (event == Event::key && !keys.back().insert(parsed.get<std::string>()).second)
      throw Error("duplicate key '" + parsed.get<std::string>() + "'");
    return true;
  };
  try {
    return Value::parse(text, limits);
  } catch (const nlohmann::json::parse_error& e) {
    // e.byte counts from 1 and points at the last byte read: the one that broke the grammar.
    std::string what = message(e);
    const std::size_t column = what.find(", column ");
    const std::size_t detail = column == std::string::npos ? std::string::npos : what.find(": ", column);
    if (detail != std::string::npos) what = what.substr(detail + 2);
    throw Error("byte " + std::to_string(base_offset + (e.byte > 0 ? e.byte - 1 : 0)) + ": " + what);
  } catch (const nlohmann::json::exception& e) {  // a number too large for a double
    throw Error(message(e) + ", expected numbers a double holds");
  }
}

/// @brief `value` as compact JSON text (`indent` >= 0: pretty, that many spaces per level).
/// Throws glovepose::Error when a string in it is not UTF-8 (JSON text must be).
inline std::string write(const Value& value, int indent = -1) {
  try {
    return value.dump(indent);
  } catch (const nlohmann::json::type_error& e) {
    throw Error("cannot write JSON: " + message(e) + ", expected UTF-8 text");
  }
}

/// @brief `s` as a JSON string literal, quotes included.
inline std::string quote(const std::string& s) { return write(Value(s)); }

/// @brief A value as a message shows it: literals and numbers as written, strings quoted, and
/// containers by kind.
inline std::string describe(const Value& v) {
  if (v.is_array()) return "an array";
  if (v.is_object()) return "an object";
  return write(v);
}

/// @brief Typed access to the members of a format's objects; errors start with the format's
/// `prefix` ("glove description: ") and name the object (`where`), the key and what was expected.
class Fields {
 public:
  explicit Fields(std::string prefix) : prefix_(std::move(prefix)) {}

  /// @brief An Error with the prefix.
  Error fail(const std::string& what) const { return Error(prefix_ + what); }

  /// @brief A member that must be present.
  const Value& at(const Value& object, const char* key, const std::string& where) const {
    const auto it = object.find(key);
    if (it == object.end()) throw fail(where + " lacks the key '" + key + "'");
    return *it;
  }
  /// @brief A member that may be absent (nullptr).
  static const Value* find(const Value& object, const char* key) {
    const auto it = object.find(key);
    return it == object.end() ? nullptr : &*it;
  }
  /// @brief A string member.
  std::string string(const Value& object, const char* key, const std::string& where) const {
    return typed(object, key, where, &Value::is_string, "a string").get<std::string>();
  }
  /// @brief A number member (any JSON number).
  double number(const Value& object, const char* key, const std::string& where) const {
    return typed(object, key, where, &Value::is_number, "a number").get<double>();
  }
  /// @brief An array member.
  const Value& array(const Value& object, const char* key, const std::string& where) const {
    return typed(object, key, where, &Value::is_array, "an array");
  }
  /// @brief An object member.
  const Value& object(const Value& object, const char* key, const std::string& where) const {
    return typed(object, key, where, &Value::is_object, "an object");
  }
  /// @brief The numbers of an array value `v` (`what` names it in the error for another value).
  std::vector<double> numbers(const Value& v, const std::string& what) const {
    if (!v.is_array()) throw fail(what + " is " + describe(v) + ", expected an array of numbers");
    std::vector<double> out;
    out.reserve(v.size());
    for (const Value& item : v) {
      if (!item.is_number()) throw fail(what + " holds " + describe(item) + ", expected numbers");
      out.push_back(item.get<double>());
    }
    return out;
  }
  /// @brief An integer member in 0..limit-1 (limit > 0), written without fraction or exponent.
  int index(const Value& object, const char* key, int limit, const std::string& where) const {
    const Value& v = at(object, key, where);
    if (!v.is_number_unsigned() || v.get<std::uint64_t>() >= static_cast<std::uint64_t>(limit))
      throw fail(where + ": '" + key + "' is " + describe(v) + ", expected an integer 0.." + std::to_string(limit - 1));
    return static_cast<int>(v.get<std::uint64_t>());
  }
  /// @brief The format's name and version, checked first so that another file or version is named
  /// as such rather than by its first unknown key.
  void format(const Value& root, const char* name, std::uint64_t version) const {
    if (!root.is_object()) throw fail("not a JSON object, expected {\"format\": \"" + std::string(name) + "\", ...}");
    const std::string format = string(root, "format", "the top-level object");
    if (format != name) throw fail("'format' is '" + format + "', expected '" + name + "'");
    const Value& v = at(root, "version", "the top-level object");
    if (!v.is_number_unsigned() || v.get<std::uint64_t>() != version)
      throw fail("'version' is " + describe(v) + ", expected " + std::to_string(version) + " (the version this build of glovepose reads)");
  }
  /// @brief Refuses keys outside `allowed`: a misspelt optional key would otherwise pass unnoticed.
  void only(const Value& object, std::initializer_list<const char*> allowed, const std::string& where) const {
    for (const auto& member : object.items()) {
      bool known = false;
      for (const char* key : allowed) known = known || member.key() == key;
      if (known) continue;
      std::string list;
      for (const char* key : allowed) list += std::string(list.empty() ? "" : ", ") + "'" + key + "'";
      throw fail(where + " has the unknown key '" + member.key() + "', expected only " + list);
    }
  }

 private:
  const Value& typed(const Value& object, const char* key, const std::string& where, bool (Value::*is)() const noexcept,
                     const char* expected) const {
    const Value& v = at(object, key, where);
    if (!(v.*is)()) throw fail(where + ": '" + key + "' is " + describe(v) + ", expected " + expected);
    return v;
  }

  std::string prefix_;
};

}  // namespace glovepose::io::json
