// How far a map's corners may be from where they were surveyed, as the
// localiser sees it: the survey sigma the map states, checked against the
// bearing residuals of the tracked frames.
//
// A landmark's bearing error has variance s_img^2 + (s_map / d)^2: the
// image noise, and its corner's survey error across the line of sight at
// horizontal distance d. Over recent frames the inlier residuals' squares
// are fitted by a + b / d^2 (a >= 0, b >= 0), which tells the two apart
// where the landmarks lie at various distances: sqrt(b) is the survey error
// the images show. A squared residual's spread grows with its variance, so
// the fit weighs each by the inverse square of the variance fitted
// (iteratively reweighted least squares, the Gaussian likelihood's): an
// even least-squares fit would rest on the nearest landmarks, whose errors
// the pose fit absorbs most.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <vector>

namespace pano {

struct SurveyErrorOptions {
  // A map that does not state its survey sigma is taken to be measured by
  // hand until the residuals say otherwise: this fraction of the typical
  // landmark distance (0.4 %: 0.5 cm at 1.2 m, a careful tape survey).
  double unstated_fraction = 0.004;
  // The estimate from the residuals never exceeds this fraction of the
  // typical landmark distance: beyond it a corner is wrong, not imprecise
  // (an outlier for the consensus, and for `panomap check`).
  double max_fraction = 0.03;
  // The estimate replaces the unstated default (and may raise a stated
  // sigma) once this many inlier bearings have been seen.
  double min_bearings = 60.0;
  // A map stated exact (0) whose residuals show a survey error above this
  // fraction of the typical landmark distance is taken to be measured after
  // all (0.05 %: 0.6 mm at 1.2 m; a rendered map edited by hand, a CAD
  // model of a room built a little differently).
  double exact_doubt_fraction = 0.0005;
  // Check the statement against the residuals at all (and let the alert
  // limit take the error they show). Off: the map's statement as it is (a
  // calibration search, whose wrong trials' residuals must not be taken for
  // survey error).
  bool check = true;
  // Where the first frames (blurred in a fast turn, a person in front)
  // agreed only under a survey error well above the map's statement, the
  // next tracked frames are tried under the statement again: one whose
  // bearings agree there as well shows the wider error was the images',
  // and the estimate starts again from the statement (a tolerance that
  // wide lets wrong edges pull later poses centimetres off). From then on
  // a frame that does not agree teaches no survey error that large again.
  // Off: what the first frames showed stays until the residuals forget it.
  bool recheck_statement = true;
  // ... and where a frame's bearings agree under the statement on clearly
  // more landmarks than under the error learned, on a pose apart from that
  // one, the statement's pose is the frame's (a tolerance that wide let a
  // wrong edge pull the pose off what most bearings agree on), and what the
  // frame taught the estimate is forgotten. Off: the learned error's pose
  // stays.
  bool statement_outvotes = true;
  // The survey probe (a frame that failed before the error is known, tried
  // under a ladder of wider errors from its prediction) tries the levels
  // below the best supported one again from that level's pose: a
  // prediction off by more than the narrow levels' windows reach agrees
  // only under a wide level otherwise. Off: from the prediction alone.
  bool probe_from_consensus = true;
  // ... where that error is also above this fraction of the typical
  // landmark distance (1.5 %: 3 cm at 2 m, beyond a careless tape survey;
  // the probe's two widest levels).
  double doubt_fraction = 0.015;
  // The image's share of the residuals is at most this (radians; the
  // localiser's max_bearing_sigma, the noise of a poor tracker): where the
  // distances cannot tell the two apart and no edge's two corners bound the
  // image noise, the excess beyond it is the map's.
  double max_image_sigma = 0.3 * M_PI / 180;
  // Each frame's evidence weighs this much less on the next (about 100
  // frames of memory).
  double forgetting = 0.99;
  // Where the estimate is all there is (a map that states nothing, or an
  // exact statement the residuals overrule), the covariances reported hold
  // this many times the estimate: the landmarks in view show a map's error
  // only across their lines of sight and the pose absorbs part of it, and
  // on some maps the estimate is half the error (measured: 0.39 - 1.09 of
  // the true sigma on 36 perturbed maps). The tolerances keep the estimate
  // (wider ones would admit a frame someone walks through). A stated sigma
  // is only raised by the estimate, not by this.
  double estimate_margin = 2.0;
  // Where the map states its error, the covariances reported hold this many
  // times the statement. A stated sigma describes maps on average; one
  // map's errors stay for the whole run, so every frame's pose is off by
  // much the same bias. The chance that it lies beyond the 3-sigma
  // ellipse is about 1 in 90 with the statement alone, 1 in 1000 with this
  // margin (measured on 24 perturbed maps stating their sigma: on one, the
  // poses ran up to 3.3 of their standard deviations off for a fifth of
  // the run).
  double stated_margin = 1.25;
  void Check() const;
};

class SurveyErrorEstimate {
 public:
  SurveyErrorEstimate() = default;
  // `typical_distance`: the typical horizontal distance of the landmarks
  // (map units), which scales the unstated default and the cap.
  SurveyErrorEstimate(const SurveyErrorOptions& options, double typical_distance);
  void Reset();
  // The survey sigma to use for a corner whose map states `stated` (NaN:
  // not stated; 0: exact): the statement, raised by the estimate where the
  // residuals show more (an exact map only beyond exact_doubt_fraction);
  // without one, the estimate once there is enough evidence, else the
  // unstated default. Until the estimate is confident, never below the
  // provisional sigma.
  double Sigma(double stated) const;
  // The sigma before any evidence: the statement, or the unstated default.
  double StatedSigma(double stated) const;
  // The sigma the reported covariances hold: stated_margin times Sigma
  // where the map states an error; where the estimate alone decides it
  // (the map stating nothing or an exact map overruled), estimate_margin
  // times the estimate, within the cap; before the
  // estimate is confident, from a frame's evidence on, where it shows twice
  // exact_doubt_fraction of the typical distance.
  double ReportedSigma(double stated) const;
  // The estimate, not yet confident, where a few frames' residuals already
  // show an error clearly beyond a careful tape survey's (1.5 times
  // unstated_fraction of the typical distance); else 0. The localiser
  // makes it provisional where the frame it came from is reported
  // (Localizer::RetrackUnderShownSurvey): the residuals of a pose not
  // reported may be a wrong pose's.
  double Early() const;
  // One accepted frame: its inlier bearings' residuals (radians) and
  // horizontal distances, and the number of pose parameters fitted to them
  // (the residuals are that much smaller than the errors). `pairs`: the
  // differences between the residuals of two corners of one vertical edge
  // (its top and bottom junctions): their bearing shares the corners'
  // survey error, so the difference is image noise alone (twice its
  // variance). They bound the image's share where the distances cannot
  // tell it from the survey's (the pose fit absorbs the near landmarks'
  // errors more than the far ones', which flattens the 1/d^2 pattern).
  // `leverages` (optional, one per residual): the share of each bearing's
  // error the pose fit absorbed (BearingLeverages; an edge's corners
  // summed); in place of the even share fitted / n. The fit leans on the
  // near landmarks most, so without it their residuals understate the
  // survey's share.
  void Update(const std::vector<double>& residuals, const std::vector<double>& distances,
              const std::vector<double>& pairs = {}, int fitted = 3, const std::vector<double>& leverages = {});
  // A frame whose bearings agree with the motion only once the map is
  // assumed this far off: the sigma is at least this much until the
  // residuals have said more.
  void Provisional(double sigma) { provisional_ = std::max(provisional_, sigma); }
  double provisional() const { return provisional_; }
  // The survey error the residuals show (map units; 0 until there is
  // evidence) and the image noise they leave (radians).
  double estimated() const { return survey_; }
  double image_sigma() const { return std::sqrt(image_variance_); }
  bool confident() const { return n_ >= opt_.min_bearings; }
  // Whether more edges with both corners found are wanted: their image
  // noise bounds the image's share once a few have been seen (twice as
  // many as that, so that a few more a while keep it so).
  bool WantsPairs() const;

 private:
  void Fit();
  // The image noise's variance the pairs show (radians^2; infinite until
  // there are enough of them).
  double PairVariance() const;
  double PairWeight() const;  // the pairs remembered, weighed as forgotten
  // The estimate above which a map stated exact is taken to be measured.
  double ExactDoubt() const;
  SurveyErrorOptions opt_;
  double typical_distance_ = 0.0;
  // Forgets the samples' weights by `keep`; drops those below `forgotten`.
  void Forget(double keep, double forgotten);
  // The inlier bearings remembered from first_sample_ on, in the order
  // seen, a column per field (the fit sums them four at a time): u = 1/d^2,
  // y = r^2 (corrected for the fit) and the weight left after forgetting
  // over weight_scale_ (forgetting scales one number, not every weight);
  // stored_weight_ the stored weights' sum, n_ the weights'.
  std::vector<double> sample_u_, sample_y_, sample_weight_;
  size_t first_sample_ = 0;
  double weight_scale_ = 1.0;
  double stored_weight_ = 0.0;
  double n_ = 0.0;
  // The pairs' halved squared differences and their weights, forgotten the
  // same way.
  struct PairSample {
    double y, weight;
  };
  std::vector<PairSample> pair_samples_;
  double survey_ = 0.0;
  double image_variance_ = 0.0;
  double provisional_ = 0.0;
};

namespace internal {

// One reweighting step of the fit: the sums of the weighted normal
// equations of y = a + b u, sample i weighing weight[i] / (a + b u[i])^2.
struct NormalSums {
  double s1 = 0.0, su = 0.0, suu = 0.0, sy = 0.0, suy = 0.0;
};
// Sample i is summed into lane i % 4 and the lanes pairwise at the end, so
// that the vector unit (where there is one) and the portable loop give the
// same sums to the bit.
NormalSums WeightedNormalSums(const double* u, const double* y, const double* weight, size_t n, double a, double b);
NormalSums PortableNormalSums(const double* u, const double* y, const double* weight, size_t n, double a, double b);

}  // namespace internal

}  // namespace pano
