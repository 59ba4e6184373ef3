// panomap check as a whole: inputs read and checked, the frames measured
// from their poses, the report, the CSV and the overlay.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

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

namespace fs = std::filesystem;

bool IsImageFile(const std::string& path) {
  std::string ext = fs::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), ::tolower);
  std::error_code ec;
  return fs::is_regular_file(path, ec) &&
         (ext == ".png" || ext == ".jpg" || ext == ".jpeg" || ext == ".pgm" || ext == ".bmp" || ext == ".tif" ||
          ext == ".tiff" || ext == ".ppm");
}

bool IsImageOutput(const std::string& path) {
  std::string ext = fs::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), ::tolower);
  return ext == ".png" || ext == ".jpg" || ext == ".jpeg";
}

// The frames of a video, a folder or pattern of images, or one image file.
class Frames {
 public:
  explicit Frames(const std::string& input) : input_(input) {
    if (IsImageFile(input)) {
      FrameSource::CheckImageComplete(input);
      image_ = cv::imread(input, cv::IMREAD_GRAYSCALE);
      if (image_.empty()) throw Error(input + ": cannot read this image");
    } else {
      source_ = std::make_unique<FrameSource>(input);
    }
  }
  int width() const { return source_ ? source_->width() : image_.cols; }
  int height() const { return source_ ? source_->height() : image_.rows; }
  double fps() const { return source_ ? source_->fps() : 0.0; }
  bool Read(cv::Mat* grey, double* time_s) {
    if (source_) return source_->Read(grey, time_s);
    if (done_) return false;
    done_ = true;
    *grey = image_;
    *time_s = std::nan("");
    return true;
  }

 private:
  std::string input_;
  std::unique_ptr<FrameSource> source_;
  cv::Mat image_;
  bool done_ = false;
};

std::shared_ptr<const RadiusTable> TableFor(const Calibration& calib, const Map& map) {
  const LutRanges need = RangesForMap(map, calib.sensor);
  if (!calib.lut_resolved.empty()) {
    try {
      auto t = std::make_shared<RadiusTable>(RadiusTable::Load(calib.lut_resolved, &calib.sensor));
      if (t->Covers(need)) return t;
    } catch (const Error&) {
      // A table that cannot be used is rebuilt below.
    }
  }
  return std::make_shared<RadiusTable>(RadiusTable::Build(calib.sensor, need));
}


int EdgeStatusRank(const EdgeCheck& e, int min_visible) {
  if (e.visible < min_visible) return 0;
  return e.findings.empty() ? 1 : 2;
}

cv::Scalar StatusColour(const EdgeCheck& e, int min_visible) {
  if (e.visible < min_visible) return cv::Scalar(160, 160, 160);
  for (MapFinding f : e.findings) {
    if (f == MapFinding::kNeverFound) return cv::Scalar(0, 0, 255);
    if (f == MapFinding::kWrongPolarity) return cv::Scalar(255, 0, 255);
    if (f == MapFinding::kBiased) return cv::Scalar(0, 140, 255);
  }
  return cv::Scalar(0, 200, 0);
}

cv::Point ToPoint(const Eigen::Vector2d& p) { return cv::Point(int(std::lround(p.x())), int(std::lround(p.y()))); }

}  // namespace

cv::Mat DrawMapCheck(const cv::Mat& grey, const FrameCheck& fc, const MapCheckReport& report,
                     const Sensor& sensor) {
  const int min_visible_frames = report.min_visible_frames;
  cv::Mat out;
  cv::cvtColor(grey, out, cv::COLOR_GRAY2BGR);
  // Findings drawn last, over the edges that are fine.
  std::vector<const EdgeFrameMeasurement*> order;
  for (const EdgeFrameMeasurement& m : fc.edges) order.push_back(&m);
  std::stable_sort(order.begin(), order.end(), [&](const EdgeFrameMeasurement* a, const EdgeFrameMeasurement* b) {
    return EdgeStatusRank(report.edges[a->edge], min_visible_frames) <
           EdgeStatusRank(report.edges[b->edge], min_visible_frames);
  });
  for (const EdgeFrameMeasurement* m : order) {
    const EdgeCheck& e = report.edges[m->edge];
    const cv::Scalar colour = StatusColour(e, min_visible_frames);
    cv::line(out, ToPoint(m->corner_px), ToPoint(m->v_end_px), colour, 1, cv::LINE_AA);
    for (const auto& curve : m->h_curves)
      for (size_t i = 1; i < curve.size(); ++i)
        cv::line(out, ToPoint(curve[i - 1]), ToPoint(curve[i]), colour, 1, cv::LINE_AA);
    if (m->found) {
      double r, az;
      sensor.to_polar(m->corner_px.x(), m->corner_px.y(), &r, &az);
      cv::drawMarker(out, ToPoint(sensor.from_polar(r, m->measured_azimuth)), colour, cv::MARKER_CROSS, 7, 1);
    }
    cv::putText(out, e.id, ToPoint(m->v_end_px) + cv::Point(3, -3), cv::FONT_HERSHEY_PLAIN, 0.8, colour, 1,
                cv::LINE_AA);
  }
  char header[96];
  std::snprintf(header, sizeof header, "frame %d: green ok, red not found, magenta polarity, orange biased",
                fc.frame);
  cv::putText(out, header, cv::Point(6, 14), cv::FONT_HERSHEY_PLAIN, 0.9, cv::Scalar(255, 255, 255), 1, cv::LINE_AA);
  return out;
}

void WriteMapCheckCsv(const std::string& path, const MapCheckReport& report) {
  std::string text =
      "edge,object,x,y,visible,found,found_fraction,polarity_fraction,residual_frames,mean_bearing_deg,"
      "std_bearing_deg,mean_radial_px,std_radial_px,mean_distance,map_shade,seen_shade,findings\n";
  char line[512];
  for (const EdgeCheck& e : report.edges) {
    std::string findings;
    for (MapFinding f : e.findings) findings += (findings.empty() ? "" : ";") + std::string(MapFindingName(f));
    std::snprintf(line, sizeof line, "%s,%s,%.6g,%.6g,%d,%d,%.4f,%.4f,%d,%.4f,%.4f,%.3f,%.3f,%.2f,%.3f,%.3f,%s\n",
                  e.id.c_str(), e.object.c_str(), e.position.x(), e.position.y(), e.visible, e.found,
                  e.found_fraction, e.polarity_fraction, e.residual_frames, e.mean_residual_deg, e.std_residual_deg,
                  e.mean_radial_px, e.std_radial_px, e.mean_distance, e.shade, e.seen_shade, findings.c_str());
    text += line;
  }
  WriteFileAtomic(path, text);
}

bool PoseFitsTheMap(const FrameCheck& fc, double limit) {
  std::vector<double> r;
  for (const EdgeFrameMeasurement& m : fc.edges)
    if (m.found && m.has_residual) r.push_back(std::abs(m.bearing_residual));
  if (r.size() < 3) return false;
  std::nth_element(r.begin(), r.begin() + static_cast<long>(r.size() / 2), r.end());
  return r[r.size() / 2] <= limit;
}

void MapCheckJob::Check() const {
  if (map_path.empty()) throw Error("--map (map_path): required");
  if (calib_path.empty()) throw Error("--calib (calib_path): required");
  if (input.empty()) throw Error("INPUT (input): a video, image folder or image is required");
  if (pose && !poses_path.empty()) throw Error("--pose and --poses: give one or the other");
  if (pose && (!std::isfinite(pose->x) || !std::isfinite(pose->y) || !std::isfinite(pose->theta)))
    throw Error("--pose (pose): expected finite x,y,theta");
  options.Check();
}

MapCheckReport RunMapCheck(const MapCheckJob& job) {
  job.Check();
  NamedPaths reads = FrameSource::InputReads(job.input);
  reads.insert(reads.end(), {{"--map", job.map_path}, {"--calib", job.calib_path}, {"--poses", job.poses_path}});
  CheckPlannedOutputs(reads, {{"-o", job.overlay}, {"--report", job.report_csv}}, job.overwrite);
  const Calibration calib = ReadCalibration(job.calib_path);
  const Map map = ReadMap(job.map_path);
  CheckMapUnits(calib, map, job.map_path, job.calib_path);
  if (map.rectangles.empty() && map.boxes.empty()) throw Error(job.map_path + ": the map has no landmarks");
  if (job.pose && !map.IsFree(job.pose->x, job.pose->y))
    throw Error("--pose: (" + std::to_string(job.pose->x) + ", " + std::to_string(job.pose->y) +
                ") is outside the room or inside a box of " + job.map_path);
  std::vector<PoseRow> rows;
  if (!job.poses_path.empty()) rows = ReadPosesOnePerFrame(job.poses_path, job.input);
  const Sensor& s = calib.sensor;
  Frames frames(job.input);
  CheckFrameSize(frames.width(), frames.height(), s, job.input, job.calib_path);
  const std::shared_ptr<const RadiusTable> table = TableFor(calib, map);
  FrameChecker checker(calib, map, table, job.options);
  const bool localise = !job.pose && job.poses_path.empty();
  std::unique_ptr<Localizer> localizer;
  if (localise) {
    localizer = std::make_unique<Localizer>(calib, map, table, LocalizerOptions());
    localizer->ResetUnknown();
  }
  std::unique_ptr<MapBuilder> builder;
  if (job.options.find_unmapped) builder = std::make_unique<MapBuilder>(calib, map, job.options.unmapped);
  std::vector<FrameCheck> checks;
  cv::Mat grey, best_grey;
  int best = -1;
  for (int frame = 0;; ++frame) {
    double timestamp = std::nan("");
    if (!frames.Read(&grey, &timestamp)) break;
    if (grey.cols != s.image_width || grey.rows != s.image_height)
      throw Error(job.input + ": frame " + std::to_string(frame) + " is " + SizeText(grey.cols, grey.rows) +
                  ", the calibration's " + SizeText(s.image_width, s.image_height));
    std::optional<Pose2> pose = job.pose;
    if (!rows.empty() || !job.poses_path.empty()) {
      if (frame >= static_cast<int>(rows.size()))
        throw Error(job.poses_path + ": " + std::to_string(rows.size()) + " rows, but " + job.input +
                    " has more frames (one row per frame expected)");
      if (rows[frame].status == PoseStatus::kOk) pose = rows[frame].pose;
    }
    if (localise) {
      const double t = std::isfinite(timestamp) ? timestamp : frame / (frames.fps() > 0 ? frames.fps() : 10.0);
      const FrameResult fr = localizer->Process(grey, frame, t);
      if (fr.row.status == PoseStatus::kOk) pose = fr.row.pose;
    }
    FrameCheck fc;
    fc.frame = frame;
    if (pose) {
      fc = checker.Measure(grey, frame, *pose);
      if (localise)
        checker.SetHeldOutResiduals(&fc);
      else
        checker.SetResiduals(&fc);
    }
    if (builder) {
      if (pose && PoseFitsTheMap(fc, job.options.unmapped_pose_residual))
        builder->AddFrame(grey, *pose);
      else
        builder->AddFrameWithoutPose();
    }
    if (!job.overlay.empty() && IsImageOutput(job.overlay) &&
        (best < 0 || fc.edges.size() > checks[best].edges.size())) {
      best = frame;
      best_grey = grey.clone();
    }
    checks.push_back(std::move(fc));
  }
  const int n = static_cast<int>(checks.size());
  if (!job.poses_path.empty() && static_cast<int>(rows.size()) != n)
    throw Error(job.poses_path + ": " + std::to_string(rows.size()) + " rows for the " + std::to_string(n) +
                " frames of " + job.input + " (one row per frame expected)");
  MapCheckReport report = SummarizeMapCheck(map, checker.edges(), checks, job.options);
  if (builder) AddUnmappedFindings(map, builder->Build(), &report);
  if (report.frames_with_pose == 0)
    throw Error(job.input + ": not localised in any of its " + std::to_string(n) + " frames with " + job.map_path +
                " (give the poses with --pose or --poses)");
  if (report.frames_with_landmarks == 0)
    throw Error(job.map_path + ": no landmark is in view in any of the " + std::to_string(n) + " frames of " +
                job.input + " (check the map's units and origin, and the poses)");
  if (!job.report_csv.empty()) WriteMapCheckCsv(job.report_csv, report);
  if (!job.overlay.empty()) {
    if (IsImageOutput(job.overlay)) {
      std::vector<uchar> png;
      const std::string ext = fs::path(job.overlay).extension().string();
      if (!cv::imencode(ext, DrawMapCheck(best_grey, checks[best], report, s), png))
        throw Error(job.overlay + ": cannot encode the overlay");
      WriteFileAtomic(job.overlay, std::string(png.begin(), png.end()));
    } else {
      // A second pass over the input: every frame annotated.
      Frames again(job.input);
      AtomicFile file(job.overlay);
      cv::VideoWriter writer;
      const double fps = again.fps() > 0 ? again.fps() : 10.0;
      const cv::Size size(s.image_width, s.image_height);
      if (!writer.open(file.temp_path(), cv::VideoWriter::fourcc('a', 'v', 'c', '1'), fps, size, true) &&
          !writer.open(file.temp_path(), cv::VideoWriter::fourcc('m', 'p', '4', 'v'), fps, size, true))
        throw Error(job.overlay + ": cannot open a video writer");
      double t;
      for (int frame = 0; frame < n && again.Read(&grey, &t); ++frame)
        writer.write(DrawMapCheck(grey, checks[frame], report, s));
      writer.release();
      file.Commit();
    }
  }
  return report;
}

}  // namespace pano
