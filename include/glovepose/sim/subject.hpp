/// @file subject.hpp
/// @brief Simulated participants: hand shapes spanning the paper's range, made by scaling the
/// reference template hand, and each person's way of moving.
///
/// Sizes. The paper's ten hands (Table 1, bounding boxes L x W x H in cm) are the default subjects
/// 0..9; further subjects are drawn from the ranges of Sec. 5.1 (length 17-20.5 cm, width 9-11 cm,
/// length/width 1.6-2.1, height 4-5 cm). The template (Tkach et al. 2017's hand model) is about
/// 18-19 cm long: we take 185 mm. Its width is not in its published data (the rest-pose spheres
/// span 83.7 mm across the splayed fingertips, thumb not included), so the template is taken to have
/// the mean aspect ratio of the paper's ten hands (1.835): 100.8 mm, and their mean height, 42 mm.
/// Lengths along the hand scale by L / 185 mm; the spacing of the knuckles by W / 100.8 mm; finger
/// girth (sphere radii, dorsal offsets) by sqrt(W/W0 * H/H0).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

#include "../config.hpp"
#include "../hand/collision.hpp"
#include "../hand/dofs.hpp"
#include "../hand/kinematics.hpp"
#include "../core/random.hpp"

namespace glovepose::sim {

/// @brief Template hand length (mm): the template hand of Tkach et al. 2017 is about 18-19 cm long.
inline constexpr double kTemplateLength = 185.0;
/// @brief Template hand width (mm): kTemplateLength / 1.835, the mean L/W of the paper's Table 1.
inline constexpr double kTemplateWidth = 100.8;
/// @brief Template hand height (mm): mean H of the paper's Table 1.
inline constexpr double kTemplateHeight = 42.0;

/// @brief Radius (mm) of the template's sphere at each digit's base joint, pose-map order (thumb,
/// index, middle, ring, pinky): spheres 19, 15, 11, 7, 3 of the template's radii (R.txt of
/// anastasia-tkach/honline-cpp-public, data/models/anastasia). With
/// hand::kReferenceDistalRadius (the sphere at the far end of each phalanx) this gives the skin's
/// distance from every joint axis.
inline constexpr std::array<double, hand::kFingerCount> kReferenceKnuckleRadius{15.6827, 8.44143, 7.68834, 7.26768, 7.84562};

/// @brief A hand's bounding box (mm), as the paper's Table 1 lists them.
struct HandSize {
  double length, width, height;
};

/// @brief The paper's ten hands (Table 1), in its row order.
inline constexpr std::array<HandSize, 10> kPaperHands{{{190, 110, 45},
                                                       {190, 95, 40},
                                                       {180, 110, 40},
                                                       {190, 110, 40},
                                                       {180, 105, 45},
                                                       {205, 100, 50},
                                                       {200, 105, 40},
                                                       {170, 100, 40},
                                                       {200, 100, 40},
                                                       {170, 90, 40}}};

/// @brief How one person's skin and soft tissue pass a motion to the glove, as multipliers of the
/// population's coefficients in glove.hpp (1 = typical). Skin elasticity and subcutaneous tissue
/// differ between people (age, body mass), so the same joint angle stretches the same cell
/// differently: lognormal with a log-SD of kSkinSpread (assumption).
struct SkinMechanics {
  double bend_zone = 1.0;        ///< Width of the bend zone over a joint.
  double joint_spill = 1.0;      ///< Neighbouring joints' lengthening reaching a joint cell.
  double sheet_tension = 1.0;    ///< Other digits' pull through the sheet.
  double slide = 1.0;            ///< Distal slide of the glove as the finger curls.
  double girth_flexion = 1.0;    ///< Girth growth over a flexed joint.
  double girth_abduction = 1.0;  ///< Girth pull of abduction.
  double knuckle_share = 1.0;    ///< Neighbouring knuckles' stretch on the back of the hand.
  double knuckle_falloff = 1.0;  ///< Reach of the knuckles' stretch over the back of the hand.
  double thumb_falloff = 1.0;    ///< Reach of the thumb's pull over the back of the hand.
};

/// @brief Log-SD of the per-person skin multipliers (assumption: a factor of 1.4 either way is one SD).
inline constexpr double kSkinSpread = 0.35;

/// @brief How a world's people differ from one another and how well they perform a calibration
/// sequence (sim/world.hpp). The defaults are the clean world's.
struct PeopleConfig {
  double skin_spread = kSkinSpread;  ///< Log-SD of the per-person skin multipliers (SkinMechanics).
  /// SD of the share of the way to each extreme pose of a calibration sequence a person falls short
  /// (half-normal per visit, at most half; 0: every extreme reached as the person forms it).
  double calibration_shortfall = 0.0;
  /// Share of a session's visits in which every finger goes its own way: each takes a gallery pose of
  /// its own (0: whole-hand gallery poses and their blends only).
  double independent_fingers = 0.0;
};

/// @brief One simulated participant: hand geometry and movement habits.
struct Subject {
  int id = 0;                                             ///< 0-based.
  HandSize size{};                                        ///< Bounding box, mm.
  std::array<double, hand::kFingerCount> finger_scale{};  ///< Individual finger proportions (about 1).
  hand::Angles style{};                                   ///< How this person forms the gallery's poses: a persistent offset per DoF (rad).
  double speed = 1.0;                                     ///< Movement speed factor (1 = the population's mean).
  double dwell = 0.7;                                     ///< Mean time (s) held at a pose.
  double coupling = 0.2;                                  ///< Share of a finger's flexion its neighbours follow (finger enslaving).
  SkinMechanics skin{};                                   ///< How this person's skin passes motion to the glove.

  /// @brief Length scale against the template.
  double length_scale() const noexcept { return size.length / kTemplateLength; }
  /// @brief Knuckle-spacing scale against the template.
  double width_scale() const noexcept { return size.width / kTemplateWidth; }
  /// @brief Girth scale against the template (finger radii).
  double girth_scale() const noexcept { return std::sqrt(width_scale() * size.height / kTemplateHeight); }

  /// @brief The template chain scaled to this hand.
  hand::HandModel hand_model() const {
    hand::HandModel model = hand::HandModel::reference();
    for (std::size_t p = 1; p <= 15; ++p) {
      const std::size_t finger = finger_of_phalanx(static_cast<int>(p));
      Eigen::Vector3d t = model.rest[p].translation();
      if (hand::kParent[p] == 0) {  // a digit's base frame on the palm
        t.x() *= width_scale();
        t.y() *= length_scale();
        t.z() *= girth_scale();
      } else {
        t *= length_scale() * finger_scale[finger];
      }
      model.rest[p].translation() = t;
    }
    for (std::size_t f = 0; f < hand::kFingerCount; ++f) model.tip_length[f] *= length_scale() * finger_scale[f];
    return model;
  }

  /// @brief Distal sphere radius of each phalanx 0..15 scaled to this hand (collision, skin offsets).
  std::array<double, 16> distal_radius() const noexcept {
    std::array<double, 16> r = hand::kReferenceDistalRadius;
    for (double& v : r) v *= girth_scale();
    return r;
  }

  /// @brief Skin radius at a digit's base joint, scaled to this hand.
  double knuckle_radius(hand::Finger f) const noexcept { return kReferenceKnuckleRadius[static_cast<std::size_t>(f)] * girth_scale(); }

  /// @brief Pose-map digit of a finger phalanx id 1..15.
  static std::size_t finger_of_phalanx(int p) noexcept {
    constexpr std::array<std::size_t, 16> digit{0, 0, 0, 0, 4, 4, 4, 3, 3, 3, 2, 2, 2, 1, 1, 1};
    return digit[static_cast<std::size_t>(p)];
  }
};

/// @brief Draws a hand size from the paper's ranges (Sec. 5.1), by rejection on the aspect ratio.
inline HandSize draw_hand_size(core::Rng& rng) noexcept {
  for (;;) {
    const HandSize s{rng.uniform(170.0, 205.0), rng.uniform(90.0, 110.0), rng.uniform(40.0, 50.0)};
    const double ratio = s.length / s.width;
    if (ratio >= 1.6 && ratio <= 2.1) return s;
  }
}

/// @brief `count` subjects from `seed`: the paper's ten hands first, then drawn sizes; their skin
/// spread as `people` says. Subject i depends only on (seed, i). Throws glovepose::Error for a count
/// below 1.
inline std::vector<Subject> make_subjects(int count, std::uint64_t seed, const PeopleConfig& people = {}) {
  if (count < 1) throw Error("make_subjects: " + std::to_string(count) + " subjects, expected at least 1");
  std::vector<Subject> subjects;
  for (int i = 0; i < count; ++i) {
    core::Rng rng(core::derive_seed(seed, {1, static_cast<std::uint64_t>(i)}));
    Subject s;
    s.id = i;
    s.size = i < static_cast<int>(kPaperHands.size()) ? kPaperHands[static_cast<std::size_t>(i)] : draw_hand_size(rng);
    // Finger proportions vary by a few percent between people (e.g. the 2D:4D ratio, SD ~3%).
    for (double& f : s.finger_scale) f = std::clamp(rng.normal(1.0, 0.025), 0.93, 1.07);
    // Style: SD 0.08 rad (~5 deg) per DoF, abductions and twists half of it.
    for (std::size_t d = 0; d < hand::kDofCount; ++d) {
      const bool small = hand::kDofs[d].motion == hand::Motion::Abduction || hand::kDofs[d].motion == hand::Motion::Twist;
      s.style[d] = rng.normal(0.0, small ? 0.04 : 0.08);
    }
    s.speed = rng.uniform(0.75, 1.3);
    s.dwell = rng.uniform(0.4, 1.0);
    s.coupling = rng.uniform(0.1, 0.3);
    for (double* m : {&s.skin.bend_zone, &s.skin.joint_spill, &s.skin.sheet_tension, &s.skin.slide, &s.skin.girth_flexion,
                      &s.skin.girth_abduction, &s.skin.knuckle_share, &s.skin.knuckle_falloff, &s.skin.thumb_falloff})
      *m = std::exp(rng.normal(0.0, people.skin_spread));
    subjects.push_back(s);
  }
  return subjects;
}

}  // namespace glovepose::sim
