// panomap build as a whole: inputs read and checked, poses from the CSV or
// the localiser, the frames given to the builder, the grown map and report.
#include <cmath>
#include <cstdio>
#include <memory>

#include "panotrack/core/atomic_file.h"
#include "panotrack/core/error.h"
#include "panotrack/core/output_check.h"
#include "panotrack/io/calibration.h"
#include "panotrack/io/map.h"
#include "panotrack/io/pose_csv.h"
#include "panotrack/pipeline/panomap.h"
#include "panotrack/pipeline/map_inputs.h"
#include "panotrack/track/localizer.h"
#include "panotrack/video/frame_source.h"

namespace pano {

namespace {


}  // namespace

void MapBuildJob::Check() const {
  if (map_path.empty()) throw Error("--map (map_path): required");
  if (calib_path.empty()) throw Error("--calib (calib_path): required");
  if (input.empty()) throw Error("VIDEO (input): a video or image sequence is required");
  if (output.empty()) throw Error("-o (output): required");
  if (has_start && !poses_path.empty()) throw Error("--start and --poses: give one or the other");
  if (has_start && (!std::isfinite(start.x) || !std::isfinite(start.y) || !std::isfinite(start.theta)))
    throw Error("--start (start): expected finite x,y,theta");
  options.Check();
}

void WriteMapBuildCsv(const std::string& path, const MapBuildResult& r) {
  std::string text = "edge,x,y,std,views,parallax_deg,rms_bearing_deg,z0,z0_std,z1,z1_std,verdict,rectangle\n";
  char line[512];
  for (size_t i = 0; i < r.edges.size(); ++i) {
    const BuiltEdge& e = r.edges[i];
    std::snprintf(line, sizeof line, "e%zu,%.4f,%.4f,%.4f,%d,%.3f,%.4f,%.3f,%.3f,%.3f,%.3f,%s,%s\n", i, e.position.x(),
                  e.position.y(), e.std_major, e.views, e.parallax_deg, e.rms_bearing_deg, e.z0, e.z0_std, e.z1,
                  e.z1_std, EdgeVerdictName(e.verdict),
                  e.rectangle >= 0 ? r.rectangles[static_cast<size_t>(e.rectangle)].rectangle.id.c_str() : "");
    text += line;
  }
  WriteFileAtomic(path, text);
}

MapBuildResult RunMapBuild(const MapBuildJob& job) {
  job.Check();
  NamedPaths reads = FrameSource::InputReads(job.input);
  reads.insert(reads.end(), {{"--map", job.map_path}, {"--calib", job.calib_path}, {"--poses", job.poses_path}});
  CheckPlannedOutputs(reads, {{"-o", job.output}, {"--report", job.report_csv}}, job.overwrite);
  const Calibration calib = ReadCalibration(job.calib_path);
  const Map seed = ReadMap(job.map_path);
  CheckMapUnits(calib, seed, job.map_path, job.calib_path);
  if (seed.rectangles.empty() && seed.boxes.empty())
    throw Error(job.map_path + ": the seed map has no landmarks (give a few measured rectangles)");
  if (job.has_start && !seed.IsFree(job.start.x, job.start.y))
    throw Error("--start: (" + std::to_string(job.start.x) + ", " + std::to_string(job.start.y) +
                ") is outside the room or inside a box of " + job.map_path);
  std::vector<PoseRow> rows;
  if (!job.poses_path.empty()) rows = ReadPosesOnePerFrame(job.poses_path, job.input);
  const Sensor& s = calib.sensor;
  FrameSource frames(job.input);
  CheckFrameSize(frames.width(), frames.height(), s, job.input, job.calib_path);
  MapBuilder builder(calib, seed, job.options);
  std::unique_ptr<Localizer> localizer;
  if (job.poses_path.empty()) {
    localizer = std::make_unique<Localizer>(
        calib, seed, std::make_shared<RadiusTable>(RadiusTable::Build(s, RangesForMap(seed, s))), LocalizerOptions());
    if (job.has_start)
      localizer->Reset(job.start, /*hint=*/true);  // as panoloc --init
    else
      localizer->ResetUnknown();
  }
  cv::Mat grey;
  int n = 0;
  for (;; ++n) {
    double timestamp = std::nan("");
    if (!frames.Read(&grey, &timestamp)) break;
    bool has_pose = false;
    Pose2 pose;
    if (!job.poses_path.empty()) {
      if (n >= static_cast<int>(rows.size()))
        throw Error(job.poses_path + ": " + std::to_string(rows.size()) + " rows, but " + job.input +
                    " has more frames (one row per frame expected)");
      if (rows[n].status == PoseStatus::kOk) {
        has_pose = true;
        pose = rows[n].pose;
      }
    } else {
      const double t = std::isfinite(timestamp) ? timestamp : n / (frames.fps() > 0 ? frames.fps() : 10.0);
      const FrameResult fr = localizer->Process(grey, n, t);
      if (fr.row.status == PoseStatus::kOk) {
        has_pose = true;
        pose = fr.row.pose;
      }
    }
    if (has_pose)
      builder.AddFrame(grey, pose);
    else
      builder.AddFrameWithoutPose();
  }
  if (!job.poses_path.empty() && static_cast<int>(rows.size()) != n)
    throw Error(job.poses_path + ": " + std::to_string(rows.size()) + " rows for the " + std::to_string(n) +
                " frames of " + job.input + " (one row per frame expected)");
  MapBuildResult r = builder.Build();
  if (r.frames_with_pose == 0)
    throw Error(job.input + ": not localised in any of its " + std::to_string(n) + " frames with " + job.map_path +
                " (give the start pose with --start, or the poses with --poses)");
  if (r.frames_with_seed == 0)
    throw Error(job.map_path + ": no seed landmark is in view in any of the " + std::to_string(n) + " frames of " +
                job.input + " (check the map's units and origin, and the poses)");
  WriteMap(job.output, r.map);
  if (!job.report_csv.empty()) WriteMapBuildCsv(job.report_csv, r);
  return r;
}

}  // namespace pano
