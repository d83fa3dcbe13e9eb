/// @file json.hpp
/// @brief A small, strict JSON reader and string escaper for the weight-file header (set-up code).
/// Errors are glovepose::Error naming the byte offset and what was expected.
#pragma once

#include <charconv>
#include <cstdint>
#include <cstdlib>
#include <set>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "../config.hpp"

namespace glovepose::io::json {

/// @brief A parsed JSON value. Objects keep their members in file order.
struct Value {
  /// @brief Kind of value.
  enum class Kind { Null, Bool, Number, String, Array, Object } kind = Kind::Null;
  bool boolean = false;                                ///< Bool.
  double number = 0.0;                                 ///< Number.
  std::string text;                                    ///< String, or the literal text of a Number.
  std::vector<Value> items;                            ///< Array.
  std::vector<std::pair<std::string, Value>> members;  ///< Object.
  std::size_t offset = 0;                              ///< Byte offset of the value in the parsed text.

  /// @brief Member by key, or nullptr.
  const Value* find(const std::string& key) const noexcept {
    for (const auto& m : members)
      if (m.first == key) return &m.second;
    return nullptr;
  }
  /// @brief Whether a Number is a non-negative integer written without fraction or exponent.
  bool is_unsigned_integer() const noexcept {
    if (kind != Kind::Number || text.empty()) return false;
    for (char c : text)
      if (c < '0' || c > '9') return false;
    return text.size() <= 19;
  }
};

/// @brief Parses `text` (whose first byte is at `base_offset` in the file, for messages).
class Parser {
 public:
  /// @brief Parses one JSON value spanning the whole text (trailing whitespace allowed).
  static Value parse(const std::string& text, std::size_t base_offset = 0) {
    Parser p(text, base_offset);
    p.skip_space();
    Value v = p.value(0);
    p.skip_space();
    if (p.pos_ != text.size()) p.fail("unexpected text after the JSON value");
    return v;
  }

 private:
  Parser(const std::string& text, std::size_t base) : s_(text), base_(base) {}

  [[noreturn]] void fail(const std::string& what) const {
    throw Error("JSON header: byte " + std::to_string(base_ + pos_) + ": " + what);
  }
  void skip_space() noexcept {
    while (pos_ < s_.size() && (s_[pos_] == ' ' || s_[pos_] == '\t' || s_[pos_] == '\n' || s_[pos_] == '\r')) ++pos_;
  }
  bool eat(char c) noexcept {
    if (pos_ < s_.size() && s_[pos_] == c) {
      ++pos_;
      return true;
    }
    return false;
  }
  void expect_word(const char* word) {
    for (const char* c = word; *c; ++c)
      if (!eat(*c)) fail(std::string("expected '") + word + "'");
  }

  Value value(int depth) {
    if (depth > 64) fail("nesting deeper than 64 levels");
    // Bounds the memory a hostile header can ask for (a model has a few dozen tensors).
    if (++values_ > kMaxValues) fail("more than " + std::to_string(kMaxValues) + " JSON values, expected a weight-file header");
    if (pos_ >= s_.size()) fail("unexpected end, expected a value");
    Value v;
    v.offset = base_ + pos_;
    const char c = s_[pos_];
    if (c == '{') {
      v.kind = Value::Kind::Object;
      ++pos_;
      skip_space();
      if (eat('}')) return v;
      std::set<std::string> keys;
      do {
        skip_space();
        if (pos_ >= s_.size() || s_[pos_] != '"') fail("expected a string key");
        std::string key = string();
        if (!keys.insert(key).second) fail("duplicate key '" + key + "'");
        skip_space();
        if (!eat(':')) fail("expected ':'");
        skip_space();
        Value member = value(depth + 1);
        v.members.emplace_back(std::move(key), std::move(member));
        skip_space();
      } while (eat(','));
      if (!eat('}')) fail("expected ',' or '}'");
    } else if (c == '[') {
      v.kind = Value::Kind::Array;
      ++pos_;
      skip_space();
      if (eat(']')) return v;
      do {
        skip_space();
        v.items.push_back(value(depth + 1));
        skip_space();
      } while (eat(','));
      if (!eat(']')) fail("expected ',' or ']'");
    } else if (c == '"') {
      v.kind = Value::Kind::String;
      v.text = string();
    } else if (c == 't') {
      expect_word("true");
      v.kind = Value::Kind::Bool;
      v.boolean = true;
    } else if (c == 'f') {
      expect_word("false");
      v.kind = Value::Kind::Bool;
    } else if (c == 'n') {
      expect_word("null");
    } else if (c == '-' || (c >= '0' && c <= '9')) {
      v.kind = Value::Kind::Number;
      const std::size_t start = pos_;
      eat('-');
      if (pos_ + 1 < s_.size() && s_[pos_] == '0' && s_[pos_ + 1] >= '0' && s_[pos_ + 1] <= '9') fail("number with a leading zero");
      if (!digits()) fail("expected digits");
      if (eat('.') && !digits()) fail("expected digits after '.'");
      if (pos_ < s_.size() && (s_[pos_] == 'e' || s_[pos_] == 'E')) {
        ++pos_;
        if (!eat('+')) eat('-');
        if (!digits()) fail("expected exponent digits");
      }
      v.text = s_.substr(start, pos_ - start);
      // from_chars: the C locale's format whatever locale the host process has set.
      const auto result = std::from_chars(v.text.data(), v.text.data() + v.text.size(), v.number);
      if (result.ec == std::errc::result_out_of_range) fail("number out of range");
    } else {
      fail(std::string("unexpected character '") + c + "', expected a JSON value");
    }
    return v;
  }

  bool digits() noexcept {
    const std::size_t start = pos_;
    while (pos_ < s_.size() && s_[pos_] >= '0' && s_[pos_] <= '9') ++pos_;
    return pos_ > start;
  }

  std::string string() {
    ++pos_;  // opening quote
    std::string out;
    while (true) {
      if (pos_ >= s_.size()) fail("unterminated string");
      const unsigned char c = static_cast<unsigned char>(s_[pos_++]);
      if (c == '"') return out;
      if (c < 0x20) fail("control character in a string");
      if (c != '\\') {
        out += static_cast<char>(c);
        continue;
      }
      if (pos_ >= s_.size()) fail("unterminated escape");
      const char e = s_[pos_++];
      switch (e) {
        case '"': out += '"'; break;
        case '\\': out += '\\'; break;
        case '/': out += '/'; break;
        case 'b': out += '\b'; break;
        case 'f': out += '\f'; break;
        case 'n': out += '\n'; break;
        case 'r': out += '\r'; break;
        case 't': out += '\t'; break;
        case 'u': {
          std::uint32_t cp = hex4();
          if (cp >= 0xd800 && cp < 0xdc00) {  // surrogate pair
            if (!eat('\\') || !eat('u')) fail("expected a low surrogate");
            const std::uint32_t low = hex4();
            if (low < 0xdc00 || low >= 0xe000) fail("invalid low surrogate");
            cp = 0x10000 + ((cp - 0xd800) << 10) + (low - 0xdc00);
          } else if (cp >= 0xdc00 && cp < 0xe000) {
            fail("unpaired low surrogate");
          }
          append_utf8(out, cp);
          break;
        }
        default: fail(std::string("invalid escape '\\") + e + "'");
      }
    }
  }

  std::uint32_t hex4() {
    std::uint32_t v = 0;
    for (int i = 0; i < 4; ++i) {
      if (pos_ >= s_.size()) fail("unterminated \\u escape");
      const char h = s_[pos_++];
      v <<= 4;
      if (h >= '0' && h <= '9') v |= static_cast<std::uint32_t>(h - '0');
      else if (h >= 'a' && h <= 'f') v |= static_cast<std::uint32_t>(h - 'a' + 10);
      else if (h >= 'A' && h <= 'F') v |= static_cast<std::uint32_t>(h - 'A' + 10);
      else fail("expected a hex digit");
    }
    return v;
  }

  static void append_utf8(std::string& out, std::uint32_t cp) {
    if (cp < 0x80) {
      out += static_cast<char>(cp);
    } else if (cp < 0x800) {
      out += static_cast<char>(0xc0 | (cp >> 6));
      out += static_cast<char>(0x80 | (cp & 0x3f));
    } else if (cp < 0x10000) {
      out += static_cast<char>(0xe0 | (cp >> 12));
      out += static_cast<char>(0x80 | ((cp >> 6) & 0x3f));
      out += static_cast<char>(0x80 | (cp & 0x3f));
    } else {
      out += static_cast<char>(0xf0 | (cp >> 18));
      out += static_cast<char>(0x80 | ((cp >> 12) & 0x3f));
      out += static_cast<char>(0x80 | ((cp >> 6) & 0x3f));
      out += static_cast<char>(0x80 | (cp & 0x3f));
    }
  }

  static constexpr std::size_t kMaxValues = 1'000'000;

  const std::string& s_;
  std::size_t base_;
  std::size_t pos_ = 0;
  std::size_t values_ = 0;
};

/// @brief `s` as a JSON string literal, quotes included.
inline std::string quote(const std::string& s) {
  std::string out = "\"";
  for (char ch : s) {
    const unsigned char c = static_cast<unsigned char>(ch);
    if (c == '"') out += "\\\"";
    else if (c == '\\') out += "\\\\";
    else if (c == '\n') out += "\\n";
    else if (c < 0x20) {
      const char hex[] = "0123456789abcdef";
      out += "\\u00";
      out += hex[c >> 4];
      out += hex[c & 15];
    } else out += ch;
  }
  return out + "\"";
}

}  // namespace glovepose::io::json
