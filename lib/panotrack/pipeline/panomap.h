// panomap's jobs over files: check, build and refine, each one function the
// program calls with the options it parsed (mapping/ holds the algorithms).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "panotrack/mapping/build.h"
#include "panotrack/mapping/check.h"
#include "panotrack/mapping/refine.h"
#include "panotrack/pose/pose2.h"

namespace pano {

// panomap check: the map checked against a video, from given poses or
// the localiser's.
struct MapCheckJob {
  std::string map_path, calib_path, input;
  std::optional<Pose2> pose;  // one pose for every frame
  std::string poses_path;     // pose CSV, one row per frame; empty: none
  // .png/.jpg (the frame with the most edges in view) or a video (every
  // frame); empty: none.
  std::string overlay;
  std::string report_csv;     // empty: none
  MapCheckOptions options;
  bool overwrite = false;     // replace existing outputs (--force)
  void Check() const;
};

// Runs the check. Throws pano::Error for bad inputs, a poses CSV that does
// not match the input's frames, and when no landmark is in view in any frame.
MapCheckReport RunMapCheck(const MapCheckJob& job);
// The per-edge CSV (--report).
void WriteMapCheckCsv(const std::string& path, const MapCheckReport& report);
// The frame with the predicted edges drawn, coloured by their edge's
// status: green fine, red never found, magenta wrong polarity, orange
// biased, grey not judged; a cross where found this frame.
cv::Mat DrawMapCheck(const cv::Mat& grey, const FrameCheck& fc, const MapCheckReport& report,
                     const Sensor& sensor);

// panomap build: landmarks the seed map lacks, found in a video and added.
struct MapBuildJob {
  std::string map_path, calib_path, input;
  std::string poses_path;  // pose CSV, one row per frame; empty: localise with the seed
  bool has_start = false;
  Pose2 start;  // the first frame's pose when localising
  std::string output, report_csv;
  MapBuildOptions options;
  bool overwrite = false;
  void Check() const;
};

// Runs the build. Throws pano::Error (nothing written) for bad inputs, a
// poses CSV that does not match the input's frames, and a seed map none of
// whose landmarks is in view in any frame.
MapBuildResult RunMapBuild(const MapBuildJob& job);
// The build's report as CSV (--report): one row per candidate edge.
void WriteMapBuildCsv(const std::string& path, const MapBuildResult& r);

// panomap refine: the map's rectangles adjusted to the junctions tracked
// in videos from their poses (mapping/refine.h).
struct MapRefineJob {
  std::string map_path, calib_path;
  std::vector<std::string> videos;  // files, image folders or printf patterns
  std::vector<std::string> poses;   // one pose CSV per video, in the same order
  std::string output, report_csv;   // refined map YAML; per-landmark CSV (empty: none)
  // The survey's sigma; none: the map's survey_sigma where it states one,
  // else options.map_sigma.
  std::optional<double> map_sigma;
  // The pose prior's sigma; none: from the poses (AutoPoseSigma).
  std::optional<double> pose_sigma;
  RefineOptions options;  // map_sigma and pose_sigma settled from the two above
  bool overwrite = false;  // replace existing outputs (--force)
};
struct MapRefineRun {
  RefineResult result;
  Map surveyed;             // the map as read
  RefineOptions options;    // as used
};
// Throws pano::Error (nothing written) for bad inputs, a pose CSV count
// that is not the videos', and a failed adjustment.
MapRefineRun RunMapRefine(const MapRefineJob& job);
// The refinement's report as CSV (--report): one row per rectangle
// parameter (landmark, parameter, observations, surveyed, refined,
// correction, std, flagged).
void WriteRefineReportCsv(const std::string& path, const RefineResult& r);

}  // namespace pano
