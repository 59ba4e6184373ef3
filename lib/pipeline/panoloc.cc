#include "pipeline/panoloc.h"

#include <unistd.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <mutex>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>
#include <thread>

#include <omp.h>

#include "core/atomic_file.h"
#include "core/error.h"
#include "io/calibration.h"
#include "io/map.h"
#include "video/frame_source.h"

namespace pano {

namespace fs = std::filesystem;

void PanolocOptions::Check() const {
  if (inputs.empty()) throw Error("no input video given");
  if (calib_path.empty()) throw Error("--calib: required");
  if (map_path.empty()) throw Error("--map: required");
  if (inputs.size() == 1 && output.empty() && out_dir.empty())
    throw Error("give -o OUT.csv (one input) or --out-dir DIR");
  if (inputs.size() > 1 && out_dir.empty())
    throw Error("several inputs: give --out-dir DIR (one CSV per input)");
  if (inputs.size() > 1 && (!debug_video.empty() || !plot.empty() || (!gt.empty() && gt != "auto")))
    throw Error("--debug-video, --plot and --gt FILE take one input (use --gt auto for several)");
  if (jobs < 0) throw Error("--jobs: expected a positive number");
  if (fps < 0 || !std::isfinite(fps)) throw Error("--fps: expected a positive number");
  if (init && (!std::isfinite(init->x) || !std::isfinite(init->y) || !std::isfinite(init->theta)))
    throw Error("--init: expected finite x,y,theta");
  localizer.Check();
}

AccuracySummary CompareToGroundTruth(const std::vector<PoseRow>& est, const std::vector<PoseRow>& gt,
                                     double typical_range) {
  AccuracySummary a;
  std::map<int, const PoseRow*> by_frame;
  for (const PoseRow& r : est)
    if (r.status == PoseStatus::kOk) by_frame[r.frame] = &r;
  std::vector<Eigen::Vector2d> errors;
  std::vector<double> heading;
  for (const PoseRow& g : gt) {
    if (g.status == PoseStatus::kLost) continue;
    ++a.frames;
    auto it = by_frame.find(g.frame);
    if (it == by_frame.end()) continue;
    errors.emplace_back(it->second->pose.x - g.pose.x, it->second->pose.y - g.pose.y);
    heading.push_back(wrap_angle(it->second->pose.theta - g.pose.theta));
  }
  a.tracked = static_cast<int>(by_frame.size());
  a.compared = static_cast<int>(errors.size());
  if (errors.empty()) return a;
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  double sum2 = 0, sum_h2 = 0;
  std::vector<double> mags;
  for (size_t i = 0; i < errors.size(); ++i) {
    mean += errors[i];
    sum2 += errors[i].squaredNorm();
    mags.push_back(errors[i].norm());
    a.max = std::max(a.max, mags.back());
    a.mean += mags.back();
    sum_h2 += heading[i] * heading[i];
    a.heading_max_deg = std::max(a.heading_max_deg, std::abs(heading[i]) * 180 / M_PI);
  }
  const double n = static_cast<double>(errors.size());
  mean /= n;
  a.mean /= n;
  a.rms = std::sqrt(sum2 / n);
  a.std = std::sqrt(std::max(0.0, sum2 / n - mean.squaredNorm()));
  a.heading_rms_deg = std::sqrt(sum_h2 / n) * 180 / M_PI;
  std::vector<double> sorted = mags;
  std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
  const double median = sorted[sorted.size() / 2];
  const double limit = std::max(5.0 * median, 0.01 * typical_range);
  Eigen::Vector2d m_in = Eigen::Vector2d::Zero();
  double s_in = 0;
  int n_in = 0;
  for (size_t i = 0; i < errors.size(); ++i) {
    if (mags[i] > limit && limit > 0) {
      ++a.outliers;
      continue;
    }
    m_in += errors[i];
    s_in += errors[i].squaredNorm();
    ++n_in;
  }
  if (n_in > 0) {
    m_in /= n_in;
    a.std_inliers = std::sqrt(std::max(0.0, s_in / n_in - m_in.squaredNorm()));
  }
  return a;
}

std::string FormatAccuracy(const AccuracySummary& a, const std::string& units) {
  char buf[512];
  std::snprintf(buf, sizeof buf,
                "position error: RMS %.3f, std %.3f, mean %.3f, max %.3f %s; heading error: RMS %.3f, "
                "max %.3f deg; outliers %d (%.1f %%); frames tracked %d/%d",
                a.rms, a.std, a.mean, a.max, units.c_str(), a.heading_rms_deg, a.heading_max_deg,
                a.outliers, a.compared ? 100.0 * a.outliers / a.compared : 0.0, a.tracked, a.frames);
  return buf;
}

std::shared_ptr<const RadiusTable> TableForMap(const Calibration& calib, const Map& map, bool quiet) {
  const LutRanges need = RangesForMap(map, calib.sensor);
  if (!calib.lut_resolved.empty()) {
    try {
      auto t = std::make_shared<RadiusTable>(RadiusTable::Load(calib.lut_resolved, &calib.sensor));
      if (t->Covers(need)) return t;
      if (!quiet)
        std::fprintf(stderr, "panoloc: note: %s does not cover the map's distances and heights; "
                             "building a table for this map\n", calib.lut_resolved.c_str());
    } catch (const Error& e) {
      if (!quiet) std::fprintf(stderr, "panoloc: note: %s; building a table instead\n", e.what());
    }
  }
  return std::make_shared<RadiusTable>(RadiusTable::Build(calib.sensor, need));
}

std::optional<Pose2> InitialPoseBeside(const std::string& input) {
  fs::path dir = fs::is_directory(input) ? fs::path(input) : fs::path(input).parent_path();
  if (dir.empty()) dir = ".";  // a file in the current folder
  for (int up = 0; up < 2 && !dir.empty(); ++up, dir = dir.parent_path()) {
    const fs::path p = dir / "case.yaml";
    if (!fs::exists(p)) continue;
    try {
      const YAML::Node n = YAML::LoadFile(p.string());
      const YAML::Node ip = n["initial_pose"];
      if (ip && ip.IsMap())
        return Pose2{ip["x"].as<double>(), ip["y"].as<double>(), ip["theta"].as<double>()};
    } catch (const YAML::Exception& e) {
      throw Error(p.string() + ": initial_pose: " + e.what());
    }
  }
  return std::nullopt;
}

namespace {

// Debug frame like the paper's Fig. 7: predicted edges (yellow), found edge
// points (green), junctions (red crosses), landmark ids.
void DrawDebug(const cv::Mat& grey, const Sensor& s, const FrameResult& fr, cv::Mat* out) {
  cv::cvtColor(grey, *out, cv::COLOR_GRAY2BGR);
  auto pt = [](const Eigen::Vector2d& p) { return cv::Point2d(p.x(), p.y()); };
  for (size_t i = 0; i < fr.predicted.size(); ++i) {
    const PredictedLandmark& p = fr.predicted[i];
    const LandmarkMeasurement& m = fr.measurements[i];
    cv::line(*out, pt(s.from_polar(p.corner_radius, p.azimuth)), pt(s.from_polar(p.v_radius, p.azimuth)),
             cv::Scalar(0, 200, 255), 1, cv::LINE_AA);
    for (const Eigen::Vector2d& q : m.edge_points)
      cv::circle(*out, pt(q), 1, cv::Scalar(0, 220, 0), cv::FILLED);
    if (m.found) {
      const Eigen::Vector2d j = s.from_polar(m.radius, m.azimuth);
      cv::drawMarker(*out, pt(j), cv::Scalar(0, 0, 255), cv::MARKER_CROSS, 9, 1);
      cv::putText(*out, p.landmark->id, pt(j) + cv::Point2d(4, -4), cv::FONT_HERSHEY_PLAIN, 0.7,
                  cv::Scalar(255, 255, 0), 1, cv::LINE_AA);
    } else {
      cv::drawMarker(*out, pt(p.corner_px), cv::Scalar(0, 128, 255), cv::MARKER_TILTED_CROSS, 5, 1);
    }
  }
  char buf[128];
  std::snprintf(buf, sizeof buf, "frame %d  %s  %d landmarks", fr.row.frame,
                pose_status_name(fr.row.status), fr.row.n_landmarks);
  cv::putText(*out, buf, cv::Point(6, 16), cv::FONT_HERSHEY_PLAIN, 1.0, cv::Scalar(255, 255, 255), 1,
              cv::LINE_AA);
}

// The map from above with the estimated trajectory (blue) and the ground
// truth (green), written atomically as PNG.
void WritePlot(const std::string& path, const Map& map, const std::vector<PoseRow>& est,
               const std::vector<PoseRow>& gt) {
  Eigen::Vector2d lo, hi;
  double top;
  map.Extent(&lo, &hi, &top);
  for (const auto& r : est)
    if (r.status != PoseStatus::kLost) {
      lo = lo.cwiseMin(Eigen::Vector2d(r.pose.x, r.pose.y));
      hi = hi.cwiseMax(Eigen::Vector2d(r.pose.x, r.pose.y));
    }
  const int size = 800, margin = 40;
  const double scale = (size - 2 * margin) / std::max(hi.x() - lo.x(), hi.y() - lo.y());
  cv::Mat img(size, size, CV_8UC3, cv::Scalar(255, 255, 255));
  auto P = [&](double x, double y) {
    return cv::Point2d(margin + (x - lo.x()) * scale, size - margin - (y - lo.y()) * scale);
  };
  if (map.room.present)
    cv::rectangle(img, P(map.room.min.x(), map.room.min.y()), P(map.room.max.x(), map.room.max.y()),
                  cv::Scalar(120, 120, 120), 2);
  for (const auto& r : map.rectangles)
    cv::line(img, P(r.from.x(), r.from.y()), P(r.to.x(), r.to.y()), cv::Scalar(40, 40, 40), 3);
  for (const auto& b : map.boxes)
    cv::rectangle(img, P(b.min.x(), b.min.y()), P(b.max.x(), b.max.y()), cv::Scalar(60, 60, 160), 2);
  auto draw = [&](const std::vector<PoseRow>& rows, const cv::Scalar& colour, int radius) {
    cv::Point2d last(-1, -1);
    for (const auto& r : rows) {
      if (r.status == PoseStatus::kLost) {
        last = cv::Point2d(-1, -1);
        continue;
      }
      const cv::Point2d p = P(r.pose.x, r.pose.y);
      if (last.x >= 0) cv::line(img, last, p, colour, 1, cv::LINE_AA);
      cv::circle(img, p, radius, colour, cv::FILLED, cv::LINE_AA);
      last = p;
    }
  };
  draw(gt, cv::Scalar(0, 160, 0), 3);
  draw(est, cv::Scalar(200, 60, 0), 2);
  cv::putText(img, "estimate (blue), ground truth (green), units: " + map.units, cv::Point(margin, 24),
              cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  AtomicFile f(path);
  if (!cv::imwrite(f.temp_path(), img)) throw Error(path + ": cannot write the plot");
  f.Commit();
}

double TypicalRange(const Map& map, const std::vector<PoseRow>& rows) {
  std::vector<Eigen::Vector2d> corners;
  for (const auto& r : map.rectangles) corners.push_back(r.from), corners.push_back(r.to);
  for (const auto& b : map.boxes) corners.push_back(b.min.head<2>()), corners.push_back(b.max.head<2>());
  double sum = 0;
  int n = 0;
  for (const auto& row : rows) {
    if (row.status == PoseStatus::kLost) continue;
    for (const auto& c : corners) sum += (c - Eigen::Vector2d(row.pose.x, row.pose.y)).norm(), ++n;
  }
  return n ? sum / n : 0.0;
}

}  // namespace

VideoSummary LocalizeVideo(const std::string& input, const std::string& output,
                           const Calibration& calib, const Map& map,
                           std::shared_ptr<const RadiusTable> table, const PanolocOptions& options,
                           const Pose2& init, const std::string& gt_path,
                           const std::string& debug_video, const std::string& plot,
                           std::atomic<long>* frames_done, std::shared_ptr<PhTableCache> ph_tables) {
  VideoSummary sum;
  sum.input = input;
  sum.output = output;
  const auto t0 = std::chrono::steady_clock::now();
  try {
    std::vector<PoseRow> gt;
    if (!gt_path.empty()) gt = ReadPoseCsv(gt_path);
    FrameSource source(input);
    const Sensor& s = calib.sensor;
    if (source.width() != s.image_width || source.height() != s.image_height)
      throw Error(input + ": frame size " + std::to_string(source.width()) + "x" +
                  std::to_string(source.height()) + " does not match the calibration's " +
                  std::to_string(s.image_width) + "x" + std::to_string(s.image_height) + " (" +
                  options.calib_path + ")");
    const double fps = options.fps > 0 ? options.fps : (source.fps() > 0 ? source.fps() : 10.0);
    Localizer loc(calib, map, table, options.localizer, std::move(ph_tables));
    loc.Reset(init);
    std::unique_ptr<AtomicFile> dbg_file;
    cv::VideoWriter dbg;
    if (!debug_video.empty()) {
      dbg_file = std::make_unique<AtomicFile>(debug_video);
      const cv::Size size(s.image_width, s.image_height);
      if (!dbg.open(dbg_file->temp_path(), cv::VideoWriter::fourcc('a', 'v', 'c', '1'), fps, size, true) &&
          !dbg.open(dbg_file->temp_path(), cv::VideoWriter::fourcc('m', 'p', '4', 'v'), fps, size, true))
        throw Error(debug_video + ": cannot open a video writer");
    }
    PoseCsvWriter csv(output, {"std_x", "std_y", "std_theta"});
    std::vector<PoseRow> rows;
    cv::Mat grey, annotated;
    for (int frame = 0; source.Read(&grey); ++frame) {
      if (grey.cols != s.image_width || grey.rows != s.image_height)
        throw Error(input + ": frame " + std::to_string(frame) + " changes size");
      const FrameResult fr = loc.Process(grey, frame, frame / fps);
      csv.Write(fr.row);
      rows.push_back(fr.row);
      ++sum.frames;
      sum.n_ok += fr.row.status == PoseStatus::kOk;
      sum.n_lost += fr.row.status == PoseStatus::kLost;
      if (dbg.isOpened()) {
        DrawDebug(grey, s, fr, &annotated);
        dbg.write(annotated);
      }
      if (frames_done) ++*frames_done;
    }
    csv.Close();
    if (dbg.isOpened()) {
      dbg.release();
      dbg_file->Commit();
    }
    if (!plot.empty()) WritePlot(plot, map, rows, gt);
    if (!gt.empty()) {
      sum.has_accuracy = true;
      sum.accuracy = CompareToGroundTruth(rows, gt, TypicalRange(map, gt));
    }
    sum.ok = true;
  } catch (const Error& e) {
    sum.error = e.what();
  } catch (const cv::Exception& e) {
    sum.error = input + ": " + e.what();
  }
  sum.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return sum;
}

std::vector<VideoSummary> RunPanoloc(const PanolocOptions& opt) {
  opt.Check();
  const Calibration calib = ReadCalibration(opt.calib_path);
  const Map map = ReadMap(opt.map_path);
  if (calib.units != map.units)
    throw Error(opt.map_path + ": units '" + map.units + "' differ from the calibration's '" +
                calib.units + "' (" + opt.calib_path + ")");
  if (opt.init && !map.IsFree(opt.init->x, opt.init->y))
    throw Error("--init: (" + std::to_string(opt.init->x) + ", " + std::to_string(opt.init->y) +
                ") is outside the room or inside a box of " + opt.map_path);
  // Per-input set-up that can fail before any work starts.
  struct Job {
    std::string input, output, gt;
    Pose2 init;
    std::string error;  // set-up failure of this input alone
  };
  std::vector<Job> jobs;
  for (const std::string& in : opt.inputs) {
    Job j;
    j.input = in;
    if (!opt.out_dir.empty()) {
      fs::create_directories(opt.out_dir);
      std::string stem = fs::path(in).stem().string();
      if (stem.empty() || stem == "video") stem = fs::path(in).parent_path().filename().string() + "_" + stem;
      j.output = (fs::path(opt.out_dir) / (stem + ".csv")).string();
    } else {
      j.output = opt.output;
    }
    if (opt.gt == "auto") {
      fs::path dir = fs::is_directory(in) ? fs::path(in) : fs::path(in).parent_path();
      if (dir.empty()) dir = ".";
      const fs::path g = dir / "gt.csv";
      if (fs::exists(g)) j.gt = g.string();
    } else {
      j.gt = opt.gt;
    }
    if (opt.init) {
      j.init = *opt.init;
    } else {
      try {
        std::optional<Pose2> p = InitialPoseBeside(in);
        if (!p) throw Error(in + ": no --init given and no case.yaml with initial_pose beside it");
        if (!map.IsFree(p->x, p->y))
          throw Error(in + ": the initial pose in case.yaml lies outside the room of " + opt.map_path);
        j.init = *p;
      } catch (const Error& e) {
        j.error = e.what();
      }
    }
    jobs.push_back(j);
  }
  std::shared_ptr<const RadiusTable> table = TableForMap(calib, map, opt.quiet);
  // One set of PH tables for every input (they depend on the sensor and the
  // map's edge heights only).
  auto ph_tables = MakeTrackingPhTables(table);
  const int n_jobs = std::max(1, std::min<int>(opt.jobs > 0 ? opt.jobs : static_cast<int>(std::thread::hardware_concurrency()),
                                               static_cast<int>(jobs.size())));
  // Parallel across videos, or across landmarks within one video. Each video
  // has a decoding thread of its own: leave it a core, since OpenMP's
  // spinning barriers collapse when the cores are oversubscribed.
  const int cores = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  omp_set_num_threads(n_jobs > 1 ? 1 : std::max(1, cores - 1));
  std::vector<VideoSummary> out(jobs.size());
  std::atomic<long> done{0};
  std::atomic<size_t> next{0};
  std::atomic<bool> finished{false};
  const bool show = opt.progress && !opt.quiet && ::isatty(2);
  long total = 0;
  if (show)
    for (const Job& j : jobs) total += std::max(0, FrameSource::FrameCount(j.input));
  const auto t0 = std::chrono::steady_clock::now();
  std::thread reporter;
  if (show) {
    reporter = std::thread([&] {
      while (!finished) {
        std::this_thread::sleep_for(std::chrono::milliseconds(250));
        const double el = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        const long d = done;
        const double rate = el > 0 ? d / el : 0;
        if (total > 0)
          std::fprintf(stderr, "\rpanoloc: %ld/%ld frames, %.1f frames/s, ETA %.0f s   ", d, total, rate,
                       rate > 0 ? (total - d) / rate : 0.0);
        else
          std::fprintf(stderr, "\rpanoloc: %ld frames, %.1f frames/s   ", d, rate);
      }
      std::fprintf(stderr, "\r%*s\r", 70, "");
    });
  }
  std::vector<std::thread> workers;
  for (int w = 0; w < n_jobs; ++w) {
    workers.emplace_back([&] {
      for (size_t i; (i = next++) < jobs.size();) {
        const Job& j = jobs[i];
        if (!j.error.empty()) {
          out[i].input = j.input;
          out[i].output = j.output;
          out[i].error = j.error;
          continue;
        }
        out[i] = LocalizeVideo(j.input, j.output, calib, map, table, opt, j.init, j.gt,
                               jobs.size() == 1 ? opt.debug_video : "", jobs.size() == 1 ? opt.plot : "",
                               &done, ph_tables);
      }
    });
  }
  for (auto& t : workers) t.join();
  finished = true;
  if (reporter.joinable()) reporter.join();
  return out;
}

}  // namespace pano
