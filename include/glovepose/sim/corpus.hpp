/// @file corpus.hpp
/// @brief The paper's capture protocol as a synthetic corpus (Sec. 5.1): each subject records five
/// sessions of five minutes with the first glove, the glove kept on through the first three
/// ("intra-session") and taken off and on again before each of the other two ("inter-session"),
/// every session preceded by a short calibration sequence of extreme poses; a second glove ("Glove
/// II", Table 3) is recorded in sessions of its own, each with a fresh donning. With
/// CorpusConfig::removal, taking a glove off and putting it on again is recorded too, before each
/// donning of a glove worn before.
///
/// Every session is an independent job whose random streams derive from (seed, subject, glove,
/// session): the corpus is identical for any number of threads.
#pragma once

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <optional>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "../core/units.hpp"
#include "../calibration/sequence.hpp"
#include "../config.hpp"
#include "../core/thread_pool.hpp"
#include "glove.hpp"
#include "motion.hpp"
#include "pose_gallery.hpp"
#include "recorder.hpp"
#include "subject.hpp"
#include "tracker.hpp"
#include "world.hpp"

namespace glovepose::sim {

/// @brief What to simulate. Defaults: the paper's protocol.
struct CorpusConfig {
  std::uint64_t seed = 1;             ///< Everything derives from it.
  int subjects = 10;                  ///< Paper: 10 people.
  int sessions = 5;                   ///< Per subject with the first glove (paper: 5).
  int intra_sessions = 3;             ///< Of those, recorded without taking the glove off (paper: 3).
  double minutes = 5.0;               ///< Per session (paper: about 5).
  int gloves = 2;                     ///< Gloves simulated; gloves after the first record `other_glove_sessions`.
  int other_glove_sessions = 2;       ///< Sessions per subject with each further glove.
  double calibration_seconds = 30.0;  ///< Calibration sequence before every session (0: none).
  /// When set, every calibration sequence follows these steps (a guided calibration, its own
  /// length) instead of visiting the extreme poses in random order for calibration_seconds.
  std::optional<calibration::Sequence> guided_calibration;
  int threads = 0;              ///< 0: all hardware threads.
  RecordingConfig recording{};  ///< Readout settings (raw rows, noise).
  World world = worlds().front();  ///< The world: clean unless set (the tools start from default_world()).
  /// The hand the glove is worn on: a left hand is the right one mirrored, wearing the right glove's
  /// sheet turned over (the same cells at the mirrored places).
  hand::Handedness handedness = hand::Handedness::Right;
  /// When set, each donning of a glove after its first is preceded by a removal recording
  /// (RecordingKind::Removal): the glove taken off the donning before, lying off the hand, put on.
  std::optional<RemovalConfig> removal;

  /// @brief One person, one glove, one session of `seconds` after a `calibration_seconds`
  /// calibration sequence, on one thread: the simulated user of tests, benchmarks and examples.
  static CorpusConfig one_session(std::uint64_t seed, double seconds, double calibration_seconds) {
    CorpusConfig c;
    c.seed = seed;
    c.subjects = c.sessions = c.gloves = 1;
    c.minutes = seconds / 60.0;
    c.calibration_seconds = calibration_seconds;
    c.threads = 1;
    return c;
  }

  /// @brief Throws glovepose::Error naming the first setting out of range.
  void validate() const {
    const auto need = [](bool ok, const std::string& what) {
      if (!ok) throw Error("simulate: " + what);
    };
    need(subjects >= 1, "--subjects " + std::to_string(subjects) + ", expected at least 1");
    need(sessions >= 1, "--sessions " + std::to_string(sessions) + ", expected at least 1");
    need(intra_sessions >= 1, "intra sessions " + std::to_string(intra_sessions) + ", expected at least 1");
    need(minutes > 0.0 && minutes <= 600.0, "--minutes " + std::to_string(minutes) + ", expected 0 < minutes <= 600");
    need(gloves >= 1 && gloves <= 16, "--gloves " + std::to_string(gloves) + ", expected 1..16");
    need(other_glove_sessions >= 0, "sessions with other gloves " + std::to_string(other_glove_sessions) + ", expected >= 0");
    need(calibration_seconds >= 0.0, "calibration seconds " + std::to_string(calibration_seconds) + ", expected >= 0");
    if (removal) removal->validate();
  }
};

/// @brief Recording kinds: a session, its calibration sequence, a removal before a donning.
enum class RecordingKind : std::uint8_t { Session = 0, Calibration = 1, Removal = 2 };

/// @brief One recorded sequence and who, with which glove and donning, recorded it.
struct SessionRecording {
  int subject = 0;                              ///< Subject id.
  int glove = 0;                                ///< Glove id.
  int session = 0;                              ///< Session index within (subject, glove).
  int donning = 0;                              ///< Index of the donning within (subject, glove): sessions kept on share it.
  RecordingKind kind = RecordingKind::Session;  ///< Session, its calibration sequence or the removal before its donning.
  Recording recording;                          ///< The frames.
};

/// @brief The poses a calibration sequence goes through: the extremes of every cell ("freely
/// explore different extreme poses", paper Sec. 4.3).
inline std::vector<KeyPose> calibration_gallery(const std::vector<KeyPose>& gallery) {
  const char* names[] = {"flat", "spread", "fist", "claw", "thumbs_up", "wave", "flat_bent", "pinch_index", "pinch_pinky", "point"};
  std::vector<KeyPose> out;
  for (const char* n : names)
    for (const KeyPose& k : gallery)
      if (k.name == n) out.push_back(k);
  return out;
}

/// @brief The guided calibration sequence the simulated corpus and the shipped files use
/// (models/calibration_glauser2019.json is its to_json()): the ten extreme poses of
/// calibration_gallery(), 3 s each, the first one pressed flat on a table, which pins the flexions
/// of the four long fingers at 0 (a person holds them within about 2 degrees; assumption: the
/// table stops the fingers, the slight hyperextension a relaxed hand shows on a table is left out).
inline calibration::Sequence guided_calibration_sequence(const std::vector<KeyPose>& gallery) {
  struct Text {
    const char* name;
    const char* instruction;
  };
  const Text texts[] = {
      {"flat", "Lay your hand flat on a table, palm down, fingers straight and together, and press it gently down."},
      {"spread", "Lift your hand and spread all fingers as wide as you can."},
      {"fist", "Make a tight fist, thumb across the fingers."},
      {"claw", "Bend the end joints of your fingers into a claw, knuckles straight."},
      {"thumbs_up", "Thumbs up: fist with the thumb pointing up."},
      {"wave", "Open your hand and bend all fingers back as far as is comfortable."},
      {"flat_bent", "Bend the fingers at the knuckles only, keeping them straight, like a flat plate."},
      {"pinch_index", "Pinch: touch your thumb tip to your index fingertip."},
      {"pinch_pinky", "Touch your thumb tip to your little fingertip."},
      {"point", "Point with your index finger, the other fingers curled."},
  };
  std::vector<calibration::Step> steps;
  for (const Text& t : texts)
    for (const KeyPose& k : gallery)
      if (k.name == t.name) {
        calibration::Step s;
        s.name = k.name == "flat" ? "flat_on_table" : k.name;
        s.instruction = t.instruction;
        s.seconds = 3.0;
        s.pose = k.angles;
        if (k.name == "flat") {
          for (int f = 1; f <= 4; ++f)
            for (hand::Motion m : {hand::Motion::BaseFlexion, hand::Motion::MiddleFlexion, hand::Motion::TipFlexion}) {
              const std::size_t d = hand::dof_of(static_cast<hand::Finger>(f), m);
              s.pose[d] = 0.0;
              s.pinned[d] = true;
            }
          s.pinned_sd = 2.0 * core::kRadiansPerDegree;
        }
        steps.push_back(s);
      }
  return calibration::Sequence("glauser2019-guided", std::move(steps), 1.8);
}

/// @brief The sessions of the protocol in a fixed order: subject, glove, session; each session's
/// calibration sequence just before it, and before that the removal that starts its donning (when
/// the glove was worn before and CorpusConfig::removal is set).
inline std::vector<SessionRecording> plan_corpus(const CorpusConfig& config) {
  config.validate();
  std::vector<SessionRecording> plan;
  for (int s = 0; s < config.subjects; ++s)
    for (int g = 0; g < config.gloves; ++g) {
      const int sessions = g == 0 ? config.sessions : config.other_glove_sessions;
      for (int k = 0; k < sessions; ++k) {
        SessionRecording r;
        r.subject = s;
        r.glove = g;
        r.session = k;
        // First glove: sessions 0..intra-1 share donning 0; each later session is a new donning.
        r.donning = g == 0 ? std::max(0, k - config.intra_sessions + 1) : k;
        const bool new_donning = g == 0 ? k >= config.intra_sessions : k > 0;
        if (config.removal && new_donning) {
          SessionRecording off = r;
          off.kind = RecordingKind::Removal;
          plan.push_back(off);
        }
        if (config.calibration_seconds > 0.0) {
          SessionRecording c = r;
          c.kind = RecordingKind::Calibration;
          plan.push_back(c);
        }
        plan.push_back(r);
      }
    }
  return plan;
}

/// @brief Everything the corpus is made of that does not depend on the session.
struct CorpusWorld {
  std::vector<Subject> subjects;  ///< By subject id.
  std::vector<Glove> gloves;      ///< By glove id.
  std::vector<KeyPose> gallery;   ///< The pose gallery of the sessions.
  std::vector<KeyPose> extremes;  ///< The poses of the calibration sequences.

  /// @brief The subjects, gloves and galleries of `config`.
  explicit CorpusWorld(const CorpusConfig& config)
      : subjects(make_subjects(config.subjects, config.seed, config.world.people)), gallery(pose_gallery()), extremes(calibration_gallery(gallery)) {
    for (int g = 0; g < config.gloves; ++g) gloves.push_back(make_glove(g, config.seed, config.world.wear.placement_sd));
  }
};

/// @brief One planned recording made ready to run: the physics of its donning, its motion, the seed
/// of its readout noise.
struct SessionSetup {
  GlovePhysics physics;      ///< The glove on the hand in this donning.
  MotionSequence motion;     ///< What the hand does.
  std::uint64_t noise_seed;  ///< Seed of the readout's noise and glitches.
  WearDrift drift;           ///< The donning's slip and gain drift, from this recording's start.

  /// @brief The recording: the world's glove material, this donning's drift, `config`'s readout.
  Recording record(const std::array<double, 16>& radii, const CorpusConfig& corpus, const RecordingConfig& config) const {
    return sim::record(physics, motion, radii, noise_seed, config, corpus.world.material, drift);
  }
};

/// @brief How `subject` wears `glove` in its donning `donning`: the same for every recording that
/// shares the donning.
inline GloveFit donning_fit(const CorpusConfig& config, const Subject& subject, const Glove& glove, int donning) {
  core::Rng rng(core::derive_seed(
      config.seed, {3, static_cast<std::uint64_t>(subject.id), static_cast<std::uint64_t>(glove.id), static_cast<std::uint64_t>(donning)}));
  return don_glove(subject, glove, rng, config.world.wear);
}

/// @brief Seconds of one calibration sequence.
inline double calibration_length(const CorpusConfig& config) {
  if (config.calibration_seconds <= 0.0) return 0.0;  // no calibration sequences are recorded
  return config.guided_calibration ? config.guided_calibration->total_seconds() : config.calibration_seconds;
}

/// @brief The slip and gain path of `subject`'s donning `donning` of glove `glove`, `seconds` long,
/// from `start` seconds after the donning: one path for every recording of the donning.
inline WearDrift donning_drift(const CorpusConfig& config, const Subject& subject, int glove, int donning, double seconds, double start) {
  return WearDrift(config.world.wear.slip_sd * loose_fit_factor(subject, config.world.wear), config.world.wear.slip_time,
                   config.world.material, seconds, start,
                   core::derive_seed(config.seed, {9, static_cast<std::uint64_t>(subject.id), static_cast<std::uint64_t>(glove),
                                                   static_cast<std::uint64_t>(donning)}));
}

/// @brief When a planned recording starts (s after its donning) and how long its donning is worn
/// (s): the sessions of a donning follow each other, each after its calibration sequence.
inline std::pair<double, double> wear_times(const CorpusConfig& config, const SessionRecording& job) {
  const double calibration = calibration_length(config), session = config.minutes * 60.0;
  const int first = job.glove == 0 ? (job.donning == 0 ? 0 : config.intra_sessions - 1 + job.donning) : job.donning;
  const int sessions = job.glove == 0 && job.donning == 0 ? std::min(config.intra_sessions, config.sessions) : 1;
  const double start = (job.session - first) * (calibration + session) + (job.kind == RecordingKind::Session ? calibration : 0.0);
  return {start, sessions * (calibration + session)};
}

/// @brief The setup of a planned recording; depends only on (seed, subject, glove, donning/session).
inline SessionSetup setup_session(const CorpusConfig& config, const CorpusWorld& world, const SessionRecording& job) {
  const Subject& subject = world.subjects[static_cast<std::size_t>(job.subject)];
  const auto id = [&](std::uint64_t purpose, int index) {
    return core::derive_seed(config.seed, {purpose, static_cast<std::uint64_t>(job.subject), static_cast<std::uint64_t>(job.glove),
                                           static_cast<std::uint64_t>(index)});
  };
  const Glove& glove = world.gloves[static_cast<std::size_t>(job.glove)];
  const GloveFit fit = donning_fit(config, subject, glove, job.donning);
  const auto [start, worn] = wear_times(config, job);
  WearDrift drift = donning_drift(config, subject, job.glove, job.donning, worn + 1.0, start);
  const bool calibration = job.kind == RecordingKind::Calibration;
  MotionConfig motion_config;
  motion_config.independent = config.world.people.independent_fingers;
  if (calibration) {  // quick, wide movements between extremes, no blends
    motion_config.explore = 0.0;
    motion_config.independent = 0.0;
    motion_config.pace = 1.5;
    motion_config.dwell = 0.5;
    motion_config.shortfall = config.world.people.calibration_shortfall;
  }
  const double seconds = calibration ? config.calibration_seconds : config.minutes * 60.0;
  const int stream = 2 * job.session + (calibration ? 1 : 0);
  GlovePhysics physics(subject, glove, fit, config.handedness);
  if (calibration && config.guided_calibration)
    return SessionSetup{std::move(physics), MotionSequence(subject, *config.guided_calibration, id(4, stream), motion_config),
                        id(5, stream), std::move(drift)};
  return SessionSetup{std::move(physics),
                      MotionSequence(subject, calibration ? world.extremes : world.gallery, seconds, id(4, stream), motion_config),
                      id(5, stream), std::move(drift)};
}

/// @brief The reference tracker's streams for a planned recording: the person's (every glove and
/// session), the session's (shared by a session and its calibration sequence) and the recording's.
inline TrackerSeeds tracker_seeds(const CorpusConfig& config, const SessionRecording& job) {
  const auto subject = static_cast<std::uint64_t>(job.subject), glove = static_cast<std::uint64_t>(job.glove);
  const auto session = static_cast<std::uint64_t>(job.session);
  return TrackerSeeds{core::derive_seed(config.seed, {7, subject}), core::derive_seed(config.seed, {8, subject, glove, session}),
                      core::derive_seed(config.seed, {6, subject, glove, 2 * session + (job.kind == RecordingKind::Calibration ? 1 : 0)})};
}

/// @brief Records a removal job: the glove taken off its donning before (worn to the end of that
/// donning's sessions, on that donning's drift path) and put on into the job's donning (whose path
/// starts at the end of the removal). Its streams derive from (seed, subject, glove, session).
inline Recording record_removal_job(const CorpusConfig& config, const CorpusWorld& world, const SessionRecording& job,
                                    const RecordingConfig& recording) {
  if (!config.removal || job.donning < 1) throw Error("record_removal_job: a removal job without a donning before it or a RemovalConfig");
  const Subject& subject = world.subjects[static_cast<std::size_t>(job.subject)];
  const Glove& glove = world.gloves[static_cast<std::size_t>(job.glove)];
  const auto id = [&](std::uint64_t purpose, int index) {
    return core::derive_seed(config.seed, {purpose, static_cast<std::uint64_t>(job.subject), static_cast<std::uint64_t>(job.glove),
                                           static_cast<std::uint64_t>(index)});
  };
  const RemovalConfig& removal = *config.removal;
  SessionRecording before = job;
  before.donning = job.donning - 1;
  const double before_worn = wear_times(config, before).second;  // the donning's length: its sessions and their calibrations
  const GlovePhysics off(subject, glove, donning_fit(config, subject, glove, before.donning), config.handedness);
  const GlovePhysics on(subject, glove, donning_fit(config, subject, glove, job.donning), config.handedness);
  MotionConfig motion_config;
  motion_config.independent = config.world.people.independent_fingers;
  const MotionSequence motion(subject, world.gallery, removal.seconds() + 1.0, id(10, job.session), motion_config);
  return record_removal(off, donning_drift(config, subject, job.glove, before.donning, before_worn + removal.seconds() + 1.0, 0.0),
                        before_worn, on, donning_drift(config, subject, job.glove, job.donning, 1.0, 0.0), motion, removal,
                        id(11, job.session), recording, config.world.material);
}

/// @brief Simulates the corpus. Deterministic in config.seed for any thread count.
inline std::vector<SessionRecording> simulate_corpus(const CorpusConfig& config) {
  std::vector<SessionRecording> plan = plan_corpus(config);
  const CorpusWorld world(config);
  const auto run = [&](SessionRecording& job) {
    RecordingConfig recording = config.recording;
    if (job.kind != RecordingKind::Session) recording.tears.clear();  // a glove tears mid-session, after its calibration
    if (job.kind == RecordingKind::Removal) {  // no pose to label
      job.recording = record_removal_job(config, world, job, recording);
      return;
    }
    const SessionSetup setup = setup_session(config, world, job);
    const Subject& subject = world.subjects[static_cast<std::size_t>(job.subject)];
    const std::array<double, 16> radii = subject.distal_radius();
    job.recording = setup.record(radii, config, recording);
    label_recording(job.recording, setup.motion, setup.physics.kinematics(), radii, config.world.tracker, tracker_seeds(config, job),
                    subject.length_scale());
  };

  const unsigned hardware = std::max(1u, std::thread::hardware_concurrency());
  const unsigned threads =
      std::min<unsigned>(config.threads > 0 ? static_cast<unsigned>(config.threads) : hardware, static_cast<unsigned>(plan.size()));
  std::atomic<std::size_t> next{0};
  core::ThreadPool pool(static_cast<int>(std::max(1u, threads)));
  pool.run([&](int) {
    try {
      for (std::size_t i = next++; i < plan.size(); i = next++) run(plan[i]);
    } catch (...) {  // the others stop taking sessions; the pool hands the first failure to the caller
      next = plan.size();
      throw;
    }
  });
  return plan;
}

}  // namespace glovepose::sim
