// The simulator: subjects, glove physics, motion, timed readout, the corpus protocol.
#include <glovepose/sim/corpus.hpp>
#include <glovepose/sim/report.hpp>
#include <glovepose/sim/tracker.hpp>
#include <glovepose/train/lag.hpp>

#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstring>

using namespace glovepose;
using namespace glovepose::sim;

namespace {

std::size_t dof(int theta) { return hand::dof_from_theta(theta); }

// Noise-free physics of subject `s` wearing glove 0 in a donning drawn from `fit_seed`.
GlovePhysics physics_of(const Subject& s, std::uint64_t fit_seed = 3) {
  core::Rng rng(fit_seed);
  return GlovePhysics(s, make_glove(0, 1), don_glove(s, rng));
}

// The true angles of `m` at 60 Hz frames, without the glove: what the reference tracker labels.
Recording true_motion(const MotionSequence& m, double seconds) {
  Recording r;
  r.frames = static_cast<int>(seconds * 60.0);
  for (int f = 0; f < r.frames; ++f) {
    const double t = (f + 1) / 60.0;
    r.timestamps.push_back(t);
    for (double a : m.at(t)) r.angles.push_back(static_cast<float>(a));
  }
  r.outlier.assign(static_cast<std::size_t>(r.frames), 0);
  return r;
}

// Label error (degrees) of frame f, DoF d.
double label_error(const Recording& r, std::size_t f, std::size_t d) {
  return (double(r.labels[f * hand::kDofCount + d]) - r.angles[f * hand::kDofCount + d]) / calibration::kRadiansPerDegree;
}

// Whether DoF d's truth at frame f is at least `margin` degrees inside its joint limits (no clamping of the label there).
bool inside(const Recording& r, std::size_t f, std::size_t d, double margin) {
  const double a = r.angles[f * hand::kDofCount + d];
  return a - hand::kDofs[d].min > margin * calibration::kRadiansPerDegree && hand::kDofs[d].max - a > margin * calibration::kRadiansPerDegree;
}

CellArray cells_at(const GlovePhysics& p, const hand::Angles& a) {
  CellArray c{};
  p.capacitances(a, c);
  return c;
}

}  // namespace

TEST_CASE("sim random: streams are reproducible, independent of use order, and distributed as stated") {
  core::Rng a(42), b(42);
  for (int i = 0; i < 100; ++i) REQUIRE(a.next() == b.next());
  CHECK(core::derive_seed(1, {2, 3}) == core::derive_seed(1, {2, 3}));
  CHECK(core::derive_seed(1, {2, 3}) != core::derive_seed(1, {3, 2}));
  CHECK(core::derive_seed(1, {2, 3}) != core::derive_seed(2, {2, 3}));
  core::Rng r(7);
  double sum = 0.0, sq = 0.0;
  const int n = 200000;
  for (int i = 0; i < n; ++i) {
    const double x = r.normal();
    sum += x;
    sq += x * x;
  }
  CHECK(std::abs(sum / n) < 0.01);       // SE 0.0022
  CHECK(std::abs(sq / n - 1.0) < 0.02);  // SE 0.0032
  int counts[4] = {};
  for (int i = 0; i < n; ++i) ++counts[r.index(4)];
  for (int c : counts) CHECK(std::abs(c - n / 4) < 1000);  // SE ~194
}

TEST_CASE("sim subjects: the paper's ten hands first, drawn hands inside the paper's ranges, chain scaled") {
  const std::vector<Subject> subjects = make_subjects(40, 5);
  for (std::size_t i = 0; i < kPaperHands.size(); ++i) {
    CHECK(subjects[i].size.length == kPaperHands[i].length);
    CHECK(subjects[i].size.width == kPaperHands[i].width);
  }
  for (const Subject& s : subjects) {
    CHECK(s.size.length >= 170.0);
    CHECK(s.size.length <= 205.0);
    CHECK(s.size.width >= 90.0);
    CHECK(s.size.width <= 110.0);
    CHECK(s.size.length / s.size.width >= 1.6 - 1e-12);
    CHECK(s.size.length / s.size.width <= 2.1 + 1e-12);
  }
  // The same seed gives the same people; another seed other habits (sizes of 0..9 are the paper's).
  CHECK(make_subjects(12, 5)[11].size.length == subjects[11].size.length);
  CHECK(make_subjects(3, 6)[2].style[0] != subjects[2].style[0]);
  CHECK_THROWS_AS(make_subjects(0, 1), Error);

  // Scaling: the middle finger's tip-to-knuckle distance follows length x finger proportion.
  const Subject& big = subjects[5];  // 20.5 cm
  const hand::Kinematics ref, scaled(big.hand_model());
  hand::Skeleton a, b;
  ref.pose(hand::Angles{}, a);
  scaled.pose(hand::Angles{}, b);
  const auto middle_base = static_cast<std::size_t>(hand::Phalanx::Middle1);
  const double ref_len = (ref.fingertip(a, hand::Finger::Middle) - a[middle_base].translation()).norm();
  const double len = (scaled.fingertip(b, hand::Finger::Middle) - b[middle_base].translation()).norm();
  CHECK(len / ref_len == doctest::Approx(big.length_scale() * big.finger_scale[2]).epsilon(1e-9));
  // Positive flexion curls towards the palm side (world -z, where the thumb sits): the physics'
  // "dorsal = local -z" rests on this.
  hand::Angles fist{};
  fist[dof(18)] = 1.5;
  ref.pose(fist, b);
  CHECK(ref.fingertip(b, hand::Finger::Middle).z() < ref.fingertip(a, hand::Finger::Middle).z() - 30.0);
}

TEST_CASE("sim physics: each joint cell answers its joint, along cells barely see girth, C = C0 (A/A0)^2") {
  const Subject s = make_subjects(1, 1)[0];
  const GlovePhysics p = physics_of(s);
  const CellArray rest = cells_at(p, hand::Angles{});
  hand::Angles bent{};
  bent[dof(14)] = 1.2;  // index base flexion
  const CellArray flexed = cells_at(p, bent);
  const double index_knuckle = flexed[21] / rest[21];  // index proximal along (main joint)
  CHECK(index_knuckle > 1.5);
  CHECK(flexed[22] / rest[22] < 1.0 + 0.2 * (index_knuckle - 1.0));  // middle finger's knuckle: sheet tension only
  CHECK(flexed[29] / rest[29] < 1.0 + 0.4 * (index_knuckle - 1.0));  // index girth cell: much less sensitive
  CHECK(flexed[40] == doctest::Approx(rest[40]).epsilon(0.05));      // index tip cell: far away
  // Middle and tip joints reach their own cells.
  hand::Angles pip{};
  pip[dof(15)] = 1.5;
  CHECK(cells_at(p, pip)[33] / rest[33] > 1.5);
  hand::Angles dip{};
  dip[dof(16)] = 1.2;
  CHECK(cells_at(p, dip)[40] / rest[40] > 1.3);
  // Spreading index from middle opens their web cell.
  hand::Angles spread{};
  spread[dof(13)] = 0.3;
  spread[dof(17)] = -0.2;
  CHECK(cells_at(p, spread)[25] / rest[25] > 1.1);
  // Eq. 1 with the stretch ratios the physics reports.
  CellArray along{}, across{};
  p.stretch(bent, along, across);
  const Glove glove = make_glove(0, 1);
  for (std::size_t c = 0; c < flexed.size(); ++c)
    CHECK(flexed[c] == doctest::Approx(glove.base_capacitance[c] * std::pow(along[c] * across[c], 2)).epsilon(1e-12));
  // Monotone in the joint's flexion over the whole range, and saturating: the last radian adds less
  // than the first.
  double previous = 0.0;
  std::vector<double> curve;
  for (double q = 0.0; q <= 1.6 + 1e-9; q += 0.1) {
    bent[dof(14)] = q;
    const double v = cells_at(p, bent)[21];
    CHECK(v >= previous);
    previous = v;
    curve.push_back(v);
  }
  CHECK(curve[16] - curve[6] < curve[10] - curve[0]);
}

TEST_CASE("sim physics: hand size pre-stretches the glove, slack on small hands, fit shifts change the gain") {
  const std::vector<Subject> subjects = make_subjects(10, 1);
  const Subject& large = subjects[5];  // 20.5 x 10 cm
  Subject small = subjects[9];         // 17 x 9 cm
  const CellArray rest_large = cells_at(physics_of(large), hand::Angles{});
  const CellArray rest_small = cells_at(physics_of(small), hand::Angles{});
  const Glove glove = make_glove(0, 1);
  CHECK(rest_large[21] > 1.2 * glove.base_capacitance[21]);                            // pre-stretched
  CHECK(rest_small[21] == doctest::Approx(glove.base_capacitance[21]).epsilon(0.02));  // slack
  // On the small hand the first few degrees only take up slack.
  hand::Angles a{};
  a[dof(14)] = 0.03;
  const GlovePhysics ps = physics_of(small), pl = physics_of(large);
  const double small_gain = cells_at(ps, a)[21] - rest_small[21];
  const double large_gain = cells_at(pl, a)[21] - rest_large[21];
  CHECK(small_gain < 0.25 * large_gain);
  // The same hand in two donnings: rest readings and gains differ.
  const GlovePhysics p1 = physics_of(large, 11), p2 = physics_of(large, 12);
  a[dof(14)] = 1.0;
  double differ = 0.0;
  for (int c : {21, 22, 23, 24})
    differ = std::max(differ, std::abs((cells_at(p1, a)[c] - cells_at(p1, {})[c]) / (cells_at(p2, a)[c] - cells_at(p2, {})[c]) - 1.0));
  CHECK(differ > 0.01);
}

TEST_CASE("sim motion: inside the limits, smooth at human speed, tips follow the middle joints") {
  const Subject s = make_subjects(1, 2)[0];
  const MotionSequence m(s, pose_gallery(), 60.0, 9);
  CHECK(m.segments().size() > 20);
  const hand::JointLimits limits;
  hand::Angles prev = m.at(0.0);
  double fastest = 0.0;
  const double dt = 1.0 / 600.0;
  for (double t = dt; t < 60.0; t += dt) {
    const hand::Angles a = m.at(t);
    for (std::size_t d = 0; d < hand::kDofCount; ++d) {
      REQUIRE(a[d] >= limits.min()[d]);
      REQUIRE(a[d] <= limits.max()[d]);
      fastest = std::max(fastest, std::abs(a[d] - prev[d]) / dt);
    }
    for (int f = 0; f < 4; ++f) {
      const double middle = a[dof(15 + 4 * f)], tip = a[dof(16 + 4 * f)];
      if (middle > 0.2 && middle < 1.8 && tip > 0.0 && tip < 1.9) CHECK(std::abs(tip - kTipCoupling * middle) < 0.3);
    }
    prev = a;
  }
  MESSAGE("fastest joint speed " << fastest << " rad/s");
  CHECK(fastest > 1.0);   // it moves
  CHECK(fastest < 12.0);  // fast finger flexion peaks near 10 rad/s
  CHECK_THROWS_AS(MotionSequence(s, {}, 1.0, 1), Error);
}

TEST_CASE("sim recorder: 60 Hz frames, the paper's 45-90 ms oldest-row age, glitches, interpolation bound") {
  const Subject s = make_subjects(1, 3)[0];
  const GlovePhysics p = physics_of(s);
  const MotionSequence m(s, pose_gallery(), 10.0, 4);
  RecordingConfig config;
  config.raw_rows = true;
  config.noise.drop_probability = 1e-3;
  const Recording r = record(p, m, s.distal_radius(), 5, config);
  CHECK(r.frames == 600);
  CHECK(r.cells.size() == 600u * kCells);
  CHECK(r.raw_rows.size() == 600u * kRows);
  for (int f = 0; f < r.frames; ++f) CHECK(r.timestamps[static_cast<std::size_t>(f)] == doctest::Approx((f + 1) / 60.0));
  int dropped = 0;
  for (float v : r.raw_rows) dropped += std::isnan(v) ? 1 : 0;
  CHECK(dropped > 30);  // 108,000 readings at 1e-3
  CHECK(dropped < 200);
  for (float v : r.cells) REQUIRE(std::isfinite(v));

  // Same seed: identical; another seed: other noise.
  const Recording again = record(p, m, s.distal_radius(), 5, config);
  CHECK(again.cells == r.cells);
  CHECK(record(p, m, s.distal_radius(), 6, config).cells != r.cells);

  // Without dropped rows every frame's oldest reading is 45-90 ms old (a dropped row keeps its
  // older readings in the mean, so glitches age a frame beyond that).
  RecordingConfig clean;
  clean.noise.drop_probability = 0.0;
  const Recording q = record(p, m, s.distal_radius(), 5, clean);
  for (double age : q.oldest_age) {
    CHECK(age >= 0.045);
    CHECK(age <= 0.090);
  }
  CHECK(*std::max_element(r.oldest_age.begin(), r.oldest_age.end()) > 0.090);

  // Physics on 12 poses per cycle, interpolated, against every row at its own instant (noise off).
  RecordingConfig exact;
  exact.noise = ReadoutNoise{0.0, 0.0, 0.0, 0.0, 0.0, 0.0};
  RecordingConfig coarse = exact;
  exact.physics_steps = kRows;
  const Recording e = record(p, m, s.distal_radius(), 5, exact), c = record(p, m, s.distal_radius(), 5, coarse);
  double worst = 0.0;
  for (std::size_t i = 0; i < e.cells.size(); ++i) worst = std::max(worst, std::abs(double(e.cells[i]) - c.cells[i]));
  MESSAGE("interpolation: largest C_c difference " << worst << " pF");
  CHECK(worst < 0.01);  // against a per-cell noise of several hundredths of a pF at the default noise
}

TEST_CASE("sim corpus: the paper's protocol, identical for any thread count") {
  CorpusConfig config;
  config.subjects = 2;
  config.sessions = 5;
  config.minutes = 0.05;
  config.calibration_seconds = 1.0;
  const std::vector<SessionRecording> plan = plan_corpus(config);
  // Per subject: 5 sessions + 2 with glove II, each after its calibration sequence.
  CHECK(plan.size() == 2u * (5 + 2) * 2);
  std::vector<int> donnings;
  for (const SessionRecording& r : plan)
    if (r.subject == 0 && r.glove == 0 && r.kind == RecordingKind::Session) donnings.push_back(r.donning);
  CHECK(donnings == std::vector<int>{0, 0, 0, 1, 2});
  config.world = world_named("tracked");  // every stream, the reference tracker's included
  config.threads = 1;
  const auto one = simulate_corpus(config);
  config.threads = 2;
  const auto two = simulate_corpus(config);
  REQUIRE(one.size() == two.size());
  for (std::size_t i = 0; i < one.size(); ++i) {
    CHECK(one[i].recording.cells == two[i].recording.cells);
    CHECK(one[i].recording.angles == two[i].recording.angles);
    CHECK(one[i].recording.labels == two[i].recording.labels);
    CHECK(one[i].recording.outlier == two[i].recording.outlier);
    CHECK(one[i].recording.labels != one[i].recording.angles);
  }
  // The world changes the labels only: the glove's readings and the truth are the clean world's.
  config.world = world_named("clean");
  const auto clean = simulate_corpus(config);
  for (std::size_t i = 0; i < one.size(); ++i) {
    CHECK(clean[i].recording.cells == one[i].recording.cells);
    CHECK(clean[i].recording.angles == one[i].recording.angles);
    CHECK(clean[i].recording.labels == clean[i].recording.angles);
  }
  CHECK_THROWS_WITH_AS(world_named("mars"), doctest::Contains("unknown world 'mars', expected one of clean, tracked"), Error);
  CHECK(one[1].recording.frames == 180);  // 3 s at 60 Hz
  CHECK(one[0].recording.frames == 60);   // the 1 s calibration sequence
  config.minutes = 0.0;
  CHECK_THROWS_WITH_AS(simulate_corpus(config), doctest::Contains("--minutes"), Error);
}

TEST_CASE("sim report: realistic readout age, outliers and signal, re-donning below pose change, not linearly solvable across people") {
  CorpusConfig config;
  config.seed = 11;
  config.subjects = 5;
  config.sessions = 2;
  config.minutes = 2.5;
  config.gloves = 1;
  config.calibration_seconds = 20.0;
  const RealismReport r = make_report(config);
  MESSAGE(format_report(r));
  CHECK(r.age_median >= 0.045);
  CHECK(r.age_median <= 0.090);
  CHECK(r.outlier_share < 0.05);
  CHECK(r.redonning_change < 0.6 * r.pose_change);
  CHECK(r.redonning_change > 0.02);  // a donning does change the readings
  for (const auto& c : r.cells) CHECK(c.snr > 10.0);
  for (std::size_t d = 0; d < hand::kDofCount; ++d)
    if (hand::kDofs[d].motion != hand::Motion::Twist) CHECK(r.dofs[d].coverage > 0.4);
  // The cross-person problem is not trivially linear: leaving a subject out costs clearly more than
  // fitting within the session.
  CHECK(r.linear_cross_deg > 1.4 * r.linear_same_deg);
  CHECK(r.linear_same_deg > 1.0);  // nor is one session linear
}

TEST_CASE("sim tracker: a perfect tracker copies the truth, the wandering error has the stated SD and time correlation") {
  const Subject s = make_subjects(1, 3)[0];
  const hand::Kinematics fk(s.hand_model());
  const MotionSequence m(s, pose_gallery(), 240.0, 4);
  Recording r = true_motion(m, 240.0);
  label_recording(r, m, fk, s.distal_radius(), TrackerConfig{}, {1, 2, 3});
  CHECK(r.labels == r.angles);

  TrackerConfig c;
  c.flexion_sd = 4.0;
  c.abduction_sd = 2.0;
  c.twist_sd = 1.0;
  c.thumb_factor = 1.5;
  c.correlation_time = 0.5;
  label_recording(r, m, fk, s.distal_radius(), c, {1, 2, 3});
  const std::size_t n = static_cast<std::size_t>(r.frames), lag = 30;  // 0.5 s
  double sq[4] = {}, count[4] = {}, product = 0.0, lag_sq = 0.0;
  for (std::size_t d = 0; d < hand::kDofCount; ++d) {
    const hand::Dof& dof = hand::kDofs[d];
    const int group = dof.motion == hand::Motion::Abduction ? 1 : dof.motion == hand::Motion::Twist ? 2 : 0;
    const double sd = group == 0 ? 4.0 : group == 1 ? 2.0 : 1.0;
    const int g = dof.finger == hand::Finger::Thumb ? 3 : group;  // thumb: each of its DoFs over its own SD
    const double scale = dof.finger == hand::Finger::Thumb ? sd * 1.5 : sd;
    for (std::size_t f = 0; f < n; ++f) {
      if (!inside(r, f, d, 4.0 * scale)) continue;
      const double e = label_error(r, f, d) / scale;
      sq[g] += e * e;
      count[g] += 1.0;
      if (f >= lag && inside(r, f - lag, d, 4.0 * scale)) {
        product += e * label_error(r, f - lag, d) / scale;
        lag_sq += e * e;
      }
    }
  }
  for (int g = 0; g < 4; ++g) {
    INFO("group " << g << ", frames " << count[g]);
    CHECK(std::sqrt(sq[g] / count[g]) == doctest::Approx(1.0).epsilon(0.08));
  }
  MESSAGE("autocorrelation at 0.5 s: " << product / lag_sq << " (stated exp(-1) = 0.368)");
  CHECK(product / lag_sq == doctest::Approx(std::exp(-1.0)).epsilon(0.1));

  // Occlusion: the SD grows with the finger's flexion as stated.
  c.occlusion_gain = 1.0;
  label_recording(r, m, fk, s.distal_radius(), c, {1, 2, 3});
  double normalised = 0.0, frames = 0.0;
  for (std::size_t d = 0; d < hand::kDofCount; ++d) {
    const hand::Dof& dof = hand::kDofs[d];
    if (dof.motion != hand::Motion::MiddleFlexion || dof.finger == hand::Finger::Thumb) continue;
    for (std::size_t f = 0; f < n; ++f) {
      const double flexion = r.angles[f * hand::kDofCount + hand::dof_of(dof.finger, hand::Motion::BaseFlexion)] +
                             r.angles[f * hand::kDofCount + d];
      const double sd = 4.0 * (1.0 + std::clamp(flexion / (180.0 * calibration::kRadiansPerDegree), 0.0, 1.0));
      if (!inside(r, f, d, 4.0 * sd)) continue;
      normalised += std::pow(label_error(r, f, d) / sd, 2);
      frames += 1.0;
    }
  }
  CHECK(std::sqrt(normalised / frames) == doctest::Approx(1.0).epsilon(0.1));

  // The tracker's collision term: outside failures a label overlaps no more than allowed (or than the truth does).
  c.collision_allowance = 20.0;
  label_recording(r, m, fk, s.distal_radius(), c, {1, 2, 3});
  hand::Skeleton skeleton;
  const auto energy_of = [&](const std::vector<float>& v, std::size_t f) {
    hand::Angles q{};
    for (std::size_t d = 0; d < hand::kDofCount; ++d) q[d] = v[f * hand::kDofCount + d];
    fk.pose(q, skeleton);
    return hand::collision_energy(fk, skeleton, s.distal_radius());
  };
  double worst = 0.0;
  long shortened = 0;
  for (std::size_t f = 0; f < n; f += 3) {
    const double over = energy_of(r.labels, f) - std::max(20.0, energy_of(r.angles, f));
    worst = std::max(worst, over);
    shortened += over > -1.0 ? 1 : 0;
  }
  MESSAGE("largest overlap beyond the allowance " << worst << " mm^2; frames at the limit " << shortened);
  CHECK(worst < 1.0);  // float labels
}

TEST_CASE("sim tracker: biases per person and per session, latency as motion lag, failures as stated") {
  const Subject s = make_subjects(1, 3)[0];
  const hand::Kinematics fk(s.hand_model());
  const MotionSequence m(s, pose_gallery(), 120.0, 4);
  const Recording truth = true_motion(m, 120.0);

  // Constant biases: the same person shares one, each session adds its own; SD sqrt(2^2 + 1.5^2) = 2.5 degrees.
  TrackerConfig c;
  c.subject_bias_sd = 2.0;
  c.session_bias_sd = 1.5;
  Recording a = truth, b = truth, other = truth;
  label_recording(a, m, fk, s.distal_radius(), c, {10, 20, 30});
  label_recording(b, m, fk, s.distal_radius(), c, {10, 20, 31});  // same session, another recording (its calibration)
  CHECK(a.labels == b.labels);
  double sq = 0.0, count = 0.0;
  for (std::uint64_t person = 0; person < 40; ++person) {
    label_recording(other, m, fk, s.distal_radius(), c, {100 + person, 200 + person, 1});
    for (std::size_t d = 0; d < hand::kDofCount; ++d) {
      const std::size_t f = 600;
      if (!inside(other, f, d, 12.0)) continue;
      sq += std::pow(label_error(other, f, d), 2);
      count += 1.0;
    }
  }
  MESSAGE("bias SD " << std::sqrt(sq / count) << " deg over " << count << " DoFs");
  CHECK(std::sqrt(sq / count) == doctest::Approx(2.5).epsilon(0.12));

  // Latency: the labels trail the truth by it (measured by the lag of their frame-to-frame changes).
  TrackerConfig late;
  late.latency = 3.0 / 60.0;
  Recording l = truth;
  label_recording(l, m, fk, s.distal_radius(), late, {1, 2, 3});
  std::vector<std::int64_t> source, run(truth.angles.size() / hand::kDofCount, 0);
  for (std::size_t f = 0; f < run.size(); ++f) source.push_back(static_cast<std::int64_t>(f));
  CHECK(train::lag_frames(l.labels, l.angles, source, run) == doctest::Approx(3.0).epsilon(0.05));

  // Failures: a frozen finger repeats its labels while the truth moves; a snapped finger collides
  // with its neighbour (collision energy over the paper's threshold: an outlier). The share of
  // frames in a failure of mean length T at rate R per second is R T / (1 + R T).
  // Ten recordings (about 60 failures of each kind) keep the count's own spread near 15%.
  TrackerConfig freeze;
  freeze.freeze_rate = 6.0;
  freeze.failure_seconds = 0.5;
  TrackerConfig snap;
  snap.snap_rate = 6.0;
  snap.failure_seconds = 0.5;
  double held = 0.0, outliers = 0.0, frames = 0.0;
  for (std::uint64_t seed = 0; seed < 10; ++seed) {
    Recording z = truth, p = truth;
    label_recording(z, m, fk, s.distal_radius(), freeze, {1, 2, seed});
    label_recording(p, m, fk, s.distal_radius(), snap, {1, 2, seed});
    for (std::size_t f = 1; f < run.size(); ++f)
      for (std::size_t finger = 0; finger < hand::kFingerCount; ++finger) {
        bool same = true;
        for (hand::Motion motion :
             {hand::Motion::Abduction, hand::Motion::BaseFlexion, hand::Motion::MiddleFlexion, hand::Motion::TipFlexion}) {
          const std::size_t d = hand::dof_of(static_cast<hand::Finger>(finger), motion);
          same = same && z.labels[f * hand::kDofCount + d] == z.labels[(f - 1) * hand::kDofCount + d] &&
                 z.angles[f * hand::kDofCount + d] != z.angles[(f - 1) * hand::kDofCount + d];
        }
        held += same ? 1.0 : 0.0;
      }
    for (std::uint8_t o : p.outlier) outliers += o;
    frames += static_cast<double>(run.size());
  }
  const double expected = 0.1 * 0.5 / (1.0 + 0.1 * 0.5);
  MESSAGE("frames with a frozen finger: " << held / frames << " (stated " << expected << ")");
  CHECK(held / frames == doctest::Approx(expected).epsilon(0.2));
  std::size_t truth_outliers = 0;  // the true poses' own collisions
  hand::Skeleton skeleton;
  for (std::size_t f = 0; f < run.size(); ++f) {
    hand::Angles q{};
    for (std::size_t d = 0; d < hand::kDofCount; ++d) q[d] = truth.angles[f * hand::kDofCount + d];
    fk.pose(q, skeleton);
    truth_outliers += hand::collision_energy(fk, skeleton, s.distal_radius()) > hand::kCollisionOutlierThreshold ? 1 : 0;
  }
  const double share = outliers / frames;
  MESSAGE("outlier share with snaps: " << share << " (frames in a snap: " << expected << "; truth alone: "
                                       << static_cast<double>(truth_outliers) / run.size() << ")");
  CHECK(share > 0.5 * expected);
  CHECK(share < 1.3 * expected + static_cast<double>(truth_outliers) / run.size());
}
