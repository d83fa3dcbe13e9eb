#include <glovepose/train/fingertip_metrics.hpp>
#include <glovepose/train/metrics_report.hpp>

#include <doctest/doctest.h>

#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include <glovepose/io/json.hpp>
#include <glovepose/sim/pose_gallery.hpp>

#include "tip_distance.hpp"

using namespace glovepose;
using namespace glovepose::train;
using glovepose::test::tip_distance;

namespace {

constexpr double kRate = 100.0;  // frames per second of the sequences below


// A pose between `from` (a = 0) and `to` (a = 1), angle by angle.
hand::Angles blend(const hand::Angles& from, const hand::Angles& to, double a) {
  hand::Angles out{};
  for (std::size_t d = 0; d < hand::kDofCount; ++d) out[d] = (1.0 - a) * from[d] + a * to[d];
  return out;
}

// True frames: open (flat) except pinching the index in [start, start + length) of every period.
bool pinching_at(int frame, int period, int start, int length) { return frame % period >= start && frame % period < start + length; }

}  // namespace

TEST_CASE("fingertip metrics: the gallery's pinches are pinches, its other poses are not (the threshold's premise)") {
  // The poses where the thumb is solved to contact with a fingertip, and that finger.
  const std::vector<std::pair<std::string, hand::Finger>> oppositions{
      {"pinch_index", hand::Finger::Index}, {"pinch_middle", hand::Finger::Middle},
      {"pinch_ring", hand::Finger::Ring},   {"pinch_pinky", hand::Finger::Pinky},
      {"ok", hand::Finger::Index},          {"key_grip", hand::Finger::Index}};
  for (const auto& [name, finger] : oppositions) {
    const double d = tip_distance(sim::gallery_pose(name).angles, finger);
    MESSAGE(name << ": thumb to " << std::string(hand::to_string(finger)) << " tip " << d << " mm");
    CHECK(d < kPinchThresholdMm);
  }
  // Every other pose keeps every pair beyond the release distance; the closest is reported.
  double closest = INFINITY;
  std::string closest_pose;
  for (const sim::KeyPose& p : sim::pose_gallery()) {
    bool opposition = false;
    for (const auto& o : oppositions) opposition = opposition || o.first == p.name;
    if (opposition) continue;
    for (std::size_t f = 1; f < hand::kFingerCount; ++f) {
      const double d = tip_distance(p.angles, static_cast<hand::Finger>(f));
      CHECK(d > kPinchReleaseMm);
      if (d < closest) closest = d, closest_pose = p.name + " (thumb to " + hand::to_string(static_cast<hand::Finger>(f)) + ")";
    }
  }
  MESSAGE("closest pair in a pose that is not a pinch: " << closest_pose << " " << closest << " mm");
}

TEST_CASE("fingertip metrics: identical angles give 0 mm, precision = recall = 1, every onset found at 0 ms") {
  const hand::Angles open = sim::gallery_pose("flat").angles, pinch = sim::gallery_pose("pinch_index").angles;
  FingertipAccumulator acc;
  acc.begin_run();
  const int frames = 200, period = 50, start = 20, length = 15;
  int expected_pinch_frames = 0, expected_onsets = 0;
  for (int i = 0; i < frames; ++i) {
    const bool on = pinching_at(i, period, start, length);
    expected_pinch_frames += on;
    expected_onsets += on && i > 0 && !pinching_at(i - 1, period, start, length);
    const hand::Angles& a = on ? pinch : open;
    CHECK(acc.add(a, a, i / kRate));
  }
  const FingertipReport r = acc.report();
  CHECK(r.frames == frames);
  for (const TipErrorSummary& t : r.tips) {
    CHECK(t.frames == frames);
    CHECK(t.mean_mm == 0.0);
    CHECK(t.p95_mm == 0.0);
    CHECK(t.max_mm == 0.0);
  }
  CHECK(r.all.frames == 5 * frames);
  const PinchScore& index = r.pinches[0];
  CHECK(std::string(index.finger) == "index");
  CHECK(index.true_frames == static_cast<std::size_t>(expected_pinch_frames));
  CHECK(index.predicted_frames == index.true_frames);
  CHECK(index.precision == 1.0);
  CHECK(index.recall == 1.0);
  CHECK(index.onsets == static_cast<std::size_t>(expected_onsets));
  CHECK(index.detected_onsets == index.onsets);
  CHECK(index.missed_onsets == 0);
  CHECK(index.false_onsets == 0);
  CHECK(index.latency_median_ms == 0.0);
  CHECK(index.distance_error_mean_mm == 0.0);
  for (std::size_t k = 1; k < kPinchPairCount; ++k) {  // no other pair pinches: precision and recall undefined
    CHECK(r.pinches[k].true_frames == 0);
    CHECK(std::isnan(r.pinches[k].precision));
    CHECK(std::isnan(r.pinches[k].recall));
    CHECK(std::isnan(r.pinches[k].latency_median_ms));
  }
  CHECK(r.all_pinches.onsets == index.onsets);
  CHECK(r.all_pinches.precision == 1.0);
}

// The reference rest rotations are typed in to 6 digits, orthonormal to about 1e-7 (the chain's lengths
// come out 1.3e-7 off): hence a relative tolerance of 1e-6.
TEST_CASE("fingertip metrics: an offset on one joint moves its tip by the chord a hand-written chain gives") {
  const double offset = 0.2;  // rad
  hand::Angles truth{};
  truth[hand::dof_of(hand::Finger::Index, hand::Motion::BaseFlexion)] = 0.3;
  truth[hand::dof_of(hand::Finger::Index, hand::Motion::MiddleFlexion)] = 0.5;

  SUBCASE("tip flexion: the tip point turns about the distal joint at the distal phalanx' length") {
    // On the reference hand and on a hand whose index is 10% longer (the hand given to begin_run is used).
    for (const double scale : {1.0, 1.1}) {
      hand::HandModel model = hand::HandModel::reference();
      model.tip_length[1] *= scale;
      hand::Angles predicted = truth;
      predicted[hand::dof_of(hand::Finger::Index, hand::Motion::TipFlexion)] += offset;
      FingertipAccumulator acc;
      acc.begin_run(hand::Kinematics(model));
      acc.add(predicted, truth, 0.0);
      const FingertipReport r = acc.report();
      const double chord = 2.0 * hand::kReferenceTipLength[1] * scale * std::sin(offset / 2.0);
      CHECK(r.tips[1].mean_mm == doctest::Approx(chord).epsilon(1e-6));
      for (std::size_t f : {0, 2, 3, 4}) CHECK(r.tips[f].mean_mm == 0.0);
    }
  }

  SUBCASE("middle flexion: a two-link chain (middle phalanx, then the distal one at rest) written out") {
    hand::Angles predicted = truth;
    predicted[hand::dof_of(hand::Finger::Index, hand::Motion::MiddleFlexion)] += offset;
    FingertipAccumulator acc;
    acc.add(predicted, truth, 0.0);  // no begin_run: the reference hand
    // The tip point in the middle phalanx' frame: the distal joint's offset plus the distal rest
    // rotation applied to (0, L, 0) (tip flexion 0). Turning the frame about its X axis by `offset`
    // moves that point on a circle whose radius is its distance from the X axis.
    const hand::RestTransform& distal = hand::kReferenceRest[static_cast<std::size_t>(hand::Phalanx::Index3)];
    const double length = hand::kReferenceTipLength[1];
    const double y = distal.translation[1] + distal.rotation[4] * length, z = distal.translation[2] + distal.rotation[7] * length;
    const double chord = 2.0 * std::sqrt(y * y + z * z) * std::sin(offset / 2.0);
    CHECK(acc.report().tips[1].mean_mm == doctest::Approx(chord).epsilon(1e-6));
  }
}

TEST_CASE("fingertip metrics: the thumb-to-fingertip distance error is |d_pred - d_true|") {
  const hand::Angles open = sim::gallery_pose("flat").angles, pinch = sim::gallery_pose("pinch_index").angles;
  FingertipAccumulator acc;
  acc.add(pinch, open, 0.0);
  const FingertipReport r = acc.report();
  for (std::size_t k = 0; k < kPinchPairCount; ++k) {
    const auto finger = static_cast<hand::Finger>(k + 1);
    CHECK(r.pinches[k].distance_error_mean_mm == doctest::Approx(std::abs(tip_distance(pinch, finger) - tip_distance(open, finger))));
  }
  CHECK(r.pinches[0].predicted_frames == 1);
  CHECK(r.pinches[0].true_frames == 0);
  CHECK(r.pinches[0].precision == 0.0);
  CHECK(std::isnan(r.pinches[0].recall));
}

TEST_CASE("fingertip metrics: pinches predicted k frames late: latency k / rate, precision and recall by counting") {
  const hand::Angles open = sim::gallery_pose("flat").angles, pinch = sim::gallery_pose("pinch_index").angles;
  const int frames = 400, period = 100, start = 30, length = 40;
  for (const int k : {0, 3, 7, 24, 26, 60}) {
    INFO("k = " << k);
    FingertipAccumulator acc;
    acc.begin_run();
    int true_frames = 0, predicted_frames = 0, both = 0, onsets = 0;
    for (int i = 0; i < frames; ++i) {
      const bool t = pinching_at(i, period, start, length), p = pinching_at(i - k + period, period, start, length);
      true_frames += t, predicted_frames += p, both += t && p;
      onsets += t && i > 0 && !pinching_at(i - 1, period, start, length);
      acc.add(p ? pinch : open, t ? pinch : open, 10.0 + i / kRate);
    }
    const PinchScore s = acc.report().pinches[0];
    CHECK(s.true_frames == static_cast<std::size_t>(true_frames));
    CHECK(s.predicted_frames == static_cast<std::size_t>(predicted_frames));
    CHECK(s.both_frames == static_cast<std::size_t>(both));
    CHECK(s.precision == doctest::Approx(static_cast<double>(both) / predicted_frames));
    CHECK(s.recall == doctest::Approx(static_cast<double>(both) / true_frames));
    CHECK(s.onsets == static_cast<std::size_t>(onsets));
    if (k / kRate <= kPinchOnsetWindowS) {  // 0.25 s: up to 25 frames late
      CHECK(s.detected_onsets == s.onsets);
      CHECK(s.missed_onsets == 0);
      CHECK(s.false_onsets == 0);
      CHECK(s.latency_median_ms == doctest::Approx(1e3 * k / kRate));
      CHECK(s.latency_mean_ms == doctest::Approx(1e3 * k / kRate));
    } else {
      CHECK(s.detected_onsets == 0);
      CHECK(s.missed_onsets == s.onsets);
      CHECK(s.false_onsets == s.onsets);  // each late onset matches nothing
      CHECK(std::isnan(s.latency_median_ms));
    }
  }
}

TEST_CASE("fingertip metrics: a prediction early by k frames has latency -k / rate, and onsets are matched within a run") {
  const hand::Angles open = sim::gallery_pose("flat").angles, pinch = sim::gallery_pose("pinch_index").angles;
  FingertipAccumulator acc;
  // Run 1: true onset at frame 30, predicted at 25. Run 2: true onset at frame 10, the prediction
  // never pinches; a predicted onset at the end of run 1 must not be taken for it.
  acc.begin_run();
  for (int i = 0; i < 60; ++i) acc.add(i >= 25 && (i < 50 || i >= 58) ? pinch : open, i >= 30 && i < 50 ? pinch : open, i / kRate);
  acc.begin_run();
  for (int i = 0; i < 40; ++i) acc.add(open, i >= 10 ? pinch : open, i / kRate);  // times start again: a new run
  const PinchScore s = acc.report().pinches[0];
  CHECK(s.onsets == 2);
  CHECK(s.detected_onsets == 1);
  CHECK(s.missed_onsets == 1);
  CHECK(s.false_onsets == 1);  // run 1's second predicted onset at frame 58
  CHECK(s.latency_median_ms == doctest::Approx(-50.0));
}

TEST_CASE("fingertip metrics: the release distance keeps a pinch on until the tips part beyond it") {
  const hand::Angles open = sim::gallery_pose("flat").angles, pinch = sim::gallery_pose("pinch_index").angles;
  // Blends of the pinch and the open hand at a chosen index-tip distance (bisection on the blend).
  const auto at_distance = [&](double mm) {
    double lo = 0.0, hi = 1.0;  // lo: distance below mm, hi: above
    for (int i = 0; i < 60; ++i) {
      const double mid = 0.5 * (lo + hi);
      (tip_distance(blend(pinch, open, mid), hand::Finger::Index) < mm ? lo : hi) = mid;
    }
    return blend(pinch, open, 0.5 * (lo + hi));
  };
  // Truth: 20 (off), 14 (on), 16.5 (still on), 14 (on), 19 (off), 16.5 (off), 14 (on: a second onset).
  const std::vector<double> distances{20.0, 14.0, 16.5, 14.0, 19.0, 16.5, 14.0};
  FingertipAccumulator acc;
  for (std::size_t i = 0; i < distances.size(); ++i) {
    const hand::Angles a = at_distance(distances[i]);
    CHECK(tip_distance(a, hand::Finger::Index) == doctest::Approx(distances[i]).epsilon(1e-6));
    acc.add(open, a, static_cast<double>(i) / kRate);
  }
  const PinchScore s = acc.report().pinches[0];
  CHECK(s.true_frames == 4);
  CHECK(s.onsets == 2);
}

TEST_CASE("fingertip metrics: a non-finite angle leaves its digit (and its pinch pair) out of that frame only") {
  const hand::Angles pose = sim::gallery_pose("pinch_index").angles;
  hand::Angles broken = pose;
  broken[hand::dof_of(hand::Finger::Index, hand::Motion::MiddleFlexion)] = NAN;
  FingertipAccumulator acc;
  CHECK(acc.add(pose, pose, 0.0));
  CHECK_FALSE(acc.add(broken, pose, 0.01));
  CHECK(acc.add(pose, pose, 0.02));
  const FingertipReport r = acc.report();
  CHECK(r.frames == 3);
  CHECK(r.tips[0].frames == 3);
  CHECK(r.tips[1].frames == 2);
  CHECK(r.tips[1].mean_mm == 0.0);
  CHECK(r.pinches[0].frames == 2);
  CHECK(r.pinches[0].onsets == 0);  // pinching before and after the gap: no onset at frame 2
  CHECK(r.pinches[1].frames == 3);
}

TEST_CASE("fingertip metrics: misuse is refused with what was expected") {
  FingertipConfig config;
  config.pinch_release_mm = 10.0;
  CHECK_THROWS_WITH_AS(FingertipAccumulator{config}, doctest::Contains("expected a distance (mm) at least pinch_threshold_mm"), Error);
  config = FingertipConfig{};
  config.onset_window_s = -1.0;
  CHECK_THROWS_AS(FingertipAccumulator{config}, Error);
  FingertipAccumulator acc;
  CHECK_THROWS_WITH_AS(acc.report(), doctest::Contains("no fingertip scored"), Error);
  const hand::Angles a{};
  acc.add(a, a, 1.0);
  CHECK_THROWS_WITH_AS(acc.add(a, a, 1.0), doctest::Contains("expected finite times increasing within a run"), Error);
  CHECK_THROWS_AS(acc.add(a, a, NAN), Error);
  acc.begin_run();
  CHECK_NOTHROW(acc.add(a, a, 0.5));  // a new run may start at any time
}

TEST_CASE("fingertip metrics: the JSON form has every key, undefined figures null, and the table names every row") {
  const hand::Angles open = sim::gallery_pose("flat").angles, pinch = sim::gallery_pose("pinch_index").angles;
  FingertipAccumulator acc;
  for (int i = 0; i < 10; ++i) acc.add(i >= 5 ? pinch : open, i >= 4 ? pinch : open, i / kRate);
  const FingertipReport r = acc.report();
  const io::json::Value json = io::json::parse(to_json(r, {{"scored_against", "\"truth\""}}));
  CHECK(json.at("frames") == 10);
  CHECK(json.at("pinch_threshold_mm") == kPinchThresholdMm);
  CHECK(json.at("scored_against") == "truth");
  REQUIRE(json.at("tips").size() == 6);
  CHECK(json.at("tips")[5].at("finger") == "all");
  REQUIRE(json.at("pinches").size() == 5);
  const auto& index = json.at("pinches")[0];
  CHECK(index.at("finger") == "index");
  CHECK(index.at("onsets") == 1);
  CHECK(index.at("latency_median_ms").get<double>() == doctest::Approx(10.0));
  CHECK(json.at("pinches")[1].at("precision").is_null());
  for (const char* key :
       {"frames", "distance_error_mean_mm", "distance_error_p95_mm", "true_frames", "predicted_frames", "both_frames", "precision",
        "recall", "onsets", "detected_onsets", "missed_onsets", "false_onsets", "latency_median_ms", "latency_mean_ms",
        "pinch_tip_error_mean_mm", "pinch_distance_error_mean_mm"})
    CHECK(index.contains(key));
  const std::string table = format_table(r, "the true angles");
  for (const char* row : {"thumb", "index", "middle", "ring", "pinky", "all", "Pinches", "10 ms"})
    CHECK(table.find(row) != std::string::npos);
}

TEST_CASE("fingertip metrics: in the true pinches, the two tips' mean error and the distance error") {
  // Truth: pinch_index every frame; prediction: the same with the index's tip flexion off by 0.2 rad,
  // which moves the index tip by the chord 2 L sin(0.1) and leaves the thumb's where it was.
  const hand::Angles pinch = sim::gallery_pose("pinch_index").angles;
  hand::Angles predicted = pinch;
  predicted[hand::dof_of(hand::Finger::Index, hand::Motion::TipFlexion)] += 0.2;
  FingertipAccumulator acc;
  for (int i = 0; i < 3; ++i) acc.add(predicted, pinch, i / kRate);
  acc.add(predicted, sim::gallery_pose("flat").angles, 3 / kRate);  // not a true pinch: not counted
  const PinchScore s = acc.report().pinches[0];
  REQUIRE(s.true_frames == 3);
  const double chord = 2.0 * hand::kReferenceTipLength[1] * std::sin(0.1);
  CHECK(s.pinch_tip_error_mean_mm == doctest::Approx(chord / 2.0).epsilon(1e-6));
  CHECK(s.pinch_distance_error_mean_mm ==
        doctest::Approx(std::abs(tip_distance(predicted, hand::Finger::Index) - tip_distance(pinch, hand::Finger::Index))));
  CHECK(std::isnan(acc.report().pinches[1].pinch_tip_error_mean_mm));  // thumb-middle never pinches
  CHECK(acc.report().all_pinches.pinch_tip_error_mean_mm == doctest::Approx(chord / 2.0).epsilon(1e-6));
}
