/// @file subject_hands.hpp
/// @brief The hand of each person in a dataset, for evaluation's fingertip measures
/// (train::EvaluationOptions::hands): a simulated corpus' people are sim::make_subjects of its seed
/// (a hand depends on the seed and the person's id only).
#pragma once

#include <cmath>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "../io/dataset.hpp"
#include "../io/json.hpp"
#include "../train/evaluate.hpp"
#include "subject.hpp"

namespace glovepose::sim {

/// @brief Each simulated person's own hand when `data` is a corpus of `glovepose simulate` whose
/// recorded sizes ("subject_sizes_mm") are those of make_subjects of its seed; anything else gets
/// the reference hand (the description says which).
inline train::SubjectHands subject_hands(const io::Dataset& data) {
  train::SubjectHands hands;
  const auto meta = [&](const char* key) {
    const auto it = data.metadata.find(key);
    return it == data.metadata.end() ? std::string() : it->second;
  };
  const auto whole = [](const std::string& text) -> std::optional<std::uint64_t> {
    if (text.empty() || text.find_first_not_of("0123456789") != std::string::npos || text.size() > 19) return std::nullopt;
    return std::stoull(text);
  };
  const std::optional<std::uint64_t> count = whole(meta("subjects")), seed = whole(meta("seed"));
  if (meta("generator") != "glovepose simulate" || !count || *count < 1 || *count > 100000 || !seed) return hands;
  const std::vector<Subject> people = make_subjects(static_cast<int>(*count), *seed);
  io::json::Value recorded;
  try {
    recorded = io::json::parse(meta("subject_sizes_mm"));
  } catch (const Error&) {
    return hands;
  }
  if (!recorded.is_array() || recorded.size() != people.size()) return hands;
  for (const Subject& p : people) {  // written with 6 decimals
    const io::json::Value& r = recorded[static_cast<std::size_t>(p.id)];
    const double size[] = {p.size.length, p.size.width, p.size.height};
    for (std::size_t i = 0; i < 3; ++i)
      if (!r.is_array() || r.size() != 3 || !r[i].is_number() || std::abs(r[i].get<double>() - size[i]) > 1e-5) return hands;
  }
  for (const Subject& p : people) hands.people.emplace_back(p.hand_model());
  hands.description = "each simulated person's own hand";
  return hands;
}

}  // namespace glovepose::sim
