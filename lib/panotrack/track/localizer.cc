#include "panotrack/track/localizer.h"

#include <algorithm>
#include <cmath>
#include <exception>
#include <iterator>
#include <limits>
#include <numeric>
#include <optional>
#include <utility>

#include <Eigen/Eigenvalues>
#include <Eigen/LU>

#include "panotrack/core/angles.h"
#include "panotrack/core/error.h"
#include "panotrack/core/parallel.h"
#include "panotrack/track/map_symmetry.h"

namespace pano {

const char* TrackingMethodName(TrackingMethod m) {
  return m == TrackingMethod::kJunction ? "junction" : "vertex";
}

void LocalizerOptions::Check() const {
  prediction.Check();
  junction.Check();
  vertex.Check();
  triangulation.Check();
  if (!(search_px > 0) || !(refine_search_px > 0) || !(max_search_px >= search_px))
    throw Error("localiser: search widths must be positive (and max_search_px >= search_px)");
  if (max_landmarks != 0 && max_landmarks < 3) throw Error("localiser: max_landmarks: expected 0 or >= 3");
  if (max_landmarks_uncertain_map != 0 && max_landmarks_uncertain_map < 3)
    throw Error("localiser: max_landmarks_uncertain_map: expected 0 or >= 3");
  if (!std::isnan(survey_sigma) && !(survey_sigma >= 0.0 && std::isfinite(survey_sigma)))
    throw Error("localiser: survey_sigma: expected a length >= 0 (NaN: the map's)");
  if (!(alert_limit >= 0.0) || !std::isfinite(alert_limit))
    throw Error("localiser: alert_limit: expected a length >= 0 (0: automatic)");
  survey.Check();
  if (refine_passes < 0 || refine_passes > 5) throw Error("localiser: refine_passes: expected 0..5");
  if (!(refine_threshold_px >= 0.0)) throw Error("localiser: refine_threshold_px: expected >= 0");
  if (!(coarse_to_fine_rate >= 0.0)) throw Error("localiser: coarse_to_fine_rate: expected >= 0");
  if (noise_pairs < 0) throw Error("localiser: noise_pairs: expected >= 0");
  if (coarse_landmarks != 0 && coarse_landmarks < 3)
    throw Error("localiser: coarse_landmarks: expected 0 or >= 3");
  if (!(exposure_fraction >= 0.0 && exposure_fraction <= 1.0))
    throw Error("localiser: exposure_fraction: expected 0..1");
  if (!(unknown_turn_per_frame >= 0.0 && unknown_turn_per_frame < M_PI))
    throw Error("localiser: unknown_turn_per_frame: expected 0..pi radians");
  if (!(compass_first_turn >= 0.0)) throw Error("localiser: compass_first_turn: expected >= 0 radians");
  if (!(lost_search_growth >= 1.0)) throw Error("localiser: lost_search_growth: expected >= 1");
  if (min_spare_bearings_with_outliers < 0)
    throw Error("localiser: min_spare_bearings_with_outliers >= 0 expected");
  if (relocalize_after < 0 || relocalize_min_landmarks < 3)
    throw Error("localiser: relocalize_after >= 0 and relocalize_min_landmarks >= 3 expected");
  if (relocalize_retrack_passes < 0) throw Error("localiser: relocalize_retrack_passes: expected >= 0");
  if (num_threads < 0) throw Error("localiser: num_threads: expected 0 (all cores) or more");
  if (search_threads < 0) throw Error("localiser: search_threads: expected 0 (num_threads) or more");
  if (!(relocalize_unseen_fraction >= 0 && relocalize_unseen_fraction <= 1))
    throw Error("localiser: relocalize_unseen_fraction: expected 0..1");
  if (relocalize_max_interval < 1) throw Error("localiser: relocalize_max_interval: expected >= 1");
  if (relocalize_eager_searches < 0) throw Error("localiser: relocalize_eager_searches: expected >= 0");
  if (relocalize_untracked_hypotheses < 0) throw Error("localiser: relocalize_untracked_hypotheses: expected >= 0");
  if (!(gate_chi2 > 0) || !(gate_heading_sigma > 0) || !(gate_position_fraction > 0))
    throw Error("localiser: gate_chi2, gate_heading_sigma and gate_position_fraction: expected > 0");
  if (!(min_quality >= 0.0 && min_quality < 1.0)) throw Error("localiser: min_quality: expected 0..1");
  if (!(protection_sigmas > 0.0) || !(alert_fraction >= 0.0))
    throw Error("localiser: protection_sigmas: expected > 0, alert_fraction: expected >= 0");
  if (!(alert_survey_factor >= 0.0) || !std::isfinite(alert_survey_factor))
    throw Error("localiser: alert_survey_factor: expected >= 0");
  if (!(integrity_confidence > 0.5 && integrity_confidence < 1.0))
    throw Error("localiser: integrity_confidence: expected 0.5..1");
  if (!(min_bearing_sigma > 0) || !(initial_bearing_sigma > 0) || !(max_bearing_sigma >= min_bearing_sigma))
    throw Error("localiser: min_bearing_sigma and initial_bearing_sigma: expected > 0");
  if (!(relocalize_confirmed_fraction >= 0))
    throw Error("localiser: relocalize_confirmed_fraction: expected >= 0 (above 1: every pose confirmed first)");
  if (!(relocalize_jump_fraction >= 0 && relocalize_jump_fraction <= 1))
    throw Error("localiser: relocalize_jump_fraction: expected in [0, 1]");
  if (!(relocalize_min_fraction >= 0 && relocalize_min_fraction <= 1) || relocalize_margin < 0 ||
      !(relocalize_distinct > 0) || !(relocalize_symmetry_tolerance >= 0) ||
      !(relocalize_ambiguity > 0 && relocalize_ambiguity <= 1))
    throw Error("localiser: relocalize_min_fraction 0..1, relocalize_margin >= 0, relocalize_distinct > 0, "
                "relocalize_symmetry_tolerance >= 0, relocalize_ambiguity in (0, 1] expected");
  if (relocalize_rival_searches < 0 || !(relocalize_rival_fit >= 1.0) || !std::isfinite(relocalize_rival_fit))
    throw Error("localiser: relocalize_rival_searches: expected >= 0, relocalize_rival_fit: expected >= 1");
  if (relocalize_sparse_frames < 0 || !(relocalize_sparse_lead >= 1.0) || !std::isfinite(relocalize_sparse_lead))
    throw Error("localiser: relocalize_sparse_frames: expected >= 0, relocalize_sparse_lead: expected >= 1");
  if (polarity_learn_frames < 1 || polarity_forget_misses < 1 || polarity_max_flips < 0)
    throw Error("localiser: polarity_learn_frames and polarity_forget_misses: expected >= 1, "
                "polarity_max_flips: expected >= 0");
  relocalize.Check();
  robust.Check();
  motion.Check();
}


namespace {

// The image noise a reported covariance holds, in units of the recent
// noise (ReportedCovariance).
constexpr double kReportedNoiseMargin = 1.5;
// A pose is reported fused with the motion model's prediction at its own
// covariance only after this many updates in a row whose time was not in
// doubt (FuseReportWithMotion): the velocity after a frame that may follow
// a dropped one is off for a frame or two.
constexpr int kSteadyUpdatesBeforeFusing = 2;
// The survey-error probe's choice: the smallest level whose bearings agree
// with at least this fraction of the inliers of the level most agree under.
constexpr double kProbeSaturation = 0.9;
// A provisional survey sigma more than this many times the map's
// statement (or the unstated default) contradicts it: the statement is
// tried again on the next tracked frames (RetrackUnderStatedSurvey). Up
// to it, a map measured a little worse than stated.
constexpr double kStatementDoubt = 3.0;
// The statement stands again after this many tracked frames in a row agree
// under it, on poses within the first of these many of their combined
// standard deviations of the pose under the error learned
// (AgreesUnderStatement); a frame held after a search is measured under the
// statement where the frame confirming it agrees within the second.
constexpr int kStatementFrames = 2;
constexpr double kStatementApart = 1.0;
constexpr double kStatementHoldApart = 2.0;
// After a frame that does not agree, the next try waits twice as long as the
// last, at most this many frames.
constexpr int kStatementCheckMaxGap = 32;
// The survey errors, as fractions of the typical landmark distance, that
// the search for a first pose tries where it verified nothing under the one
// assumed (LocalizerOptions::relocalize_survey_probe).
constexpr double kSearchProbeFractions[] = {0.005, 0.01, 0.02};
// The survey error one frame's residuals show scatters about the map's by
// up to about twice it (measured: 4.2 cm on a map stated and measured to
// 2 cm); a held pose's confirming frame may show this many times the error
// the pose was found under (HeldSurveyBound).
constexpr double kHeldSurveyScatter = 3.0;
// A pose fits clearly better than another (FitsClearlyBetter) where the
// other's RMS residual is this many times its own, both fitting at least
// kFitComparedBearings. Two fits under the same noise differ so much in
// variance (a ratio of 9, F-distributed) with a chance of 1.5 % at 8
// bearings each, 0.09 % at 13 and 0.002 % at 20; a twin about as well
// supported fits 20 or so.
constexpr double kClearlyBetterFit = 3.0;
constexpr int kFitComparedBearings = 13;
// Bearings that pulled the pose (DropPulledBearings) left out of one
// frame at most: a person or two in front of edges.
constexpr int kMaxPulledBearings = 2;
// ... tested at this false-alarm rate per bearing (Baarda's 0.001: 3.29
// standard deviations); a false alarm costs the frame one bearing.
constexpr double kPulledBearingAlpha = 0.001;

// The landmarks a frame's measurement found, chosen or not.
int FoundLandmarks(const FrameResult& fr) {
  int found = 0;
  for (const LandmarkMeasurement& m : fr.measurements) found += m.found;
  return found;
}

// What Measure wrote into `from` (the landmarks measured, the polarities
// they were measured with, and the partners with the flag that asked for
// them), moved into `to`.
void TakeMeasurements(FrameResult* from, FrameResult* to) {
  to->either_polarity = from->either_polarity;
  to->predicted = std::move(from->predicted);
  to->measurements = std::move(from->measurements);
  to->with_partners = from->with_partners;
  to->from_prediction = from->from_prediction;
  to->partners = std::move(from->partners);
  to->partner_measurements = std::move(from->partner_measurements);
}

// A frame to be measured again from scratch: its row and prediction kept.
FrameResult FrameToMeasure(const PoseRow& row, const Pose2& predicted) {
  FrameResult fr;
  fr.row = row;
  fr.predicted_pose = predicted;
  return fr;
}

// The landmarks of coarse-to-fine's first pass (0: all in view), of
// `max_landmarks` tracked in full.
int CoarseLandmarks(const LocalizerOptions& options, int max_landmarks) {
  if (options.coarse_landmarks == 0) return max_landmarks;
  return max_landmarks == 0 ? options.coarse_landmarks : std::min(options.coarse_landmarks, max_landmarks);
}

// A search's hypotheses (and the relocalisation index) leave out the
// horizontal edges whose lines pass within this many mirror distances
// (PredictionOptions::min_line_distance_mirrors): a hypothesis a grid step
// off predicts those strongly curved edges far from where they are.
constexpr double kSearchLineDistanceMirrors = 2.0;

PredictionOptions SearchPrediction(PredictionOptions o) {
  o.min_line_distance_mirrors = std::max(o.min_line_distance_mirrors, kSearchLineDistanceMirrors);
  return o;
}

}  // namespace

int SearchThreadCount(const LocalizerOptions& options) {
  return ThreadCount(options.search_threads > 0 ? options.search_threads : options.num_threads);
}

std::shared_ptr<PhTableCache> MakeTrackingPhTables(std::shared_ptr<const RadiusTable> table,
                                                   int num_threads) {
  // 0.5 px x 0.5 degree nodes: within 0.006 px of the exact PH, and quick
  // to build (under a millisecond per edge height) for short clips.
  PhTableOptions o;
  o.r_step = 0.5;
  o.dtheta_step = 0.5 * M_PI / 180;
  o.num_threads = num_threads;
  return std::make_shared<PhTableCache>(std::move(table), o);
}

std::unique_ptr<LandmarkTracker> MakeTracker(TrackingMethod method, const Sensor& sensor,
                                             std::shared_ptr<const RadiusTable> table,
                                             const LocalizerOptions& options,
                                             std::shared_ptr<PhTableCache> ph_tables) {
  if (method == TrackingMethod::kVertex) return std::make_unique<VertexTracker>(sensor, options.vertex);
  if (!ph_tables) ph_tables = MakeTrackingPhTables(table, options.num_threads);
  return std::make_unique<JunctionTracker>(sensor, ph_tables, options.junction);
}

Localizer::Localizer(const Calibration& calib, const Map& map,
                     std::shared_ptr<const RadiusTable> table, const LocalizerOptions& options,
                     std::shared_ptr<PhTableCache> ph_tables)
    : calib_(calib), map_(map), scene_(Scene::FromMap(map, /*with_distractors=*/false)),
      table_(std::move(table)), opt_(options), landmarks_(LandmarksFromMap(map)),
      compass_(calib.sensor) {
  opt_.Check();
  if (!table_ || table_->empty()) throw Error("localiser: no E(D,Z) lookup table");
  if (!calib_.sensor.aligned()) {
    // A real rig's faults: track in the aligned view of its frames.
    const double typical = TypicalLandmarkDistance(map_);
    view_.emplace(calib_.sensor, typical > 0 ? typical : 20 * calib_.sensor.params.curvature_radius,
                  /*grid_step_px=*/2, opt_.num_threads);
    calib_.sensor = view_->view_sensor();
    compass_ = AzimuthCompass(calib_.sensor);
  }
  const double typical = TypicalLandmarkDistance(map_);
  errors_.typical_distance = typical > 0 ? typical : 1.0;
  errors_.survey = SurveyErrorEstimate(opt_.survey, errors_.typical_distance);
  {
    Eigen::Vector2d lo, hi;
    double top;
    map_.Extent(&lo, &hi, &top);
    errors_.room_size = (hi - lo).maxCoeff();
  }
  UpdateLandmarkBudget();
  errors_.index_prediction = SearchPrediction(errors_.prediction);
  motion_options_ = opt_.motion.Scaled(map_.UnitsPerMetre());
  motion_ = MotionModel(motion_options_);
  tracker_ = MakeTracker(opt_.method, calib_.sensor, table_, opt_, std::move(ph_tables));
  for (const Landmark& l : landmarks_) shades_.any_known = shades_.any_known || !std::isnan(l.shade);
}

void Localizer::Reset(const Pose2& robot_initial, bool hint) {
  const Pose2 initial = view_ ? view_->ViewPose(robot_initial) : robot_initial;
  track_.initial = track_.last = initial;
  track_.frame_motion = Pose2{0, 0, 0};
  images_.blur_fraction = opt_.exposure_fraction;
  images_.recentre_rate = 0.0;
  track_.n_good = 0;
  track_.n_lost = 0;
  track_.started = true;
  track_.known_start = true;
  track_.start_is_hint = hint;
  track_.ever_tracked = false;
  track_.start_time.reset();
  motion_ = MotionModel(motion_options_);
  track_.last_dt = 0.0;
  track_.dropped_s = 0.0;
  reloc_.next_frame = 0;
  reloc_.failures = 0;
  reloc_.held = reloc_.held_jump = false;
  reloc_.held_frame.reset();
  reloc_.sparse_chain.clear();
  reloc_.confirmed_holds.clear();
  reloc_.rivalries.clear();
  reloc_.sparse_holds = 0;
  track_.last_known.reset();
  errors_.bearing_sigma = 0.0;
  errors_.survey.Reset();
  errors_.survey_before_search.reset();
  errors_.next_statement_check = 0;
  errors_.statement_check_gap = 1;
  errors_.statement_verified = false;
  errors_.statement_agreements = 0;
  errors_.statement_supports_hold = false;
  errors_.residual_memory.assign(landmarks_.size(), 0.0);
  errors_.residual_frame.assign(landmarks_.size(), -2);
  UpdateLandmarkBudget();
  track_.motion_updates = 0;
  track_.steady_updates = 0;
  track_.frame_pose = initial;
  ForgetCompassHistory();
  shades_.polarity.assign(landmarks_.size(), LandmarkPolarity{});
  shades_.object_contradicted.assign(landmarks_.empty() ? 0 : static_cast<size_t>(landmarks_.back().object) + 1, 0);
  shades_.map_contradicted = shades_.map_confirmed = false;
}

void Localizer::ResetUnknown() {
  Reset(Pose2{0, 0, 0}, true);
  track_.known_start = false;
}

int Localizer::SearchPolarity(const EdgePolarityEvidence& e, int map_polarity, int object, bool either) const {
  if (e.flips > opt_.polarity_max_flips) return 0;
  // A few contradictions among many confirmations are wrong edges, not a
  // wrong shade.
  const bool map_trusted = map_polarity != 0 && !shades_.map_contradicted &&
                           !shades_.object_contradicted[static_cast<size_t>(object)] &&
                           (e.disagree == 0 || e.agree > 2 * e.disagree);
  if (map_trusted) return either && e.agree == 0 ? 0 : map_polarity;
  return e.learned;
}

bool Localizer::EitherFallbackUseful() const {
  return shades_.any_known && !shades_.map_confirmed && !shades_.map_contradicted;
}

std::vector<std::string> Localizer::ContradictedShades() const {
  std::vector<std::string> out;
  for (size_t i = 0; i < landmarks_.size(); ++i) {
    const std::string id = landmarks_[i].id.substr(0, landmarks_[i].id.find('/'));
    for (const EdgePolarityEvidence* e : {&shades_.polarity[i].v, &shades_.polarity[i].h})
      if (e->disagree >= opt_.polarity_learn_frames && e->disagree > e->agree &&
          std::find(out.begin(), out.end(), id) == out.end())
        out.push_back(id);
  }
  return out;
}

void Localizer::LearnPolarity(const FrameResult& fr, const TriangulationResult& tri) {
  std::vector<char> inlier(fr.predicted.size(), 0);
  for (int i : InlierPredictions(fr, tri)) inlier[static_cast<size_t>(i)] = 1;
  auto observe = [&](EdgePolarityEvidence* e, int sign, int map_polarity, double contrast) {
    if (sign == 0) return;
    e->misses = 0;
    if (map_polarity != 0) ++(sign == map_polarity ? e->agree : e->disagree);
    e->contrast = e->contrast > 0 ? 0.8 * e->contrast + 0.2 * std::abs(contrast) : std::abs(contrast);
    if (sign == e->candidate) {
      ++e->run;
    } else {
      e->candidate = sign;
      e->run = 1;
    }
    if (e->run >= opt_.polarity_learn_frames && e->learned != sign) {
      if (e->last_learned != 0 && e->last_learned != sign) ++e->flips;
      e->learned = e->last_learned = sign;
    }
  };
  auto miss = [&](EdgePolarityEvidence* e) {
    if (++e->misses < opt_.polarity_forget_misses || e->learned == 0) return;
    // Lost for a while with its learned sign: what lies beyond the edge may
    // have changed; search either sign again.
    e->learned = e->candidate = e->run = e->misses = 0;
  };
  for (size_t i = 0; i < fr.predicted.size() && i < fr.measurements.size(); ++i) {
    const PredictedLandmark& p = fr.predicted[i];
    const LandmarkMeasurement& m = fr.measurements[i];
    LandmarkPolarity& lp = shades_.polarity[static_cast<size_t>(p.index)];
    if (m.found && inlier[i]) {
      observe(&lp.v, m.v_polarity, p.map_v_polarity, m.v_contrast);
      observe(&lp.h, m.h_polarity, p.map_h_polarity, m.h_contrast);
    } else if (!m.found) {
      miss(&lp.v);
      miss(&lp.h);
    }
  }
  // Per map object and over the map: contradicted where more of its edges'
  // measurements disagree with the map than agree; confirmed where a few
  // edges agree.
  std::vector<int> agree(shades_.object_contradicted.size(), 0), disagree(shades_.object_contradicted.size(), 0);
  int confirmed_edges = 0;
  for (size_t i = 0; i < landmarks_.size(); ++i)
    for (const EdgePolarityEvidence* e : {&shades_.polarity[i].v, &shades_.polarity[i].h}) {
      agree[static_cast<size_t>(landmarks_[i].object)] += e->agree;
      disagree[static_cast<size_t>(landmarks_[i].object)] += e->disagree;
      confirmed_edges += e->agree >= opt_.polarity_learn_frames && e->agree > 2 * e->disagree;
    }
  int contradicted = 0, trusted = 0;
  for (size_t k = 0; k < shades_.object_contradicted.size(); ++k) {
    shades_.object_contradicted[k] = disagree[k] > agree[k];
    contradicted += shades_.object_contradicted[k];
    trusted += agree[k] > disagree[k];
  }
  shades_.map_contradicted = contradicted > trusted;
  shades_.map_confirmed = shades_.map_confirmed || confirmed_edges >= 3;
}

void Localizer::Measure(const Pose2& pose, double search_px, FrameResult* out, const Pose2* solved_motion,
                        bool either, bool azimuth_only, bool tracking) const {
  out->either_polarity = either;
  out->from_prediction = tracking;
  out->with_partners = tracking && !azimuth_only && PairsWanted();
  out->blur_turn = solved_motion ? std::optional<double>(solved_motion->theta) : std::nullopt;
  // The motion over the last frame interval; unknown: the fastest turn.
  const bool known = track_.motion_updates >= 2 || solved_motion;
  const Pose2 motion = solved_motion ? *solved_motion
                       : known       ? track_.frame_motion
                                     : Pose2{0, 0, opt_.unknown_turn_per_frame};
  const Pose2 before{pose.x - motion.x, pose.y - motion.y, pose.theta - motion.theta};
  // Edges may be blurred a little more than the estimate says.
  const double fraction = known ? std::min(opt_.exposure_fraction, 1.3 * images_.blur_fraction + 0.05)
                                : opt_.exposure_fraction;
  // The landmarks to track, spread in azimuth (SelectSpread): the chosen
  // ones first, the others only when they are needed.
  SpreadPrediction prediction(landmarks_, map_, scene_, calib_.sensor, *table_, pose,
                              tracking ? errors_.prediction : SearchPrediction(errors_.prediction),
                              azimuth_only ? CoarseLandmarks(opt_, MaxLandmarks()) : MaxLandmarks(),
                              out->with_partners ? opt_.noise_pairs : 0);
  // The polarities to search for (the map's, or what the images showed),
  // and the expected motion blur.
  auto prepare = [&](std::vector<PredictedLandmark>* batch) {
    for (PredictedLandmark& p : *batch) {
      const LandmarkPolarity& lp = shades_.polarity[static_cast<size_t>(p.index)];
      const int object = p.landmark->object;
      p.v_polarity = SearchPolarity(lp.v, p.map_v_polarity, object, either);
      p.h_polarity = SearchPolarity(lp.h, p.map_h_polarity, object, either);
    }
    SetImageMotion(map_, calib_.sensor, *table_, before, fraction, batch);
  };
  // An edge of unknown polarity that the tracked frames have not shown
  // for a while (most likely no contrast there, which an unknown shade
  // cannot predict): its landmark goes last, tracked only when too few of
  // the others are found.
  auto never_seen = [&](const EdgePolarityEvidence& e, int polarity) {
    return polarity == 0 && e.last_learned == 0 && e.misses >= opt_.polarity_forget_misses;
  };
  auto seen = [&](const PredictedLandmark& p) {
    const LandmarkPolarity& lp = shades_.polarity[static_cast<size_t>(p.index)];
    return !(never_seen(lp.v, p.v_polarity) || never_seen(lp.h, p.h_polarity));
  };
  std::vector<PredictedLandmark> ordered = prediction.First();
  prepare(&ordered);
  const int n_first = static_cast<int>(ordered.size());
  bool have_rest = !prediction.HasMore();
  auto add_rest = [&]() {
    std::vector<PredictedLandmark> rest = prediction.Rest();
    prepare(&rest);
    ordered.insert(ordered.end(), rest.begin(), rest.end());
    have_rest = true;
    std::stable_partition(ordered.begin(), ordered.end(), seen);
  };
  // Unseen ones among the chosen give their places to the rest; without
  // any, the chosen stay first whatever the rest holds.
  if (!std::all_of(ordered.begin(), ordered.end(), seen)) {
    if (have_rest)
      std::stable_partition(ordered.begin(), ordered.end(), seen);
    else
      add_rest();
  }
  std::vector<LandmarkMeasurement> meas(ordered.size());
  // Inside a parallel search each hypothesis is measured on its own thread.
  const int threads = InParallelRegion() ? 1 : ThreadCount(opt_.num_threads);
  auto measure = [&](int begin, int end) {
    // Landmarks are independent: track them in parallel.
    std::vector<std::exception_ptr> errors(static_cast<size_t>(end - begin));
#pragma omp parallel for schedule(dynamic, 1) num_threads(threads) if (end - begin > 4)
    for (int i = begin; i < end; ++i) {
      try {
        const double width = SearchWidth(ordered[i], search_px);
        meas[i] = azimuth_only ? tracker_->MeasureAzimuth(ordered[i], width) : tracker_->Measure(ordered[i], width);
      } catch (...) {
        errors[static_cast<size_t>(i - begin)] = std::current_exception();
      }
    }
    RethrowFirst(errors);
  };
  // Tracking on from a pose, the landmarks whose horizontal edges pass
  // near (never chosen for the spread) are tracked besides the chosen; not
  // to confirm a held pose or to probe the survey error (the survey error
  // they carry, least known where they are near, would decide those).
  int n_near = 0;
  if (tracking && !ConfirmingOrProbing()) {
    std::vector<PredictedLandmark> near = prediction.NearLines();
    prepare(&near);
    // (not those whose edges the frames have not shown: the rest's
    // reordering below keeps the measured ones in place)
    near.erase(std::remove_if(near.begin(), near.end(), [&](const PredictedLandmark& p) { return !seen(p); }),
               near.end());
    n_near = static_cast<int>(near.size());
    ordered.insert(ordered.begin() + n_first, near.begin(), near.end());
    meas.resize(ordered.size());
  }
  measure(0, n_first + n_near);
  int found = 0;
  for (int i = 0; i < n_first; ++i) found += meas[i].found;
  // Too few of the chosen ones (occluded, off their edges): track the rest.
  int used = n_first + n_near;
  if (found < std::max(opt_.triangulation.min_landmarks + 3, n_first / 2) && prediction.HasMore()) {
    if (!have_rest) add_rest();
    const int n_all = static_cast<int>(ordered.size());
    meas.resize(ordered.size());
    measure(n_first + n_near, n_all);
    used = n_all;
  }
  ordered.resize(used);
  meas.resize(used);
  out->predicted = std::move(ordered);
  out->measurements = std::move(meas);
  out->partners = prediction.Partners();
  // A partner tracked with the rest already is a landmark of the frame.
  out->partners.erase(std::remove_if(out->partners.begin(), out->partners.end(),
                                     [&](const PredictedLandmark& p) {
                                       return std::any_of(out->predicted.begin(), out->predicted.end(),
                                                          [&](const PredictedLandmark& q) { return q.index == p.index; });
                                     }),
                      out->partners.end());
  prepare(&out->partners);
  out->partner_measurements.clear();
  for (const PredictedLandmark& p : out->partners)
    out->partner_measurements.push_back(tracker_->Measure(p, SearchWidth(p, search_px)));
}

int Localizer::ChosenInliers(const FrameResult& fr, const TriangulationResult& tri) const {
  const int chosen = static_cast<int>(ChosenToTrack(fr));
  std::vector<int> seen = InlierPredictions(fr, tri);
  std::sort(seen.begin(), seen.end());
  seen.erase(std::unique(seen.begin(), seen.end()), seen.end());
  return static_cast<int>(std::count_if(seen.begin(), seen.end(), [&](int i) { return i < chosen; }));
}

std::vector<int> Localizer::InlierPredictions(const FrameResult& fr, const TriangulationResult& tri) const {
  const std::vector<BearingObservation> obs = Observations(fr);
  std::vector<int> out;
  for (int i : tri.inliers) out.push_back(obs[static_cast<size_t>(i)].id);
  return out;
}

double Localizer::InlierThreshold() const {
  return errors_.bearing_sigma > 0
             ? std::clamp(3.0 * errors_.bearing_sigma, opt_.min_inlier_threshold, opt_.robust.inlier_threshold)
             : opt_.robust.inlier_threshold;
}

bool Localizer::PairsWanted() const {
  // Only while tracking on from a reported pose: the pairs of a search's
  // hypotheses, a held pose's confirmation or the survey probe's trials
  // may be a wrong pose's, and a search measures many poses.
  return opt_.noise_pairs > 0 && opt_.survey.check && errors_.survey.WantsPairs() && track_.ever_tracked &&
         track_.n_lost == 0 && !ConfirmingOrProbing();
}

double Localizer::SurveySigma(const Landmark& l) const {
  return std::max(errors_.survey.Sigma(StatedSurveySigma(l)), reloc_.probe_sigma);
}

double Localizer::StatedSurveySigma(const Landmark& l) const {
  return std::isnan(opt_.survey_sigma) ? l.survey_sigma : opt_.survey_sigma;
}

double Localizer::MeanSurveySigma() const {
  double sum = 0.0;
  for (const Landmark& l : landmarks_) sum += SurveySigma(l);
  return landmarks_.empty() ? 0.0 : sum / static_cast<double>(landmarks_.size());
}

double Localizer::LargestSurveySigma() const {
  double largest = 0.0;
  for (const Landmark& l : landmarks_) largest = std::max(largest, SurveySigma(l));
  return largest;
}

void Localizer::UpdateLandmarkBudget() {
  // It changes only with the noise and survey estimates: computed when they
  // change, not on every call in a frame (the mean runs over the whole map).
  errors_.max_landmarks = opt_.max_landmarks;
  UpdatePrediction();
  if (opt_.max_landmarks != 0 && MeanSurveySigma() / errors_.typical_distance > ReferenceSigma())
    errors_.max_landmarks =
        opt_.max_landmarks_uncertain_map == 0 ? 0 : std::max(opt_.max_landmarks, opt_.max_landmarks_uncertain_map);
}

void Localizer::UpdatePrediction() {
  // A corner within three survey sigmas of a wall (behind it, as measured)
  // is not hidden by it.
  errors_.prediction = opt_.prediction;
  errors_.prediction.surface_tolerance = std::max(opt_.prediction.surface_tolerance, 3.0 * LargestSurveySigma());
}

double Localizer::SearchWidth(const PredictedLandmark& p, double search_px) const {
  // The corner's survey error moves its edges by about this much in the
  // image (its angle at the corner's image radius), three sigmas of it.
  const double survey_px = 3.0 * SurveySigma(*p.landmark) / std::max(p.distance, 1e-9) * p.corner_radius;
  return std::min(std::hypot(search_px, survey_px), std::max(search_px, 2.0 * opt_.max_search_px));
}

double Localizer::NormalizedRms(const std::vector<BearingObservation>& obs, const TriangulationResult& tri) {
  // Each weight was divided by its spread squared (Observations).
  double sum_r2 = 0.0, sum_w = 0.0;
  for (int i : tri.inliers) {
    const BearingObservation& o = obs[static_cast<size_t>(i)];
    const double r = tri.bearing_residuals[static_cast<size_t>(i)];
    sum_r2 += o.weight * r * r;
    sum_w += o.weight * o.spread * o.spread;
  }
  return sum_w > 0 ? std::sqrt(sum_r2 / sum_w) : 0.0;
}

std::vector<BearingObservation> Localizer::Observations(const FrameResult& fr, double reference_sigma) const {
  std::vector<BearingObservation> obs;
  for (size_t i = 0; i < fr.predicted.size(); ++i) {
    const LandmarkMeasurement& m = fr.measurements[i];
    if (!m.found) continue;
    const PredictedLandmark& p = fr.predicted[i];
    BearingObservation o;
    o.landmark = p.landmark->corner.head<2>();
    o.bearing = calib_.sensor.bearing_of_azimuth(m.azimuth);
    // The corner's survey error across the line of sight, as an angle.
    const double survey = SurveySigma(*p.landmark) / std::max(p.distance, 1e-9);
    o.spread = std::sqrt(1.0 + (survey * survey) / (reference_sigma * reference_sigma));
    o.weight = m.weight / (o.spread * o.spread);
    o.id = static_cast<int>(i);
    obs.push_back(o);
  }
  // The top and bottom corners of one edge measure one bearing: they share
  // its weight, and count once as evidence.
  for (size_t i = 0; i < obs.size(); ++i) {
    if (obs[i].group >= 0) continue;
    std::vector<size_t> same{i};
    for (size_t j = i + 1; j < obs.size(); ++j)
      if ((obs[j].landmark - obs[i].landmark).squaredNorm() < 1e-12) same.push_back(j);
    if (same.size() < 2) continue;
    for (size_t j : same) {
      obs[j].group = static_cast<int>(i);
      obs[j].weight /= static_cast<double>(same.size());
    }
  }
  return obs;
}

TriangulationResult Localizer::Solve(const FrameResult& fr, const Pose2& prior) const {
  const std::vector<BearingObservation> obs = Observations(fr);
  TriangulationResult out = SolveBearings(obs, prior);
  if (!out.ok) return out;
  DropSuddenResiduals(fr, obs, prior, &out);
  // The RMS residual in units of image noise: the map's share taken out.
  out.rms_bearing = NormalizedRms(obs, out);
  // A few residuals can fit better than the bearings' noise: the covariance
  // is never scaled below the noise of recent frames. (Where the survey
  // error dominates, that noise also holds what the survey estimate has not
  // caught up with yet, and the covariance is the map's anyway.)
  const double floor2 = errors_.bearing_sigma * errors_.bearing_sigma;
  if (!SurveyLimits() && out.variance_factor > 0 && out.variance_factor < floor2) {
    out.covariance *= floor2 / out.variance_factor;
    out.variance_factor = floor2;
  }
  return out;
}

std::vector<int> Localizer::SuddenResiduals(const FrameResult& fr, const std::vector<BearingObservation>& obs,
                                            const TriangulationResult& tri) const {
  // Each inlier tracked on the previous frame, its bearing moved by the
  // residual it had there: the map's error taken out, what is left is the
  // image noise and whatever changed since.
  std::vector<BearingObservation> corrected;
  std::vector<int> which;
  for (int i : tri.inliers) {
    const BearingObservation& o = obs[static_cast<size_t>(i)];
    const size_t index = static_cast<size_t>(fr.predicted[static_cast<size_t>(o.id)].index);
    if (errors_.residual_frame[index] != track_.frame - 1) continue;
    BearingObservation c = o;
    c.bearing = WrapAngle(o.bearing + errors_.residual_memory[index]);
    c.weight = o.weight * o.spread * o.spread;
    c.spread = 1.0;
    corrected.push_back(c);
    which.push_back(i);
  }
  std::vector<int> all(corrected.size());
  for (size_t k = 0; k < all.size(); ++k) all[k] = static_cast<int>(k);
  if (DistinctBearings(corrected, all) < 6) return {};
  RobustPoseOptions robust = opt_.robust;
  robust.inlier_threshold = InlierThreshold();
  const RobustTriangulationResult r = RobustTriangulate(corrected, tri.pose, robust, opt_.triangulation);
  if (!r.ok) return {};
  std::vector<char> agrees(corrected.size(), 0);
  for (int k : r.inliers) agrees[static_cast<size_t>(k)] = 1;
  std::vector<int> sudden;
  for (size_t k = 0; k < corrected.size(); ++k)
    if (!agrees[k]) sudden.push_back(which[k]);
  // Most must agree: else the view changed (a kidnap, a jump of the pose),
  // not a few edges.
  if (3 * sudden.size() > corrected.size()) return {};
  return sudden;
}

void Localizer::DropSuddenResiduals(const FrameResult& fr, const std::vector<BearingObservation>& obs,
                                    const Pose2& prior, TriangulationResult* tri) const {
  // Only where the survey's tolerance is wide enough to hide a bias (an
  // edge half hidden by someone walking past); with an exact map the
  // consensus's own threshold rejects it.
  if (!SurveyLimits()) return;
  const std::vector<int> sudden = SuddenResiduals(fr, obs, *tri);
  if (sudden.empty()) return;
  std::vector<char> drop(obs.size(), 0);
  for (int i : sudden) drop[static_cast<size_t>(i)] = 1;
  SolveWithout(obs, drop, prior, tri);
}

bool Localizer::SolveWithout(const std::vector<BearingObservation>& obs, const std::vector<char>& drop,
                             const Pose2& prior, TriangulationResult* tri) const {
  std::vector<BearingObservation> kept;
  std::vector<int> index;
  for (size_t i = 0; i < obs.size(); ++i)
    if (!drop[i]) {
      kept.push_back(obs[i]);
      index.push_back(static_cast<int>(i));
    }
  TriangulationResult again = SolveBearings(kept, prior);
  if (!again.ok) return false;
  for (int& i : again.inliers) i = index[static_cast<size_t>(i)];
  again.bearing_residuals.assign(obs.size(), 0.0);
  for (size_t i = 0; i < obs.size(); ++i) again.bearing_residuals[i] = BearingResidual(obs[i], again.pose);
  *tri = std::move(again);
  return true;
}

void Localizer::DropPulledBearings(const FrameResult& fr, TriangulationResult* tri) const {
  if (!tri->ok || !SurveyLimits()) return;
  const std::vector<BearingObservation> obs = Observations(fr);
  // The integrity test's bearings: the same found landmarks, each weighed
  // by its expected error relative to the test's noise.
  const double sigma = IntegritySigma();
  const std::vector<BearingObservation> tested = Observations(fr, sigma);
  const double limit = NormalQuantile(1.0 - 0.5 * kPulledBearingAlpha);
  std::vector<char> drop(obs.size(), 0);
  for (int round = 0; round < kMaxPulledBearings; ++round) {
    const std::vector<double> w = StandardizedResiduals(tested, *tri, sigma);
    size_t worst = w.size();
    double largest = limit;
    for (size_t k = 0; k < w.size(); ++k)
      if (std::abs(w[k]) > largest) {
        largest = std::abs(w[k]);
        worst = k;
      }
    if (worst == w.size()) return;
    const int group = BearingGroup(obs, tri->inliers[worst]);
    for (size_t j = 0; j < obs.size(); ++j)
      if (BearingGroup(obs, static_cast<int>(j)) == group) drop[j] = 1;
    // Enough left to test what remains: else the integrity check judges
    // the frame as it is.
    std::vector<int> left;
    for (int j : tri->inliers)
      if (!drop[static_cast<size_t>(j)]) left.push_back(j);
    if (DistinctBearings(obs, left) < 4 || !SolveWithout(obs, drop, tri->pose, tri)) return;
  }
}

TriangulationResult Localizer::SolveBearings(const std::vector<BearingObservation>& obs, const Pose2& prior) const {
  TriangulationResult plain = Triangulate(obs, prior, opt_.triangulation);
  if (!opt_.robust_pose || obs.size() < 4) return plain;
  // Inliers within five times the recent noise: an edge half hidden by
  // someone walking past is off by less than the fixed threshold, but far
  // more than the noise.
  RobustPoseOptions robust = opt_.robust;
  robust.inlier_threshold = InlierThreshold();
  // Every bearing agreeing with the least-squares pose: nothing to reject
  // (most frames; the consensus costs milliseconds).
  TriangulationResult out = plain;
  bool all_agree = plain.ok && plain.inliers.size() == obs.size();
  for (size_t i = 0; all_agree && i < obs.size(); ++i)
    all_agree = std::abs(plain.bearing_residuals[i]) <= robust.inlier_threshold * obs[i].spread;
  if (!all_agree) out = RobustTriangulate(obs, prior, robust, opt_.triangulation);
  if (errors_.bearing_sigma > 0 || !out.ok || obs.size() < 6) return out;
  // No noise seen yet (the first frame): the widest threshold admits an edge
  // a few tenths of a degree off (a corner of unknown polarity matched by a
  // wrong template, a half-hidden edge). This frame's own residuals (their
  // median, robust to those) say how far good bearings lie from the pose.
  std::vector<double> abs_residuals;
  for (size_t i = 0; i < obs.size(); ++i) abs_residuals.push_back(std::abs(out.bearing_residuals[i]) / obs[i].spread);
  std::nth_element(abs_residuals.begin(), abs_residuals.begin() + abs_residuals.size() / 2, abs_residuals.end());
  const double own = std::clamp(3.0 * 1.4826 * abs_residuals[abs_residuals.size() / 2], opt_.min_inlier_threshold,
                                opt_.robust.inlier_threshold);
  if (own >= robust.inlier_threshold) return out;
  robust.inlier_threshold = own;
  TriangulationResult tight = RobustTriangulate(obs, prior, robust, opt_.triangulation);
  return tight.ok ? tight : out;
}

bool Localizer::TrackFrom(const Pose2& pose, double search_px, FrameResult* fr,
                          TriangulationResult* tri, bool either) const {
  Measure(pose, search_px, fr, nullptr, either);
  *tri = Solve(*fr, pose);
  for (int pass = 0; pass < 1 + opt_.refine_passes && Acceptable(*fr, *tri); ++pass) {
    FrameResult again;
    Measure(tri->pose, opt_.refine_search_px, &again, nullptr, either);
    TriangulationResult tri2 = Solve(again, tri->pose);
    if (!Acceptable(again, tri2)) break;
    TakeMeasurements(&again, fr);
    *tri = tri2;
  }
  return Acceptable(*fr, *tri);
}

bool Localizer::RetrackFromFound(bool either, FrameResult* fr, TriangulationResult* tri) const {
  for (int pass = 0; pass < opt_.relocalize_retrack_passes; ++pass) {
    // A pose and the spare bearings that check it (as Acceptable asks of
    // a fit that leaves found bearings out): fewer fit a wrong pose nearby.
    const size_t inliers = tri->inliers.size();
    if (!tri->ok || inliers < static_cast<size_t>(3 + opt_.min_spare_bearings_with_outliers)) return false;
    const Pose2 fitted = tri->pose;
    FrameResult again;
    TriangulationResult tri_again;
    const bool tracked = TrackFrom(fitted, opt_.search_px, &again, &tri_again, either);
    if (!tracked && tri_again.inliers.size() <= inliers) return false;
    *fr = std::move(again);
    *tri = tri_again;
    if (tracked) return true;
  }
  return false;
}

bool Localizer::Relocalize(const cv::Mat& grey, bool near_last, FrameResult* fr, TriangulationResult* tri,
                           std::vector<VerifiedPose>* verified, bool settle_rivalry) const {
  if (!relocalization_index_) {
    const auto build = [this] {
      return std::make_unique<const RelocalizationIndex>(calib_.sensor, *table_, map_, scene_, landmarks_,
                                                         errors_.index_prediction, opt_.relocalize,
                                                         SearchThreadCount(opt_));
    };
    relocalization_index_ = shared_index_ ? shared_index_->Get(build) : build();
  }
  const int count = track_.ever_tracked ? 0 : opt_.relocalize_untracked_hypotheses;
  const std::vector<PoseHypothesis> hyps = relocalization_index_->Hypotheses(grey, SearchThreadCount(opt_), count);
  reloc_.sparse_candidates.clear();
  reloc_.any_verified = reloc_.sparse_lead = false;
  // With the map's polarities, then (while the images have not confirmed
  // them) with either; a lost frame's search that verified nothing, a
  // sparse image's lead.
  const bool found = RelocalizeWith(hyps, false, near_last, fr, tri, verified, settle_rivalry, settle_rivalry) ||
                     (EitherFallbackUseful() && RelocalizeWith(hyps, true, near_last, fr, tri, verified, false, settle_rivalry));
  if (found || !settle_rivalry || reloc_.any_verified) return found;
  return reloc_.sparse_lead = SparseLead(fr, tri);
}

bool Localizer::SparselySupported(const FrameResult& fr, const TriangulationResult& tri) const {
  const int inliers = static_cast<int>(tri.inliers.size());
  return tri.ok && inliers >= opt_.relocalize_min_landmarks &&
         inliers >= opt_.relocalize_confirmed_fraction * FoundLandmarks(fr);
}

bool Localizer::SparseLead(FrameResult* fr, TriangulationResult* tri) const {
  std::vector<Relocalization::SparseCandidate>& candidates = reloc_.sparse_candidates;
  if (opt_.relocalize_sparse_frames <= 0 || candidates.empty()) return false;
  const auto inliers = [](const Relocalization::SparseCandidate& c) { return static_cast<int>(c.tri.inliers.size()); };
  // The best supported of every pose tracked (a place whose bearings a
  // narrow tolerance splits is a rival too), if it is a lead at all.
  const auto best = std::max_element(candidates.begin(), candidates.end(), [&](const auto& a, const auto& b) {
    return inliers(a) < inliers(b);
  });
  const bool ahead = best->supported && std::all_of(candidates.begin(), candidates.end(), [&](const auto& c) {
                       return !DistinctPlaces(c.tri.pose, best->tri.pose) ||
                              opt_.relocalize_sparse_lead * inliers(c) <= inliers(*best);
                     });
  // A twin of what it saw (a symmetry of the map) is as far ahead.
  if (!ahead || TwinPoses(best->fr, best->tri).size() > 1 || !Consistent(&best->fr, best->tri)) return false;
  *fr = std::move(best->fr);
  *tri = best->tri;
  return true;
}

bool Localizer::RelocalizeWith(const std::vector<PoseHypothesis>& hyps, bool either, bool near_last, FrameResult* fr,
                               TriangulationResult* tri, std::vector<VerifiedPose>* verified_out,
                               bool settle_rivalry, bool collect_sparse) const {
  struct Verified {
    FrameResult fr;
    TriangulationResult tri;
    int chosen = 0;  // ChosenInliers
    bool enough = false;  // EnoughForRelocalized (else a sparse candidate)
  };
  // Each hypothesis tracked on its own (in parallel), kept in their order.
  std::vector<std::optional<Verified>> tracked(hyps.size());
  ParallelForOnOwnThreads(
      static_cast<int>(hyps.size()),
      [&](int i) {
        Verified v;
        // The normal search first: a wide one invites wrong edges.
        const Pose2& pose = hyps[static_cast<size_t>(i)].pose;
        if (!TrackFrom(pose, opt_.search_px, &v.fr, &v.tri, either) &&
            !TrackFrom(pose, opt_.max_search_px, &v.fr, &v.tri, either) &&
            !RetrackFromFound(either, &v.fr, &v.tri)) {
          return;
        }
        v.enough = EnoughForRelocalized(v.fr, v.tri);
        if (!v.enough && !collect_sparse) return;
        v.chosen = ChosenInliers(v.fr, v.tri);
        tracked[static_cast<size_t>(i)] = std::move(v);
      },
      SearchThreadCount(opt_));
  std::vector<Verified> verified;
  for (std::optional<Verified>& v : tracked) {
    if (v && v->enough) verified.push_back(std::move(*v));
    else if (v) reloc_.sparse_candidates.push_back({std::move(v->fr), v->tri, SparselySupported(v->fr, v->tri)});
  }
  reloc_.any_verified = reloc_.any_verified || !verified.empty();
  auto count = [](const Verified& v) { return static_cast<int>(v.tri.inliers.size()); };
  auto as_pose = [&](const Verified& v) { return VerifiedPose{v.tri.pose, count(v), v.chosen, v.tri.residual}; };
  if (verified_out)
    for (const Verified& v : verified) verified_out->push_back(as_pose(v));
  if (verified.empty()) return false;
  // The pose that outranks every pose elsewhere, the best supported first;
  // none: the search is ambiguous.
  std::stable_sort(verified.begin(), verified.end(),
                   [&](const Verified& a, const Verified& b) { return count(a) > count(b); });
  std::vector<VerifiedPose> ranked;
  for (const Verified& v : verified) ranked.push_back(as_pose(v));
  const auto outranks_all = [&](size_t a) {
    for (size_t i = 0; i < ranked.size(); ++i)
      if (i != a && DistinctPlaces(ranked[i].pose, ranked[a].pose) && !SearchOutranks(ranked[a], ranked[i], either))
        return false;
    return true;
  };
  size_t best_index = 0;
  while (best_index < ranked.size() && !outranks_all(best_index)) ++best_index;
  if (settle_rivalry) {
    if (best_index < ranked.size())
      reloc_.rivalries.clear();  // not ambiguous
    else if (SettlesRivalry(ranked, either))
      best_index = 0;
  }
  if (best_index == ranked.size()) return false;
  const auto best = verified.begin() + static_cast<std::ptrdiff_t>(best_index);
  // The best-supported pose, unambiguous, must also pass the integrity test
  // (a pose with fewer inliers that passes it is no better: few bearings
  // fit a wrong pose easily).
  if (!Consistent(&best->fr, best->tri)) {
    if (!errors_.survey.confident() && SurveyEvidence(best->fr, best->tri))
      reloc_.survey_evidence.emplace(best->fr, best->tri);
    return false;
  }
  if (!ChooseAmongTwins(either, near_last, &best->fr, &best->tri)) return false;
  *fr = std::move(best->fr);
  *tri = best->tri;
  return true;
}

bool Localizer::SearchOutranks(const VerifiedPose& a, const VerifiedPose& b, bool either) const {
  // A pose that found few of the landmarks it chose tracks more of them,
  // and may fit more in all: it outranks none clearly better supported on
  // the landmarks chosen.
  if (ClearlyBetterSupported(b.chosen_inliers, a.chosen_inliers)) return false;
  return Outranks(a.inliers, a.residual, b.inliers, b.residual) ||
         (!either && a.inliers >= b.inliers && ClearlyBetterSupported(a.chosen_inliers, b.chosen_inliers));
}

bool Localizer::SettlesRivalry(const std::vector<VerifiedPose>& ranked, bool either) const {
  // Ambiguous between the best supported place and one rival place (every
  // pose not outranked lies there): does the first keep leading?
  const VerifiedPose& leader = ranked.front();
  const auto rival = std::find_if(ranked.begin(), ranked.end(), [&](const VerifiedPose& v) {
    return DistinctPlaces(v.pose, leader.pose) && !SearchOutranks(leader, v, either);
  });
  const bool two_places = rival != ranked.end() && std::all_of(ranked.begin(), ranked.end(), [&](const VerifiedPose& v) {
                            return !DistinctPlaces(v.pose, leader.pose) || !DistinctPlaces(v.pose, rival->pose) ||
                                   SearchOutranks(leader, v, either);
                          });
  if (!two_places) {
    reloc_.rivalries.clear();
    return false;
  }
  // The leader leads each pose at the rival's place it does not outrank:
  // as many inliers or more (among the chosen too), and a residual
  // relocalize_rival_fit times smaller, or one no larger on
  // relocalize_margin more inliers.
  const double own = std::max(leader.residual, ReferenceSigma() * errors_.typical_distance);
  const auto leads = [&](const VerifiedPose& v) {
    if (!DistinctPlaces(v.pose, leader.pose) || SearchOutranks(leader, v, either)) return true;
    if (leader.inliers < v.inliers || leader.chosen_inliers < v.chosen_inliers ||
        v.inliers < std::max(opt_.relocalize_min_landmarks, kFitComparedBearings))
      return false;
    return v.residual >= opt_.relocalize_rival_fit * own ||
           (leader.inliers >= v.inliers + opt_.relocalize_margin && v.residual >= own);
  };
  return LedRivalLongEnough(leader.pose, rival->pose, std::all_of(ranked.begin(), ranked.end(), leads));
}

bool Localizer::LedRivalLongEnough(const Pose2& leader, const Pose2& rival, bool leads) const {
  std::vector<Relocalization::Rivalry>& led = reloc_.rivalries;
  // Under the exact statement's tolerances (or a probe's) a chance subset
  // of a measured map's corners can favour either place; and support
  // counted under different tolerances does not compare.
  const double sigma = LargestSurveySigma();
  if (!leads || opt_.relocalize_rival_searches <= 0 || reloc_.probe_sigma > 0.0 || !(sigma > 0.0)) {
    led.clear();
    return false;
  }
  // The same two places as the last search's: each within the robot's
  // reach of where it was (the twin moves as the robot's mirror image).
  if (!led.empty()) {
    const Relocalization::Rivalry& last = led.back();
    const double reach = motion_options_.max_speed * std::max(0.0, track_.time_s - last.time_s) +
                         opt_.relocalize_distinct * errors_.room_size;
    const auto within = [&](const Pose2& a, const Pose2& b) { return std::hypot(a.x - b.x, a.y - b.y) <= reach; };
    if (last.survey_sigma != sigma || !within(leader, last.leader) || !within(rival, last.rival)) led.clear();
  }
  led.push_back({track_.time_s, leader, rival, sigma});
  return static_cast<int>(led.size()) >= opt_.relocalize_rival_searches;
}

std::vector<Pose2> Localizer::TwinPoses(const FrameResult& fr, const TriangulationResult& tri) const {
  std::vector<int> seen;
  for (int i : InlierPredictions(fr, tri)) seen.push_back(fr.predicted[static_cast<size_t>(i)].index);
  const std::vector<FloorMotion> motions =
      LandmarkSymmetries(landmarks_, seen, opt_.relocalize_symmetry_tolerance * errors_.room_size);
  std::vector<Pose2> poses{tri.pose};
  for (const FloorMotion& m : motions) {
    const Pose2 twin = m.Apply(tri.pose);
    if (map_.IsFree(twin.x, twin.y)) poses.push_back(twin);  // not behind a wall
  }
  return poses;
}

bool Localizer::ChooseAmongTwins(bool either, bool near_last, FrameResult* fr, TriangulationResult* tri) const {
  std::vector<Pose2> poses = TwinPoses(*fr, *tri);
  if (poses.size() == 1) return true;
  // Which twin is nearest the last pose tells only while the robot is
  // likely still near it: after a jump of the view (a kidnap) the twins
  // stay ambiguous until a view breaks the symmetry.
  if ((!track_.ever_tracked && !track_.known_start) || !near_last) return false;
  auto from_last = [this](const Pose2& p) { return std::hypot(p.x - track_.last.x, p.y - track_.last.y); };
  std::stable_sort(poses.begin(), poses.end(),
                   [&](const Pose2& a, const Pose2& b) { return from_last(a) < from_last(b); });
  // Clearly nearest: the others at least twice as far.
  if (from_last(poses[1]) < 2.0 * from_last(poses[0])) return false;
  const Pose2& chosen = poses[0];
  if (std::hypot(chosen.x - tri->pose.x, chosen.y - tri->pose.y) == 0.0) return true;
  FrameResult twin_fr;
  TriangulationResult twin_tri;
  if (!TrackFrom(chosen, opt_.search_px, &twin_fr, &twin_tri, either) || !EnoughForRelocalized(twin_fr, twin_tri) ||
      !Consistent(&twin_fr, twin_tri))
    return false;
  *fr = std::move(twin_fr);
  *tri = twin_tri;
  return true;
}

bool Localizer::Acceptable(const FrameResult& fr, const TriangulationResult& tri) const {
  if (!tri.ok || tri.rms_bearing > opt_.max_rms_bearing) return false;
  // Of the landmarks chosen to track, and of the others (tracked only when
  // too few of those were found) the ones found: an unfound extra is
  // likely hidden or faint, one found off the pose counts against it. The
  // ones tracked besides the chosen because the map's survey error makes
  // more worth having (MaxLandmarks: farther, fainter) count only by their
  // inliers.
  const size_t n_chosen = static_cast<size_t>(ChosenLandmarks(fr));
  const size_t n_first = std::max(n_chosen, static_cast<size_t>(SurveyChosenLandmarks(fr)));
  // Tracked on from a pose the sequence vouches for (tracked, or a start
  // given as known), an extra found on the pose is one more that fits, not
  // a sign that the chosen were missed at a wrong pose: images that hide
  // most of the chosen corners (compressed, blurred) leave the extras to
  // carry the pose. A search's hypothesis has no such anchor: there every
  // extra found counts, whatever it fits.
  const bool anchored = opt_.extras_on_tracked_pose_count_for_it && fr.from_prediction &&
                        (track_.ever_tracked || StartGivenAsPose());
  const std::vector<BearingObservation> obs = Observations(fr);
  std::vector<char> on_pose(fr.measurements.size(), 0);
  if (anchored)
    for (int i : tri.inliers) on_pose[static_cast<size_t>(obs[static_cast<size_t>(i)].id)] = 1;
  double n_counted = static_cast<double>(n_chosen);
  for (size_t i = n_first; i < fr.measurements.size(); ++i) n_counted += fr.measurements[i].found && !on_pose[i];
  if (n_counted >= 8 && tri.inliers.size() < opt_.min_inlier_fraction * n_counted) return false;
  std::vector<int> all(obs.size());
  std::iota(all.begin(), all.end(), 0);
  const int used = DistinctBearings(obs, tri.inliers);
  return used == DistinctBearings(obs, all) || used - 3 >= opt_.min_spare_bearings_with_outliers;
}

namespace {

// Two poses this far apart in heading (radians) are different places to a
// search, wherever they stand: the same pose verified from two hypotheses
// converges to within a fraction of a degree.
constexpr double kDistinctHeading = 10.0 * M_PI / 180.0;
// Chi-square of two degrees of freedom at 95 %: a position outside the
// ellipse that holds 95 % of a pose's reported errors.
constexpr double kRefutedChi2 = 5.991;

// The prior odds against a frame having been dropped before this one.
constexpr double kDroppedFrameOdds = 100.0;

// A triangulated pose as a measurement for the motion model: its covariance
// with floors (it is estimated from a few residuals), the position's from
// the mean distance of the landmarks used.
PoseMeasurement MeasurementOf(const TriangulationResult& tri, const std::vector<BearingObservation>& obs,
                              double position_fraction, double heading_sigma) {
  double distance = 0.0;
  for (int i : tri.inliers) distance += (obs[static_cast<size_t>(i)].landmark - Eigen::Vector2d(tri.pose.x, tri.pose.y)).norm();
  distance /= std::max<size_t>(1, tri.inliers.size());
  PoseMeasurement m;
  m.pose = tri.pose;
  m.covariance = tri.covariance;
  const double sp = position_fraction * distance;
  m.covariance(0, 0) += sp * sp;
  m.covariance(1, 1) += sp * sp;
  m.covariance(2, 2) += heading_sigma * heading_sigma;
  return m;
}

}  // namespace

PoseMeasurement Localizer::MotionMeasurement(const FrameResult& fr, const TriangulationResult& tri) const {
  return MeasurementOf(tri, Observations(fr), opt_.gate_position_fraction, opt_.gate_heading_sigma);
}

double Localizer::StrictGate() const { return std::min(opt_.gate_chi2, kGateChiSquare3Dof99); }

double Localizer::IntegritySigma() const {
  // Three times the recent noise: the residuals' spread varies from frame
  // to frame with blur and geometry; a wrong junction is off by far more.
  return std::clamp(errors_.bearing_sigma > 0 ? 3.0 * errors_.bearing_sigma : opt_.initial_bearing_sigma,
                    opt_.min_bearing_sigma, opt_.max_bearing_sigma);
}

bool Localizer::Consistent(FrameResult* fr, const TriangulationResult& tri) const {
  IntegrityOptions io;
  io.sigma_bearing = IntegritySigma();
  io.confidence = opt_.integrity_confidence;
  io.protection_sigmas = opt_.protection_sigmas;
  io.alert_fraction = opt_.alert_fraction;
  io.alert_limit = opt_.alert_limit;
  // Each bearing's expected error: the test's image noise and its corner's
  // survey error (its spread relative to that noise).
  const std::vector<BearingObservation> obs = Observations(*fr, io.sigma_bearing);
  double survey = 0.0;
  for (int i : tri.inliers) survey += SurveySigma(*fr->predicted[static_cast<size_t>(obs[static_cast<size_t>(i)].id)].landmark);
  survey /= std::max<size_t>(1, tri.inliers.size());
  // The position error the map allows: its survey error, or the error
  // this frame's residuals show across the landmarks' distances, whichever
  // is larger (with few landmarks at similar distances the image's and the
  // map's shares of the residuals cannot be told apart, and a map stated
  // exact may not be).
  double sum_squares = 0.0;
  for (int i : tri.inliers) {
    const BearingObservation& o = obs[static_cast<size_t>(i)];
    const double d = (o.landmark - Eigen::Vector2d(tri.pose.x, tri.pose.y)).norm();
    const double r = tri.bearing_residuals[static_cast<size_t>(i)] * d;
    sum_squares += r * r;
  }
  const size_t n = tri.inliers.size();
  const double shown = n > 3 && opt_.survey.check ? std::sqrt(sum_squares / static_cast<double>(n - 3)) : 0.0;
  // The factor on a survey error the map states, or that the residuals
  // have shown for long enough: not on a probe's provisional level (a
  // wrong guess of the start agrees with the map under some error).
  const bool survey_known = errors_.survey.confident() || StatedSurveySigma() > 0.0;
  io.alert_margin = opt_.protection_sigmas * std::max((survey_known ? opt_.alert_survey_factor : 1.0) * survey, shown);
  io.reference_position_std += survey;
  fr->integrity = IntegrityCheck(tri, obs, io);
  // Three bearings always fit a pose: without a spare one nothing is checked.
  return fr->integrity.testable && fr->integrity.consistent && fr->integrity.quality >= opt_.min_quality &&
         fr->integrity.within_alert_limit;
}

bool Localizer::AgreesWithStart(const FrameResult& fr, const TriangulationResult& tri) const {
  if (!opt_.known_start_bounds_first_pose || track_.ever_tracked || !StartGivenAsPose() || !track_.start_time)
    return true;
  // The position only: a map's error turns the heading that fits best by
  // more than the pose's heading deviation shows (0.8 degrees on a 2 cm map).
  const double reach = motion_options_.max_speed * std::max(0.0, track_.time_s - *track_.start_time);
  const Eigen::Matrix2d s = ReportedCovariance(fr, Observations(fr), tri).topLeftCorner<2, 2>() +
                            reach * reach * Eigen::Matrix2d::Identity();
  const Eigen::Vector2d r(tri.pose.x - track_.initial.x, tri.pose.y - track_.initial.y);
  return r.dot(s.ldlt().solve(r)) <= kGateChiSquare2Dof99;
}

bool Localizer::AgreesWithMotion(FrameResult* fr, const TriangulationResult& tri) const {
  if (!motion_.initialized()) return AgreesWithStart(*fr, tri);
  const PoseMeasurement m = MotionMeasurement(*fr, tri);
  fr->innovation = motion_.Innovation(m);
  fr->after_drop = false;
  if (fr->innovation <= opt_.gate_chi2) return true;
  const std::optional<MotionModel> later = AfterDroppedFrame();
  if (!later) return false;
  // A fit there as close as 99 % of right poses fit their prediction (a
  // thinly measured wrong pose passes the wider gate a frame interval on),
  // and more likely there than here by the odds against a dropped frame
  // (kDroppedFrameOdds to one).
  const double innovation = later->Innovation(m);
  if (innovation > StrictGate() || fr->innovation - innovation < 2.0 * std::log(kDroppedFrameOdds))
    return false;
  fr->innovation = innovation;
  fr->after_drop = true;
  return true;
}

bool Localizer::ResumesTrack(const FrameResult& fr, const TriangulationResult& tri, bool under_probe) const {
  // One lost frame only: the model's prediction has widened over a frame
  // interval, not over a loss (after several, a wrong pose nearby fits it).
  // It must fit within the 99 % gate of three degrees of freedom, on most
  // of what the frame found.
  return opt_.resume_after_lost_frame && !under_probe && track_.n_lost == 1 && SparselySupported(fr, tri) &&
         ModelVouchesFor(fr, tri);
}

bool Localizer::ModelVouchesFor(const FrameResult& fr, const TriangulationResult& tri) const {
  return track_.ever_tracked && track_.motion_updates >= 2 && motion_.initialized() &&
         motion_.Innovation(MotionMeasurement(fr, tri)) <= StrictGate();
}

std::optional<MotionModel> Localizer::AfterDroppedFrame() const {
  // Only right after a tracked frame: after a lost one the prediction has
  // widened over the loss, and a wrong pose passes the gate a frame later.
  if (!opt_.dropped_frames || !track_.motion_stepped || track_.odometry_predicted || !opt_.constant_velocity ||
      track_.motion_updates < 2 || track_.n_lost > 0 || !(track_.last_dt > 0.0) ||
      !track_.before_prediction.initialized())
    return std::nullopt;
  MotionModel later = track_.before_prediction;
  later.Predict(motion_.time() + track_.last_dt);
  return later;
}

bool Localizer::SurveyEvidence(const FrameResult& fr, const TriangulationResult& tri) const {
  if (!tri.ok || static_cast<int>(tri.inliers.size()) < opt_.relocalize_min_landmarks + 2 || !Acceptable(fr, tri))
    return false;
  if (!motion_.initialized()) return AgreesWithStart(fr, tri);
  return motion_.Innovation(MotionMeasurement(fr, tri)) <= opt_.gate_chi2;
}

double Localizer::StatedSurveySigma() const {
  return std::isnan(opt_.survey_sigma) ? map_.survey_sigma : opt_.survey_sigma;
}

double Localizer::ShownSurveySigma() const {
  const double stated = StatedSurveySigma();
  const double used = errors_.survey.Sigma(stated);
  if (std::isnan(stated)) return errors_.survey.confident() ? errors_.survey.estimated() : std::nan("");
  return used > 1.5 * stated ? errors_.survey.estimated() : std::nan("");
}

bool Localizer::ProbeSurveyError(const Pose2& pred, double widest, Pose2* found) {
  // A ladder of survey errors: the levels under which the frame's bearings
  // agree (a map error makes them miss an exact map's narrow tolerance, or
  // its search windows, by a few of its sigmas). Most of what is found must
  // agree: a wrong pose fits a few bearings within a wide tolerance, not
  // most of them. Of those levels, the smallest that lets nearly as many
  // bearings agree as any: below the map's error a subset of the bearings
  // agrees on a pose off by it (a start centimetres off that later frames
  // keep), above it no more agree, only wrong ones fit more easily.
  const double current = LargestSurveySigma();
  struct Level {
    double sigma;
    size_t inliers = 0;  // 0: its bearings did not agree
    Pose2 from;          // ... tracked from there
    Pose2 solved;        // its solution from the prediction
  };
  std::vector<Level> levels;
  for (double fraction : {0.0025, 0.005, 0.01, 0.02, opt_.survey.max_fraction}) {
    const double level = fraction * errors_.typical_distance;
    if (level <= 1.5 * current || level > widest || (errors_.statement_verified && level > StatementBound()))
      continue;
    levels.push_back({level, 0, pred, pred});
  }
  // The frame tracked from `from` under `level`: its inliers where they agree.
  const auto agreeing_under = [&](Level* level, const Pose2& from) -> Pose2 {
    reloc_.probe_sigma = level->sigma;
    // The walls of that error (corners behind them in view), but the
    // landmarks of the error assumed: a longer list under a wide tolerance
    // lets a wrong pose gather the evidence of a right one.
    UpdatePrediction();
    FrameResult fr;
    fr.predicted_pose = pred;
    TriangulationResult tri;
    TrackPredictions(from, &fr, &tri);
    RefineAroundSolution(&fr, &tri);
    const size_t n_found = static_cast<size_t>(FoundLandmarks(fr));
    const bool agree = SurveyEvidence(fr, tri) && Consistent(&fr, tri) && 3 * tri.inliers.size() >= 2 * n_found;
    if (agree && tri.inliers.size() > level->inliers) {
      level->inliers = tri.inliers.size();
      level->from = from;
    }
    return tri.pose;
  };
  for (Level& level : levels) level.solved = agreeing_under(&level, pred);
  // A prediction off by more than the narrow levels' windows reach (a
  // dropped frame, a sudden turn) agrees only under a wide one, whose
  // tolerance lets wrong edges in: the narrower levels are tried again from
  // the best supported consensus, and where as many agree there, the map's
  // error is no larger than theirs.
  const auto fewer = [](const Level& a, const Level& b) { return a.inliers < b.inliers; };
  const auto best = std::max_element(levels.begin(), levels.end(), fewer);
  if (opt_.survey.probe_from_consensus && best != levels.end() && best->inliers > 0) {
    for (auto level = levels.begin(); level != best; ++level) agreeing_under(&*level, best->solved);
  }
  reloc_.probe_sigma = 0.0;
  const auto most_agreeing = std::max_element(levels.begin(), levels.end(), fewer);
  const size_t most = most_agreeing == levels.end() ? 0 : most_agreeing->inliers;
  for (const Level& level : levels)
    if (level.inliers > 0 && static_cast<double>(level.inliers) >= kProbeSaturation * static_cast<double>(most)) {
      errors_.survey.Provisional(level.sigma);
      if (found) *found = level.from;
      break;
    }
  UpdateLandmarkBudget();
  return most > 0;
}

Eigen::Matrix3d Localizer::ReportedCovariance(const FrameResult& fr, const std::vector<BearingObservation>& obs,
                                              const TriangulationResult& tri) const {
  // The image's share: the recent noise with a margin (a tracker's bias
  // on an edge lasts for frames, which the frame's residuals do not show;
  // the consensus's reference before there is any noise seen).
  const double reference = errors_.bearing_sigma > 0 ? kReportedNoiseMargin * errors_.bearing_sigma : ReferenceSigma();
  Eigen::Matrix3d info = Eigen::Matrix3d::Zero();
  for (int i : tri.inliers) {
    const BearingObservation& o = obs[static_cast<size_t>(i)];
    const Landmark& l = *fr.predicted[static_cast<size_t>(o.id)].landmark;
    const double d = std::max((o.landmark - Eigen::Vector2d(tri.pose.x, tri.pose.y)).norm(), 1e-9);
    // The corner's reported survey sigma (its statement as SurveySigma
    // takes it, with the estimate's margin where only the estimate
    // decides), never below the one weighed by.
    const double statement = StatedSurveySigma(l);
    const double survey = std::max(SurveySigma(l), errors_.survey.ReportedSigma(statement));
    // The weight without its spread (Observations), over the full variance.
    const double weight = o.weight * o.spread * o.spread;
    Eigen::Vector3d j;
    BearingResidual(o, tri.pose, &j);
    info += weight / (reference * reference + (survey / d) * (survey / d)) * j * j.transpose();
  }
  const Eigen::FullPivLU<Eigen::Matrix3d> lu(info);
  if (!lu.isInvertible()) return tri.covariance;
  const Eigen::Matrix3d predicted = lu.inverse();
  // The larger of the two, by the position's largest variance.
  const auto largest = [](const Eigen::Matrix3d& c) {
    return Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(c.topLeftCorner<2, 2>()).eigenvalues().maxCoeff();
  };
  return largest(predicted) > largest(tri.covariance) ? predicted : tri.covariance;
}

bool Localizer::PartialBeforeSurvey(const FrameResult& fr, const TriangulationResult& tri) const {
  if (!opt_.survey.check || errors_.survey.confident()) return false;
  const bool first_from_hint = !track_.ever_tracked && track_.start_is_hint;
  const bool stated_exact = StatedSurveySigma() == 0.0;
  if (!first_from_hint && !stated_exact) return false;
  const int n_found = FoundLandmarks(fr);
  const int inliers = static_cast<int>(tri.inliers.size());
  if (first_from_hint && 2 * inliers < n_found) return true;
  // A map stated exact allows the image noise alone: fewer left out are a
  // sign of its error too (a search's pose held has its own rules:
  // ConfirmHeldPose).
  if (reloc_.held || !stated_exact) return false;
  const int left_out = n_found - inliers;
  if (left_out <= 0) return false;
  const bool many_left_out = 6 * left_out > n_found;
  const bool weak = !Corroborated(fr, tri);
  if (first_from_hint) return many_left_out || weak;
  // Later, both signs on a consensus smaller than the landmarks an exact
  // map tracks: a pose that many bearings agree on is not a chance subset's
  // (nor is a twin of the room that leaves few of those it found out,
  // which the survey probe would fit under a wider error).
  return many_left_out && weak && inliers < opt_.max_landmarks;
}

double Localizer::SurveyShownBy(const FrameResult& fr, const TriangulationResult& tri) {
  const LearnedSurvey before{errors_.survey, errors_.bearing_sigma};
  UpdateBearingNoise(Observations(fr), tri);
  UpdateSurveyEstimate(fr, tri);
  const double shown = errors_.survey.Early();
  RestoreSurvey(before);
  return shown;
}

double Localizer::HeldSurveyBound() const {
  return std::max(kHeldSurveyScatter * LargestSurveySigma(), WidestSearchSurveySigma());
}

bool Localizer::RetrackUnderShownSurvey(FrameResult* fr, TriangulationResult* tri) {
  // What this frame would teach, from the solution reported.
  const double assumed = MeanSurveySigma();
  const double shown = SurveyShownBy(*fr, *tri);
  const double level = errors_.statement_verified ? std::min(shown, StatementBound()) : shown;
  if (!(level > 1.5 * assumed)) return false;
  errors_.survey.Provisional(level);
  UpdateLandmarkBudget();
  // (Never a relocalised frame: Process does not call this for one.)
  FrameResult again = FrameToMeasure(fr->row, fr->predicted_pose);
  TriangulationResult solved;
  TrackPredictions(tri->pose, &again, &solved);
  RefineAroundSolution(&again, &solved);
  // The wider tolerance is to take back bearings the map's error left out,
  // not to trade them for fewer: a retrack fitting fewer has let in a wrong
  // edge that pulls the pose (its tolerance grown from this frame's own
  // residuals), and the frame keeps its solution.
  const bool accepted = Acceptable(again, solved) && Consistent(&again, solved) &&
                        (AgreesWithMotion(&again, solved) || Corroborated(again, solved)) &&
                        solved.inliers.size() >= tri->inliers.size();
  if (!accepted) return false;
  *fr = std::move(again);
  *tri = solved;
  return true;
}

double Localizer::StatementBound() const {
  return std::max(kStatementDoubt * errors_.survey.StatedSigma(StatedSurveySigma()),
                  opt_.survey.doubt_fraction * errors_.typical_distance);
}

bool Localizer::StatementInDoubt() const {
  return opt_.survey.check && opt_.survey.recheck_statement && errors_.survey.provisional() > StatementBound();
}

Localizer::LearnedSurvey Localizer::AssumeStatementOnly() {
  LearnedSurvey learned{errors_.survey, errors_.bearing_sigma};
  const int budget = errors_.max_landmarks;
  errors_.survey.Reset();
  errors_.bearing_sigma = 0.0;
  UpdateLandmarkBudget();
  // The landmarks the error learned tracks: under a narrower budget the
  // few nearest agree on a map centimetres off as well.
  errors_.max_landmarks = budget;
  return learned;
}

void Localizer::RestoreSurvey(const LearnedSurvey& learned) {
  errors_.survey = learned.survey;
  errors_.bearing_sigma = learned.bearing_sigma;
  UpdateLandmarkBudget();
}

bool Localizer::AgreesUnderStatement(const FrameResult& fr, const TriangulationResult& tri, FrameResult* again,
                                     TriangulationResult* solved, double* apart) {
  *apart = std::numeric_limits<double>::infinity();
  *again = FrameToMeasure(fr.row, fr.predicted_pose);
  TrackPredictions(tri.pose, again, solved);
  RefineAroundSolution(again, solved);
  // Most of what it finds agrees, as large a share as under the error
  // learned (a narrower tolerance finds fewer landmarks in view).
  const double found = FoundLandmarks(*again);
  const double inliers = static_cast<double>(solved->inliers.size());
  if (!(SurveyEvidence(*again, *solved) && Consistent(again, *solved) && 3.0 * inliers >= 2.0 * found &&
        inliers * FoundLandmarks(fr) >= kProbeSaturation * static_cast<double>(tri.inliers.size()) * found))
    return false;
  // How far apart the two poses lie, in their combined standard deviations.
  const Eigen::Vector2d between(solved->pose.x - tri.pose.x, solved->pose.y - tri.pose.y);
  const Eigen::Matrix2d both = tri.covariance.topLeftCorner<2, 2>() + solved->covariance.topLeftCorner<2, 2>();
  const Eigen::FullPivLU<Eigen::Matrix2d> lu(both);
  if (lu.isInvertible()) *apart = std::sqrt(std::max(0.0, between.dot(lu.solve(between))));
  return true;
}

bool Localizer::RetrackUnderStatedSurvey(FrameResult* fr, TriangulationResult* tri, const LearnedSurvey& at_begin) {
  errors_.statement_supports_hold = false;
  if (track_.frame < errors_.next_statement_check || !StatementInDoubt()) return false;
  const LearnedSurvey learned = AssumeStatementOnly();
  FrameResult again;
  TriangulationResult solved;
  double apart = 0.0;
  const bool shares = AgreesUnderStatement(*fr, *tri, &again, &solved, &apart);
  // On the same pose: the same edges' errors are in both solutions, so
  // agreeing ones lie within their combined deviations of each other (a
  // map 2 cm off, stated exact, lets a subset agree under the statement on
  // a pose 1.3 - 6 of them away).
  const bool agrees = shares && apart <= kStatementApart;
  errors_.statement_supports_hold = shares && apart <= kStatementHoldApart;
  // Two tracked frames in a row: one with few landmarks in view may agree
  // under a tolerance narrower than the map's error by chance.
  if (agrees && ++errors_.statement_agreements >= kStatementFrames) {
    errors_.statement_agreements = 0;
    errors_.statement_check_gap = 1;
    errors_.statement_verified = true;
    *fr = std::move(again);
    *tri = solved;
    return true;
  }
  // Clearly more bearings agreeing under the narrower tolerance, on a pose
  // apart: the wider one let a wrong edge pull this frame's pose off the
  // consensus (a map off by more than it states leaves a subset agreeing
  // under the statement, not more), and its residuals taught the estimate
  // an error the map does not have.
  const bool outvoted = opt_.survey.statement_outvotes && shares && !agrees &&
                        ClearlyBetterSupported(static_cast<int>(solved.inliers.size()),
                                               static_cast<int>(tri->inliers.size())) &&
                        AgreesWithMotion(&again, solved);
  if (outvoted) {
    RestoreSurvey(at_begin);
    errors_.statement_agreements = 0;
    errors_.next_statement_check = track_.frame + 1;
    *fr = std::move(again);
    *tri = solved;
    return true;
  }
  RestoreSurvey(learned);
  if (agrees) {
    errors_.next_statement_check = track_.frame + 1;
  } else {
    errors_.statement_agreements = 0;
    errors_.next_statement_check = track_.frame + errors_.statement_check_gap;
    errors_.statement_check_gap = std::min(2 * errors_.statement_check_gap, kStatementCheckMaxGap);
  }
  return false;
}

void Localizer::CheckFrame(const cv::Mat& grey, int frame) const {
  if (!track_.started) throw Error("localiser: Process() before Reset()");
  if (grey.type() != CV_8UC1 || grey.cols != calib_.sensor.image_width ||
      grey.rows != calib_.sensor.image_height)
    throw Error("frame " + std::to_string(frame) + ": expected an 8-bit grey image of " +
                std::to_string(calib_.sensor.image_width) + "x" +
                std::to_string(calib_.sensor.image_height));
}

Pose2 Localizer::PredictMotion(double time_s, const OdometryIncrement* odometry) {
  if (!motion_.initialized()) return track_.last;  // the start pose, or the last one before a loss
  const double t =
      std::isfinite(time_s) ? std::max(MotionClock(time_s), motion_.time()) : motion_.time() + track_.last_dt;
  const double dt = t - motion_.time();
  // The frame interval: the shortest recent step (a dropped frame is longer).
  if (dt > 0) track_.last_dt = track_.last_dt > 0 && dt > track_.last_dt ? 0.95 * track_.last_dt + 0.05 * dt : dt;
  track_.before_prediction = motion_;
  track_.odometry_predicted = odometry != nullptr;
  if (odometry)
    motion_.PredictWithOdometry(t, *odometry);
  else
    motion_.Predict(t);
  track_.motion_stepped = true;
  const Eigen::Vector2d v = motion_.PredictedVelocity();
  track_.frame_motion =
      Pose2{v.x() * track_.last_dt, v.y() * track_.last_dt, motion_.PredictedHeadingRate() * track_.last_dt};
  // The velocity is known after two poses, and stays so over short losses.
  return (opt_.constant_velocity && track_.motion_updates >= 2) || odometry ? motion_.pose() : track_.last;
}

std::optional<double> Localizer::CompassHeading(const std::vector<float>& signature) const {
  // From a held search pose too: its frame's signature was kept with it, and
  // the turn since that frame is what tracking from it must follow.
  if (!opt_.compass || heading_.last_signature.empty() || !(track_.ever_tracked || reloc_.held)) return std::nullopt;
  double score;
  const double turn = compass_.Rotation(heading_.last_signature, signature, opt_.compass_max_rotation, &score);
  if (score < opt_.compass_min_score) return std::nullopt;
  return WrapAngle(heading_.signature_heading + turn);
}

std::optional<Pose2> Localizer::CompassPose(const Pose2& pred) const {
  if (!heading_.compass_heading || std::abs(WrapAngle(*heading_.compass_heading - pred.theta)) <= 0.5 * M_PI / 180)
    return std::nullopt;
  Pose2 by_compass = pred;
  by_compass.theta = *heading_.compass_heading;
  return by_compass;
}

void Localizer::ForgetCompassHistory() {
  heading_.last_signature.clear();
  ForgetCompassRecord();
}

void Localizer::ForgetCompassRecord() {
  heading_.model_error = heading_.compass_error = -1.0;
  heading_.error_frames = 0;
}

bool Localizer::CompassFirst(const Pose2& pred, const Pose2& by_compass) const {
  // Translation biases the compass by a few degrees in a small room: it
  // goes first only where it has been the better guide.
  return heading_.error_frames >= 10 && heading_.compass_error < 0.5 * heading_.model_error &&
         std::abs(WrapAngle(by_compass.theta - pred.theta)) > opt_.compass_first_turn;
}

void Localizer::UpdatePredictionErrors(const Pose2& model_pred, const FrameResult& fr,
                                       const TriangulationResult& tri) {
  if (!heading_.compass_heading || fr.relocalized) return;
  auto update = [](double* mean, double error) { *mean = *mean < 0 ? error : 0.9 * *mean + 0.1 * error; };
  update(&heading_.model_error, std::abs(WrapAngle(tri.pose.theta - model_pred.theta)));
  update(&heading_.compass_error, std::abs(WrapAngle(tri.pose.theta - *heading_.compass_heading)));
  ++heading_.error_frames;
}

void Localizer::TrackPredictions(const Pose2 pred, FrameResult* fr, TriangulationResult* tri) const {
  // `pred` by value: the caller passes fr->predicted_pose, which this sets.
  const double search =
      std::min(opt_.max_search_px, opt_.search_px * std::pow(opt_.lost_search_growth, std::min(track_.n_lost, 8)));
  // The visual compass measures the turn since the last frame from the
  // images. Translation biases it by a few degrees in a small room, so the
  // motion model's prediction goes first and the compass's heading is
  // tried when that fails: it keeps sudden turns in view. Where the compass
  // has been the better guide and the two disagree by a turn the model's
  // windows would miss, the compass goes first (CompassFirst).
  std::vector<Pose2> predictions{pred};
  const std::optional<Pose2> by_compass = CompassPose(pred);
  const bool compass_first = by_compass && CompassFirst(pred, *by_compass);
  fr->compass_first = compass_first;
  if (by_compass) predictions.insert(compass_first ? predictions.begin() : predictions.end(), *by_compass);
  // A pose found from the compass's heading that lies nearer the model's
  // (the compass misled) is kept only when the model's finds none.
  std::optional<std::pair<FrameResult, TriangulationResult>> misled;
  // Measured from the compass's heading, the edges are blurred by the turn
  // it measured (a robot that begins to spin: the model's turn is none).
  const std::optional<Pose2> compass_motion = by_compass ? SolvedMotion(*by_compass) : std::nullopt;
  const auto blur_motion = [&](const Pose2& p) -> const Pose2* {
    return compass_motion && p.theta == by_compass->theta ? &*compass_motion : nullptr;
  };
  for (const Pose2& p : predictions) {
    Measure(p, search, fr, blur_motion(p), false, false, true);
    *tri = Solve(*fr, p);
    if (!Acceptable(*fr, *tri)) continue;
    fr->predicted_pose = p;
    if (compass_first && &p == &predictions.front() &&
        std::abs(WrapAngle(tri->pose.theta - p.theta)) > std::abs(WrapAngle(tri->pose.theta - pred.theta))) {
      misled.emplace(*fr, *tri);
      continue;
    }
    return;
  }
  if (misled) {
    *fr = std::move(misled->first);
    *tri = misled->second;
    return;
  }
  // A sudden lurch moves the edges beyond the search: widen it within the
  // same frame before declaring the frame lost.
  for (double wider = 2.0 * search; !Acceptable(*fr, *tri) && wider <= 2.0 * opt_.max_search_px;
       wider *= 2.0) {
    for (const Pose2& p : predictions) {
      Measure(p, wider, fr, blur_motion(p), false, false, true);
      *tri = Solve(*fr, p);
      if (Acceptable(*fr, *tri)) break;
    }
  }
  // The map's polarities found nothing usable and no frame has confirmed
  // them yet (its shades may be wrong): search either polarity.
  if (Acceptable(*fr, *tri) || !EitherFallbackUseful()) return;
  for (double width : {search, 2.0 * opt_.max_search_px})
    for (const Pose2& p : predictions) {
      Measure(p, width, fr, blur_motion(p), true, false, true);
      *tri = Solve(*fr, p);
      if (Acceptable(*fr, *tri)) {
        fr->predicted_pose = p;
        return;
      }
    }
}

std::optional<Pose2> Localizer::SolvedMotion(const Pose2& pose) const {
  if (!track_.ever_tracked || track_.n_lost > 0) return std::nullopt;
  const double k = track_.frame_intervals;
  return Pose2{(pose.x - track_.frame_pose.x) / k, (pose.y - track_.frame_pose.y) / k,
               WrapAngle(pose.theta - track_.frame_pose.theta) / k};
}

double Localizer::MaxShiftPx(const FrameResult& fr) {
  double max_shift = 0.0;
  for (size_t i = 0; i < fr.predicted.size(); ++i)
    if (fr.measurements[i].found)
      max_shift = std::max(max_shift, std::abs(WrapAngle(fr.measurements[i].azimuth - fr.predicted[i].azimuth)) *
                                          fr.predicted[i].corner_radius);
  return max_shift;
}

bool Localizer::CoarseToFineUseful() const {
  return tracker_->MeasuresAzimuthCheaply() && opt_.refine_passes > 0 && track_.n_lost == 0 &&
         images_.recentre_rate > opt_.coarse_to_fine_rate;
}

bool Localizer::TrackCoarseToFine(const Pose2 pred, FrameResult* fr, TriangulationResult* tri,
                                  bool* recentred) const {
  const std::optional<Pose2> by_compass = CompassPose(pred);
  const bool compass_first = by_compass && CompassFirst(pred, *by_compass);
  const Pose2 start = compass_first ? *by_compass : pred;
  FrameResult coarse;
  Measure(start, opt_.search_px, &coarse, nullptr, false, true, true);
  const TriangulationResult first = Solve(coarse, start);
  if (!Acceptable(coarse, first)) return false;
  *recentred = MaxShiftPx(coarse) > opt_.refine_threshold_px;
  const std::optional<Pose2> solved = SolvedMotion(first.pose);
  Measure(first.pose, opt_.refine_search_px, fr, solved ? &*solved : nullptr, false, false, true);
  *tri = Solve(*fr, first.pose);
  if (!Acceptable(*fr, *tri)) return false;
  fr->predicted_pose = start;
  fr->compass_first = compass_first;
  fr->coarse_to_fine = true;
  return true;
}

bool Localizer::RefineAroundSolution(FrameResult* fr, TriangulationResult* tri) const {
  // How far the found landmarks lie from their predictions (px).
  const double max_shift = MaxShiftPx(*fr);
  double max_radius = 0.0;
  for (const PredictedLandmark& p : fr->predicted) max_radius = std::max(max_radius, p.corner_radius);
  // A turn faster or slower than the measurement assumed (the motion
  // model's, or a first pass's) blurs the edges more or less than the
  // search allowed for: measure again with the solved motion.
  std::optional<Pose2> solved = SolvedMotion(tri->pose);
  const double assumed_turn = fr->blur_turn.value_or(track_.frame_motion.theta);
  const double turn_error = solved ? std::abs(WrapAngle(solved->theta - assumed_turn)) : 0.0;
  const bool blur_mispredicted = turn_error * max_radius * images_.blur_fraction > opt_.refine_threshold_px;
  const bool off_centre = max_shift > opt_.refine_threshold_px || blur_mispredicted;
  for (int pass = 0; pass < opt_.refine_passes && off_centre && Acceptable(*fr, *tri); ++pass) {
    FrameResult again;
    solved = SolvedMotion(tri->pose);
    Measure(tri->pose, opt_.refine_search_px, &again, solved ? &*solved : nullptr, fr->either_polarity, false,
            fr->from_prediction);
    TriangulationResult tri2 = Solve(again, tri->pose);
    if (!Acceptable(again, tri2)) break;
    TakeMeasurements(&again, fr);
    fr->refined = true;
    *tri = tri2;
  }
  return off_centre;
}

bool Localizer::ViewUnlikePrediction(const FrameResult& fr, const TriangulationResult& tri) const {
  if (!(opt_.relocalize_unseen_fraction > 0)) return false;
  const size_t chosen = static_cast<size_t>(ChosenLandmarks(fr));
  int found = 0;
  for (size_t i = 0; i < chosen && i < fr.measurements.size(); ++i) found += fr.measurements[i].found;
  if (found < opt_.relocalize_unseen_fraction * static_cast<double>(chosen)) return true;
  // Corner-like responses elsewhere fit a pose (a few, never an acceptable
  // one) that the motion so far rules out.
  if (!tri.ok || Acceptable(fr, tri) || !motion_.initialized()) return false;
  return motion_.Innovation(MotionMeasurement(fr, tri)) > opt_.gate_chi2;
}

bool Localizer::RelocalizeIfLost(const cv::Mat& grey, int frame, bool at_once, FrameResult* fr,
                                 TriangulationResult* tri, bool* under_probe, bool* sparse_lead) {
  *under_probe = *sparse_lead = false;
  // Before the first pose (no start, or a start the frames did not confirm)
  // at once; later after relocalize_after lost frames (at once when the
  // view is not the predicted one), then less and less often while it
  // keeps failing: a search that finds a pose (held for the next frame to
  // confirm) shows the room in view, and the schedule starts again.
  const bool due = track_.ever_tracked
                       ? opt_.relocalize_after > 0 && (track_.n_lost + 1 >= opt_.relocalize_after || at_once)
                       : opt_.relocalize_after > 0 || !StartGivenAsPose();
  if (!due || frame < reloc_.next_frame) return false;
  FrameResult found;
  TriangulationResult t;
  reloc_.survey_evidence.reset();
  bool relocalized = Relocalize(grey, !at_once, &found, &t, nullptr, true);
  *sparse_lead = relocalized && reloc_.sparse_lead;
  if (reloc_.survey_evidence) UpdateSurveyEstimate(reloc_.survey_evidence->first, reloc_.survey_evidence->second);
  reloc_.survey_evidence.reset();
  if (!relocalized && !track_.ever_tracked && opt_.relocalize_survey_probe && opt_.survey.check &&
      !errors_.survey.confident())
    relocalized = *under_probe = RelocalizeUnderProbe(grey, !at_once, &found, &t);
  if (!relocalized) {
    ++reloc_.failures;
    reloc_.next_frame = BackedOffRelocalizeFrame(frame);
    return false;
  }
  reloc_.failures = 0;
  AdoptSearchResult({std::move(found), t}, fr, tri);
  return true;
}

double Localizer::WidestSearchSurveySigma() const {
  return kSearchProbeFractions[std::size(kSearchProbeFractions) - 1] * errors_.typical_distance;
}

bool Localizer::RelocalizeUnderProbe(const cv::Mat& grey, bool near_last, FrameResult* fr, TriangulationResult* tri) {
  // As ProbeSurveyError's ladder, the smallest level that verifies a pose:
  // a wrong pose fits a few bearings more easily the wider the tolerance.
  const double current = LargestSurveySigma();
  bool found = false;
  for (double fraction : kSearchProbeFractions) {
    const double level = fraction * errors_.typical_distance;
    if (level <= 1.5 * current) continue;
    reloc_.probe_sigma = level;
    UpdatePrediction();
    found = Relocalize(grey, near_last, fr, tri);
    reloc_.probe_sigma = 0.0;
    UpdatePrediction();
    if (found) {
      errors_.survey.Provisional(level);
      UpdateLandmarkBudget();
      break;
    }
  }
  reloc_.survey_evidence.reset();
  return found;
}

void Localizer::AdoptSearchResult(SearchResult&& found, FrameResult* fr, TriangulationResult* tri) {
  TakeMeasurements(&found.first, fr);
  fr->integrity = found.first.integrity;
  fr->innovation = -1.0;
  fr->relocalized = true;
  *tri = found.second;
  track_.n_good = 0;  // no velocity across the jump
}

namespace {

// Of `predicted` landmarks, those within a per-frame budget (0: all).
double WithinBudget(size_t predicted, int budget) {
  return static_cast<double>(budget > 0 ? std::min<size_t>(predicted, static_cast<size_t>(budget)) : predicted);
}

}  // namespace

double Localizer::ChosenLandmarks(const FrameResult& fr) const {
  // More are tracked when few of the chosen ones are found.
  return WithinBudget(fr.predicted.size(), opt_.max_landmarks);
}

int Localizer::BackedOffRelocalizeFrame(int frame) const {
  // No pose to track from: every frame is a chance (relocalize_eager_searches).
  if (!track_.ever_tracked && reloc_.failures <= opt_.relocalize_eager_searches) return frame + 1;
  return frame + std::min(opt_.relocalize_max_interval, 1 << std::clamp(reloc_.failures - 2, 0, 16));
}

bool Localizer::EnoughForRelocalized(const FrameResult& fr, const TriangulationResult& tri) const {
  const int inliers = static_cast<int>(tri.inliers.size());
  // Of all the landmarks the search tracked: a wrong pose finds a few
  // within a survey error's wide tolerance more easily than an exact map's.
  if (inliers < opt_.relocalize_min_landmarks || inliers < opt_.relocalize_min_fraction * ChosenToTrack(fr))
    return false;
  // Where the survey error widens every tolerance, wrong correspondences
  // fit too: most of what was found must agree (a confirmed fraction).
  if (!SurveyLimits()) return true;
  return inliers >= opt_.relocalize_confirmed_fraction * FoundLandmarks(fr);
}

double Localizer::SurveyChosenLandmarks(const FrameResult& fr) const {
  return WithinBudget(fr.predicted.size(), MaxLandmarks());
}

bool Localizer::FewChosenBeforeSurvey(const FrameResult& fr, const TriangulationResult& tri,
                                      double fraction) const {
  return opt_.survey.check && !errors_.survey.confident() && ChosenInliers(fr, tri) < fraction * ChosenToTrack(fr);
}

bool Localizer::Corroborated(const FrameResult& fr, const TriangulationResult& tri, double fraction) const {
  // The motion model cannot vouch for it: after a loss its prediction is
  // too wide to tell a right pose from a wrong one nearby.
  return static_cast<double>(tri.inliers.size()) >= fraction * ChosenToTrack(fr);
}

Localizer::RoomSearch Localizer::SearchRoomAgainst(const cv::Mat& grey, const FrameResult& fr,
                                                   const TriangulationResult& tri) const {
  RoomSearch search;
  FrameResult found;
  TriangulationResult t;
  std::vector<VerifiedPose> verified;
  // Not near the pose checked: it is what is being checked.
  if (Relocalize(grey, false, &found, &t, &verified)) search.chosen.emplace(std::move(found), t);
  search.own = static_cast<int>(tri.inliers.size());
  search.own_residual = tri.residual;
  for (const VerifiedPose& v : verified) {
    if (DistinctPlaces(v.pose, tri.pose)) {
      search.elsewhere.push_back(v);
    } else {
      search.own = std::max(search.own, v.inliers);
      search.own_chosen = std::max(search.own_chosen, v.chosen_inliers);
      search.own_residual = std::min(search.own_residual, v.residual);
    }
  }
  search.refuted = opt_.relocalize_refutes && search.chosen && Refutes(*search.chosen, fr, tri);
  return search;
}

bool Localizer::Refutes(const SearchResult& chosen, const FrameResult& fr, const TriangulationResult& tri) const {
  const TriangulationResult& other = chosen.second;
  if (DistinctPlaces(other.pose, tri.pose) || other.inliers.size() < tri.inliers.size() ||
      ChosenInliers(chosen.first, other) < ChosenInliers(fr, tri) || !(other.residual < tri.residual))
    return false;
  const Eigen::Matrix2d covariance = ReportedCovariance(fr, Observations(fr), tri).topLeftCorner<2, 2>();
  const Eigen::Vector2d apart(other.pose.x - tri.pose.x, other.pose.y - tri.pose.y);
  return apart.dot(covariance.inverse() * apart) > kRefutedChi2;
}

bool Localizer::NoRivalElsewhere(const RoomSearch& search) const {
  // A rival that found few of the landmarks it chose (and tracked more to
  // fit more in all) is outranked on those chosen.
  return std::none_of(search.elsewhere.begin(), search.elsewhere.end(), [&](const VerifiedPose& v) {
    return !Outranks(search.own, search.own_residual, v.inliers, v.residual) &&
           !ClearlyBetterSupported(search.own_chosen, v.chosen_inliers);
  });
}

bool Localizer::DistinctPlaces(const Pose2& a, const Pose2& b) const {
  // Near a room's centre of symmetry its half-turned twin stands within a
  // few centimetres of the true pose: a heading apart is another place.
  return std::hypot(a.x - b.x, a.y - b.y) > opt_.relocalize_distinct * errors_.room_size ||
         std::abs(WrapAngle(a.theta - b.theta)) > kDistinctHeading;
}

bool Localizer::ClearlyBetterSupported(int a, int b) const {
  return a >= b + opt_.relocalize_margin && b < opt_.relocalize_ambiguity * a;
}

bool Localizer::FitsClearlyBetter(int a, double a_residual, int b, double b_residual) const {
  // Residuals of the image noise alone at the typical distance count as a
  // perfect fit: below that no pose fits better than another.
  const double floor = ReferenceSigma() * errors_.typical_distance;
  return std::min(a, b) >= std::max(opt_.relocalize_min_landmarks, kFitComparedBearings) &&
         a >= opt_.relocalize_ambiguity * b && b_residual > kClearlyBetterFit * std::max(a_residual, floor);
}

bool Localizer::BeyondReach(const Pose2& pose, double time_s) const {
  if (!track_.last_known) return false;
  const auto& [known, known_time] = *track_.last_known;
  const double reach = motion_options_.max_speed * std::max(0.0, time_s - known_time) +
                       opt_.relocalize_distinct * errors_.room_size;
  return std::hypot(pose.x - known.x, pose.y - known.y) > reach;
}

bool Localizer::ConfirmsJump(const FrameResult& fr, const TriangulationResult& tri) const {
  return !reloc_.held_jump || !SurveyLimits() || Corroborated(fr, tri, opt_.relocalize_jump_fraction);
}

bool Localizer::WithinReachOfHeld(const FrameResult& fr, const TriangulationResult& tri) const {
  // At a held pose the motion model bounds nothing (it is not started, or
  // at a sparse lead takes the top speed as the velocity's standard
  // deviation): a wrong pose near the held one, fitted under a wide
  // tolerance, would confirm it.
  if (!reloc_.held_frame) return true;
  const HeldFrame& held = *reloc_.held_frame;
  double dt = fr.row.time_s - held.row.time_s;
  if (!std::isfinite(dt)) dt = track_.last_dt;
  if (!(dt >= 0.0)) return true;
  const Eigen::Vector2d moved(tri.pose.x - held.pose.x, tri.pose.y - held.pose.y);
  const double beyond = moved.norm() - motion_options_.max_speed * dt;
  if (beyond <= 0.0) return true;
  const Eigen::Vector2d along = moved.normalized();
  const Eigen::Matrix2d combined =
      (held.covariance + ReportedCovariance(fr, Observations(fr), tri)).topLeftCorner<2, 2>();
  return beyond * beyond <= kGateChiSquare1Dof99 * along.dot(combined * along);
}

void Localizer::HoldForConfirmation(const Pose2& pose, int frame, bool jump) {
  // As from a start pose given as a hint: no velocity, any turn, and a new
  // room-wide search at once if the next frame does not track.
  track_.last = track_.frame_pose = pose;
  track_.frame_motion = Pose2{0, 0, 0};
  track_.known_start = track_.start_is_hint = true;
  track_.ever_tracked = false;
  motion_ = MotionModel(motion_options_);
  track_.motion_updates = 0;
  track_.steady_updates = 0;
  track_.n_good = 0;
  track_.n_lost = 0;  // the confirming frame searches as narrowly as a tracked one
  // The compass starts its record again but keeps the held frame's
  // signature: the turn since it predicts the confirming frame's heading.
  ForgetCompassRecord();
  reloc_.held = true;
  reloc_.held_jump = jump;
  // Held poses that keep failing to confirm back off like failed searches.
  reloc_.next_frame = reloc_.failures >= 3 ? BackedOffRelocalizeFrame(frame) : 0;
}

bool Localizer::VelocityStillKnown() const {
  // Over a loss the velocity random-walks; once its spread nears the top
  // speed, nothing of the motion before is left to keep (and a pose far off
  // would be read as a fast motion there).
  if (!motion_.initialized()) return false;
  const Eigen::Matrix2d velocity = motion_.state().covariance.block<2, 2>(3, 3);
  const double half_top = 0.5 * motion_options_.max_speed;
  return velocity.selfadjointView<Eigen::Lower>().eigenvalues().maxCoeff() < half_top * half_top;
}

void Localizer::KeepMotion(MotionModel&& before, int updates, const FrameResult& fr, const TriangulationResult& tri) {
  motion_ = std::move(before);
  motion_.Update(MotionMeasurement(fr, tri));
  track_.motion_updates = updates + 1;
  track_.steady_updates = 0;
}

void Localizer::FollowSparseLead(MotionModel&& lead_motion, int lead_updates, const FrameResult& fr,
                                 const TriangulationResult& tri) {
  // A lead's first frame starts the model; the frames after it go on with it.
  if (reloc_.sparse_holds > 1 && lead_motion.initialized())
    return KeepMotion(std::move(lead_motion), lead_updates, fr, tri);
  motion_.Reset(MotionClock(fr.row.time_s), tri.pose, MotionMeasurement(fr, tri).covariance,
                motion_options_.max_speed, motion_options_.max_turn_rate);
  track_.motion_updates = 1;
  track_.steady_updates = 0;
}

void Localizer::UpdateBlurEstimate(const FrameResult& fr) {
  // A box ramp of width W seen through optics of width w0 measures about
  // sqrt((0.7 W)^2 + w0^2) between its 15 % and 85 % levels.
  std::vector<double> fractions, still;
  for (size_t i = 0; i < fr.measurements.size(); ++i) {
    const LandmarkMeasurement& m = fr.measurements[i];
    const double motion = fr.predicted[i].full_tangential_motion_px;
    if (!m.found || m.edge_width_px < 0) continue;
    if (motion < 1.0) still.push_back(m.edge_width_px);
    if (motion < 4.0) continue;
    const double w2 = m.edge_width_px * m.edge_width_px - images_.still_edge_width_px * images_.still_edge_width_px;
    fractions.push_back(std::sqrt(std::max(0.0, w2)) / (0.7 * motion));
  }
  auto median = [](std::vector<double> v) {
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    return v[v.size() / 2];
  };
  if (still.size() >= 3) images_.still_edge_width_px = 0.8 * images_.still_edge_width_px + 0.2 * median(still);
  if (fractions.size() >= 3)
    images_.blur_fraction =
        std::clamp(0.5 * images_.blur_fraction + 0.5 * median(fractions), 0.0, opt_.exposure_fraction);
}

void Localizer::UpdateNoiseEstimates(const FrameResult& fr, const TriangulationResult& tri) {
  const std::vector<BearingObservation> obs = Observations(fr);
  UpdateBearingNoise(obs, tri);
  UpdateSurveyEstimate(fr, tri);
  for (int i : tri.inliers) {
    const size_t index = static_cast<size_t>(fr.predicted[static_cast<size_t>(obs[static_cast<size_t>(i)].id)].index);
    errors_.residual_memory[index] = tri.bearing_residuals[static_cast<size_t>(i)];
    errors_.residual_frame[index] = track_.frame;
  }
}

void Localizer::UpdateBearingNoise(const std::vector<BearingObservation>& obs, const TriangulationResult& tri) {
  // The noise from all the bearings (a robust scale, the median absolute
  // residual in units of each one's spread): the inliers' own RMS is
  // trimmed by the threshold it sets. The first frame's from its inliers
  // alone: with no noise known yet its search may have found as many wrong
  // edges as right ones, which would set every later threshold far too
  // wide.
  std::vector<double> abs_residuals;
  if (errors_.bearing_sigma > 0) {
    for (size_t i = 0; i < obs.size() && i < tri.bearing_residuals.size(); ++i)
      abs_residuals.push_back(std::abs(tri.bearing_residuals[i]) / obs[i].spread);
  } else {
    for (int i : tri.inliers)
      abs_residuals.push_back(std::abs(tri.bearing_residuals[static_cast<size_t>(i)]) / obs[static_cast<size_t>(i)].spread);
  }
  if (!abs_residuals.empty()) {
    std::nth_element(abs_residuals.begin(), abs_residuals.begin() + abs_residuals.size() / 2, abs_residuals.end());
    const double scale = 1.4826 * abs_residuals[abs_residuals.size() / 2];
    errors_.bearing_sigma = errors_.bearing_sigma > 0 ? 0.9 * errors_.bearing_sigma + 0.1 * scale : scale;
  }
}

void Localizer::UpdateSurveyEstimate(const FrameResult& fr, const TriangulationResult& tri) {
  // The tolerances of the survey error assumed cut the residuals of a
  // larger one short: the map error they do not admit is then seen
  // nowhere, and the estimate stays low. The residuals are taken from the
  // pose solved again under twice the survey error assumed, at least a
  // careful tape survey's (the unstated default).
  // (Not once a map taken as exact has shown nothing for a while: the
  // second solve of every frame would only confirm it.)
  const double assumed = MeanSurveySigma();
  const bool settled_exact =
      errors_.survey.confident() && assumed == 0.0 &&
      errors_.survey.estimated() < 0.5 * opt_.survey.exact_doubt_fraction * errors_.typical_distance;
  reloc_.probe_sigma =
      settled_exact ? 0.0 : std::max(opt_.survey.unstated_fraction * errors_.typical_distance, 2.0 * assumed);
  const std::vector<BearingObservation> obs = Observations(fr);
  TriangulationResult shadowed = settled_exact ? TriangulationResult() : SolveBearings(obs, tri.pose);
  reloc_.probe_sigma = 0.0;
  const TriangulationResult* used = shadowed.ok ? &shadowed : &tri;
  // The survey error the inliers show, one bearing per vertical edge; the
  // image noise alone, from the edges whose two corners were both found.
  // The pose fit absorbs part of each edge's error, the more the more it
  // leans on the edge (a near one most): its leverage, the share of the
  // hat matrix's diagonal of the edge's corners.
  const std::vector<double> leverage = BearingLeverages(obs, *used);
  std::vector<double> residuals, distances, leverages, pairs;
  struct Edge {
    int group;
    double residual;  // its first inlier's
    size_t index;     // in residuals
    Eigen::Vector2d landmark;
    bool paired;
  };
  std::vector<Edge> edges;
  for (size_t k = 0; k < used->inliers.size(); ++k) {
    const BearingObservation& o = obs[static_cast<size_t>(used->inliers[k])];
    const double r = BearingResidual(o, used->pose);
    const auto seen = std::find_if(edges.begin(), edges.end(), [&](const Edge& e) { return e.group == o.group; });
    if (o.group >= 0 && seen != edges.end()) {
      pairs.push_back(r - seen->residual);
      seen->paired = true;
      leverages[seen->index] += leverage[k];
      continue;
    }
    edges.push_back({o.group, r, residuals.size(), o.landmark, false});
    residuals.push_back(r);
    distances.push_back((o.landmark - Eigen::Vector2d(used->pose.x, used->pose.y)).norm());
    leverages.push_back(leverage[k]);
  }
  // The partners measured for this (FrameResult::partners): the other
  // corner of an inlier edge (never one of the frame's landmarks: Measure
  // leaves those out).
  for (size_t i = 0; i < fr.partners.size() && i < fr.partner_measurements.size(); ++i) {
    if (!fr.partner_measurements[i].found) continue;
    BearingObservation o;
    o.landmark = fr.partners[i].landmark->corner.head<2>();
    o.bearing = calib_.sensor.bearing_of_azimuth(fr.partner_measurements[i].azimuth);
    const auto edge = std::find_if(edges.begin(), edges.end(), [&](const Edge& e) {
      return !e.paired && (e.landmark - o.landmark).squaredNorm() < 1e-12;
    });
    if (edge == edges.end()) continue;
    pairs.push_back(BearingResidual(o, used->pose) - edge->residual);
    edge->paired = true;
  }
  errors_.survey.Update(residuals, distances, pairs, 3, leverages);
  UpdateLandmarkBudget();
}

void Localizer::RecordOutcome(FrameResult* fr, const TriangulationResult& tri, bool accepted, int n_found) {
  PoseRow* row = &fr->row;
  const int steady = track_.steady_updates;
  track_.steady_updates = 0;
  if (accepted) {
    const bool without_velocity = WithoutVelocity(*fr);
    const std::vector<BearingObservation> obs = Observations(*fr);
    FillReportedRow(fr, obs, tri);
    // Not reported where one bearing could have pulled it beyond the alert
    // limit; the track goes on from it as from any accepted pose.
    if (without_velocity && !SeparationWithinAlertLimit(*fr, tri)) WithholdReport(fr);
    const PoseMeasurement m = MeasurementOf(tri, obs, opt_.gate_position_fraction, opt_.gate_heading_sigma);
    if (!motion_.initialized()) {
      motion_.Reset(MotionClock(row->time_s), tri.pose, m.covariance, motion_options_.max_speed,
                    motion_options_.max_turn_rate);
      track_.motion_updates = 1;
    } else if (fr->relocalized || fr->innovation > opt_.gate_chi2) {
      motion_.Reinitialize(std::max(MotionClock(row->time_s), motion_.time()), tri.pose, m.covariance);
      track_.motion_updates = 1;
      track_.n_good = 0;  // no velocity across the jump
    } else {
      if (fr->after_drop) {
        // The frame came a frame interval later than its timestamp says.
        motion_ = *AfterDroppedFrame();
        track_.dropped_s += track_.last_dt;
      }
      const MotionState prior = motion_.state();
      std::optional<MotionState> one_frame_later;
      if (const std::optional<MotionModel> later = AfterDroppedFrame()) one_frame_later = later->state();
      motion_.Update(m);
      ++track_.motion_updates;
      if (opt_.report_fused_with_motion) {
        // A frame whose time is in doubt (it may follow a dropped frame)
        // leaves the velocity in doubt for the next frames too.
        const bool on_time = FitsItsOwnTime(*fr, tri.pose, m.covariance, prior, one_frame_later);
        if (!without_velocity && !fr->withheld)
          FuseReportWithMotion(fr, prior, one_frame_later, on_time && steady >= kSteadyUpdatesBeforeFusing);
        track_.steady_updates = on_time ? steady + 1 : 0;
      }
    }
    track_.frame_pose = tri.pose;
    track_.motion_stepped = true;
    UpdateNoiseEstimates(*fr, tri);
    track_.last = tri.pose;
    track_.last_known.emplace(tri.pose, row->time_s);
    reloc_.held_jump = false;
    UpdateBlurEstimate(*fr);
    track_.ever_tracked = true;
    ++track_.n_good;
    track_.n_lost = 0;
    return;
  }
  if (!track_.ever_tracked && track_.known_start && row->frame == 0) {
    // No measurement yet: report the user's initial pose as such.
    row->status = PoseStatus::kInit;
    row->pose = track_.initial;
  } else {
    // Lost: tracking goes on from the motion model's prediction.
    row->status = PoseStatus::kLost;
  }
  row->n_landmarks = n_found;
  row->extra.assign(4, std::nan(""));
  if (BeyondAlertLimitOnly(fr, tri)) {
    // Not reported, but the robot is there: the motion follows it (a turn
    // through a few such frames would otherwise leave the windows behind).
    motion_.Update(MotionMeasurement(*fr, tri));
    ++track_.motion_updates;
    track_.motion_stepped = true;
    track_.frame_pose = track_.last = tri.pose;
    track_.last_known.emplace(tri.pose, row->time_s);
    track_.n_lost = 0;
    return;
  }
  track_.frame_pose = fr->predicted_pose;
  track_.n_good = 0;
  ++track_.n_lost;
}

bool Localizer::FitsItsOwnTime(const FrameResult& fr, const Pose2& pose, const Eigen::Matrix3d& covariance,
                               const MotionState& prior, const std::optional<MotionState>& one_frame_later) const {
  if (fr.after_drop) return false;
  if (!one_frame_later) return true;
  return PoseInnovation(pose, covariance, prior) <= PoseInnovation(pose, covariance, *one_frame_later);
}

void Localizer::FuseReportWithMotion(FrameResult* fr, const MotionState& prior,
                                     const std::optional<MotionState>& one_frame_later, bool time_settled) const {
  // Where the frame's time, or the velocity after one in doubt, may be a
  // frame interval off, the prediction is no better than that step along it.
  MotionState widened = prior;
  if (!time_settled && one_frame_later) {
    const Eigen::Vector3d slip = StepTowardState(prior.pose(), *one_frame_later);
    widened.covariance.topLeftCorner<3, 3>() += slip * slip.transpose();
  }
  PoseMeasurement measured;
  measured.pose = fr->row.pose;
  measured.covariance = fr->covariance;
  const std::optional<PoseMeasurement> fused = FuseWithState(measured, widened, kGateChiSquare3Dof99);
  if (!fused) return;
  fr->row.pose = fused->pose;
  fr->covariance = fused->covariance;
  for (int k = 0; k < 3; ++k) fr->row.extra[static_cast<size_t>(k)] = std::sqrt(std::max(0.0, fr->covariance(k, k)));
}

void Localizer::FillReportedRow(FrameResult* fr, const std::vector<BearingObservation>& obs,
                                const TriangulationResult& tri) const {
  PoseRow* row = &fr->row;
  row->status = PoseStatus::kOk;
  row->pose = tri.pose;
  row->n_landmarks = static_cast<int>(tri.inliers.size());
  row->residual = tri.residual;
  row->extra.clear();
  fr->covariance = ReportedCovariance(*fr, obs, tri);
  for (int k = 0; k < 3; ++k) row->extra.push_back(std::sqrt(std::max(0.0, fr->covariance(k, k))));
  row->extra.push_back(fr->integrity.quality);
}

std::optional<FrameResult> Localizer::ReportConfirmedHold(const HeldFrame& held) {
  FrameResult fr;
  fr.row = held.row;
  fr.predicted_pose = held.pose;
  fr.relocalized = true;
  TriangulationResult tri;
  tracker_->BeginFrame(held.grey);
  const auto supported = [&](const FrameResult& f, const TriangulationResult& t) {
    return EnoughForRelocalized(f, t) || (held.sparse && SparselySupported(f, t));
  };
  if (!TrackFrom(held.pose, opt_.search_px, &fr, &tri, opt_.held_polarity_as_found && held.either) ||
      !Consistent(&fr, tri) || !supported(fr, tri))
    return std::nullopt;
  // Where the survey error it was found under is in doubt (a search's wide
  // tolerance on a blurred frame) and the frame that confirmed it agrees
  // under the map's statement, it is reported only as measured under the
  // statement too. (Where that frame does not agree either, the map may
  // well be as far off as the error learned.)
  if (StatementInDoubt() && errors_.statement_supports_hold) {
    const LearnedSurvey learned = AssumeStatementOnly();
    FrameResult again;
    TriangulationResult solved;
    double apart = 0.0;
    const bool agrees = AgreesUnderStatement(fr, tri, &again, &solved, &apart) && apart <= kStatementHoldApart &&
                        supported(again, solved);
    const bool reported = agrees && SeparationWithinAlertLimit(again, solved);
    if (reported) FinishHeldReport(&again, solved);
    RestoreSurvey(learned);
    if (!reported) return std::nullopt;
    return again;
  }
  if (!SeparationWithinAlertLimit(fr, tri)) return std::nullopt;
  FinishHeldReport(&fr, tri);
  return fr;
}

void Localizer::FinishHeldReport(FrameResult* fr, const TriangulationResult& tri) const {
  fr->relocalized = true;
  fr->triangulation = tri;
  FillReportedRow(fr, Observations(*fr), tri);
  if (view_) fr->row.pose = view_->RobotPose(fr->row.pose);
}

bool Localizer::WithoutVelocity(const FrameResult& fr) const {
  return !motion_.initialized() || fr.relocalized || fr.innovation > opt_.gate_chi2 || track_.motion_updates < 2 ||
         !VelocityStillKnown();
}

bool Localizer::SeparationWithinAlertLimit(const FrameResult& fr, const TriangulationResult& tri) const {
  if (!opt_.separation_without_velocity || !(opt_.alert_fraction > 0.0 || opt_.alert_limit > 0.0)) return true;
  FrameResult checked = fr;
  Consistent(&checked, tri);
  const IntegrityReport& in = checked.integrity;
  const std::vector<BearingObservation> obs = Observations(checked, IntegritySigma());
  return in.protection_level + SolutionSeparation(obs, tri) <= std::min(in.alert_limit, StatedAlertLimit(fr, obs, tri));
}

double Localizer::StatedAlertLimit(const FrameResult& fr, const std::vector<BearingObservation>& obs,
                                   const TriangulationResult& tri) const {
  // Not a survey probe's provisional level, nor the error this frame's own
  // residuals show: one wrong corner among a few bearings widens both by
  // as much as it pulls the pose.
  if (opt_.alert_limit > 0.0 || errors_.survey.confident()) return std::numeric_limits<double>::infinity();
  double stated = 0.0, distance = 0.0;
  for (int i : tri.inliers) {
    const BearingObservation& o = obs[static_cast<size_t>(i)];
    const double sigma = StatedSurveySigma(*fr.predicted[static_cast<size_t>(o.id)].landmark);
    if (!(sigma > 0.0)) return std::numeric_limits<double>::infinity();
    stated += sigma;
    distance += (o.landmark - Eigen::Vector2d(tri.pose.x, tri.pose.y)).norm();
  }
  const double n = static_cast<double>(std::max<size_t>(1, tri.inliers.size()));
  return opt_.alert_fraction * distance / n + opt_.protection_sigmas * opt_.alert_survey_factor * stated / n;
}

void Localizer::WithholdReport(FrameResult* fr) const {
  fr->withheld = true;
  fr->row.status = PoseStatus::kLost;
  fr->row.extra.assign(4, std::nan(""));
  fr->covariance.setZero();
}

bool Localizer::BeyondAlertLimitOnly(FrameResult* fr, const TriangulationResult& tri) const {
  if (!tri.ok || fr->relocalized || fr->unconfirmed || !motion_.initialized()) return false;
  Consistent(fr, tri);  // the report of this solution (the last test may have been another's)
  const IntegrityReport& in = fr->integrity;
  return in.testable && in.consistent &&
         in.quality >= opt_.min_quality && !in.within_alert_limit && Acceptable(*fr, tri) &&
         AgreesWithMotion(fr, tri);
}

// Prediction from the motion model, then the visual compass's heading;
// tracked coarse to fine where it pays, else (or where that is not
// accepted: the azimuths alone misled, under heavy blur) the full way. A
// pose is accepted only when its residuals are consistent and it agrees
// with the motion so far; one the motion model did not expect (a sudden
// stop or turn) only on strong evidence, as a relocalised one.
void Localizer::TrackFromPrediction(double time_s, const OdometryIncrement* odometry,
                                    const std::vector<float>& signature, FrameWork* w) {
  FrameResult& fr = w->fr;
  TriangulationResult& tri = w->tri;
  fr.predicted_pose = w->model_pred = PredictMotion(time_s, odometry);
  heading_.compass_heading = CompassHeading(signature);
  auto acceptable = [&] {
    return Acceptable(fr, tri) && Consistent(&fr, tri) && (AgreesWithMotion(&fr, tri) || Corroborated(fr, tri));
  };
  const Pose2 pred = fr.predicted_pose;
  // A held hypothesis is confirmed on its bearings as they are: leaving
  // out those a wrong pose fits worst would help it pass.
  const auto drop_pulled = [&] {
    if (!reloc_.held) DropPulledBearings(fr, &tri);
  };
  if (CoarseToFineUseful() && TrackCoarseToFine(pred, &fr, &tri, &w->recentred)) {
    RefineAroundSolution(&fr, &tri);
    drop_pulled();
    w->accepted = acceptable();
  }
  // A coarse-to-fine pose that leaves out much of what it found may rest
  // on the wrong edges its azimuths led to: the full pass decides, on
  // more inliers.
  const bool partial = w->accepted && tri.inliers.size() < opt_.relocalize_confirmed_fraction * FoundLandmarks(fr);
  if (!w->accepted || partial) {
    // The coarse-to-fine solution (its integrity report and innovation
    // with it), taken back where the full pass fits no more.
    struct Solution {
      FrameResult fr;
      TriangulationResult tri;
      bool recentred;
    };
    std::optional<Solution> coarse;
    if (partial) coarse = Solution{fr, tri, w->recentred};
    fr = FrameToMeasure(fr.row, pred);
    TrackPredictions(pred, &fr, &tri);
    w->recentred = RefineAroundSolution(&fr, &tri);
    drop_pulled();
    w->accepted = acceptable();
    if (coarse && !(w->accepted && tri.inliers.size() > coarse->tri.inliers.size())) {
      fr = std::move(coarse->fr);
      tri = coarse->tri;
      w->recentred = coarse->recentred;
      w->accepted = true;
    }
  }
  // A frame taken to follow a dropped one is measured again with the blur
  // of one frame interval's motion (the solved motion spans two).
  if (w->accepted && fr.after_drop) {
    track_.frame_intervals = 2;
    RefineAroundSolution(&fr, &tri);
    drop_pulled();
    w->accepted = acceptable();
  }
  // A held relocalised pose is confirmed only on as much evidence as a
  // relocalised pose needs (the frame is nearly the same image).
  // Before the residuals have shown the map's error, it must also find
  // half the landmarks it chose (a wrong pose tracks extra landmarks where
  // few of those are found, and fits some of them).
  // A sparse lead is confirmed by frames in a row that fit it as well.
  if (reloc_.held) {
    w->accepted = w->accepted && WithinReachOfHeld(fr, tri);
    const bool enough = EnoughForRelocalized(fr, tri) && !FewChosenBeforeSurvey(fr, tri, opt_.relocalize_min_fraction);
    if (w->accepted && !enough && reloc_.sparse_holds > 0 && SparselySupported(fr, tri)) {
      w->accepted = reloc_.sparse_holds + 1 >= opt_.relocalize_sparse_frames;
      w->sparse_continues = !w->accepted;
    } else {
      w->accepted = w->accepted && enough;
    }
  }
  // One beyond the robot's reach, where the map's survey error widens
  // every tolerance, stands on its own evidence, on this frame and on
  // every frame tracked from it until one does: a partial twin of the
  // room then tracks as well as the true pose from one frame to the next.
  // So does a sparse lead's frame.
  const bool stands = (w->accepted || w->sparse_continues) && ConfirmsJump(fr, tri) && !PartialBeforeSurvey(fr, tri);
  w->accepted = w->accepted && stands;
  w->sparse_continues = w->sparse_continues && stands;
  if (reloc_.held && !w->accepted && !w->sparse_continues) ++reloc_.failures;
  fr.unconfirmed = w->sparse_continues;
}

// Until the residuals have shown how well the map was measured, a frame
// whose bearings agree on a pose (a consensus of many) but not within the
// survey error assumed teaches it, though it is not reported; where the
// survey probe finds a wider error, the frame is tracked again under it.
// A frame tracked from a held pose is tried under no wider error than
// HeldSurveyBound.
void Localizer::LearnSurveyFromRejected(FrameWork* w) {
  FrameResult& fr = w->fr;
  TriangulationResult& tri = w->tri;
  if (SurveyEvidence(fr, tri)) UpdateSurveyEstimate(fr, tri);
  Pose2 found;
  if (!ProbeSurveyError(fr.predicted_pose, w->held_survey_bound, &found)) return;
  const Pose2 pred = fr.predicted_pose;
  fr = FrameToMeasure(fr.row, pred);
  TrackPredictions(found, &fr, &tri);
  RefineAroundSolution(&fr, &tri);
  w->accepted = Acceptable(fr, tri) && Consistent(&fr, tri) && AgreesWithMotion(&fr, tri) && ConfirmsJump(fr, tri);
  // A held pose is confirmed under the wider error only from within the
  // robot's reach, as under the narrower one.
  if (w->was_held) w->accepted = w->accepted && WithinReachOfHeld(fr, tri);
}

// A pose tracked from a search's pose, until the residuals have shown the
// map's error: the tolerances they have shown since may let the search
// find the true pose that narrower ones missed (a map stated exact but
// centimetres off: a twin on a few bearings was all it found). A tracked
// pose gives way only to one clearly better supported on the landmarks
// chosen to track (a twin tracking many extra landmarks can fit more of
// them in all), and is then replaced by the search's pose, or forgotten.
// So is a tracked pose that fits few of the landmarks chosen where the
// survey error widens every tolerance: the place a kidnapped robot was
// carried from fits a few of them under the motion model's prediction.
// Either gives way as well to the search's choice beside it where that
// refutes it (Refutes).
void Localizer::CheckAgainstRoomSearch(const cv::Mat& grey, FrameWork* w) {
  w->after_search = errors_.survey_before_search && opt_.survey.check && !errors_.survey.confident();
  const bool weakly_supported = SurveyLimits() && !w->fr.relocalized && !Corroborated(w->fr, w->tri);
  if (!w->accepted || w->was_held || !(w->after_search || weakly_supported)) return;
  RoomSearch search = SearchRoomAgainst(grey, w->fr, w->tri);
  const int own = std::max(search.own_chosen, ChosenInliers(w->fr, w->tri));
  const bool outranked = std::any_of(search.elsewhere.begin(), search.elsewhere.end(), [&](const VerifiedPose& v) {
    return Outranks(v.chosen_inliers, v.residual, own, search.own_residual);
  });
  if (outranked || search.refuted) w->GiveWay(std::move(search.chosen), search.refuted);
}

// Lost for a while (the robot may have been carried), or never found: the
// room is searched. A pose near the prediction whose bearings agree, though
// its error bound was too wide to report it, keeps the robot against a
// search's pose far away no better supported than it (a room nearly
// symmetric, a map error that makes another place fit as well).
void Localizer::RelocalizeWhenLost(const cv::Mat& grey, int frame, FrameWork* w) {
  FrameResult& fr = w->fr;
  TriangulationResult& tri = w->tri;
  const bool near_consistent = fr.integrity.testable && fr.integrity.consistent;
  std::optional<std::pair<FrameResult, TriangulationResult>> near;
  if (near_consistent) near.emplace(fr, tri);
  bool under_probe = false;
  if (!RelocalizeIfLost(grey, frame, track_.ever_tracked && ViewUnlikePrediction(fr, tri), &fr, &tri, &under_probe,
                        &w->sparse_lead))
    return;
  if (near && DistinctPlaces(tri.pose, near->second.pose) &&
      !ClearlyBetterSupported(static_cast<int>(tri.inliers.size()), static_cast<int>(near->second.inliers.size()))) {
    // The pose near the prediction is only a hypothesis (the robot may
    // have been carried off, and a held pose is one).
    fr = std::move(near->first);
    tri = near->second;
    return;
  }
  // A pose found only under a survey error wider than the map's waits for
  // the next frame: a twin of the room fits under it as well. So does one
  // resting on extra landmarks (tracked because few of those chosen were
  // found) before the residuals have shown the map's error: a map stated
  // exact but centimetres off lets a wrong pose fit a few anywhere.
  // So does a sparse lead, for relocalize_sparse_frames frames.
  w->accepted = Corroborated(fr, tri) && !under_probe && !w->sparse_lead &&
                !FewChosenBeforeSurvey(fr, tri, opt_.relocalize_confirmed_fraction);
  if (!w->accepted && ResumesTrack(fr, tri, under_probe)) {
    // The motion model vouched for the pose: the track goes on with the
    // model's velocity (a model started again there knows none, and the
    // next frame's windows would open over the room).
    w->accepted = true;
    w->sparse_lead = false;
    fr.relocalized = false;
  }
  fr.unconfirmed = !w->accepted;
}

// The frame's outcome: retracked under the survey error its residuals show
// (before it is known), the prediction errors, the row, the polarities
// learned, the motion step, the held frame reported or a new hypothesis
// held; a hypothesis not confirmed, or a pose that gave way to nothing,
// starts the room's search again with the survey estimate as it was.
void Localizer::FinishFrame(const cv::Mat& grey, int frame, double time_s, std::vector<float>&& signature,
                            FrameWork* w) {
  FrameResult& fr = w->fr;
  TriangulationResult& tri = w->tri;
  const bool accepted = w->accepted;
  // A relocalised pose has its own evidence: its verification. (A frame
  // tracked from a held one is tried under the statement too: that frame
  // is reported under what this one leaves.)
  if (accepted && !fr.relocalized && !w->sparse_continues) RetrackUnderStatedSurvey(&fr, &tri, w->survey_at_begin);
  if (accepted && !fr.relocalized && opt_.survey.check && !errors_.survey.confident())
    RetrackUnderShownSurvey(&fr, &tri);
  fr.triangulation = tri;
  if (accepted && (fr.relocalized || w->was_held) && opt_.survey.check && !errors_.survey.confident())
    errors_.survey_before_search = w->was_held ? *w->survey_before_hold : errors_.survey;
  if (accepted) UpdatePredictionErrors(w->model_pred, fr, tri);
  if (accepted && !fr.relocalized) images_.recentre_rate = 0.9 * images_.recentre_rate + 0.1 * w->recentred;
  RecordOutcome(&fr, tri, accepted, w->n_found);
  if (accepted) LearnPolarity(fr, tri);
  if (accepted) {
    reloc_.failures = 0;
    reloc_.next_frame = 0;
    reloc_.rivalries.clear();
  }
  // The step of the model that tracked up to this frame (a hold starts a new one).
  fr.has_motion_step = track_.motion_stepped;
  if (fr.has_motion_step) fr.motion_step = motion_.step();
  // The held frame's pose is the one this frame tracked from and accepted
  // (not a pose the search found elsewhere): the held frame is reported,
  // and with it the sparse lead's frames it continued.
  const bool confirms_held = w->was_held && accepted && !fr.relocalized && reloc_.held_frame;
  if (reloc_.held_frame) reloc_.sparse_chain.push_back(std::move(*reloc_.held_frame));
  reloc_.held_frame.reset();
  if (confirms_held)
    for (const HeldFrame& held : reloc_.sparse_chain)
      if (std::optional<FrameResult> report = ReportConfirmedHold(held))
        reloc_.confirmed_holds.push_back(std::move(*report));
  // A frame that continues a sparse lead keeps the lead's frames held.
  if (!w->sparse_continues) reloc_.sparse_chain.clear();
  reloc_.sparse_holds = w->sparse_lead ? 1 : w->sparse_continues ? reloc_.sparse_holds + 1 : 0;
  if (fr.unconfirmed) {
    reloc_.held_frame = HeldFrame{grey.clone(), fr.row, tri.pose, ReportedCovariance(fr, Observations(fr), tri),
                                  reloc_.sparse_holds > 0, fr.either_polarity};
    const bool where_predicted = opt_.hold_keeps_motion && VelocityStillKnown() && ModelVouchesFor(fr, tri);
    MotionModel lead_motion = motion_;
    const int lead_updates = track_.motion_updates;
    HoldForConfirmation(tri.pose, frame, BeyondReach(tri.pose, time_s));
    if (where_predicted)
      KeepMotion(std::move(lead_motion), lead_updates, fr, tri);
    else if (reloc_.sparse_holds > 0)
      FollowSparseLead(std::move(lead_motion), lead_updates, fr, tri);
  } else if (w->was_held && !accepted) {
    // A search's hypothesis that its next frame did not confirm is no
    // start (tracking from it lets a wrong pose be accepted once the survey
    // probe has widened the tolerances far enough), and what its frame
    // taught the survey estimate is forgotten. The room is searched again.
    track_.known_start = false;
    errors_.survey = *w->survey_before_hold;
    UpdateLandmarkBudget();
  } else if (w->gave_way && !w->searched && w->after_search) {
    // The room is searched again from the next frame, and what the
    // given-way pose's frames taught the survey estimate goes with it.
    track_.known_start = track_.ever_tracked = false;
    errors_.survey = *errors_.survey_before_search;
    errors_.statement_verified = false;
    UpdateLandmarkBudget();
  }
  if (errors_.survey.confident()) errors_.survey_before_search.reset();
  // The compass measures the next turn from the last frame whose heading
  // was measured (or held): a lost frame's image (covered, a person in
  // front of the mirror) is no reference, and its heading only the
  // model's guess.
  if (opt_.compass &&
      (!opt_.compass_from_measured || track_.n_lost == 0 || heading_.last_signature.empty())) {
    heading_.last_signature = std::move(signature);
    heading_.signature_heading = track_.frame_pose.theta;
  }
  if (view_ && fr.row.status != PoseStatus::kLost) fr.row.pose = view_->RobotPose(fr.row.pose);
}

// The frame in the view tracked in (a rig's aligned view), the tracker and
// the compass started on it; this frame's state reset.
const cv::Mat& Localizer::BeginFrame(const cv::Mat& frame_image, int frame, double time_s, FrameWork* w) {
  CheckFrame(frame_image, frame);
  track_.frame = frame;
  track_.time_s = time_s;
  if (!track_.start_time) track_.start_time = time_s;
  reloc_.confirmed_holds.clear();  // the previous frame's, not taken
  if (view_) view_->Resample(frame_image, &view_frame_);
  const cv::Mat& grey = view_ ? view_frame_ : frame_image;
  track_.motion_stepped = false;
  track_.frame_intervals = 1;
  w->fr.row.frame = frame;
  w->fr.row.time_s = time_s;
  tracker_->BeginFrame(grey);
  if (opt_.compass) w->signature = compass_.Signature(grey);
  heading_.compass_heading.reset();
  w->model_pred = track_.last;
  w->survey_at_begin = LearnedSurvey{errors_.survey, errors_.bearing_sigma};
  return grey;
}

void Localizer::ConfirmHeldPose(const cv::Mat& grey, FrameWork* w) {
  w->was_held = reloc_.held;
  reloc_.held = false;
  if (w->was_held) {
    w->survey_before_hold = errors_.survey;
    if (opt_.held_survey_bounded) w->held_survey_bound = HeldSurveyBound();
  }
  if (!w->accepted && !w->sparse_continues && opt_.survey.check && !errors_.survey.confident() &&
      (track_.known_start || track_.ever_tracked))
    LearnSurveyFromRejected(w);
  // The frame shows nearly the held frame's image: where the held pose was
  // right, its bearings fit it about as well as under the error it was
  // found under, and what they teach the survey estimate
  // (RetrackUnderShownSurvey takes it up) stays within HeldSurveyBound,
  // unless the estimate was beyond it before. A wrong pose's misfit, taken
  // for the map's error, confirmed a twin a metre off on residuals of 6 cm
  // where the map stated 0.5 cm.
  if (w->accepted && w->was_held && opt_.held_survey_bounded && opt_.survey.check && !errors_.survey.confident() &&
      w->survey_before_hold->Early() <= w->held_survey_bound &&
      SurveyShownBy(w->fr, w->tri) > w->held_survey_bound)
    w->accepted = false;
  // A search's hypothesis confirmed before the residuals have shown how well
  // the map was measured: within a map error's tolerances (the probe's, or
  // a map stated exact but centimetres off) a wrong pose fits most of what
  // it finds too. It stands only where the room-wide search under the same
  // tolerances finds no rival about as well supported (the true pose fits
  // many more bearings there than a twin); else the search below runs. Nor
  // where the search's choice beside it refutes it (tracked from the held
  // pose without a velocity, the edges found may be the wrong ones): that
  // choice is taken instead.
  if (w->accepted && w->was_held && opt_.survey.check && !errors_.survey.confident()) {
    RoomSearch search = SearchRoomAgainst(grey, w->fr, w->tri);
    w->accepted = NoRivalElsewhere(search);
    if (w->accepted && search.refuted) w->GiveWay(std::move(search.chosen), true);
  }
}

FrameResult Localizer::Process(const cv::Mat& frame_image, int frame, double time_s,
                               const OdometryIncrement* odometry) {
  FrameWork w;
  const cv::Mat& grey = BeginFrame(frame_image, frame, time_s, &w);
  // Predict, measure, solve and check the pose (paper sections 2-4).
  if (track_.known_start || track_.ever_tracked) TrackFromPrediction(time_s, odometry, w.signature, &w);
  ConfirmHeldPose(grey, &w);
  CheckAgainstRoomSearch(grey, &w);
  w.n_found = FoundLandmarks(w.fr);  // before any relocalisation
  if (w.gave_way && w.searched) {
    const int n_good = track_.n_good;
    AdoptSearchResult(std::move(*w.searched), &w.fr, &w.tri);
    if (w.refuted && track_.n_lost == 0 && ModelVouchesFor(w.fr, w.tri)) {
      // Beside the pose it refuted, where the motion model predicted it:
      // the track goes on with the model's velocity (a model started again
      // knows none, and the next frame's windows would miss a turn).
      w.fr.relocalized = false;
      track_.n_good = n_good;
      w.accepted = true;
    } else {
      w.accepted = Corroborated(w.fr, w.tri);
    }
    w.fr.unconfirmed = !w.accepted;
  }
  if (!w.accepted && !w.gave_way && !w.sparse_continues) RelocalizeWhenLost(grey, frame, &w);
  FinishFrame(grey, frame, time_s, std::move(w.signature), &w);
  return w.fr;
}

}  // namespace pano
