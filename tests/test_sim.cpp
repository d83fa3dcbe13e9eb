// The simulator: subjects, glove physics, motion, timed readout, the corpus protocol.
#include <glovepose/sim/corpus.hpp>
#include <glovepose/sim/corpus_dataset.hpp>
#include <glovepose/sim/report.hpp>
#include <glovepose/sim/tracker.hpp>
#include <glovepose/train/lag.hpp>

#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <map>
#include <set>
#include <utility>

using namespace glovepose;
using namespace glovepose::sim;

namespace {

std::size_t dof(int theta) { return hand::dof_from_theta(theta); }

// Noise-free physics of subject `s` wearing glove 0 in a donning drawn from `fit_seed`.
GlovePhysics physics_of(const Subject& s, std::uint64_t fit_seed = 3) {
  core::Rng rng(fit_seed);
  const Glove glove = make_glove(0, 1);
  return GlovePhysics(s, glove, don_glove(s, glove, rng));
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
  return (double(r.labels[f * hand::kDofCount + d]) - r.angles[f * hand::kDofCount + d]) / core::kRadiansPerDegree;
}

// Whether DoF d's truth at frame f is at least `margin` degrees inside its joint limits (no clamping of the label there).
bool inside(const Recording& r, std::size_t f, std::size_t d, double margin) {
  const double a = r.angles[f * hand::kDofCount + d];
  return a - hand::kDofs[d].min > margin * core::kRadiansPerDegree && hand::kDofs[d].max - a > margin * core::kRadiansPerDegree;
}

CellArray cells_at(const GlovePhysics& p, const hand::Angles& a) {
  CellArray c{};
  p.capacitances(a, c);
  return c;
}

// Relative change of cell `c` from the rest pose when DoF `d` alone bends to `angle` (radians).
double rise(const GlovePhysics& p, std::size_t d, double angle, std::size_t c) {
  hand::Angles bent{};
  bent[d] = angle;
  return cells_at(p, bent)[c] / cells_at(p, hand::Angles{})[c] - 1.0;
}

// The strain along cell `c` before the textile (pre-stretch, slack, saturation) shaped it, from its
// stretch ratio along: the inverse of the physics' softplus and tanh, for an along-cut cell.
double strain_before_textile(double along, const GloveFit& fit, std::size_t c) {
  const double taut = kSaturation * std::atanh((along - 1.0) / kSaturation);
  const double strain = kSlackWidth * std::log(std::expm1(taut / kSlackWidth));
  return (strain + 1.0) / fit.pre_along[c] - 1.0;
}

// Along-cut cells of digit `digit` on `segment`.
std::vector<std::size_t> along_cells(int digit, sensor::Segment segment) {
  std::vector<std::size_t> cells;
  const auto sites = glauser2019_sites();
  for (std::size_t c = 0; c < kCells; ++c)
    if (sites[c].digit == digit && sites[c].segment == segment && sites[c].along) cells.push_back(c);
  return cells;
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

TEST_CASE("sim recorder: a torn trace's cells beyond the break leave every row from the tear on") {
  const Subject s = make_subjects(1, 3)[0];
  const GlovePhysics p = physics_of(s);
  const MotionSequence m(s, pose_gallery(), 4.0, 4);
  const sensor::TraceLayout layout = sensor::TraceLayout::glauser2019();
  RecordingConfig config;
  config.raw_rows = true;
  config.noise.spike_probability = config.noise.drop_probability = 0.0;
  const Recording intact = record(p, m, s.distal_radius(), 5, config);
  const TraceTear tear{layout.bottom_traces() + 4, 1, 2.0};  // top trace 4, torn after its first cell
  config.tears = {tear};
  const std::vector<int> floating = cells_beyond_tear(layout, glauser2019_sites(), tear);
  const Recording torn = record(p, m, s.distal_radius(), 5, config);
  // The cells of top trace 4 from the wrist out; all but the first float.
  std::vector<int> on_trace;
  for (int c = 0; c < layout.cell_count(); ++c)
    if (layout.cells()[static_cast<std::size_t>(c)].top == 4) on_trace.push_back(c);
  REQUIRE(on_trace.size() >= 2);
  CHECK(floating.size() == on_trace.size() - 1);
  for (int c : floating) CHECK(std::find(on_trace.begin(), on_trace.end(), c) != on_trace.end());

  // Before the tear the rows are the intact glove's, bit for bit; after it, so are the rows of no
  // floating cell, and the difference of the others lies in the span of the floating cells' columns
  // of M: a least-squares fit of it leaves only the cells' motion within the cycle (each row is read
  // at its own instant), and the fitted capacitances are those cells' (the intact solve's, within
  // its 5-frame mean and noise).
  Eigen::MatrixXd m_floating(kRows, static_cast<Eigen::Index>(floating.size()));
  for (std::size_t k = 0; k < floating.size(); ++k) m_floating.col(static_cast<Eigen::Index>(k)) = layout.measurement_matrix().col(floating[k]);
  const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(m_floating);
  double worst_residual = 0.0, worst_cell = 0.0;
  for (int f = 0; f < intact.frames; ++f) {
    Eigen::VectorXd difference(kRows);
    for (int r = 0; r < kRows; ++r)
      difference(r) = static_cast<double>(intact.raw_rows[static_cast<std::size_t>(f * kRows + r)]) -
                      static_cast<double>(torn.raw_rows[static_cast<std::size_t>(f * kRows + r)]);
    if (intact.timestamps[static_cast<std::size_t>(f)] <= 2.0) {
      REQUIRE(difference.cwiseAbs().maxCoeff() == 0.0);
      continue;
    }
    if (intact.timestamps[static_cast<std::size_t>(f)] < 2.0 + 1.0 / 60.0) continue;  // the cycle the tear falls in
    for (int r = 0; r < kRows; ++r)
      if (m_floating.row(r).sum() == 0.0) REQUIRE(difference(r) == 0.0);
    const Eigen::VectorXd fitted = qr.solve(difference);
    worst_residual = std::max(worst_residual, (m_floating * fitted - difference).cwiseAbs().maxCoeff());
    for (std::size_t k = 0; k < floating.size(); ++k)
      worst_cell = std::max(worst_cell, std::abs(fitted(static_cast<Eigen::Index>(k)) -
                                                 intact.cells[static_cast<std::size_t>(f * kCells + floating[k])]));
  }
  MESSAGE("torn after 2 s: " << floating.size() << " cells float; rows' difference off their span by at most " << worst_residual
                             << " pF; fitted against the intact cells within " << worst_cell << " pF");
  CHECK(worst_residual < 1.0);  // measured 0.36 pF
  CHECK(worst_cell < 1.5);      // measured 0.73 pF
  // The readout's full-M solve reads the floating cells as about 0 once its 5-frame mean holds only torn rows.
  for (int c : floating) CHECK(std::abs(torn.cells[static_cast<std::size_t>((torn.frames - 1) * kCells + c)]) < 0.5);
  CHECK_THROWS_AS(cells_beyond_tear(layout, glauser2019_sites(), {27, 0, 0.0}), Error);

  // A second trace (bottom trace 7, whole) tearing at 3 s: until then the rows are the first tear's
  // alone, bit for bit; at the end the cells of both read about 0.
  const TraceTear second{7, 0, 3.0};
  config.tears = {tear, second};
  const Recording both = record(p, m, s.distal_radius(), 5, config);
  REQUIRE(both.frames == torn.frames);
  for (int f = 0; f < both.frames && both.timestamps[static_cast<std::size_t>(f)] < 3.0; ++f)  // the frame ending at 3 s holds a row read at the tear
    for (int r = 0; r < kRows; ++r)
      REQUIRE(both.raw_rows[static_cast<std::size_t>(f * kRows + r)] == torn.raw_rows[static_cast<std::size_t>(f * kRows + r)]);
  std::vector<int> all_floating = cells_beyond_tear(layout, glauser2019_sites(), second);
  REQUIRE(!all_floating.empty());
  all_floating.insert(all_floating.end(), floating.begin(), floating.end());
  for (int c : all_floating) CHECK(std::abs(both.cells[static_cast<std::size_t>((both.frames - 1) * kCells + c)]) < 0.5);
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
  config.world = world_named("worn");  // every stream, the reference tracker's and the glove's drift included
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
  // The tracker changes the labels only: the glove's readings and the truth are the clean world's;
  // the wear and material effects change the readings only.
  config.world = world_named("clean");
  const auto clean = simulate_corpus(config);
  config.world = world_named("tracked");
  const auto tracked = simulate_corpus(config);
  for (std::size_t i = 0; i < one.size(); ++i) {
    CHECK(clean[i].recording.cells == tracked[i].recording.cells);
    CHECK(clean[i].recording.angles == tracked[i].recording.angles);
    CHECK(clean[i].recording.labels == clean[i].recording.angles);
    CHECK(tracked[i].recording.labels == one[i].recording.labels);
    CHECK(tracked[i].recording.cells != one[i].recording.cells);
  }
  CHECK_THROWS_WITH_AS(world_named("mars"), doctest::Contains("unknown world 'mars', expected one of clean, tracked, worn"), Error);
  CHECK(one[1].recording.frames == 180);  // 3 s at 60 Hz
  CHECK(one[0].recording.frames == 60);   // the 1 s calibration sequence
  config.minutes = 0.0;
  CHECK_THROWS_WITH_AS(simulate_corpus(config), doctest::Contains("--minutes"), Error);
}

TEST_CASE("sim session: the dataset's first session frame is the first after the simulated calibration") {
  const CorpusConfig config = CorpusConfig::one_session(17, 1.0, 2.0);
  const std::vector<SessionRecording> corpus = simulate_corpus(config);
  REQUIRE(corpus.size() == 2);
  REQUIRE(corpus[0].kind == RecordingKind::Calibration);
  const io::Dataset d = to_dataset(corpus, config);
  // From the recordings' own fields: the session's clock continues the calibration's, so its first
  // frame is the first one past the calibration recording's last time.
  const double calibration_end = corpus[0].recording.timestamps.back();
  std::size_t past = 0;
  while (past < d.frames() && d.timestamps[past] <= calibration_end) ++past;
  CHECK(past == static_cast<std::size_t>(corpus[0].recording.frames));
  CHECK(std::abs(static_cast<double>(past) - config.calibration_seconds * config.recording.cycle_rate) <= 1.0);
  CHECK(d.first_session_frame() == past);
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
  // Across people, calibration helps (the paper's generic model: 8.3 without, 7.6 with).
  CHECK(r.linear_uncalibrated_deg > r.linear_cross_deg);
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
      const double sd = 4.0 * (1.0 + std::clamp(flexion / (180.0 * core::kRadiansPerDegree), 0.0, 1.0));
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

TEST_CASE("sim tracker: a person's wandering error grows as their hand is shorter, times their own factor") {
  TrackerConfig c;
  c.flexion_sd = 4.0;
  c.size_power = 1.0;
  // The geometry: a millimetre of the camera's error turns a phalanx 0.9 times as long 1 / 0.9 times as far.
  CHECK(tracker_person_factor(c, 0.9, 7) == doctest::Approx(1.0 / 0.9).epsilon(1e-12));
  c.size_power = 0.0;
  c.subject_noise_spread = 0.3;
  double sum = 0.0, sq = 0.0;
  const int people = 400;
  for (int k = 0; k < people; ++k) {
    const double log_factor = std::log(tracker_person_factor(c, 1.0, 1000 + static_cast<std::uint64_t>(k)));
    sum += log_factor;
    sq += log_factor * log_factor;
  }
  const double mean = sum / people, sd = std::sqrt(sq / people - mean * mean);
  MESSAGE("log-SD of the person factors " << sd << " (stated 0.3), mean " << mean);
  CHECK(sd == doctest::Approx(0.3).epsilon(0.1));  // sampling error of an SD over 400: 3.5%
  CHECK(std::abs(mean) < 0.05);                    // 3.3 standard errors
  // The labels carry it: one person's flexion errors over 4 minutes have the SD 4 x their factor.
  const Subject s = make_subjects(1, 3)[0];
  const hand::Kinematics fk(s.hand_model());
  const MotionSequence m(s, pose_gallery(), 240.0, 4);
  Recording r = true_motion(m, 240.0);
  c.size_power = 1.0;
  const double scale = 0.92, expected = 4.0 * tracker_person_factor(c, scale, 55);
  label_recording(r, m, fk, s.distal_radius(), c, {55, 2, 3}, scale);
  double err_sq = 0.0, frames = 0.0;
  for (std::size_t d = 0; d < hand::kDofCount; ++d) {
    const hand::Dof& dof = hand::kDofs[d];
    if (dof.finger == hand::Finger::Thumb || dof.motion == hand::Motion::Abduction || dof.motion == hand::Motion::Twist) continue;
    for (std::size_t f = 0; f < static_cast<std::size_t>(r.frames); ++f) {
      if (!inside(r, f, d, 4.0 * expected)) continue;
      err_sq += std::pow(label_error(r, f, d), 2);
      frames += 1.0;
    }
  }
  MESSAGE("flexion error SD " << std::sqrt(err_sq / frames) << " deg, stated " << expected);
  CHECK(std::sqrt(err_sq / frames) == doctest::Approx(expected).epsilon(0.08));
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

TEST_CASE("sim wear: donning shifts with their stated SDs, more on a loose fit, each glove's cells placed apart") {
  const std::vector<Subject> subjects = make_subjects(10, 1);
  const Subject& full = subjects[5];   // 20.5 x 10 cm: fills the glove, no slack
  const Subject& small = subjects[9];  // 17 x 9 cm
  CHECK(glove_slack(full) == 0.0);
  CHECK(glove_slack(small) == doctest::Approx((1.0 - 170.0 / 175.0) + (1.0 - 90.0 / 95.0)));
  WearConfig wear;
  wear.donning_shift = 3.0;
  wear.cell_shift = 2.0;
  wear.loose_gain = 1.0;
  wear.placement_sd = 1.0;
  const Glove glove = make_glove(0, 1, wear.placement_sd), bare = make_glove(0, 1);
  CHECK(glove.base_capacitance == bare.base_capacitance);  // placement does not disturb the other fabrication draws
  CHECK(glove.cross_gain == bare.cross_gain);
  // Each cell's shift = its placement + the glove's shift + its own; over 2000 donnings the glove's
  // part has SD donning_shift x loose, the rest cell_shift x loose.
  for (const Subject* who : {&full, &small}) {
    const double loose = loose_fit_factor(*who, wear);
    double global_sq = 0.0, cell_sq = 0.0, cells = 0.0;
    const int donnings = 2000;
    for (int k = 0; k < donnings; ++k) {
      core::Rng rng(core::derive_seed(5, {static_cast<std::uint64_t>(k)}));
      const GloveFit fit = don_glove(*who, glove, rng, wear);
      double mean = 0.0;
      for (std::size_t c = 0; c < kCells; ++c) mean += (fit.shift[c] - glove.placement[c]) / kCells;
      global_sq += mean * mean;
      for (std::size_t c = 0; c < kCells; ++c) {
        cell_sq += std::pow(fit.shift[c] - glove.placement[c] - mean, 2);
        cells += 1.0;
      }
    }
    const double global_sd = std::sqrt(global_sq / donnings), cell_sd = std::sqrt(cell_sq / cells * kCells / (kCells - 1));
    MESSAGE("loose factor " << loose << ": glove shift SD " << global_sd << ", cell shift SD " << cell_sd << " mm");
    // 2000 donnings: the glove's SD has a sampling error of 1.6%, the cells' (88,000 draws) 0.24%.
    CHECK(std::abs(global_sd / std::hypot(3.0 * loose, 2.0 * loose / std::sqrt(double(kCells))) - 1.0) < 0.05);
    CHECK(std::abs(cell_sd / (2.0 * loose) - 1.0) < 0.01);
  }
  CHECK(loose_fit_factor(small, wear) == doctest::Approx(1.0 + glove_slack(small) / 0.1));
  // Two gloves of the design: their cells sit placement_sd apart from the design, independently.
  const Glove second = make_glove(1, 1, wear.placement_sd);
  double sq = 0.0, cross = 0.0;
  for (std::size_t c = 0; c < kCells; ++c) {
    sq += glove.placement[c] * glove.placement[c] + second.placement[c] * second.placement[c];
    cross += glove.placement[c] * second.placement[c];
  }
  CHECK(std::abs(std::sqrt(sq / (2 * kCells)) - 1.0) < 0.23);  // 88 draws: sampling error 7.5%
  CHECK(std::abs(cross / kCells) < 0.35);  // correlation of the two gloves' placements: sampling error 0.15
  // Without shifts a fit puts every cell at its placement.
  WearConfig still;
  still.donning_shift = still.cell_shift = 0.0;
  core::Rng rng(3);
  CHECK(don_glove(full, glove, rng, still).shift == glove.placement);
}

TEST_CASE("sim wear: the size coupling passes its share of the hand's size to the cells' pre-stretch") {
  const std::vector<Subject> subjects = make_subjects(10, 1);
  const Subject& large = subjects[5];  // 20.5 x 10 cm
  const Glove glove = make_glove(0, 1);
  const auto sites = glauser2019_sites();
  WearConfig wear;
  wear.pre_stretch_spread = 0.0;  // the size's share alone
  for (double coupling : {1.0, 0.5, 0.0}) {
    wear.size_coupling = coupling;
    core::Rng rng(3);
    const GloveFit fit = don_glove(large, glove, rng, wear);
    for (std::size_t c = 0; c < kCells; ++c) {
      if (sites[c].segment == sensor::Segment::Metacarpal) continue;
      const double ratio = large.size.length / kGloveRelaxedLength * large.finger_scale[static_cast<std::size_t>(sites[c].digit)];
      CHECK(fit.pre_along[c] == doctest::Approx(1.0 + coupling * (ratio - 1.0)).epsilon(1e-12));
    }
    // Without the size's share the large hand leaves its cells relaxed at rest, as a hand of the glove's size would.
    if (coupling == 0.0) CHECK(cells_at(GlovePhysics(large, glove, fit), hand::Angles{})[21] == doctest::Approx(glove.base_capacitance[21]).epsilon(0.02));
  }
}

TEST_CASE("sim wear: a finger shorter or longer than the glove's leaves its cells off their joints") {
  const std::vector<Subject> subjects = make_subjects(10, 1);
  const Glove glove = make_glove(0, 1);
  const auto sites = glauser2019_sites();
  WearConfig wear;
  wear.donning_shift = wear.cell_shift = wear.pre_stretch_spread = 0.0;  // the size's share alone
  wear.size_coupling = 0.5;
  wear.length_misplacement = 1.0;
  for (const int who : {9, 5}) {  // 17 cm and 20.5 cm hands against the glove relaxed on 17.5 cm
    const Subject& subject = subjects[static_cast<std::size_t>(who)];
    // Joint places from the posed rest skeleton: the cell's joint against its digit's anchor (a
    // finger's MCP, the thumb's MCP), straight-line, a computation apart from the model's chain.
    const hand::Kinematics kinematics(subject.hand_model());
    hand::Skeleton rest;
    kinematics.pose(hand::Angles{}, rest);
    core::Rng rng(3);
    const GloveFit fit = don_glove(subject, glove, rng, wear);
    double distal_shift = 0.0;
    for (std::size_t c = 0; c < kCells; ++c) {
      const CellSite& site = sites[c];
      if (site.segment == sensor::Segment::Metacarpal || site.segment == sensor::Segment::Web) {
        CHECK(fit.shift[c] == glove.placement[c]);
        continue;
      }
      const auto finger = static_cast<hand::Finger>(site.digit);
      const hand::Motion anchor = site.digit == 0 ? hand::Motion::MiddleFlexion : hand::Motion::BaseFlexion;
      const auto joint_of = [&](std::size_t d) { return rest[static_cast<std::size_t>(hand::kDofs[d].phalanx)].translation(); };
      const double x = (joint_of(static_cast<std::size_t>(site.flexion_dof)) - joint_of(hand::dof_of(finger, anchor))).norm();
      const double k = subject.size.length / kGloveRelaxedLength * subject.finger_scale[static_cast<std::size_t>(site.digit)];
      // Placed for the relaxed hand at x / k, moved by half the length difference: x/k (1 + 0.5 (k - 1)) - x.
      const double expected = x / k * (1.0 + 0.5 * (k - 1.0)) - x;
      // The rest finger is slightly bent: the straight line is up to 0.01% shorter than the bones.
      CHECK(fit.shift[c] - glove.placement[c] == doctest::Approx(expected).epsilon(1e-3));
      if (site.segment == sensor::Segment::Distal && site.digit > 0) distal_shift += expected / 4.0;
    }
    MESSAGE("subject " << who << ": the fingers' distal cells sit " << distal_shift << " mm off their joints");
    if (who == 9) CHECK(distal_shift > 0.1);   // short fingers: the cells sit beyond the joints
    if (who == 5) CHECK(distal_shift < -2.0);  // long fingers: before them
  }
  // The whole misplacement, without the coupling's help, costs the large hand's DIP cells signal:
  // they catch less of the joint's bend zone.
  const Subject& large = subjects[5];
  wear.size_coupling = 0.0;
  core::Rng rng(3);
  const GlovePhysics misplaced(large, glove, don_glove(large, glove, rng, wear));
  wear.length_misplacement = 0.0;
  const GlovePhysics placed(large, glove, don_glove(large, glove, rng, wear));
  const std::size_t dip = hand::dof_of(hand::Finger::Middle, hand::Motion::TipFlexion);
  for (std::size_t c = 0; c < kCells; ++c) {
    if (sites[c].flexion_dof != static_cast<int>(dip) || !sites[c].along) continue;
    const double off = rise(misplaced, dip, 1.2, c), on = rise(placed, dip, 1.2, c);
    MESSAGE("middle DIP cell " << c << " at 69 degrees: relative rise " << off << " misplaced, " << on << " on its joint");
    CHECK(off < 0.9 * on);
  }
}

TEST_CASE("sim wear: a glove too big leaves all of the shortfall as slack, which the first motion takes up") {
  const std::vector<Subject> subjects = make_subjects(10, 1);
  const Subject& small = subjects[9];  // 17 x 9 cm
  const Subject& large = subjects[5];  // 20.5 x 10 cm
  const Glove glove = make_glove(0, 1);
  const auto sites = glauser2019_sites();
  WearConfig wear;
  wear.donning_shift = wear.cell_shift = wear.pre_stretch_spread = 0.0;
  wear.size_coupling = 0.5;
  wear.relaxed_length = 185.0;
  wear.relaxed_width = 100.0;
  CHECK(glove_slack(small, wear) == doctest::Approx((1.0 - 170.0 / 185.0) + (1.0 - 90.0 / 100.0)));
  for (const double loose_slack : {0.0, 1.0}) {
    wear.loose_slack = loose_slack;
    for (const Subject* who : {&small, &large}) {
      core::Rng rng(3);
      const GloveFit fit = don_glove(*who, glove, rng, wear);
      for (std::size_t c = 0; c < kCells; ++c) {
        if (sites[c].segment == sensor::Segment::Metacarpal) continue;
        const double k = who->size.length / 185.0 * who->finger_scale[static_cast<std::size_t>(sites[c].digit)];
        // A shortfall reaches the cells in full at loose_slack 1, by the size coupling at 0; a stretch always by the coupling.
        const double share = k < 1.0 ? 0.5 + 0.5 * loose_slack : 0.5;
        CHECK(fit.pre_along[c] == doctest::Approx(1.0 + share * (k - 1.0)).epsilon(1e-12));
      }
    }
  }
  // The slack is a dead zone: a small flexion of the small hand's index PIP reaches its cell only
  // once the textile is taut. Strain per radian at the joint is about r / L; below the slack the
  // cell reads within the softplus ramp of its rest value.
  core::Rng rng(3);
  const GlovePhysics slack(small, glove, don_glove(small, glove, rng, wear));
  wear.loose_slack = 0.0;
  const GlovePhysics shared(small, glove, don_glove(small, glove, rng, wear));
  const std::size_t pip = hand::dof_of(hand::Finger::Index, hand::Motion::MiddleFlexion);
  for (std::size_t c = 0; c < kCells; ++c) {
    if (sites[c].flexion_dof != static_cast<int>(pip) || !sites[c].along) continue;
    const double all = rise(slack, pip, 0.05, c), part = rise(shared, pip, 0.05, c);  // 3 degrees
    MESSAGE("index PIP cell " << c << " at 3 degrees: relative rise " << all << " all slack, " << part << " shared");
    CHECK(all < 0.5 * part);
    CHECK(rise(slack, pip, 1.2, c) > 0.5);  // taut once the slack is taken up: the large flexion still reads
  }
}

TEST_CASE("sim wear: straighter neighbours hold back part of a finger's knuckle lengthening through the sheet") {
  const Subject s = make_subjects(1, 1)[0];
  const Glove glove = make_glove(0, 1);
  WearConfig wear;
  wear.donning_shift = wear.cell_shift = wear.pre_stretch_spread = 0.0;
  const auto fit_with = [&](double hold) {
    WearConfig w = wear;
    w.neighbour_hold = hold;
    core::Rng rng(3);
    return don_glove(s, glove, rng, w);
  };
  // The person's sheet-tension multiplier scales the hold: these give holds of 0, 1/2 and 1.
  const GloveFit free_fit = fit_with(0.0), half_fit = fit_with(0.5 / s.skin.sheet_tension), full_fit = fit_with(10.0);
  const GlovePhysics free(s, glove, free_fit), half(s, glove, half_fit), full(s, glove, full_fit);
  const auto base = [](hand::Finger f) { return hand::dof_of(f, hand::Motion::BaseFlexion); };
  const auto along = [](const GlovePhysics& p, const hand::Angles& a) {
    CellArray al{}, ac{};
    p.stretch(a, al, ac);
    return std::pair{al, ac};
  };
  // A fist's knuckles flex together: nothing is held back.
  hand::Angles fist{};
  for (hand::Finger f : {hand::Finger::Index, hand::Finger::Middle, hand::Finger::Ring, hand::Finger::Pinky}) fist[base(f)] = 1.0;
  CHECK(cells_at(full, fist) == cells_at(free, fist));
  // The index alone: a full hold leaves its knuckle cells and the back of the hand behind its
  // knuckle at rest along (nothing else moved), half of it halves their strain; the girth across is
  // not the sheet's to hold.
  hand::Angles alone{};
  alone[base(hand::Finger::Index)] = 0.6;
  const auto [rest_along, rest_across] = along(full, hand::Angles{});
  const auto [free_along, free_across] = along(free, alone);
  const auto [half_along, half_across] = along(half, alone);
  const auto [full_along, full_across] = along(full, alone);
  const std::vector<std::size_t> index_cells = along_cells(1, sensor::Segment::Proximal);
  REQUIRE(!index_cells.empty());
  for (std::size_t c : index_cells) {
    CHECK(full_along[c] == rest_along[c]);
    CHECK(full_across[c] == free_across[c]);
    const double strain = strain_before_textile(free_along[c], free_fit, c);
    CHECK(strain > 0.05);
    CHECK(strain_before_textile(half_along[c], half_fit, c) == doctest::Approx(0.5 * strain).epsilon(1e-6));
  }
  for (std::size_t c : along_cells(1, sensor::Segment::Metacarpal)) {
    CHECK(full_along[c] == rest_along[c]);
    CHECK(free_along[c] > rest_along[c] + 1e-3);
  }
}

TEST_CASE("sim wear: past the stick angle the sheet slides off a joint's cell, half to each neighbouring joint's") {
  const Subject s = make_subjects(1, 1)[0];
  const Glove glove = make_glove(0, 1);
  WearConfig wear;
  wear.donning_shift = wear.cell_shift = wear.pre_stretch_spread = 0.0;
  wear.stick_angle = 20.0;
  const auto fit_with = [&](double share) {
    WearConfig w = wear;
    w.slide_share = share;
    core::Rng rng(3);
    return don_glove(s, glove, rng, w);
  };
  const double share = 0.5, stick = 20.0 * core::kRadiansPerDegree / s.skin.slide;
  const GloveFit stuck_fit = fit_with(0.0), sliding_fit = fit_with(share);
  const GlovePhysics stuck(s, glove, stuck_fit), sliding(s, glove, sliding_fit);
  const std::size_t pip = hand::dof_of(hand::Finger::Index, hand::Motion::MiddleFlexion);
  const auto strain = [&](const GlovePhysics& p, const GloveFit& fit, double angle, std::size_t c) {
    hand::Angles a{};
    a[pip] = angle;
    CellArray al{}, ac{};
    p.stretch(a, al, ac);
    return strain_before_textile(al[c], fit, c);
  };
  const std::vector<std::size_t> joint = along_cells(1, sensor::Segment::Middle);
  const std::vector<std::size_t> before = along_cells(1, sensor::Segment::Proximal), after = along_cells(1, sensor::Segment::Distal);
  REQUIRE(!joint.empty());
  REQUIRE(!before.empty());
  REQUIRE(!after.empty());
  const double low = stick + 0.5, high = stick + 0.9;  // well past the grip's smooth give (a tenth of the stick angle)
  for (std::size_t c : joint) {
    // Held below the stick angle; past it, the cell's strain grows by 1 - share per radian.
    CHECK(strain(sliding, sliding_fit, 0.25 * stick, c) == doctest::Approx(strain(stuck, stuck_fit, 0.25 * stick, c)).epsilon(0.01));
    const double slope_stuck = strain(stuck, stuck_fit, high, c) - strain(stuck, stuck_fit, low, c);
    const double slope_sliding = strain(sliding, sliding_fit, high, c) - strain(sliding, sliding_fit, low, c);
    CHECK(slope_stuck > 0.05);
    CHECK(slope_sliding / slope_stuck == doctest::Approx(1.0 - share).epsilon(0.005));
  }
  // What slides reaches the cells over the MCP and the DIP alike: the same length (mm) on each.
  const auto gained = [&](std::size_t c) {
    const double length = glauser2019_sites()[c].length;
    return length * (strain(sliding, sliding_fit, high, c) - strain(stuck, stuck_fit, high, c));
  };
  for (std::size_t b : before)
    for (std::size_t d : after) {
      CHECK(gained(b) > 0.5);  // mm
      CHECK(gained(d) == doctest::Approx(gained(b)).epsilon(1e-6));
    }
}

TEST_CASE("sim wear: slip and gain drift follow their processes, continuous across a donning's recordings") {
  GloveMaterial material;
  material.drift_rate = 0.01;  // 1% per sqrt(minute)
  const double slip_sd = 2.0, slip_time = 100.0;
  // Ornstein-Uhlenbeck from 0: SD slip_sd sqrt(1 - exp(-2 t / tau)); correlation exp(-lag / tau) once
  // stationary. Random walk gain: SD drift_rate sqrt(minutes). 2000 paths: the SDs' sampling error is
  // about 1.6% (the gain's 0.4%), the correlation's 0.02; the bounds are about 3 of them.
  const int paths = 2000;
  double sq_early = 0.0, sq_late = 0.0, late_lag = 0.0, gain_sq = 0.0;
  for (int k = 0; k < paths; ++k) {
    const WearDrift d(slip_sd, slip_time, material, 1000.0, 0.0, core::derive_seed(9, {static_cast<std::uint64_t>(k)}));
    sq_early += std::pow(d.slip(50.0), 2);
    sq_late += std::pow(d.slip(800.0), 2);
    late_lag += d.slip(800.0) * d.slip(900.0);
    for (std::size_t c = 0; c < kCells; ++c) gain_sq += std::pow(d.gain(c, 900.0) - 1.0, 2);
  }
  const double early_sd = std::sqrt(sq_early / paths), late_sd = std::sqrt(sq_late / paths);
  const double correlation = late_lag / sq_late, gain_sd = std::sqrt(gain_sq / (paths * kCells));
  MESSAGE("slip SD at 50 s " << early_sd << ", at 800 s " << late_sd << " mm; correlation over 100 s " << correlation << "; gain SD at 15 min "
                              << gain_sd);
  const auto near = [](double value, double expected, double relative) { return std::abs(value - expected) <= relative * std::abs(expected); };
  CHECK(near(early_sd, slip_sd * std::sqrt(1.0 - std::exp(-2.0 * 50.0 / slip_time)), 0.05));
  CHECK(near(late_sd, slip_sd, 0.05));
  CHECK(std::abs(correlation - std::exp(-1.0)) < 0.06);
  CHECK(near(gain_sd, 0.01 * std::sqrt(15.0), 0.015));
  // A recording that starts 400 s into the donning sees the donning's path from there.
  const WearDrift whole(slip_sd, slip_time, material, 1000.0, 0.0, 77), later(slip_sd, slip_time, material, 1000.0, 400.0, 77);
  for (double t : {0.0, 12.3, 250.7}) {
    CHECK(later.slip(t) == doctest::Approx(whole.slip(400.0 + t)).epsilon(1e-12));
    CHECK(later.gain(7, t) == doctest::Approx(whole.gain(7, 400.0 + t)).epsilon(1e-12));
  }
  // Warm-up: the common gain rises to 1 + warmup_gain with its time constant from the donning.
  GloveMaterial warm;
  warm.warmup_gain = 0.03;
  warm.warmup_time = 200.0;
  const WearDrift w(0.0, slip_time, warm, 1000.0, 100.0, 5);
  CHECK(w.gain(3, 100.0) == doctest::Approx(1.0 + 0.03 * (1.0 - std::exp(-1.0))));
  CHECK(w.slip(100.0) == 0.0);
  const WearDrift none;
  CHECK(none.slip(5.0) == 0.0);
  CHECK(none.gain(0, 5.0) == 1.0);

  // The corpus: the recordings of one donning follow each other, each after its calibration sequence.
  CorpusConfig config;
  config.minutes = 0.05;  // 3 s
  config.calibration_seconds = 1.0;
  std::vector<std::pair<double, double>> times;
  for (const SessionRecording& r : plan_corpus(config))
    if (r.subject == 0 && r.glove == 0) times.push_back(wear_times(config, r));
  // calibration 0, session 0, calibration 1, session 1, calibration 2, session 2 (one donning, 12 s), then two donnings of 4 s.
  const std::vector<std::pair<double, double>> expected{{0, 12}, {1, 12}, {4, 12}, {5, 12}, {8, 12}, {9, 12}, {0, 4}, {1, 4}, {0, 4}, {1, 4}};
  CHECK(times == expected);
}

TEST_CASE("sim material: a play operator's loop has its stated area, and the recorder applies it within its width") {
  // Driven between a and b the play's loop encloses 2 w (b - a - 2 w) (shoelace over one period).
  const double a = 1.0, b = 1.6, w = 0.05;
  double out = a, area = 0.0, px = a, py = a;
  for (int i = 1; i <= 4000; ++i) {
    const double x = a + (b - a) * 0.5 * (1.0 - std::cos(2.0 * 3.14159265358979323846 * i / 2000.0));
    out = play(out, x, w);
    if (i > 2000) area += px * out - x * py;  // second period: the loop is established
    px = x;
    py = out;
  }
  CHECK(std::abs(area) / 2.0 == doctest::Approx(2.0 * w * (b - a - 2.0 * w)).epsilon(1e-3));
  CHECK(play(0.5, 0.52, 0.05) == 0.5);
  CHECK(play(0.5, 0.60, 0.05) == doctest::Approx(0.55));

  // In a noise-free recording without creep, the hysteretic share moves each cell's contribution to a
  // row reading by at most share x width x C0, so a row by at most that summed over its cells; on the
  // moving hand the largest change comes close to it.
  const Subject s = make_subjects(1, 3)[0];
  const GlovePhysics p = physics_of(s);
  const MotionSequence m(s, pose_gallery(), 10.0, 4);
  RecordingConfig quiet;
  quiet.noise = ReadoutNoise{0.0, 0.0, 0.0, 0.0, 0.0, 0.0};
  quiet.raw_rows = true;
  GloveMaterial plain;
  plain.creep_share = 0.0;
  GloveMaterial hysteretic = plain;
  hysteretic.hysteresis_share = 0.5;
  hysteretic.hysteresis_width = 0.02;
  const Recording r0 = record(p, m, s.distal_radius(), 5, quiet, plain), r1 = record(p, m, s.distal_radius(), 5, quiet, hysteretic);
  const Eigen::MatrixXd matrix = sensor::TraceLayout::glauser2019().measurement_matrix();
  std::vector<double> bound(kRows, 0.0);
  for (int r = 0; r < kRows; ++r)
    for (int c = 0; c < kCells; ++c) bound[static_cast<std::size_t>(r)] += matrix(r, c) * 0.5 * 0.02 * p.glove().base_capacitance[static_cast<std::size_t>(c)];
  double worst_ratio = 0.0;
  for (int f = 0; f < r0.frames; ++f)
    for (int r = 0; r < kRows; ++r) {
      const auto i = static_cast<std::size_t>(f * kRows + r);
      worst_ratio = std::max(worst_ratio, std::abs(double(r1.raw_rows[i]) - r0.raw_rows[i]) / bound[static_cast<std::size_t>(r)]);
    }
  MESSAGE("largest hysteretic change of a row / (share x width x its cells' C0): " << worst_ratio);
  CHECK(worst_ratio <= 1.0 + 1e-4);  // float rows
  CHECK(worst_ratio > 0.5);
}

TEST_CASE("sim worlds: every effect can be switched back to the clean world's, by name") {
  const World& worn = world_named("worn");
  for (std::size_t i = 0; i < kEffectNames.size(); ++i) CHECK(effect_named(kEffectNames[i]) == static_cast<Effect>(i));
  CHECK_THROWS_WITH_AS(effect_named("gravity"), doctest::Contains("unknown effect 'gravity', expected one of tracker, donning, slip"), Error);
  World w = without(without(worn, Effect::Slip), Effect::Slip);
  CHECK(w.ablated == "slip");
  CHECK(w.wear.slip_sd == 0.0);
  CHECK(w.wear.donning_shift == worn.wear.donning_shift);
  w = without(w, Effect::Drift);
  CHECK(w.ablated == "slip,drift");
  CHECK(w.material.drift_rate == 0.0);
  CHECK(w.material.warmup_gain == 0.0);
  CHECK(w.material.hysteresis_share == worn.material.hysteresis_share);
  // Every effect off: the tracked world without its tracker, i.e. the clean world's settings.
  World all = worn;
  for (std::size_t i = 0; i < kEffectNames.size(); ++i) all = without(all, static_cast<Effect>(i));
  const World& clean = world_named("clean");
  CHECK(all.tracker.flexion_sd == clean.tracker.flexion_sd);
  CHECK(all.wear.donning_shift == clean.wear.donning_shift);
  CHECK(all.wear.cell_shift == clean.wear.cell_shift);
  CHECK(all.wear.slip_sd == clean.wear.slip_sd);
  CHECK(all.wear.loose_gain == clean.wear.loose_gain);
  CHECK(all.wear.placement_sd == clean.wear.placement_sd);
  CHECK(all.wear.size_coupling == clean.wear.size_coupling);
  CHECK(all.material.hysteresis_share == clean.material.hysteresis_share);
  CHECK(all.material.drift_rate == clean.material.drift_rate);
  CHECK(all.people.skin_spread == clean.people.skin_spread);
  CHECK(all.people.calibration_shortfall == clean.people.calibration_shortfall);
  CHECK(all.people.independent_fingers == clean.people.independent_fingers);
  // Each effect switches back exactly the parameters kEffectParameters lists: from a world with every
  // parameter at a value no world uses, the ones that change are those names, "tracker." the tracker's.
  World odd = worn;
  const auto odd_value = [](const WorldParameter& p) { return p.minimum + 0.125; };  // a value no world uses
  for (const WorldParameter& p : world_parameters()) odd = with(odd, p.name, odd_value(p));
  for (std::size_t i = 0; i < kEffectNames.size(); ++i) {
    World w = without(odd, static_cast<Effect>(i));
    std::string changed, tracker;
    for (const WorldParameter& p : world_parameters()) {
      if (p.field(w) != odd_value(p)) changed += (changed.empty() ? "" : ",") + std::string(p.name);
      if (std::string(p.name).rfind("tracker.", 0) == 0) tracker += (tracker.empty() ? "" : ",") + std::string(p.name);
    }
    CHECK_MESSAGE(changed == (std::string(kEffectParameters[i]) == "tracker." ? tracker : std::string(kEffectParameters[i])), kEffectNames[i]);
  }
}

TEST_CASE("sim worlds: every parameter can be set by name, and the settings are recorded") {
  World worn = world_named("worn");
  std::set<std::string> names;
  for (const WorldParameter& p : world_parameters()) {
    names.insert(p.name);
    const double value = p.minimum + 0.125;  // a value no world uses
    World w = with(worn, p.name, value);
    CHECK_MESSAGE(p.field(w) == value, p.name);
    char text[64];
    std::snprintf(text, sizeof text, "%.6g", value);
    CHECK(w.settings == std::string(p.name) + "=" + text);
    // Only that parameter changed: the others read as in the world it came from.
    for (const WorldParameter& q : world_parameters())
      if (std::string(q.name) != p.name) CHECK_MESSAGE(q.field(w) == q.field(worn), q.name);
  }
  CHECK(names.size() == world_parameters().size());  // unique names
  World w = with(with(worn, "people.skin_spread=0.7"), "wear.slip_sd", 2.0);
  CHECK(w.people.skin_spread == 0.7);
  CHECK(w.wear.slip_sd == 2.0);
  CHECK(w.settings == "people.skin_spread=0.7,wear.slip_sd=2");
  CHECK_THROWS_WITH_AS(with(worn, "wear.gravity", 1.0), doctest::Contains("unknown world parameter 'wear.gravity', expected one of"), Error);
  CHECK_THROWS_WITH_AS(with(worn, "wear.slip_sd", -1.0), doctest::Contains("expected a finite value >= 0"), Error);
  CHECK_THROWS_WITH_AS(with(worn, "wear.relaxed_length", 0.0), doctest::Contains("expected a finite value >= 100"), Error);
  for (const char* bad : {"wear.slip_sd", "wear.slip_sd=", "wear.slip_sd=1mm", "=1"})
    CHECK_THROWS_AS(with(worn, std::string(bad)), Error);
}

TEST_CASE("sim worlds: the fitted world is the worn world with the fitting command's settings") {
  // The command docs/simulator.md gives for the fit; the named world must be exactly it.
  World set = world_named("worn");
  for (const char* assignment : {"tracker.subject_bias_sd=5", "wear.pre_stretch_spread=0.01", "wear.size_coupling=0.5", "material.drift_rate=0.01",
                                 "people.skin_spread=0.7", "people.calibration_shortfall=0.5", "people.independent_fingers=0.4"})
    set = with(set, std::string(assignment));
  World fitted = world_named("fitted");
  for (const WorldParameter& p : world_parameters()) CHECK_MESSAGE(p.field(fitted) == p.field(set), p.name);
  // Every effect off, the fitted world is the clean one too.
  for (std::size_t i = 0; i < kEffectNames.size(); ++i) fitted = without(fitted, static_cast<Effect>(i));
  World clean = world_named("clean");
  for (const WorldParameter& p : world_parameters()) CHECK_MESSAGE(p.field(fitted) == p.field(clean), p.name);
}

TEST_CASE("sim people: the skin spread scales every person's log skin multipliers and keeps the rest") {
  PeopleConfig wide;
  wide.skin_spread = 0.7;
  const std::vector<Subject> typical = make_subjects(400, 5), spread = make_subjects(400, 5, wide);
  double sum = 0.0, sum2 = 0.0;
  long n = 0;
  for (std::size_t i = 0; i < typical.size(); ++i) {
    const SkinMechanics& a = typical[i].skin;
    const SkinMechanics& b = spread[i].skin;
    CHECK(spread[i].size.length == typical[i].size.length);
    CHECK(spread[i].style == typical[i].style);
    for (const auto& [x, y] : {std::pair{a.bend_zone, b.bend_zone}, std::pair{a.slide, b.slide}, std::pair{a.thumb_falloff, b.thumb_falloff}}) {
      // The same draws, twice as far from 1 in the log: log(y) = 2 log(x).
      CHECK(std::log(y) == doctest::Approx(2.0 * std::log(x)).epsilon(1e-12));
      sum += std::log(y);
      sum2 += std::log(y) * std::log(y);
      ++n;
    }
  }
  const double sd = std::sqrt(sum2 / n - (sum / n) * (sum / n));
  MESSAGE("log skin multiplier SD " << sd << " for a spread of 0.7 (" << n << " draws)");
  CHECK(std::abs(sd - 0.7) < 3.0 * 0.7 / std::sqrt(2.0 * n));
}

namespace {
// A person who forms every pose exactly (no style, enslaving or visit variation) moving between the
// flat hand and flat_bent, so that a motion effect can be read off the targets: 20 minutes of it.
MotionSequence plain_motion(MotionConfig config, std::uint64_t seed, std::vector<KeyPose>& gallery) {
  Subject s = make_subjects(1, 3)[0];
  s.style = {};
  s.coupling = 0.0;
  gallery.clear();
  for (const KeyPose& k : pose_gallery())
    if (k.name == "flat" || k.name == "flat_bent") gallery.push_back(k);
  REQUIRE(gallery.size() == 2);
  REQUIRE(gallery.front().name == "flat");
  config.explore = 0.0;
  config.visit_spread = 0.0;
  config.tip_spread = 0.0;
  return MotionSequence(s, gallery, 1200.0, seed, config);
}
}  // namespace

TEST_CASE("sim people: with independent fingers each finger takes a gallery pose of its own") {
  const std::size_t index = hand::dof_of(hand::Finger::Index, hand::Motion::BaseFlexion),
                    pinky = hand::dof_of(hand::Finger::Pinky, hand::Motion::BaseFlexion);
  // Which of the two poses a finger's base flexion came from, and the share of visits whose index
  // and little finger came from different poses.
  const auto mixed = [&](double independent) {
    MotionConfig c;
    c.independent = independent;
    std::vector<KeyPose> gallery;
    const MotionSequence motion = plain_motion(c, 12, gallery);
    long n = 0, differ = 0;
    for (const MotionSegment& seg : motion.segments()) {
      const auto source = [&](std::size_t d) {
        return std::abs(seg.to[d] - gallery[1].angles[d]) < std::abs(seg.to[d] - gallery[0].angles[d]) ? 1 : 0;
      };
      differ += source(index) != source(pinky) ? 1 : 0;
      ++n;
    }
    return std::pair<double, long>{static_cast<double>(differ) / static_cast<double>(n), n};
  };
  CHECK(mixed(0.0).first == 0.0);
  const auto [share, n] = mixed(0.6);  // a free visit mixes them half the time
  MESSAGE("index and little finger from different poses in " << share << " of " << n << " visits (expected 0.3)");
  REQUIRE(n > 300);
  CHECK(std::abs(share - 0.3) < 3.0 * std::sqrt(0.3 * 0.7 / static_cast<double>(n)));
}

TEST_CASE("sim people: a calibration shortfall stops each visit short of its pose by a half-normal share") {
  const std::size_t dof = hand::dof_of(hand::Finger::Middle, hand::Motion::BaseFlexion);
  // The share of the way from flat_bent back to the flat hand each visit of flat_bent stops short.
  const auto shares = [&](double shortfall) {
    MotionConfig c;
    c.shortfall = shortfall;
    std::vector<KeyPose> gallery;
    const MotionSequence motion = plain_motion(c, 11, gallery);
    const double from = gallery[1].angles[dof], to = gallery[0].angles[dof];
    REQUIRE(std::abs(from - to) > 1.0);
    std::vector<double> out;
    for (const MotionSegment& seg : motion.segments())
      if (seg.key == 1) out.push_back((seg.to[dof] - from) / (to - from));
    return out;
  };
  for (double r : shares(0.0)) CHECK(std::abs(r) < 1e-12);
  const std::vector<double> r = shares(0.1);
  double mean = 0.0;
  for (double v : r) {
    CHECK(v >= 0.0);
    CHECK(v <= 0.5);
    mean += v / static_cast<double>(r.size());
  }
  // Half-normal: mean sd sqrt(2 / pi), SD sd sqrt(1 - 2 / pi).
  constexpr double kPi = 3.14159265358979323846;
  const double expected = 0.1 * std::sqrt(2.0 / kPi), se = 0.1 * std::sqrt((1.0 - 2.0 / kPi) / static_cast<double>(r.size()));
  MESSAGE("mean shortfall " << mean << " of " << r.size() << " visits, expected " << expected);
  REQUIRE(r.size() > 300);
  CHECK(std::abs(mean - expected) < 3.0 * se);
}

TEST_CASE("sim: off the hand a removal reads the relaxed sheet, and the new donning's glove after it") {
  const Subject subject = make_subjects(1, 5, {}).front();
  const Glove glove = make_glove(0, 5);
  core::Rng rng(8);
  const GlovePhysics before(subject, glove, don_glove(subject, glove, rng));
  const GlovePhysics after(subject, glove, don_glove(subject, glove, rng));
  const MotionSequence motion(subject, pose_gallery(), 20.0, 3);
  RemovalConfig removal;
  removal.fold_sd = 0.0;
  RecordingConfig config;
  config.noise.session_gain_sd = 0.0;
  const Recording r = record_removal(before, {}, 60.0, after, {}, motion, removal, 4, config);
  REQUIRE(r.frames == static_cast<int>(std::floor(removal.seconds() * 60.0)));
  CellArray relaxed{};
  after.off_hand_capacitances(CellArray{}, relaxed);
  // After the pull and the textile's relaxation (5 creep times), the off frames hold the relaxed sheet.
  double worst = 0.0;
  long off_frames = 0;
  for (int f = 0; f < r.frames; ++f) {
    const double t = r.timestamps[static_cast<std::size_t>(f)];
    for (std::size_t d = 0; d < hand::kDofCount; ++d) CHECK(std::isnan(r.angles[static_cast<std::size_t>(f) * hand::kDofCount + d]));
    if (t < removal.doff_seconds + 5.0 * kCreepTime || t > removal.doff_seconds + removal.off_seconds) continue;
    ++off_frames;
    for (std::size_t c = 0; c < kCells; ++c) worst = std::max(worst, std::abs(r.cells[static_cast<std::size_t>(f) * kCells + c] - relaxed[c]));
  }
  CHECK(off_frames > 200);
  CHECK(worst < 0.5);  // pF: the readout's noise through the solve (0.3 pF per row)
  // The last frames are the new donning's glove in the hand's pose.
  CellArray worn{};
  after.capacitances(motion.at(r.timestamps.back()), worn);
  double last = 0.0;
  for (std::size_t c = 0; c < kCells; ++c)
    last = std::max(last, std::abs(r.cells[(static_cast<std::size_t>(r.frames) - 1) * kCells + c] - worn[c]) / worn[c]);
  CHECK(last < 0.2);  // within the textile's lag (kCreepShare of a reading follows with a 1 s lag)
  removal.doff_seconds = 0.0;
  CHECK_THROWS_AS(record_removal(before, {}, 60.0, after, {}, motion, removal, 4, config), Error);
}

TEST_CASE("sim: a corpus with removals records one before each later donning, its frames carry no pose and validate") {
  CorpusConfig config = CorpusConfig::one_session(11, 20.0, 0.0);
  config.sessions = 3;
  config.intra_sessions = 1;
  config.removal.emplace();
  config.removal->off_seconds = 4.0;
  const std::vector<SessionRecording> corpus = simulate_corpus(config);
  int removals = 0;
  for (const SessionRecording& r : corpus)
    if (r.kind == RecordingKind::Removal) {
      ++removals;
      CHECK(r.donning == r.session);
      CHECK(r.recording.frames == static_cast<int>(std::floor(config.removal->seconds() * 60.0)));
    }
  CHECK(removals == 2);  // before sessions 1 and 2
  const io::Dataset data = to_dataset(corpus, config);
  data.validate();
  std::map<int, std::pair<double, double>> clock;  // per session: removal's last time, the session's first
  for (std::size_t i = 0; i < data.frames(); ++i) {
    if (data.kind[i] == io::kKindRemoval) clock[data.session[i]].first = data.timestamps[i];
    if (data.kind[i] == io::kKindRecording && clock[data.session[i]].second == 0.0) clock[data.session[i]].second = data.timestamps[i];
  }
  CHECK(clock[1].second > clock[1].first);  // the session continues the removal's clock
  CHECK(clock[1].second - clock[1].first < 0.02);
  // The dataset refuses a removal frame with a pose, and kinds beyond 2.
  io::Dataset bad = data;
  std::size_t removal_frame = 0;
  while (bad.kind[removal_frame] != io::kKindRemoval) ++removal_frame;
  bad.true_angles[removal_frame * hand::kDofCount] = 0.1f;
  CHECK_THROWS_WITH_AS(bad.validate(), doctest::Contains("a removal frame has no pose"), Error);
  bad = data;
  bad.kind[0] = 3;
  CHECK_THROWS_WITH_AS(bad.validate(), doctest::Contains("2 (removal)"), Error);
}
