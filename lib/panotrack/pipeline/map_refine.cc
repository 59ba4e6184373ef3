// panomap refine as a whole: inputs read and guarded, the adjustment's
// sigmas settled, the map refined and written with its report.
#include <cstdio>
#include <sstream>

#include "panotrack/core/atomic_file.h"
#include "panotrack/core/error.h"
#include "panotrack/core/output_check.h"
#include "panotrack/io/calibration.h"
#include "panotrack/io/map.h"
#include "panotrack/io/pose_csv.h"
#include "panotrack/pipeline/panomap.h"
#include "panotrack/video/frame_source.h"

namespace pano {

void WriteRefineReportCsv(const std::string& path, const RefineResult& r) {
  std::ostringstream out;
  out << "landmark,parameter,observations,surveyed,refined,correction,std,flagged\n";
  char line[256];
  for (const LandmarkCorrection& l : r.landmarks)
    for (int i = 0; i < kRectangleParams; ++i) {
      const size_t ii = static_cast<size_t>(i);
      std::snprintf(line, sizeof line, "%s,%s,%d,%.6f,%.6f,%.6f,%.6f,%d\n", l.id.c_str(), kRectangleParamNames[ii],
                    l.observations, l.surveyed[ii], l.refined[ii], l.refined[ii] - l.surveyed[ii], l.std[ii],
                    l.flagged ? 1 : 0);
      out << line;
    }
  WriteFileAtomic(path, out.str());
}

MapRefineRun RunMapRefine(const MapRefineJob& job) {
  if (job.poses.size() != job.videos.size())
    throw Error("--poses: " + std::to_string(job.poses.size()) + " pose CSVs for " +
                std::to_string(job.videos.size()) + " videos (give one per video, in the same order)");
  NamedPaths reads = {{"--map", job.map_path}, {"--calib", job.calib_path}};
  for (const std::string& p : job.poses) reads.push_back({"--poses", p});
  for (const std::string& v : job.videos)
    for (const auto& read : FrameSource::InputReads(v, "VIDEO")) reads.push_back(read);
  CheckPlannedOutputs(reads, {{"-o", job.output}, {"--report", job.report_csv}}, job.overwrite);
  const Calibration calib = ReadCalibration(job.calib_path);
  MapRefineRun run;
  run.surveyed = ReadMap(job.map_path);
  std::vector<RefineVideo> videos;
  for (size_t i = 0; i < job.videos.size(); ++i)
    videos.push_back({job.videos[i], job.poses[i], ReadPoseCsv(job.poses[i])});
  run.options = job.options;
  if (job.map_sigma) run.options.map_sigma = *job.map_sigma;
  else if (run.surveyed.survey_sigma > 0.0) run.options.map_sigma = run.surveyed.survey_sigma;
  run.options.pose_sigma = job.pose_sigma ? *job.pose_sigma : AutoPoseSigma(videos, run.options.map_sigma);
  run.result = RefineMap(calib, run.surveyed, videos, run.options);
  WriteMap(job.output, run.result.map);
  if (!job.report_csv.empty()) WriteRefineReportCsv(job.report_csv, run.result);
  return run;
}

}  // namespace pano
