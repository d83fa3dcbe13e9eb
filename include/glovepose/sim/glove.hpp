/// @file glove.hpp
/// @brief The simulated glove: fabrication (one glove's spread of base capacitances and direction
/// selectivity), fit (how the cells sit on a hand each time the glove is put on) and the sensor
/// physics from the posed hand to the 44 cell capacitances C_c.
///
/// Physics, per cell, from the posed hand's geometry:
///  - strain along the digit: the skin over a flexing joint lengthens by about r * angle (r: the
///    skin's distance from the joint axis, the template's sphere radius there, scaled to the hand);
///    a cell catches the share of that lengthening that falls under it (its length against a bend
///    zone of width 1.2 r centred on the joint: a shifted cell catches less), plus a little from the
///    digit's neighbouring joints (the skin slides along the finger). Back-of-hand cells catch the
///    knuckles' lengthening with an exponential fall-off over their distance from the knuckle line.
///  - the sheet between the skin and the cells (WearConfig, off in the named worlds): straighter
///    neighbours hold back part of a finger's knuckle lengthening (the one-piece sheet joins the
///    fingers), and past a stick angle friction lets go and part of a joint's lengthening slides to
///    the cells over the digit's neighbouring joints. Both make a cell's reading depend on the pose
///    in ways no weighted sum of the angles can follow.
///  - strain across: finger cells see the girth grow over a flexed joint and the web pull when the
///    finger abducts against its neighbours; web (abduction) cells see the change of the distance
///    between the two digits' proximal phalanxes; back-of-hand cells see the spread of the dorsal
///    knuckle points and the thumb's distance from the index knuckle, with distance fall-off.
///  - pre-stretch: the glove's sheet is relaxed on a hand of WearConfig::relaxed_length x
///    relaxed_width x kGloveRelaxedHeight;
///    a bigger hand stretches every cell before any motion, a smaller one leaves slack that the first
///    motion only takes up (the textile carries no compression: a smooth ramp of width kSlackWidth).
///  - the textile stiffens at large stretch: strain saturates as kSaturation * tanh(s / kSaturation).
///  - the cuts beside each cell make it compliant along them (paper Sec. 3.1): the other direction
///    reaches the cell attenuated by the glove's cross gain (about kCrossGain).
///  - area ratio A/A0 = lambda_along * lambda_across, and C = C0 (A/A0)^2 (paper eq. 1, volume
///    conservation), C0 = eps_r eps_0 A0 / d for the cell's size (5 x 7.5 or 5 x 11.5 mm, Sec. 3.3).
/// Every constant below says where its value comes from; those marked "assumption" are ours. The
/// coupling coefficients are the population's; each subject multiplies them by its own
/// SkinMechanics (subject.hpp).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <string>

#include "../config.hpp"
#include "../hand/dofs.hpp"
#include "../hand/kinematics.hpp"
#include "../sensor/layout.hpp"
#include "../core/random.hpp"
#include "../core/units.hpp"
#include "subject.hpp"

namespace glovepose::sim {

/// @brief Cells of the simulated glove (the paper's layout, sensor::TraceLayout::glauser2019()).
inline constexpr int kCells = sensor::kGlauser2019Cells;
/// @brief One value per cell.
using CellArray = std::array<double, kCells>;

/// @brief Hand the glove's sheet is relaxed on (mm), length: assumption, the medium glove's 20 cm
/// outline (paper Sec. 5.2) less the wrist strap and seams, so that the paper's 17 cm hands wear it
/// with a little slack and its 20.5 cm hand with 17% pre-stretch.
inline constexpr double kGloveRelaxedLength = 175.0;
/// @brief Width (mm) of the hand the sheet is relaxed on: assumption, the 12.5 cm outline less the
/// textile margins; the paper's 9-11 cm hands span -5..+16% across pre-stretch.
inline constexpr double kGloveRelaxedWidth = 95.0;
/// @brief Height (mm) of the hand the sheet is relaxed on (assumption, the paper's smallest, 4 cm).
inline constexpr double kGloveRelaxedHeight = 40.0;
/// @brief Cell widths and lengths (mm): paper Sec. 3.3, "5 x 7.5 mm and 5 x 11.5"; the longer ones
/// are the main-joint cells ("longer sensors directly correspond to the main joints", Sec. 3.1).
inline constexpr double kCellWidth = 5.0, kShortCellLength = 7.5, kLongCellLength = 11.5;
/// @brief Relative permittivity of the silicone dielectric (assumption: typical of PDMS-class
/// silicones, 2.7-3.0).
inline constexpr double kPermittivity = 2.8;
/// @brief Dielectric thickness (mm), assumption: the 0.85 mm sheet less two 0.22 mm conductive
/// layers (paper Sec. 3.2) and two shielding layers.
inline constexpr double kDielectricThickness = 0.2;
/// @brief Vacuum permittivity in pF/mm.
inline constexpr double kEpsilon0 = 8.8541878128e-3;
/// @brief Fabrication spread of C0 (relative SD): assumption, hand-cast layers of tape-controlled
/// thickness (Sec. 3.2) vary by a few percent.
inline constexpr double kBaseCapacitanceSpread = 0.05;
/// @brief Share of the stretch across a cell's cuts that reaches it (assumption; paper Sec. 3.1:
/// the joint cells are "much less sensitive" to girth), and its spread between cells.
inline constexpr double kCrossGain = 0.2, kCrossGainSpread = 0.05;
/// @brief Width of the bend zone over a joint, in units of the skin radius r (assumption).
inline constexpr double kBendZone = 1.2;
/// @brief Share of a neighbouring joint's skin lengthening that reaches a joint cell (assumption).
inline constexpr double kNeighbourJointSpill = 0.08;
/// @brief Extension (negative flexion) stretches the dorsal skin less than flexion compresses the
/// palmar side; the dorsal skin's response to extension is this share (assumption).
inline constexpr double kExtensionShare = 0.3;
/// @brief Girth strain per radian of flexion of the joint under a finger cell (assumption).
inline constexpr double kGirthPerFlexion = 0.06;
/// @brief Girth strain per radian of abduction against the neighbours, proximal cells (assumption).
inline constexpr double kGirthPerAbduction = 0.15;
/// @brief Fall-off length (mm) of the knuckles' stretch over the back of the hand (assumption).
inline constexpr double kKnuckleFalloff = 12.0;
/// @brief Fall-off length (mm) of the thumb's pull over the back of the hand (assumption).
inline constexpr double kThumbFalloff = 25.0;
/// @brief Share of a neighbouring digit's knuckle lengthening a back-of-hand cell sees (assumption:
/// the sheet passes strain sideways).
inline constexpr double kNeighbourKnuckleShare = 0.25;
/// @brief Skin spans (mm) over which a distance change between digits spreads: finger webs, the
/// thumb web, the back of the hand across knuckles, the thumb over the back (assumption).
inline constexpr double kFingerWebSpan = 10.0, kThumbWebSpan = 25.0, kKnuckleSpan = 15.0, kThumbBackSpan = 40.0;
/// @brief Distal slide (mm per radian) of the glove over a finger's back as the joints proximal to a
/// cell flex: the textile is pulled towards the fingertip when the finger curls (assumption).
inline constexpr double kSlidePerFlexion = 1.5;
/// @brief Share of the mean knuckle lengthening of the other digits that reaches every finger cell
/// through the tension of the one-piece sheet (assumption).
inline constexpr double kSheetTension = 0.05;
/// @brief Width of the slack ramp (strain): the textile takes up slack smoothly (assumption).
inline constexpr double kSlackWidth = 0.01;
/// @brief Strain at which the textile locks up (assumption: elastane jersey, paper Sec. 3.2).
inline constexpr double kSaturation = 0.6;
/// @brief Donning: SD (mm) of the whole glove's shift along the fingers, of each cell's own shift, and
/// the relative SD of each cell's pre-stretch (assumption: "shifts of a few millimetres"; the wrist
/// strap of Sec. 3.2 bounds them).
inline constexpr double kDonningShift = 1.5, kCellShift = 1.0, kPreStretchSpread = 0.02;

/// @brief How the glove sits on and moves over a hand, and how two gloves of the design differ: the
/// wear effects of a simulated world (sim/world.hpp). The defaults are the clean world's.
struct WearConfig {
  double donning_shift = kDonningShift;           ///< SD (mm) of the whole glove's shift along the fingers at a donning.
  double cell_shift = kCellShift;                 ///< SD (mm) of each cell's own shift at a donning.
  double pre_stretch_spread = kPreStretchSpread;  ///< Relative SD of each cell's pre-stretch at a donning.
  /// Stationary SD (mm) of the glove's slip along the fingers while it is worn: an Ornstein-Uhlenbeck
  /// process from the donning's fit, pulled back by the wrist strap with time constant slip_time (s).
  double slip_sd = 0.0;
  double slip_time = 600.0;  ///< Time constant (s) of the slip.
  /// A glove too big for the hand sits loosely: donning shifts and slip x (1 + loose_gain x slack /
  /// 10%), slack = the hand's shortfall against the glove's relaxed length plus that of its width.
  double loose_gain = 0.0;
  double placement_sd = 0.0;  ///< SD (mm) of each cell's place on a fabricated glove (hand-made steps).
  /// Share of a hand's size difference from the glove's relaxed hand that reaches the cells'
  /// pre-stretch; the jersey around the stiffer sensor sheet takes the rest (1: all of it).
  double size_coupling = 1.0;
  /// A glove too big carries no load for the jersey to share, so all of the hand's shortfall should
  /// reach the cells as slack: the share of the part size_coupling leaves out that does (1: the
  /// physics; 0: slack coupled like a stretch, as the worlds fitted before this effect were).
  double loose_slack = 0.0;
  /// Length and width (mm) of the hand the glove's sheet is relaxed on (kGloveRelaxedLength, Width).
  double relaxed_length = kGloveRelaxedLength;
  double relaxed_width = kGloveRelaxedWidth;
  /// Share of the finger cells' misplacement on a finger longer or shorter than the glove's that is
  /// modelled: the cells are placed for the relaxed hand's joints and travel with the hand's length
  /// only by size_coupling, so a cell x mm from the finger's base sits x (1 - c)(1 - k) / k mm off
  /// its joint (k: the finger's length against the glove's, c: size_coupling). 1: the geometry; 0:
  /// cells follow every hand's joints (the worlds fitted before this effect).
  double length_misplacement = 0.0;
  /// Share of a finger's lengthening over its base joint that straighter neighbours hold back: the
  /// one-piece sheet joins the fingers across the webs, so a finger that flexes further than its
  /// neighbours drags sheet anchored over them, and every cell its knuckle reaches (over the
  /// knuckle, on the back of the hand, in the webs) sees only part of the difference; in a fist
  /// every knuckle's sheet carries its own. Times the person's sheet-tension multiplier, at most 1.
  /// 0: each finger's sheet on its own (the worlds fitted before this effect).
  double neighbour_hold = 0.0;
  /// Share of a flexion beyond the stick angle that the sheet slides away from the cell over the
  /// joint, half of it to the cells over each neighbouring joint of the digit: friction holds the
  /// sheet on the skin until the tension over the flexing joint exceeds it. 0: the sheet sticks
  /// (the worlds fitted before this effect).
  double slide_share = 0.0;
  /// Flexion (degrees) a joint's sheet holds by friction before it slides, for typical skin (divided
  /// by the person's slide multiplier: skin the glove slides on more easily lets go earlier).
  double stick_angle = 20.0;
};

/// @brief The stretch ratio a cell gets from a hand whose size ratio to the glove's relaxed hand is
/// `ratio`, when `coupling` of the difference reaches it (exactly `ratio` at coupling 1).
inline double coupled_size(double ratio, double coupling) noexcept {
  return coupling == 1.0 ? ratio : 1.0 + coupling * (ratio - 1.0);
}

/// @brief The stretch ratio a cell gets before any motion from a hand whose size ratio to the
/// glove's relaxed hand is `ratio`: a stretch shared with the jersey (size_coupling), a shortfall
/// as slack (WearConfig::loose_slack).
inline double rest_stretch(double ratio, const WearConfig& wear) noexcept {
  const double slack_coupling = wear.size_coupling + wear.loose_slack * (1.0 - wear.size_coupling);
  return coupled_size(ratio, ratio >= 1.0 ? wear.size_coupling : slack_coupling);
}

/// @brief How loosely the glove sits on `subject`: the shortfall of the hand's length and width
/// against the hand the sheet is relaxed on (0 for a hand that fills the glove).
inline double glove_slack(const Subject& subject, const WearConfig& wear = {}) noexcept {
  return std::max(0.0, 1.0 - subject.size.length / wear.relaxed_length) + std::max(0.0, 1.0 - subject.size.width / wear.relaxed_width);
}

/// @brief The factor by which a loose fit multiplies the donning shifts and the slip.
inline double loose_fit_factor(const Subject& subject, const WearConfig& wear) noexcept {
  return 1.0 + wear.loose_gain * glove_slack(subject, wear) / 0.1;
}

/// @brief Where a cell is and how it couples to the hand (derived from the layout, plus the
/// back-of-hand cells' distances from the knuckle line, our reading of Fig. 4).
struct CellSite {
  int digit = 0;                     ///< Pose-map digit (thumb 0 .. pinky 4).
  sensor::Segment segment{};         ///< Place along the digit.
  bool along = true;                 ///< Cut direction: senses along the digit best.
  double length = kShortCellLength;  ///< mm along the digit.
  double knuckle_distance = 0.0;     ///< Back of the hand: mm from the knuckle line (toward the wrist).
  double thumb_distance = 0.0;       ///< Back of the hand: mm from the thumb's web.
  int flexion_dof = -1;              ///< Finger cells: DoF index of the joint under the cell.
};

/// @brief The 44 sites of the paper's glove.
inline std::array<CellSite, kCells> glauser2019_sites() {
  const sensor::TraceLayout layout = sensor::TraceLayout::glauser2019();
  // Back of the hand, knuckle-line distance (mm): the knuckle-side column of the stretch maps
  // (11-15 along; 2, 4, 7, 10, 19 across) at 12 mm, the wrist-side one (3, 5, 6 along; 17, 18
  // across) at 30 mm. Thumb distance: from the thumb web across the back, digit by digit.
  const auto back_distance = [](int cell) { return (cell == 3 || cell == 5 || cell == 6 || cell == 17 || cell == 18) ? 30.0 : 12.0; };
  constexpr std::array<double, 5> thumb_distance{0.0, 20.0, 38.0, 55.0, 70.0};
  std::array<CellSite, kCells> sites{};
  for (int c = 0; c < kCells; ++c) {
    const sensor::Cell& cell = layout.cells()[static_cast<std::size_t>(c)];
    CellSite& s = sites[static_cast<std::size_t>(c)];
    s.digit = static_cast<int>(cell.digit);
    s.segment = cell.segment;
    s.along = cell.direction == sensor::Direction::Along;
    s.length = cell.category == sensor::Category::MainJoint ? kLongCellLength : kShortCellLength;
    s.thumb_distance = thumb_distance[static_cast<std::size_t>(s.digit)];
    if (cell.segment == sensor::Segment::Metacarpal) s.knuckle_distance = back_distance(c);
    // The joint under a finger cell. The thumb's main joints are MCP and IP (theta 11, 12): its
    // "proximal" cells sit over theta 11 and its "middle" ones over theta 12.
    hand::Motion motion = hand::Motion::BaseFlexion;
    if (cell.segment == sensor::Segment::Middle) motion = hand::Motion::MiddleFlexion;
    if (cell.segment == sensor::Segment::Distal) motion = hand::Motion::TipFlexion;
    if (s.digit == 0 && cell.segment == sensor::Segment::Proximal) motion = hand::Motion::MiddleFlexion;
    if (s.digit == 0 && cell.segment == sensor::Segment::Middle) motion = hand::Motion::TipFlexion;
    s.flexion_dof = static_cast<int>(hand::dof_of(static_cast<hand::Finger>(s.digit), motion));
  }
  return sites;
}

/// @brief One fabricated glove: its cells' base capacitances and cross-direction gains.
struct Glove {
  int id = 0;                    ///< 0-based.
  CellArray base_capacitance{};  ///< C0 (pF) of each cell.
  CellArray cross_gain{};        ///< Share of the stretch across the cuts that reaches each cell.
  CellArray placement{};         ///< mm along the digit each cell sits from its design place (WearConfig::placement_sd).
};

/// @brief Glove `id` from `seed`: nominal C0 = eps_r eps_0 A0 / d with the fabrication spread, and its
/// cells' places off the design by placement_sd (mm).
inline Glove make_glove(int id, std::uint64_t seed, double placement_sd = 0.0) {
  core::Rng rng(core::derive_seed(seed, {2, static_cast<std::uint64_t>(id)}));
  const auto sites = glauser2019_sites();
  Glove g;
  g.id = id;
  for (int c = 0; c < kCells; ++c) {
    const auto i = static_cast<std::size_t>(c);
    const double nominal = kPermittivity * kEpsilon0 * kCellWidth * sites[i].length / kDielectricThickness;
    g.base_capacitance[i] = nominal * std::max(0.8, rng.normal(1.0, kBaseCapacitanceSpread));
    g.cross_gain[i] = std::clamp(rng.normal(kCrossGain, kCrossGainSpread), 0.05, 0.4);
  }
  for (double& p : g.placement) p = rng.normal(0.0, placement_sd);  // after C0 and gains: those stay as they were
  return g;
}

/// @brief How far (mm, towards the fingertip positive) a finger cell sits off its joint because
/// the hand's finger is `ratio` times as long as the glove's and only `coupling` of the difference
/// moves the cells. The glove's fingers are anchored at their base (assumption: the finger crotches
/// sit on the webs, the thumb's at its MCP), so a cell x mm beyond the base on the relaxed hand
/// lands at x (1 + c (k - 1)) while its joint is at k x. The cells travel by the size coupling on a
/// short finger too (assumption: a loose sheet that did not follow a short finger at all would put
/// them 1 / (1 - c) times as far off). Back-of-hand and web cells: 0.
inline double size_misplacement(const hand::HandModel& hand, const CellSite& site, double ratio, double coupling) noexcept {
  if (site.segment == sensor::Segment::Metacarpal || site.segment == sensor::Segment::Web || site.flexion_dof < 0) return 0.0;
  const auto& dof = hand::kDofs[static_cast<std::size_t>(site.flexion_dof)];
  // The digit's anchor joint: a finger's MCP (its base phalanx), the thumb's MCP (its middle one).
  const hand::Motion anchor_motion = site.digit == 0 ? hand::Motion::MiddleFlexion : hand::Motion::BaseFlexion;
  const int anchor = hand::kDofs[hand::dof_of(static_cast<hand::Finger>(site.digit), anchor_motion)].phalanx;
  double along = 0.0;  // the joint's distance from the anchor on this hand (mm)
  for (int p = anchor + 1; p <= dof.phalanx; ++p) along += hand.rest[static_cast<std::size_t>(p)].translation().norm();
  return along * (1.0 - coupling) * (1.0 - ratio) / ratio;
}

/// @brief How the glove sits on one hand for one donning.
struct GloveFit {
  CellArray shift{};       ///< mm along the digit (towards the fingertip positive) of each cell.
  CellArray pre_along{};   ///< Stretch ratio along each cell before any motion.
  CellArray pre_across{};  ///< Stretch ratio across each cell before any motion.
  double neighbour_hold = 0.0;  ///< WearConfig::neighbour_hold.
  double slide_share = 0.0;     ///< WearConfig::slide_share.
  double stick_angle = 0.0;     ///< WearConfig::stick_angle, radians.
};

/// @brief Puts `glove` on a hand: the pre-stretch follows the hand's size against the glove's
/// relaxed size (the share WearConfig::size_coupling of it), and every donning shifts the cells
/// (more on a loose fit) and varies their pre-stretch a little; the cells sit where the glove's
/// fabrication put them.
inline GloveFit don_glove(const Subject& subject, const Glove& glove, core::Rng& rng, const WearConfig& wear = {}) {
  const auto sites = glauser2019_sites();
  const hand::HandModel hand = subject.hand_model();
  GloveFit fit;
  fit.neighbour_hold = wear.neighbour_hold;
  fit.slide_share = wear.slide_share;
  fit.stick_angle = wear.stick_angle * core::kRadiansPerDegree;
  const double loose = loose_fit_factor(subject, wear);
  const double global_shift = rng.normal(0.0, wear.donning_shift * loose);
  const double global_pre = rng.normal(1.0, wear.pre_stretch_spread / 2.0);
  const double girth = std::sqrt(subject.size.width / wear.relaxed_width * subject.size.height / kGloveRelaxedHeight);
  for (int c = 0; c < kCells; ++c) {
    const auto i = static_cast<std::size_t>(c);
    const CellSite& s = sites[i];
    const bool on_finger = s.segment != sensor::Segment::Metacarpal;
    const double length =
        subject.size.length / wear.relaxed_length * (on_finger ? subject.finger_scale[static_cast<std::size_t>(s.digit)] : 1.0);
    const double across = on_finger && s.segment != sensor::Segment::Web ? girth : subject.size.width / wear.relaxed_width;
    fit.shift[i] = glove.placement[i] + global_shift + rng.normal(0.0, wear.cell_shift * loose) +
                   wear.length_misplacement * size_misplacement(hand, s, length, wear.size_coupling);
    fit.pre_along[i] = rest_stretch(length, wear) * global_pre * rng.normal(1.0, wear.pre_stretch_spread);
    fit.pre_across[i] = rest_stretch(across, wear) * global_pre * rng.normal(1.0, wear.pre_stretch_spread);
  }
  return fit;
}

/// @brief The sensor physics of one glove on one hand in one fit: pose -> cell capacitances.
/// Immutable after construction; the per-pose calls are noexcept and allocation-free.
class GlovePhysics {
 public:
  /// @brief Physics for `glove` worn by `subject` as `fit` describes, on the subject's right hand or
  /// left (the mirrored hand wearing the mirrored glove: hand/handedness.hpp).
  GlovePhysics(const Subject& subject, const Glove& glove, const GloveFit& fit, hand::Handedness side = hand::Handedness::Right)
      : kinematics_(subject.hand_model(), side),
        glove_(glove),
        fit_(fit),
        skin_(subject.skin),
        sites_(glauser2019_sites()),
        radius_(subject.distal_radius()) {
    for (std::size_t f = 0; f < hand::kFingerCount; ++f) knuckle_radius_[f] = subject.knuckle_radius(static_cast<hand::Finger>(f));
    hand::Skeleton rest;
    kinematics_.pose(hand::Angles{}, rest);
    reference_ = distances(rest);
  }

  /// @brief The hand's kinematic chain.
  const hand::Kinematics& kinematics() const noexcept { return kinematics_; }
  /// @brief The glove worn.
  const Glove& glove() const noexcept { return glove_; }

  /// @brief Stretch ratios (along, across) of every cell in the pose, after pre-stretch, slack,
  /// saturation and the cuts' direction selectivity; `slip` (mm) moves the whole glove along the
  /// fingers from its fit.
  GLOVEPOSE_REALTIME void stretch(const hand::Angles& a, CellArray& along, CellArray& across, double slip = 0.0) const noexcept {
    hand::Skeleton s;
    kinematics_.pose(a, s);
    const Distances now = distances(s);
    for (int c = 0; c < kCells; ++c) {
      const auto i = static_cast<std::size_t>(c);
      const CellSite& site = sites_[i];
      const double shift = fit_.shift[i] + slip;
      double strain_along = 0.0, strain_across = 0.0;
      if (site.segment == sensor::Segment::Metacarpal) {
        strain_along = back_along(site, a, shift);
        strain_across = back_across(site, now, shift);
      } else if (site.segment == sensor::Segment::Web) {
        strain_across = (now.web[static_cast<std::size_t>(site.digit)] - reference_.web[static_cast<std::size_t>(site.digit)]) /
                        (site.digit == 0 ? kThumbWebSpan : kFingerWebSpan);
        strain_along = 0.3 * knuckle_lengthening(site.digit, a) / site.length;
      } else {
        strain_along = (joint_lengthening(site, a, shift + slide(site, a)) + sheet_tension(site.digit, a)) / site.length;
        strain_across = girth_strain(site, a);
      }
      const double s_along = textile(fit_.pre_along[i] * (1.0 + strain_along) - 1.0);
      const double s_across = textile(fit_.pre_across[i] * (1.0 + strain_across) - 1.0);
      along[i] = 1.0 + (site.along ? 1.0 : glove_.cross_gain[i]) * s_along;
      across[i] = 1.0 + (site.along ? glove_.cross_gain[i] : 1.0) * s_across;
    }
  }

  /// @brief Cell capacitances C_c (pF) of the glove off the hand (sim::RemovalConfig): the sheet
  /// without pre-stretch or any strain from a hand, each cell strained only by its fold `fold`
  /// (along and across alike), through the same textile response and cut selectivity as stretch().
  GLOVEPOSE_REALTIME void off_hand_capacitances(const CellArray& fold, CellArray& out) const noexcept {
    for (std::size_t i = 0; i < out.size(); ++i) {
      const double s = textile(fold[i]);
      const double along = 1.0 + (sites_[i].along ? 1.0 : glove_.cross_gain[i]) * s;
      const double across = 1.0 + (sites_[i].along ? glove_.cross_gain[i] : 1.0) * s;
      const double area = along * across;
      out[i] = glove_.base_capacitance[i] * area * area;
    }
  }

  /// @brief Cell capacitances C_c (pF) in the pose: C0 (A/A0)^2 with A/A0 = along * across; `slip` as
  /// in stretch().
  GLOVEPOSE_REALTIME void capacitances(const hand::Angles& a, CellArray& out, double slip = 0.0) const noexcept {
    CellArray along, across;
    stretch(a, along, across, slip);
    for (std::size_t i = 0; i < out.size(); ++i) {
      const double area = along[i] * across[i];
      out[i] = glove_.base_capacitance[i] * area * area;
    }
  }

 private:
  // Distances between skin points that the web and back-of-hand cells see (mm).
  struct Distances {
    std::array<double, hand::kFingerCount> web{};      // digit d to its neighbour towards the pinky (thumb: to index)
    std::array<double, hand::kFingerCount> knuckle{};  // dorsal knuckle points, d to its ulnar neighbour (pinky: to ring)
    double thumb_back = 0.0;                           // dorsal thumb metacarpal to the index knuckle
  };

  Distances distances(const hand::Skeleton& s) const noexcept {
    Distances d;
    std::array<Eigen::Vector3d, hand::kFingerCount> web_point, knuckle_point;
    for (std::size_t f = 0; f < hand::kFingerCount; ++f) {
      const auto base = static_cast<std::size_t>(hand::kFingerBase[f]);
      // Finger webs: 40% along the proximal phalanx; thumb: just past its MCP (Thumb2's origin).
      const std::size_t web_frame = f == 0 ? base + 1 : base;
      const double along = f == 0 ? 5.0 : 0.4 * kinematics_.model().rest[base + 1].translation().y();
      web_point[f] = s[web_frame] * Eigen::Vector3d(0.0, along, 0.0);
      // Dorsal skin over the knuckle: local -z is the back of the finger (flexion turns +y to +z).
      knuckle_point[f] = s[base] * Eigen::Vector3d(0.0, 6.0, -knuckle_radius_[f]);
    }
    for (std::size_t f = 0; f < hand::kFingerCount; ++f) {
      const std::size_t next = f == 4 ? 3 : f + 1;  // towards the pinky; the pinky pairs with the ring
      d.web[f] = (web_point[f] - web_point[next]).norm();
      d.knuckle[f] = (knuckle_point[f] - knuckle_point[next]).norm();
    }
    const auto thumb = static_cast<std::size_t>(hand::Phalanx::Thumb1);
    const double metacarpal = kinematics_.model().rest[thumb + 1].translation().y();
    d.thumb_back = (s[thumb] * Eigen::Vector3d(0.0, 0.6 * metacarpal, -knuckle_radius_[0] * 0.5) - knuckle_point[1]).norm();
    return d;
  }

  // Dorsal skin's response to a joint angle: flexion lengthens it fully, extension a little.
  static double bend(double angle) noexcept { return angle >= 0.0 ? angle : kExtensionShare * angle; }

  // Skin radius at the joint a DoF rotates: the knuckle sphere for a digit's base joint, else the
  // distal sphere of the parent phalanx.
  double joint_radius(int dof) const noexcept {
    const auto& d = hand::kDofs[static_cast<std::size_t>(dof)];
    const int parent = hand::kParent[static_cast<std::size_t>(d.phalanx)];
    return parent == 0 ? knuckle_radius_[static_cast<std::size_t>(d.finger)] : radius_[static_cast<std::size_t>(parent)];
  }

  // Lengthening (mm) of the sheet over a digit's base joint.
  double knuckle_lengthening(int digit, const hand::Angles& a) const noexcept {
    const int dof = flexion_dof(digit, hand::Motion::BaseFlexion);
    return joint_radius(dof) * knuckle_flexion(digit, a);
  }

  // Flexion (rad) of a digit's base joint that the sheet over it carries: the dorsal skin's, less
  // what straighter neighbouring fingers hold back through the sheet.
  double knuckle_flexion(int digit, const hand::Angles& a) const noexcept {
    const double own = bend(a[static_cast<std::size_t>(flexion_dof(digit, hand::Motion::BaseFlexion))]);
    return fit_.neighbour_hold > 0.0 && digit > 0 ? own - held_back(digit, a) : own;
  }

  static int flexion_dof(int digit, hand::Motion motion) noexcept {
    return static_cast<int>(hand::dof_of(static_cast<hand::Finger>(digit), motion));
  }

  // Finger cells: the share of the joint's skin lengthening under the cell, plus the neighbours'.
  double joint_lengthening(const CellSite& site, const hand::Angles& a, double shift) const noexcept {
    const int dof = site.flexion_dof;
    const double r = joint_radius(dof);
    const double zone = kBendZone * skin_.bend_zone * r;
    // The cell spans [shift - L/2, shift + L/2] around the joint; the bend zone [-zone/2, zone/2].
    const double overlap = std::max(0.0, std::min(shift + site.length / 2, zone / 2) - std::max(shift - site.length / 2, -zone / 2));
    const bool knuckle = site.segment == sensor::Segment::Proximal && site.digit > 0;  // a finger's base joint
    double flexion = knuckle ? knuckle_flexion(site.digit, a) : bend(a[static_cast<std::size_t>(dof)]);
    if (fit_.slide_share > 0.0) flexion -= fit_.slide_share * slid(a[static_cast<std::size_t>(dof)]);
    double lengthening = overlap / zone * r * flexion;
    for (int other = dof - 1; other <= dof + 1; other += 2) {  // the digit's neighbouring flexion joints
      if (other < 0 || other >= static_cast<int>(hand::kDofCount)) continue;
      const auto& o = hand::kDofs[static_cast<std::size_t>(other)];
      const bool flexion_joint =
          o.motion == hand::Motion::BaseFlexion || o.motion == hand::Motion::MiddleFlexion || o.motion == hand::Motion::TipFlexion;
      if (!flexion_joint || static_cast<int>(o.finger) != site.digit) continue;
      const double angle = a[static_cast<std::size_t>(other)];
      lengthening += kNeighbourJointSpill * skin_.joint_spill * joint_radius(other) * bend(angle);
      if (fit_.slide_share > 0.0) lengthening += 0.5 * fit_.slide_share * joint_radius(other) * slid(angle);
    }
    return lengthening;
  }

  // Flexion (rad) beyond what friction holds the sheet over a joint at: the part that can slide.
  // Smoothed over a tenth of the stick angle (the grip gives way gradually).
  double slid(double angle) const noexcept {
    const double past = bend(angle), stick = fit_.stick_angle / skin_.slide;
    if (stick <= 0.0) return std::max(0.0, past);
    const double width = 0.1 * stick, x = (past - stick) / width;
    return x > 30.0 ? past - stick : width * std::log1p(std::exp(x));
  }

  // The mean of value(n) over a finger's neighbouring fingers (digits 1-4; the thumb has none here).
  template <typename Value>
  static double neighbour_mean(int digit, const Value& value) noexcept {
    double sum = 0.0;
    int count = 0;
    for (int n = digit - 1; n <= digit + 1; n += 2)
      if (n >= 1 && n <= 4) {
        sum += value(n);
        ++count;
      }
    return sum / count;
  }

  // Flexion (rad) of a finger's base joint that its straighter neighbours hold back through the sheet.
  double held_back(int digit, const hand::Angles& a) const noexcept {
    const auto base = [&](int d) { return bend(a[static_cast<std::size_t>(flexion_dof(d, hand::Motion::BaseFlexion))]); };
    const double hold = std::min(1.0, fit_.neighbour_hold * skin_.sheet_tension);
    return hold * std::max(0.0, base(digit) - neighbour_mean(digit, base));
  }

  // How far the glove has slid towards the fingertip over a cell: the flexion of the joints between
  // the cell and the palm pulls the textile.
  double slide(const CellSite& site, const hand::Angles& a) const noexcept {
    double flexion = 0.0;
    for (int d = flexion_dof(site.digit, hand::Motion::BaseFlexion); d < site.flexion_dof; ++d)
      flexion += std::max(0.0, a[static_cast<std::size_t>(d)]);
    return kSlidePerFlexion * skin_.slide * flexion;
  }

  // The sheet's tension: the other digits' knuckle lengthening, shared.
  double sheet_tension(int digit, const hand::Angles& a) const noexcept {
    double sum = 0.0;
    for (int d = 0; d < static_cast<int>(hand::kFingerCount); ++d)
      if (d != digit) sum += knuckle_lengthening(d, a);
    return kSheetTension * skin_.sheet_tension * sum / (hand::kFingerCount - 1);
  }

  // Finger cells across: girth over the flexed joint; proximal cells also the abduction's pull.
  double girth_strain(const CellSite& site, const hand::Angles& a) const noexcept {
    double strain = kGirthPerFlexion * skin_.girth_flexion * std::max(0.0, a[static_cast<std::size_t>(site.flexion_dof)]);
    if (site.segment == sensor::Segment::Proximal && site.digit > 0) {
      const auto abduction = [&](int digit) { return a[static_cast<std::size_t>(flexion_dof(digit, hand::Motion::Abduction))]; };
      strain += kGirthPerAbduction * skin_.girth_abduction * std::abs(abduction(site.digit) - neighbour_mean(site.digit, abduction));
    }
    return strain;
  }

  // Back of the hand, along: the knuckles' lengthening with fall-off from the knuckle line.
  double back_along(const CellSite& site, const hand::Angles& a, double shift) const noexcept {
    const double falloff = std::exp(-std::max(0.0, site.knuckle_distance - shift) / (kKnuckleFalloff * skin_.knuckle_falloff));
    double lengthening = knuckle_lengthening(site.digit, a);
    for (int n = site.digit - 1; n <= site.digit + 1; n += 2)
      if (n >= 1 && n <= 4 && site.digit >= 1) lengthening += kNeighbourKnuckleShare * skin_.knuckle_share * knuckle_lengthening(n, a);
    if (site.digit == 0)  // the thumb's metacarpal cell: its CMC flexion and abduction
      lengthening += 0.5 * knuckle_radius_[0] * bend(a[static_cast<std::size_t>(flexion_dof(0, hand::Motion::Abduction))]);
    return falloff * lengthening / site.length;
  }

  // Back of the hand, across: knuckle spread with fall-off, and the thumb's pull with its own.
  double back_across(const CellSite& site, const Distances& now, double shift) const noexcept {
    const auto d = static_cast<std::size_t>(site.digit);
    const double falloff = std::exp(-std::max(0.0, site.knuckle_distance - shift) / (kKnuckleFalloff * skin_.knuckle_falloff));
    const double knuckles = site.digit == 0 ? 0.0 : (now.knuckle[d] - reference_.knuckle[d]) / kKnuckleSpan;
    const double thumb =
        std::exp(-site.thumb_distance / (kThumbFalloff * skin_.thumb_falloff)) * (now.thumb_back - reference_.thumb_back) / kThumbBackSpan;
    return falloff * knuckles + thumb;
  }

  // Pre-stretched strain -> what the cell sees: slack taken up smoothly, saturation at large strain.
  static double textile(double strain) noexcept {
    const double x = strain / kSlackWidth;
    const double taut = x > 30.0 ? strain : kSlackWidth * std::log1p(std::exp(x));  // softplus
    return kSaturation * std::tanh(taut / kSaturation);
  }

  hand::Kinematics kinematics_;
  Glove glove_;
  GloveFit fit_;
  SkinMechanics skin_;
  std::array<CellSite, kCells> sites_;
  std::array<double, 16> radius_;
  std::array<double, hand::kFingerCount> knuckle_radius_{};
  Distances reference_;
};

}  // namespace glovepose::sim
