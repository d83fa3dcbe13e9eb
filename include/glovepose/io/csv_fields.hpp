/// @file csv_fields.hpp
/// @brief The fields of one line of comma-separated text, and numbers read from them independent of
/// the locale: what every CSV reader of the library (dataset CSV, recording import) shares.
/// Set-up code: a field that is not what was expected is a glovepose::Error that starts with the
/// caller's `where` (file, line, column).
#pragma once

#include <charconv>
#include <cmath>
#include <cstdint>
#include <istream>
#include <string>
#include <system_error>
#include <vector>

#include "../config.hpp"

namespace glovepose::io {

/// @brief The comma-separated fields of `line`, each without surrounding blanks (spaces, tabs, a
/// carriage return). An empty line is one empty field.
inline std::vector<std::string> split_csv_line(const std::string& line) {
  std::vector<std::string> out;
  std::size_t start = 0;
  while (true) {
    const std::size_t comma = line.find(',', start);
    const std::string field = line.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
    const std::size_t a = field.find_first_not_of(" \t\r"), b = field.find_last_not_of(" \t\r");
    out.push_back(a == std::string::npos ? std::string() : field.substr(a, b - a + 1));
    if (comma == std::string::npos) return out;
    start = comma + 1;
  }
}

/// @brief Whether column `name` matches `pattern`: '*' stands for any run of characters (also
/// none), '?' for any one character, everything else for itself (case-sensitive).
inline bool column_matches(const std::string& name, const std::string& pattern) {
  // Greedy wildcard matching with one backtrack point: the last '*' seen.
  std::size_t n = 0, p = 0, star = std::string::npos, resume = 0;
  while (n < name.size()) {
    if (p < pattern.size() && (pattern[p] == '?' || (pattern[p] != '*' && pattern[p] == name[n]))) {
      ++n, ++p;
    } else if (p < pattern.size() && pattern[p] == '*') {
      star = p++;
      resume = n;
    } else if (star != std::string::npos) {
      p = star + 1;
      n = ++resume;
    } else {
      return false;
    }
  }
  while (p < pattern.size() && pattern[p] == '*') ++p;
  return p == pattern.size();
}

/// @brief Whether column `name` is one of `patterns` (column_matches()).
inline bool column_listed(const std::string& name, const std::vector<std::string>& patterns) {
  for (const std::string& pattern : patterns)
    if (column_matches(name, pattern)) return true;
  return false;
}

/// @brief Whether `line` holds nothing but blanks.
inline bool blank_csv_line(const std::string& line) { return line.find_first_not_of(" \t\r") == std::string::npos; }

/// @brief Whether a recording's CSV reader passes over `line`: blank, or a comment ('#' first).
inline bool skipped_csv_line(const std::string& line) {
  return blank_csv_line(line) || line[line.find_first_not_of(" \t")] == '#';
}

/// @brief Reads the next line that skipped_csv_line() does not pass over into `line`, counting
/// every line read in `line_no`; false at the end of `in`.
inline bool next_csv_line(std::istream& in, std::string& line, std::size_t& line_no) {
  while (std::getline(in, line)) {
    ++line_no;
    if (!skipped_csv_line(line)) return true;
  }
  return false;
}

/// @brief The field `text` as a finite number of type T (a leading '+' allowed). Throws
/// glovepose::Error "<where> is not a number" or "... is not a finite number".
template <typename T>
T parse_csv_number(const std::string& text, const std::string& where) {
  const char* begin = text.data();
  if (text.size() > 1 && text[0] == '+' && text[1] != '-') ++begin;
  T v{};
  const auto r = std::from_chars(begin, text.data() + text.size(), v);
  if (r.ptr != text.data() + text.size() || text.empty() || (r.ec != std::errc() && r.ec != std::errc::result_out_of_range))
    throw Error(where + " is not a number");
  if (r.ec != std::errc() || !std::isfinite(v)) throw Error(where + " is not a finite number");
  return v;
}

/// @brief The field `text` as an id: a non-negative integer that fits 32 bits. Throws
/// glovepose::Error "<where> is not a non-negative integer".
inline std::int32_t parse_csv_id(const std::string& text, const std::string& where) {
  std::int32_t v = 0;
  const auto r = std::from_chars(text.data(), text.data() + text.size(), v);
  if (text.empty() || r.ec != std::errc() || r.ptr != text.data() + text.size() || v < 0)
    throw Error(where + " is not a non-negative integer");
  return v;
}

}  // namespace glovepose::io
