#pragma once
/// \file parameters.hpp
/// Sensing path parameters (paper §III.D, Fig. 8): the motion form (v, t, n) — constant speed v along
/// the arc, n captures at interval t — and the angle form (α, β) — the angle between neighbouring views
/// and the coverage angle; conversions both ways, and the offline determination of §III.D.2.
///
/// Which angle: α and β are *target angles*, measured at the target center T (arc_angle.hpp). The
/// robot travels along the arc L of radius rho (rho = r when T lies in P; rho = sqrt(r^2 − h^2) with
/// h = dist(T, P) otherwise), so the central step between views is v·t/rho and the whole path spans
/// (n − 1)·v·t/rho at the arc's center; these central angles are converted to angles at T. With T in
/// P this is the paper's β = v·t·(n − 1)/r, α = β/(n − 1). With T off P, α is still the same for every
/// pair of neighbours but β < (n − 1)·α.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <map>
#include <type_traits>
#include <vector>

#include "binpick/active_vision/arc_angle.hpp"
#include "binpick/core/errors.hpp"

namespace binpick::active_vision {

/// The motion form of Fig. 8 (right).
template <typename Scalar>
struct MotionParameters {
  Scalar speed = Scalar(0);     ///< v, constant speed along the arc [m/s] (the paper's robot: 100 % ≈ 1 m/s)
  Scalar interval = Scalar(0);  ///< t, time between captures [s]
  int num_views = 0;            ///< n, captures on the path (M and N included)
};

/// The angle form of Fig. 8 (left), angles at T.
template <typename Scalar>
struct PathAngles {
  Scalar alpha = Scalar(0);  ///< α, angle at T between neighbouring views [rad]
  Scalar beta = Scalar(0);   ///< β, coverage angle at T between the first and the last view [rad]
};

/// (v, t, n) → (α, β) on an arc of radius `arc_radius` rho of a sphere of radius `sphere_radius` r
/// (pass rho = r when T lies in P). Throws `std::invalid_argument` on non-positive or non-finite v or t,
/// n < 2, an invalid arc, or a path longer than half the arc ((n − 1)·v·t > pi·rho: the angle at T would
/// shrink again past the point opposite the start).
template <typename Scalar>
PathAngles<Scalar> path_angles_from_motion(const MotionParameters<Scalar>& motion, Scalar sphere_radius,
                                           Scalar arc_radius) {
  require(std::isfinite(motion.speed) && motion.speed > Scalar(0), "motion.speed", "must be finite and > 0");
  require(std::isfinite(motion.interval) && motion.interval > Scalar(0), "motion.interval", "must be finite and > 0");
  require(motion.num_views >= 2, "motion.num_views", "must be >= 2");
  detail::require_arc(sphere_radius, arc_radius);
  const Scalar step = motion.speed * motion.interval / arc_radius;  // central angle per interval
  const Scalar total = step * Scalar(motion.num_views - 1);
  require(total <= Scalar(3.14159265358979323846), "motion",
          "(n - 1) * v * t exceeds half the arc (pi * arc_radius)");
  return PathAngles<Scalar>{central_to_target_angle(step, sphere_radius, arc_radius),
                            central_to_target_angle(total, sphere_radius, arc_radius)};
}

/// (v, t, n) → (α, β) with T in P: β = v·t·(n − 1)/r, α = β/(n − 1).
template <typename Scalar>
PathAngles<Scalar> path_angles_from_motion(const MotionParameters<Scalar>& motion, Scalar sphere_radius) {
  return path_angles_from_motion(motion, sphere_radius, sphere_radius);
}

/// (α, β) and the capture interval t [s] → (v, t, n) on the same arc: the central angles of α and β
/// give n = round(phi_β / phi_α) + 1 and v = phi_α·rho / t, so the views keep the spacing α exactly and
/// β is met to the nearest whole view. Throws on α <= 0, β < α, angles the arc cannot offer, t <= 0,
/// an invalid arc, or more than 100000 views.
template <typename Scalar>
MotionParameters<Scalar> motion_from_path_angles(const PathAngles<Scalar>& angles, Scalar interval,
                                                 Scalar sphere_radius, Scalar arc_radius) {
  require(std::isfinite(angles.alpha) && angles.alpha > Scalar(0), "angles.alpha", "must be finite and > 0");
  require(std::isfinite(angles.beta) && angles.beta >= angles.alpha, "angles.beta", "must be finite and >= alpha");
  require(std::isfinite(interval) && interval > Scalar(0), "interval", "must be finite and > 0");
  const Scalar step = target_to_central_angle(angles.alpha, sphere_radius, arc_radius);
  const Scalar total = target_to_central_angle(angles.beta, sphere_radius, arc_radius);
  require(step > Scalar(0), "angles.alpha", "too small for the scalar type");
  const Scalar steps = std::round(total / step);
  require(steps <= Scalar(99999), "angles", "beta / alpha asks for more than 100000 views");
  return MotionParameters<Scalar>{step * arc_radius / interval, interval, int(steps) + 1};
}

/// (α, β), t → (v, t, n) with T in P.
template <typename Scalar>
MotionParameters<Scalar> motion_from_path_angles(const PathAngles<Scalar>& angles, Scalar interval,
                                                 Scalar sphere_radius) {
  return motion_from_path_angles(angles, interval, sphere_radius, sphere_radius);
}

// ---- offline determination (§III.D.2) ------------------------------------------------------------

/// One offline trial: the sensor swept at speed v capturing every t, the first n views fused and
/// estimated, and the number of objects recognized.
template <typename Scalar>
struct ParameterTrial {
  Scalar speed = Scalar(0);       ///< v [m/s]
  Scalar interval = Scalar(0);    ///< t [s]
  int num_views = 0;              ///< n
  Scalar recognized = Scalar(0);  ///< objects recognized (a count; fractional if averaged over repeats)
};

/// The band of step <1>, in standard deviations above the mean of the recognized counts.
template <typename Scalar>
struct ParameterSelectionSettings {
  Scalar band_low_sigma = Scalar(1);   ///< keep counts >= mean + band_low_sigma * sigma [-]
  Scalar band_high_sigma = Scalar(2);  ///< keep counts <= mean + band_high_sigma * sigma [-]
  std::size_t min_trials = 3;          ///< fewer trials than this cannot estimate sigma: error
};

enum class ParameterSelectionStatus {
  ok,
  empty_band,    ///< no trial's count lies in the band (a skewed table): nothing selected
  arc_too_long,  ///< the selected (v, t, n) sweeps more than half the arc: `angles` left zero
};

template <typename Scalar>
struct ParameterSelection {
  ParameterSelectionStatus status = ParameterSelectionStatus::empty_band;
  MotionParameters<Scalar> motion;  ///< the selected (v, t, n)
  PathAngles<Scalar> angles;        ///< its (α, β) at T
  Scalar mean = Scalar(0);          ///< mean recognized count over all trials
  Scalar sigma = Scalar(0);         ///< its standard deviation (population, divides by the count)
  std::size_t trials_in_band = 0;   ///< after step <1>
  std::size_t trials_with_n = 0;    ///< after step <2>
  bool ok() const { return status == ParameterSelectionStatus::ok; }
};

/// The offline determination of §III.D.2 over a table of trials:
///  <1> "Assume the numbers of recognized objects follow a Gaussian distribution. Filter the data with
///      the range from σ to 2σ to avoid noise." Reading taken: keep the trials whose count lies in
///      [mean + σ, mean + 2σ]. The search aims at "the highest number of recognized objects", so the
///      band is the upper one: below mean + σ are the ordinary and poor settings, above mean + 2σ the
///      rare lucky outliers (the "noise", under the Gaussian assumption ~2 % of trials). With σ = 0 the
///      band is the mean itself, i.e. every trial.
///  <2> "Filter the rest of the data with the most frequent value of n": keep the trials with the n
///      that occurs most often in the band; ties go to the smaller n (the paper seeks the minimum view
///      number).
///  <3> "Find the highest value of v from the rest": the trial with the highest v; ties go to the higher
///      count, then to the smaller t.
/// The chosen (v, t, n) is converted to (α, β) on the arc (sphere_radius r, arc_radius rho; rho = r for
/// the paper's offline sweep, which keeps the sensor on a sphere around the pile).
/// Throws `std::invalid_argument` when there are fewer than `settings.min_trials` trials or a trial has
/// v <= 0, t <= 0, n < 2 or a negative / non-finite count.
template <typename Scalar>
ParameterSelection<Scalar> select_path_parameters(const std::vector<ParameterTrial<Scalar>>& trials,
                                                  Scalar sphere_radius, Scalar arc_radius,
                                                  const ParameterSelectionSettings<Scalar>& settings = {}) {
  require(settings.min_trials >= 2, "settings.min_trials", "must be >= 2 (sigma needs two trials)");
  require(trials.size() >= settings.min_trials, "trials", "too few trials to estimate the count's spread");
  require(std::isfinite(settings.band_low_sigma) && std::isfinite(settings.band_high_sigma) &&
              settings.band_low_sigma <= settings.band_high_sigma,
          "settings", "band_low_sigma <= band_high_sigma, both finite");
  detail::require_arc(sphere_radius, arc_radius);
  for (const auto& trial : trials) {
    require(std::isfinite(trial.speed) && trial.speed > Scalar(0), "trials", "speed must be finite and > 0");
    require(std::isfinite(trial.interval) && trial.interval > Scalar(0), "trials", "interval must be finite and > 0");
    require(trial.num_views >= 2, "trials", "num_views must be >= 2");
    require(std::isfinite(trial.recognized) && trial.recognized >= Scalar(0), "trials",
            "recognized must be finite and >= 0");
  }
  ParameterSelection<Scalar> result;
  // Mean and population sigma in double (two passes), whatever the scalar.
  double mean = 0;
  for (const auto& trial : trials) mean += double(trial.recognized);
  mean /= double(trials.size());
  double var = 0;
  for (const auto& trial : trials) var += (double(trial.recognized) - mean) * (double(trial.recognized) - mean);
  const double sigma = std::sqrt(var / double(trials.size()));
  result.mean = Scalar(mean);
  result.sigma = Scalar(sigma);
  // Step <1>; a little slack so counts on the band's edges (common with integer counts) are kept.
  const double slack = 1e-9 * (std::abs(mean) + sigma + 1) +
                       (std::is_same<Scalar, float>::value ? 1e-5 * (std::abs(mean) + sigma + 1) : 0.0);
  const double lo = mean + double(settings.band_low_sigma) * sigma - slack;
  const double hi = mean + double(settings.band_high_sigma) * sigma + slack;
  std::vector<const ParameterTrial<Scalar>*> band;
  for (const auto& trial : trials)
    if (double(trial.recognized) >= lo && double(trial.recognized) <= hi) band.push_back(&trial);
  result.trials_in_band = band.size();
  if (band.empty()) {
    result.status = ParameterSelectionStatus::empty_band;
    return result;
  }
  // Step <2>: the most frequent n (std::map iterates n ascending, so '>' keeps the smaller on ties).
  std::map<int, std::size_t> frequency;
  for (const auto* trial : band) ++frequency[trial->num_views];
  int best_n = 0;
  std::size_t best_count = 0;
  for (const auto& [n, count] : frequency)
    if (count > best_count) best_n = n, best_count = count;
  result.trials_with_n = best_count;
  // Step <3>: the highest v; ties to the higher count, then the smaller t.
  const ParameterTrial<Scalar>* best = nullptr;
  for (const auto* trial : band) {
    if (trial->num_views != best_n) continue;
    if (!best || trial->speed > best->speed ||
        (trial->speed == best->speed &&
         (trial->recognized > best->recognized ||
          (trial->recognized == best->recognized && trial->interval < best->interval))))
      best = trial;
  }
  result.motion = MotionParameters<Scalar>{best->speed, best->interval, best->num_views};
  const Scalar total = best->speed * best->interval * Scalar(best->num_views - 1) / arc_radius;
  if (!(total <= Scalar(3.14159265358979323846))) {
    result.status = ParameterSelectionStatus::arc_too_long;
    return result;
  }
  result.angles = path_angles_from_motion(result.motion, sphere_radius, arc_radius);
  result.status = ParameterSelectionStatus::ok;
  return result;
}

/// The offline determination with T in P (the paper's sweep on a sphere around the pile).
template <typename Scalar>
ParameterSelection<Scalar> select_path_parameters(const std::vector<ParameterTrial<Scalar>>& trials,
                                                  Scalar sphere_radius,
                                                  const ParameterSelectionSettings<Scalar>& settings = {}) {
  return select_path_parameters(trials, sphere_radius, sphere_radius, settings);
}

}  // namespace binpick::active_vision
