#include "panotrack/render/writers.h"

#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "panotrack/core/angles.h"
#include "panotrack/core/atomic_file.h"
#include "panotrack/core/error.h"
#include "panotrack/io/calibration.h"
#include "panotrack/io/map.h"
#include "panotrack/io/pose_csv.h"
#include "panotrack/io/tum.h"
#include "panotrack/io/yaml_util.h"
#include "panotrack/render/sequence.h"

namespace fs = std::filesystem;

namespace pano {

void WritePng(const std::string& path, const cv::Mat& image) {
  AtomicFile f(path);
  bool ok = false;
  try {
    ok = cv::imwrite(f.temp_path(), image);
  } catch (const cv::Exception& e) {
    throw Error(path + ": cannot write the PNG: " + e.what());
  }
  if (!ok) throw Error(path + ": cannot write the PNG (is the folder writable, the name *.png?)");
  f.Commit();
}

StagingDir::StagingDir(const std::string& final_dir, bool overwrite, const std::string& option)
    : final_(final_dir), overwrite_(overwrite) {
  if (final_.empty()) throw Error(option + ": expected an output folder");
  while (final_.size() > 1 && final_.back() == '/') final_.pop_back();
  std::error_code ec;
  const fs::path parent = fs::path(final_).parent_path();
  if (!parent.empty() && !fs::is_directory(parent, ec))
    throw Error(option + ": '" + final_ + "': the parent folder '" + parent.string() + "' does not exist");
  if (fs::exists(final_, ec)) {
    if (!fs::is_directory(final_, ec)) throw Error(option + ": '" + final_ + "' exists and is not a folder");
    if (!fs::is_empty(final_, ec) && !overwrite_)
      throw Error(option + ": '" + final_ + "' exists and is not empty (use --force to replace it)");
  }
  temp_ = final_ + ".tmp-" + std::to_string(::getpid());
  fs::remove_all(temp_, ec);
  if (!fs::create_directory(temp_, ec))
    throw Error(option + ": cannot create '" + temp_ + "': " + ec.message());
}

StagingDir::~StagingDir() {
  if (!committed_) {
    std::error_code ec;
    fs::remove_all(temp_, ec);
  }
}

void StagingDir::Commit() {
  std::error_code ec;
  std::string old;
  if (fs::exists(final_, ec)) {
    old = final_ + ".old-" + std::to_string(::getpid());
    fs::remove_all(old, ec);
    fs::rename(final_, old, ec);
    if (ec) throw Error(final_ + ": cannot move the old folder aside: " + ec.message());
  }
  fs::rename(temp_, final_, ec);
  if (ec) {
    std::error_code ec2;
    if (!old.empty()) fs::rename(old, final_, ec2);
    throw Error(final_ + ": cannot move the finished folder into place: " + ec.message());
  }
  committed_ = true;
  if (!old.empty()) fs::remove_all(old, ec);
}

std::string CaseYaml(const SequenceCase& c, const std::string& codec) {
  const RenderOptions& r = c.options;
  YamlWriter w;
  w.Comment("panosim test case: ground truth is gt.csv (a pose CSV), map.yaml and calib.yaml.");
  w.BeginMap();
  w.Key("preset").String(c.name);
  w.Key("description").String(c.description);
  w.Key("units").String(c.map.units);
  w.Key("frames").Int(static_cast<long long>(c.poses.size()));
  w.Key("fps").Double(c.fps);
  w.Key("seed").Unsigned(r.seed);
  const SurveyError& e = c.survey;
  if (e.any()) {
    if (e.sigma > 0.0) w.Key("map_sigma").Double(e.sigma);
    if (e.offset_sigma > 0.0) w.Key("map_offset_sigma").Double(e.offset_sigma);
    if (e.gross > 0) {
      w.Key("map_gross").Int(e.gross);
      w.Key("map_faults").String("map_faults.yaml");
    }
    w.Key("map_seed").Unsigned(e.seed);
  }
  w.Key("initial_pose").BeginMap();
  w.Key("x").Double(c.poses.front().x);
  w.Key("y").Double(c.poses.front().y);
  w.Key("theta").Double(c.poses.front().theta);
  w.EndMap();
  auto int_list = [&](const std::vector<int>& values) {
    w.BeginList();
    for (int v : values) w.Int(v);
    w.EndList();
  };
  if (!c.kidnap_frames.empty()) {
    w.Key("kidnap_frame").Int(c.kidnap_frames.front());  // the first, for readers of one kidnap
    w.Key("kidnap_frames");
    int_list(c.kidnap_frames);
  }
  if (!codec.empty()) {
    w.Key("video").String("video.mp4");
    w.Key("video_codec").String(codec);
  }
  w.Key("render").BeginMap();
  w.Key("supersample").Int(r.supersample);
  w.Key("noise_sigma").Double(r.noise_sigma);
  w.Key("blur_3x3").Bool(r.blur);
  w.Key("illumination").Double(r.illumination);
  w.Key("gradient").Double(r.gradient);
  w.Key("gradient_angle").Double(r.gradient_angle);
  w.Key("distractors").Int(static_cast<long long>(c.map.distractors.size()));
  w.Key("camera_radius_px").Double(r.camera_radius_px);
  // The factors of real cameras and rooms, only when on (older cases stay as they were).
  const int n = static_cast<int>(c.poses.size());
  if (r.exposure > 0.0) {
    w.Key("exposure").Double(r.exposure);
    w.Key("blur_samples").Int(r.blur_samples);
  }
  if (r.auto_exposure > 0.0) w.Key("auto_exposure").Double(r.auto_exposure);
  if (r.texture > 0.0) w.Key("texture").Double(r.texture);
  if (r.people > 0) w.Key("people").Int(r.people);
  if (r.covered_frames > 0) {
    w.Key("covered_frames");  // true frame numbers (see gt.csv's time column)
    int_list(CoveredFrames(r, n));
  }
  if (r.dropped_frames > 0) {
    w.Key("dropped_frames");  // true frame numbers left out of video.mp4 and gt.csv
    int_list(DroppedFrames(r, n));
  }
  w.EndMap();
  w.EndMap();
  return w.Text();
}

namespace {

// `v` printed with `format` and read back: the value a CSV reader gets.
double AsWritten(double v, const char* format) {
  char buf[64];
  std::snprintf(buf, sizeof buf, format, v);
  return std::strtod(buf, nullptr);
}

}  // namespace

std::string MapFaultsYaml(const std::vector<MapFault>& faults, const std::string& units) {
  YamlWriter w;
  w.Comment("panosim: the gross errors of map.yaml; map_true.yaml is the room rendered.");
  w.BeginMap();
  w.Key("units").String(units);
  w.Key("faults").BeginList();
  for (const MapFault& f : faults) {
    w.BeginMap();
    w.Key("id").String(f.id);
    w.Key("kind").String(MapFaultName(f.kind));
    if (f.kind == MapFaultKind::kMoved) w.Key("offset").Numbers({f.offset.x(), f.offset.y()});
    w.EndMap();
  }
  w.EndList();
  w.EndMap();
  return w.Text();
}

SequenceWriteResult WriteSequence(const SequenceCase& c, const std::string& dir,
                                  const SequenceWriteOptions& wo) {
  CheckCase(c, c.name == "custom" ? "sequence" : "preset '" + c.name + "'");
  if (!wo.video && !wo.frames) throw Error("--no-video: nothing to write (give --frames)");
  StagingDir sd(dir, wo.overwrite);
  const Sensor& sensor = c.calib.sensor;
  const SurveyedMap survey = SurveyMap(c.map, c.survey);
  SequenceCase rendered = c;  // the room as it stands
  rendered.map = survey.room;
  const SequenceRenderer renderer(rendered);
  const Scene& scene = renderer.scene();
  SequenceWriteResult res;
  cv::VideoWriter video;
  const cv::Size size(sensor.image_width, sensor.image_height);
  if (wo.video) {
    const std::string vpath = sd.File("video.mp4");
    if (video.open(vpath, cv::VideoWriter::fourcc('a', 'v', 'c', '1'), c.fps, size, true)) {
      res.codec = "h264";
    } else if (video.open(vpath, cv::VideoWriter::fourcc('m', 'p', '4', 'v'), c.fps, size, true)) {
      res.codec = "mp4v";
      if (wo.on_note)
        wo.on_note("warning: H.264 encoding is not available in this OpenCV; video.mp4 uses MPEG-4 part 2 (mp4v)");
    } else {
      throw Error(dir + "/video.mp4: OpenCV cannot open a video writer (neither avc1 nor mp4v)");
    }
  }
  if (wo.frames) fs::create_directory(sd.File("frames"));
  PoseCsvWriter gt(sd.File("gt.csv"));
  TumWriter gt_tum(sd.File("gt.tum"), TumConversionForMap(c.map));
  const int n = static_cast<int>(c.poses.size());
  cv::Mat bgr;
  // Dropped frames are left out: the video stays constant-rate, and gt.csv's
  // frame column is the video's frame index while its time is the true time.
  int written = 0;
  for (int i = 0; i < n; ++i) {
    if (renderer.Dropped(i)) continue;
    const Pose2& pose = c.poses[static_cast<size_t>(i)];
    const cv::Mat img = renderer.RenderFrame(i);
    if (wo.video) {
      cv::cvtColor(img, bgr, cv::COLOR_GRAY2BGR);
      video.write(bgr);
    }
    if (wo.frames) {
      char name[64];
      std::snprintf(name, sizeof(name), "frames/frame_%04d.png", written);
      WritePng(sd.File(name), img);
    }
    PoseRow row;
    row.frame = written++;
    row.time_s = i / c.fps;
    row.status = PoseStatus::kOk;
    row.pose = pose;
    row.n_landmarks = static_cast<int>(VisibleCorners(sensor, survey.room, scene, pose).size());
    row.residual = 0.0;
    gt.Write(row);
    // On the video's clock (its frame / fps), which panoloc's rows carry,
    // so that evo pairs them by time even after dropped frames; the pose as
    // gt.csv has it, the truth panoloc's accuracy is measured against, so
    // that evo's statistics are panoloc's.
    row.time_s = row.frame / c.fps;
    row.pose = {AsWritten(pose.x, "%.4f"), AsWritten(pose.y, "%.4f"),
                AsWritten(WrapAngle(pose.theta), "%.6f")};
    gt_tum.Write(row);
    if (wo.on_progress && ((i + 1) % 10 == 0 || i + 1 == n)) wo.on_progress(i + 1, n);
  }
  gt.Close();
  gt_tum.Close();
  if (wo.video) video.release();
  WriteMap(sd.File("map.yaml"), survey.map, false);
  if (c.survey.any()) WriteMap(sd.File("map_true.yaml"), survey.room, false);
  if (!survey.faults.empty())
    WriteFileAtomic(sd.File("map_faults.yaml"), MapFaultsYaml(survey.faults, c.map.units));
  Calibration calib = c.calib;
  calib.lut.clear();
  WriteCalibration(sd.File("calib.yaml"), calib);
  WriteFileAtomic(sd.File("case.yaml"), CaseYaml(c, res.codec));
  sd.Commit();
  res.frames = written;
  return res;
}

}  // namespace pano
