#include "panotrack/pipeline/panosim.h"

#include <cstdio>

#include "panotrack/core/error.h"
#include "panotrack/core/output_check.h"
#include "panotrack/io/calibration.h"
#include "panotrack/io/map.h"

namespace pano {

namespace {

// Board images targets renders at most with auto_count (a calibration uses
// 20..50).
constexpr int kMaxAutoImages = 1000;

void Adjust(const RenderAdjustments& adjust, Sensor* sensor) {
  if (adjust.sensor) adjust.sensor(sensor);
}

void Adjust(const RenderAdjustments& adjust, RenderOptions* options) {
  if (adjust.options) adjust.options(options);
  options->num_threads = adjust.num_threads;
  options->Check("options");
}

// The still's sensor, map, pose and options: from a preset or from files.
void StillScene(const StillJob& job, Sensor* sensor, Map* map, Pose2* pose, RenderOptions* ro) {
  if (!job.preset.empty()) {
    if (!job.map_path.empty() || !job.calib_path.empty() || job.pose)
      throw Error("--preset: give either --preset or --map/--calib/--pose, not both");
    const SequenceCase c = MakePreset(job.preset);
    if (job.frame < 0 || job.frame >= static_cast<int>(c.poses.size()))
      throw Error("--frame: " + std::to_string(job.frame) + " is outside 0.." + std::to_string(c.poses.size() - 1) +
                  " of preset '" + job.preset + "'");
    *sensor = c.calib.sensor;
    *map = c.map;
    *pose = c.poses[static_cast<size_t>(job.frame)];
    *ro = c.options;
    return;
  }
  if (job.map_path.empty()) throw Error("--map: required (or give --preset)");
  if (job.calib_path.empty()) throw Error("--calib: required (or give --preset)");
  if (!job.pose) throw Error("--pose: required: x,y,theta (map units, radians)");
  *map = ReadMap(job.map_path);
  *sensor = ReadCalibration(job.calib_path).sensor;
  *pose = *job.pose;
  CheckPose(*map, *pose, "--pose");
}

SequenceCase SequenceCaseOf(const SequenceJob& job) {
  if (!job.preset.empty()) {
    if (!job.map_path.empty() || !job.calib_path.empty() || !job.trajectory_path.empty())
      throw Error("--preset: give either --preset or --map/--calib/--trajectory, not both");
    SequenceCase c = MakePreset(job.preset);
    if (job.fps) c.fps = *job.fps;
    return c;
  }
  if (job.map_path.empty()) throw Error("--map: required (or give --preset)");
  if (job.calib_path.empty()) throw Error("--calib: required (or give --preset)");
  if (job.trajectory_path.empty()) throw Error("--trajectory: required (or give --preset)");
  return MakeCase(job.map_path, job.calib_path, job.trajectory_path, job.fps.value_or(10.0));
}

std::vector<BoardPose> BoardPosesOf(const TargetsJob& job, const Sensor& sensor, uint64_t seed) {
  if (!job.board_poses_path.empty()) {
    std::vector<BoardPose> poses = ReadBoardPoses(job.board_poses_path);
    for (size_t i = 0; i < poses.size(); ++i)
      if (job.on_warning && !BoardFullyVisible(sensor, job.board, poses[i], 0.0, 1.0))
        job.on_warning(job.board_poses_path + ": line " + std::to_string(i + 2) +
                       ": not every inner corner of the board is in view");
    return poses;
  }
  if (job.auto_count) {
    if (*job.auto_count > kMaxAutoImages)  // (below 1: AutoBoardPoses says so)
      throw Error("--auto: expected at most " + std::to_string(kMaxAutoImages) + " images, got " +
                  std::to_string(*job.auto_count));
    return AutoBoardPoses(sensor, job.board, *job.auto_count, seed, job.min_visible);
  }
  throw Error("--poses or --auto: give the board poses file or the number of images to generate");
}

}  // namespace

void RunStill(const StillJob& job) {
  Sensor sensor;
  Map map;
  Pose2 pose;
  RenderOptions ro;
  CheckPlannedOutputs({{"--map", job.map_path}, {"--calib", job.calib_path}}, {{"-o", job.output}}, job.overwrite);
  StillScene(job, &sensor, &map, &pose, &ro);
  Adjust(job.adjust, &sensor);
  Adjust(job.adjust, &ro);
  WritePng(job.output, RenderStill(sensor, map, pose, ro));
}

SequenceWriteResult RunSequence(const SequenceJob& job) {
  // The output folder is replaced as a whole, overwrite or not.
  CheckFolderOutputHoldsNoInput(
      {{"--map", job.map_path}, {"--calib", job.calib_path}, {"--trajectory", job.trajectory_path}}, "-o",
      job.output);
  SequenceCase c = SequenceCaseOf(job);
  // The video encoder's range of frame rates (x264 fails outside it with its own lines).
  if (!(c.fps >= 0.01 && c.fps <= 1000)) {
    char fps[64];
    std::snprintf(fps, sizeof fps, "%g", c.fps);
    throw Error(std::string("--fps: expected a frame rate from 0.01 to 1000 frames/s, got ") + fps);
  }
  Adjust(job.adjust, &c.calib.sensor);
  // A preset's survey error stays unless the job replaces it.
  const SurveyError preset = c.survey;
  c.survey = job.survey;
  c.survey.sigma = job.survey_sigma.value_or(preset.sigma);
  c.survey.seed = job.survey_seed.value_or(preset.seed);
  Adjust(job.adjust, &c.options);
  return WriteSequence(c, job.output, job.write);
}

void RunTargets(const TargetsJob& job) {
  // The output folder is replaced as a whole, overwrite or not.
  CheckFolderOutputHoldsNoInput({{"--calib", job.calib_path}, {"--poses", job.board_poses_path}}, "-o", job.output);
  if (job.calib_path.empty() && job.preset.empty()) throw Error("--calib: required (or give --preset)");
  Calibration calib = job.preset.empty() ? ReadCalibration(job.calib_path) : MakePreset(job.preset).calib;
  Adjust(job.adjust, &calib.sensor);
  RenderOptions ro;
  Adjust(job.adjust, &ro);
  const std::vector<BoardPose> poses = BoardPosesOf(job, calib.sensor, ro.seed);
  WriteTargetImages(job.output, calib, job.board, poses, ro, job.write);
}

}  // namespace pano
