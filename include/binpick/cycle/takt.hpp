#pragma once
/// \file takt.hpp
/// Time of a picking cycle: the paper's model of the whole sensing scheme (Table I, Eq. 2) and the
/// measured timeline of one cycle (robot segments and processing stages with start and end).
///
/// Table I / Eq. 2, every constant a setting (defaults are the paper's, milliseconds in the table,
/// seconds here):
///
///   paired 2D images  (exposure + transfer) · n + t · (n − 1)      3n + 90n + t(n − 1)
///   kinematics        read + transfer · n                            20n
///   3D                stereo depth per view · n + fusion per view · n 150n + 80n
///   estimation        6D pose and grasp                              200
///   path planning     sensing, dropping and grasping paths           20
///   total             343n + t(n − 1) + 220 ms     (Eq. 2; n = 4, t = 30 ms → 1682 ms)
///
/// Sensing in takt (§IV.D.3, Table II): the time the place action takes beyond the direct move B→C —
/// the detour of B→M→N→C (including the stop for view 1) — plus any time the robot waits at C for the
/// processing to finish. For a stop-and-go cell (baseline C) it is the whole time sensing and
/// processing add to the cycle (see CycleTakt).

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "binpick/core/errors.hpp"

namespace binpick::cycle {

/// The constants of Table I [s]. Hardware durations a simulation cannot measure (exposure, image
/// transfer, kinematics read, stereo depth generation) are taken from here by the pipeline as well.
struct TaktSettings {
  double exposure = 0.003;          ///< exposure per view [s] (§IV.A: 3 ms)
  double transfer = 0.090;          ///< image pair transfer per view [s]
  double kinematics = 0.020;        ///< robot kinematics read and transfer per view [s]
  double stereo_depth = 0.150;      ///< stereo matching to a depth image, per view [s]
  double fusion_per_view = 0.080;   ///< 3D fusion per view [s] (model only; the pipeline measures it)
  double estimation = 0.200;        ///< 6D pose and grasp estimation [s] (model only)
  double planning = 0.020;          ///< grasp, sensing and dropping path planning [s] (model only)
};

/// Table I's columns for n views at interval t.
struct SensingSchemeTime {
  double images = 0;      ///< (exposure + transfer)·n + t·(n − 1) [s]
  double kinematics = 0;  ///< kinematics·n [s]
  double depth_3d = 0;    ///< (stereo depth + fusion per view)·n [s]
  double estimation = 0;  ///< [s]
  double planning = 0;    ///< [s]
  double total() const { return images + kinematics + depth_3d + estimation + planning; }
};

/// Table I for `num_views` n >= 1 captured at `interval` t >= 0 [s]. Throws std::invalid_argument naming
/// `num_views` or `interval`, or `settings` when a constant is negative or not finite.
inline SensingSchemeTime sensing_scheme_time(int num_views, double interval, const TaktSettings& settings = {}) {
  require(num_views >= 1, "num_views", "must be >= 1");
  require(std::isfinite(interval) && interval >= 0, "interval", "must be finite and >= 0");
  for (double c : {settings.exposure, settings.transfer, settings.kinematics, settings.stereo_depth,
                   settings.fusion_per_view, settings.estimation, settings.planning})
    require(std::isfinite(c) && c >= 0, "settings", "every constant must be finite and >= 0");
  const double n = num_views;
  SensingSchemeTime r;
  r.images = (settings.exposure + settings.transfer) * n + interval * (n - 1);
  r.kinematics = settings.kinematics * n;
  r.depth_3d = (settings.stereo_depth + settings.fusion_per_view) * n;
  r.estimation = settings.estimation;
  r.planning = settings.planning;
  return r;
}

/// Eq. 2: 343n + t(n − 1) + 220 ms with the default settings [s].
inline double sensing_scheme_total(int num_views, double interval, const TaktSettings& settings = {}) {
  return sensing_scheme_time(num_views, interval, settings).total();
}

/// Which lane of the timeline an entry belongs to.
enum class Lane {
  robot,       ///< a robot motion segment or a stop/wait
  capture,     ///< exposure and kinematics reads during data collection
  processing,  ///< the data processing phase (worker thread)
};

inline const char* to_string(Lane l) {
  switch (l) {
    case Lane::robot: return "robot";
    case Lane::capture: return "capture";
    case Lane::processing: return "processing";
  }
  return "unknown";
}

/// One interval of the timeline, in Clock time [s].
struct TimelineEntry {
  std::string name;     ///< e.g. "drop N->C", "fusion"
  Lane lane = Lane::robot;
  double start = 0;     ///< [s]
  double end = 0;       ///< [s] >= start
  bool measured = false;  ///< true: measured compute time; false: clock time of the cell or a Table I setting
  double duration() const { return end - start; }
};

/// The timeline of one or more cycles: every robot segment and processing stage with start and end.
class Timeline {
 public:
  /// Appends [start, end]; end is clamped to >= start. Throws std::invalid_argument naming `start` or
  /// `end` when not finite.
  void add(std::string name, Lane lane, double start, double end, bool measured = false) {
    require(std::isfinite(start), "start", "must be finite");
    require(std::isfinite(end), "end", "must be finite");
    entries_.push_back({std::move(name), lane, start, std::max(start, end), measured});
  }
  /// Appends every entry of `other`.
  void append(const Timeline& other) { entries_.insert(entries_.end(), other.entries_.begin(), other.entries_.end()); }

  const std::vector<TimelineEntry>& entries() const { return entries_; }
  bool empty() const { return entries_.empty(); }

  /// The first entry called `name`, or null.
  const TimelineEntry* find(const std::string& name) const {
    for (const auto& e : entries_)
      if (e.name == name) return &e;
    return nullptr;
  }
  /// Sum of the durations of the entries called `name` [s].
  double total(const std::string& name) const {
    double s = 0;
    for (const auto& e : entries_)
      if (e.name == name) s += e.duration();
    return s;
  }
  /// Sum of the durations on `lane` [s].
  double total(Lane lane) const {
    double s = 0;
    for (const auto& e : entries_)
      if (e.lane == lane) s += e.duration();
    return s;
  }
  /// Earliest start and latest end over all entries (0, 0 when empty) [s].
  double begin() const {
    double b = entries_.empty() ? 0 : entries_.front().start;
    for (const auto& e : entries_) b = std::min(b, e.start);
    return b;
  }
  double end() const {
    double b = entries_.empty() ? 0 : entries_.front().end;
    for (const auto& e : entries_) b = std::max(b, e.end);
    return b;
  }
  /// Time the entries called `a_name` overlap entries on `lane` (summed over pairs; entries of one lane
  /// do not overlap each other) [s] — e.g. how much processing ran during "drop N->C".
  double overlap(const std::string& a_name, Lane lane) const {
    double s = 0;
    for (const auto& x : entries_) {
      if (x.name != a_name) continue;
      for (const auto& y : entries_)
        if (y.lane == lane) s += std::max(0.0, std::min(x.end, y.end) - std::max(x.start, y.start));
    }
    return s;
  }

 private:
  std::vector<TimelineEntry> entries_;
};

/// What one cycle costs in takt [s].
struct CycleTakt {
  double cycle_time = 0;        ///< from the pull-up point B to the next pull-up point [s]
  double detour = 0;            ///< the place action's time beyond the direct move B→C (stop included) [s]
  double robot_wait = 0;        ///< the robot standing still waiting for processing [s]
  double processing = 0;        ///< the whole data processing phase (hardware model + measured) [s]
  double processing_compute = 0;  ///< its measured part: fusion with ICP, estimation, planning [s]
  /// Sensing in takt (Table II): detour + robot_wait.
  double sensing_in_takt() const { return detour + robot_wait; }
};

}  // namespace binpick::cycle
