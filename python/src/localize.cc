// Localisation: the per-frame Localizer (as panoloc drives it), whole inputs
// through panoloc's own RunPanoloc, and grey frames read as panoloc reads them.
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <future>
#include <limits>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "bindings.h"
#include "panotrack/core/error.h"
#include "panotrack/io/calibration.h"
#include "panotrack/io/map.h"
#include "panotrack/io/pose_csv.h"
#include "panotrack/pipeline/panoloc.h"
#include "panotrack/track/localizer.h"
#include "panotrack/video/frame_source.h"

namespace pano::python {

namespace {

namespace fs = std::filesystem;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
using PoseArg = std::optional<std::array<double, 3>>;

TrackingMethod MethodOf(const std::string& name) {
  if (name == "junction") return TrackingMethod::kJunction;
  if (name == "vertex") return TrackingMethod::kVertex;
  throw Error("method: expected junction or vertex, got '" + name + "'");
}

std::optional<Pose2> PoseOf(const PoseArg& p) {
  if (!p) return std::nullopt;
  const Pose2 pose{(*p)[0], (*p)[1], (*p)[2]};
  if (!std::isfinite(pose.x) || !std::isfinite(pose.y) || !std::isfinite(pose.theta))
    throw Error("init: expected finite x, y, theta");
  return pose;
}

std::string PathOf(const py::object& o) { return py::str(py::module_::import("os").attr("fspath")(o)); }

// A Calibration or a Map given as the object or as its file's path.
Calibration CalibrationOf(const py::object& o) {
  if (py::isinstance<Calibration>(o)) return o.cast<Calibration>();
  return ReadCalibration(PathOf(o));
}
Map MapOf(const py::object& o) {
  if (py::isinstance<Map>(o)) return o.cast<Map>();
  return ReadMap(PathOf(o));
}

// panoloc's localiser options (--method, --search-px, --min-step,
// --alert-fraction, the per-input threads).
LocalizerOptions LocalizerOptionsOf(const std::string& method, int num_threads, double search_px, double min_step,
                                    double alert_fraction) {
  LocalizerOptions o;
  o.method = MethodOf(method);
  o.num_threads = num_threads;
  o.search_px = search_px;
  o.junction.min_step = min_step;
  o.alert_fraction = alert_fraction;
  return o;
}

// A 2-D uint8 numpy array as a cv::Mat sharing its memory (rows may be
// strided; columns must be contiguous).
cv::Mat GreyView(const py::array& frame) {
  if (frame.ndim() != 2 || !frame.dtype().is(py::dtype::of<uint8_t>()) || frame.strides(1) != 1)
    throw py::value_error("frame: expected a 2-D uint8 array (H x W grey image) with contiguous rows");
  return cv::Mat(static_cast<int>(frame.shape(0)), static_cast<int>(frame.shape(1)), CV_8UC1,
                 const_cast<void*>(frame.data()), static_cast<size_t>(frame.strides(0)));
}

py::array_t<double> Matrix3(const Eigen::Matrix3d& m) {
  py::array_t<double> a({3, 3});
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) *a.mutable_data(r, c) = m(r, c);
  return a;
}

double Extra(const PoseRow& row, size_t k) { return k < row.extra.size() ? row.extra[k] : kNaN; }

// The localiser panoloc runs per input (pipeline/localize_video.cc), one
// frame at a time.
class PyLocalizer {
 public:
  PyLocalizer(const py::object& calibration, const py::object& map, const std::string& method, const PoseArg& init,
              int num_threads, double fps, double search_px, double min_step, double alert_fraction)
      : calib_(CalibrationOf(calibration)), map_(MapOf(map)), fps_(fps) {
    if (calib_.units != map_.units)
      throw Error("map: units '" + map_.units + "' differ from the calibration's '" + calib_.units + "'");
    if (!(fps > 0) || !std::isfinite(fps)) throw Error("fps: expected a positive number");
    options_ = LocalizerOptionsOf(method, num_threads, search_px, min_step, alert_fraction);
    options_.Check();
    py::gil_scoped_release release;
    table_ = TableForMap(calib_, map_, /*quiet=*/true, TableCacheOptions(), options_.num_threads);
    ph_tables_ = MakeTrackingPhTables(table_, options_.num_threads);
    localizer_ = std::make_unique<Localizer>(calib_, map_, table_, options_, ph_tables_);
    ResetTo(PoseOf(init));
  }

  void Reset(const PoseArg& init) { ResetTo(PoseOf(init)); }

  py::dict Track(const py::array& frame, std::optional<double> time_s, bool details) {
    const cv::Mat grey = GreyView(frame);
    FrameResult fr;
    std::vector<FrameResult> confirmed;
    {
      py::gil_scoped_release release;
      // One frame at a time, whichever Python threads call; the frame
      // counter moves on only when the frame was processed.
      std::lock_guard<std::mutex> lock(busy_);
      const int index = next_frame_;
      fr = localizer_->Process(grey, index, time_s ? *time_s : index / fps_);
      confirmed = localizer_->TakeConfirmedHolds();
      next_frame_ = index + 1;
    }
    py::dict d = ResultDict(fr, details);
    d["unconfirmed"] = fr.unconfirmed;
    py::list confirms;
    py::object previous = py::none();
    for (const FrameResult& held : confirmed) {
      py::dict h = ResultDict(held, details);
      confirms.append(h);
      if (held.row.frame == fr.row.frame - 1) previous = h;
    }
    d["confirms"] = confirms;
    d["confirms_previous"] = previous;
    return d;
  }

  int next_frame() const { return next_frame_.load(); }
  const Calibration& calibration() const { return calib_; }
  const Map& map() const { return map_; }
  std::string method() const { return TrackingMethodName(options_.method); }

 private:
  py::dict ResultDict(const FrameResult& fr, bool details) const {
    const PoseRow& row = fr.row;
    const bool ok = row.status == PoseStatus::kOk;
    const bool has_pose = row.status != PoseStatus::kLost;
    py::dict d;
    d["frame"] = row.frame;
    d["time_s"] = row.time_s;
    d["status"] = PoseStatusName(row.status);
    d["x"] = has_pose ? row.pose.x : kNaN;
    d["y"] = has_pose ? row.pose.y : kNaN;
    d["theta"] = has_pose ? WrapAngle(row.pose.theta) : kNaN;
    d["std_x"] = Extra(row, 0);
    d["std_y"] = Extra(row, 1);
    d["std_theta"] = Extra(row, 2);
    d["quality"] = Extra(row, 3);
    d["covariance"] = ok ? Matrix3(fr.covariance) : Matrix3(Eigen::Matrix3d::Constant(kNaN));
    d["n_landmarks"] = row.n_landmarks;
    d["residual"] = has_pose ? row.residual : kNaN;
    d["relocalized"] = fr.relocalized;
    d["innovation"] = fr.innovation >= 0 ? fr.innovation : kNaN;
    d["predicted"] = py::make_tuple(fr.predicted_pose.x, fr.predicted_pose.y, fr.predicted_pose.theta);
    if (details) d["landmarks"] = Landmarks(fr);
    return d;
  }

  // As panoloc: a given pose is a hint (the room-wide search takes over when
  // the first frame does not confirm it); none: the room-wide search.
  void ResetTo(const std::optional<Pose2>& init) {
    if (init && !map_.IsFree(init->x, init->y))
      throw Error("init: (" + std::to_string(init->x) + ", " + std::to_string(init->y) +
                  ") is outside the room or inside a box of the map");
    if (init)
      localizer_->Reset(*init, /*hint=*/true);
    else
      localizer_->ResetUnknown();
    next_frame_ = 0;
  }

  // What the frame's measurement saw, as panoloc's debug video draws it
  // (pipeline/debug_draw.cc): per predicted landmark its id, the predicted
  // corner and vertical edge, whether it was found, the junction and why
  // not; the edges' image points with the landmark they belong to.
  py::dict Landmarks(const FrameResult& fr) const {
    const Sensor& s = calib_.sensor;
    const size_t n = std::min(fr.predicted.size(), fr.measurements.size());
    const py::ssize_t k = static_cast<py::ssize_t>(n);
    py::list ids, why;
    py::array_t<bool> found(k);
    py::array_t<double> corner({k, py::ssize_t{2}}), edge({k, py::ssize_t{2}, py::ssize_t{2}}),
        junction({k, py::ssize_t{2}}), world({k, py::ssize_t{3}});
    size_t n_points = 0;
    for (size_t i = 0; i < n; ++i) n_points += fr.measurements[i].edge_points.size();
    py::array_t<double> points({static_cast<py::ssize_t>(n_points), py::ssize_t{2}});
    py::array_t<int32_t> owner(static_cast<py::ssize_t>(n_points));
    py::ssize_t q = 0;
    for (size_t i = 0; i < n; ++i) {
      const PredictedLandmark& p = fr.predicted[i];
      const LandmarkMeasurement& m = fr.measurements[i];
      const py::ssize_t r = static_cast<py::ssize_t>(i);
      ids.append(p.landmark ? p.landmark->id : std::string());
      why.append(m.found ? std::string() : std::string(m.why ? m.why : ""));
      found.mutable_at(r) = m.found;
      const Eigen::Vector2d a = s.from_polar(p.corner_radius, p.azimuth), b = s.from_polar(p.v_radius, p.azimuth);
      const Eigen::Vector2d j = m.found ? s.from_polar(m.radius, m.azimuth) : Eigen::Vector2d(kNaN, kNaN);
      const Eigen::Vector3d w = p.landmark ? p.landmark->corner : Eigen::Vector3d::Constant(kNaN);
      for (int c = 0; c < 2; ++c) {
        corner.mutable_at(r, c) = p.corner_px[c];
        edge.mutable_at(r, 0, c) = a[c];
        edge.mutable_at(r, 1, c) = b[c];
        junction.mutable_at(r, c) = j[c];
      }
      for (int c = 0; c < 3; ++c) world.mutable_at(r, c) = w[c];
      for (const Eigen::Vector2d& e : m.edge_points) {
        points.mutable_at(q, 0) = e.x();
        points.mutable_at(q, 1) = e.y();
        owner.mutable_at(q) = static_cast<int32_t>(i);
        ++q;
      }
    }
    py::dict d;
    d["ids"] = ids;
    d["found"] = found;
    d["why"] = why;
    d["corner_world"] = world;
    d["predicted_corner_px"] = corner;
    d["predicted_edge_px"] = edge;
    d["junction_px"] = junction;
    d["edge_points_px"] = points;
    d["edge_point_landmark"] = owner;
    return d;
  }

  Calibration calib_;
  Map map_;
  double fps_;
  LocalizerOptions options_;
  std::shared_ptr<const RadiusTable> table_;
  std::shared_ptr<PhTableCache> ph_tables_;
  std::unique_ptr<Localizer> localizer_;
  std::mutex busy_;
  std::atomic<int> next_frame_{0};
};

// A scratch folder removed when it goes out of scope.
class ScratchFolder {
 public:
  ScratchFolder() {
    std::string pattern = (fs::temp_directory_path() / "panotrack_py_XXXXXX").string();
    if (!::mkdtemp(pattern.data())) throw Error("cannot create a temporary folder in " + fs::temp_directory_path().string());
    path_ = pattern;
  }
  ~ScratchFolder() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

py::dict AccuracyDict(const AccuracySummary& a) {
  py::dict d;
  d["frames"] = a.frames;
  d["tracked"] = a.tracked;
  d["compared"] = a.compared;
  d["rms"] = a.rms;
  d["std"] = a.std;
  d["max"] = a.max;
  d["mean"] = a.mean;
  d["heading_rms_deg"] = a.heading_rms_deg;
  d["heading_max_deg"] = a.heading_max_deg;
  d["outliers"] = a.outliers;
  return d;
}

// RunPanoloc on one input into a scratch CSV, read back: the rows are
// panoloc's, as it writes them. Ctrl-C stops the run (cancel flag) and
// raises KeyboardInterrupt.
py::tuple LocalizeVideoColumns(const std::string& input, const std::string& calib_path, const std::string& map_path,
                               const std::string& method, const PoseArg& init, double fps, int num_threads,
                               const std::string& gt, double search_px, double min_step, double alert_fraction) {
  ScratchFolder scratch;
  std::atomic<bool> cancel{false};
  PanolocOptions opt;
  opt.inputs = {input};
  opt.output = scratch.path() + "/poses.csv";
  opt.calib_path = calib_path;
  opt.map_path = map_path;
  opt.init = PoseOf(init);
  opt.fps = fps;
  opt.num_threads = num_threads;
  opt.quiet = true;
  opt.gt = gt;
  opt.localizer = LocalizerOptionsOf(method, 0, search_px, min_step, alert_fraction);
  opt.cancel = &cancel;
  std::future<std::vector<VideoSummary>> run = std::async(std::launch::async, [&opt] { return RunPanoloc(opt); });
  for (;;) {
    bool ready;
    {
      py::gil_scoped_release release;
      ready = run.wait_for(std::chrono::milliseconds(100)) == std::future_status::ready;
    }
    if (ready) break;
    if (PyErr_CheckSignals() != 0) {
      cancel = true;
      py::gil_scoped_release release;
      run.wait();
      py::gil_scoped_acquire acquire;
      throw py::error_already_set();
    }
  }
  const VideoSummary sum = run.get().at(0);
  if (sum.end == VideoEnd::kFailed) throw Error(sum.error);
  const std::vector<PoseRow> rows = fs::exists(opt.output) ? ReadPoseCsv(opt.output) : std::vector<PoseRow>{};

  const py::ssize_t n = static_cast<py::ssize_t>(rows.size());
  py::array_t<int32_t> frame(n), n_landmarks(n);
  std::vector<std::string> status(rows.size());
  const char* names[] = {"time_s", "x", "y", "theta_rad", "residual", "std_x", "std_y", "std_theta", "quality"};
  std::vector<py::array_t<double>> cols;
  for (size_t k = 0; k < std::size(names); ++k) cols.emplace_back(n);
  for (py::ssize_t i = 0; i < n; ++i) {
    const PoseRow& r = rows[static_cast<size_t>(i)];
    const bool lost = r.status == PoseStatus::kLost;
    frame.mutable_at(i) = r.frame;
    n_landmarks.mutable_at(i) = r.n_landmarks;
    status[static_cast<size_t>(i)] = PoseStatusName(r.status);
    const double values[] = {r.time_s,   lost ? kNaN : r.pose.x,     lost ? kNaN : r.pose.y,
                             lost ? kNaN : r.pose.theta, lost ? kNaN : r.residual, Extra(r, 0),
                             Extra(r, 1), Extra(r, 2),   Extra(r, 3)};
    for (size_t k = 0; k < std::size(names); ++k) cols[k].mutable_at(i) = values[k];
  }
  py::dict columns;
  columns["frame"] = frame;
  columns["status"] = status;
  columns["n_landmarks"] = n_landmarks;
  for (size_t k = 0; k < std::size(names); ++k) columns[names[k]] = cols[k];

  py::dict summary;
  summary["input"] = sum.input;
  summary["end"] = VideoEndName(sum.end);
  summary["ok"] = sum.ok;
  summary["error"] = sum.error;
  summary["frames"] = sum.frames;
  summary["n_ok"] = sum.n_ok;
  summary["n_lost"] = sum.n_lost;
  summary["seconds"] = sum.seconds;
  summary["accuracy"] = sum.has_accuracy ? py::object(AccuracyDict(sum.accuracy)) : py::object(py::none());
  return py::make_tuple(columns, summary);
}

// Grey frames of a video, image folder or pattern, decoded as panoloc decodes them.
class PyFrameReader {
 public:
  explicit PyFrameReader(const std::string& path) : source_(std::make_unique<FrameSource>(path)) {}
  py::tuple Next() {
    if (!source_) throw py::stop_iteration();
    cv::Mat grey;
    double t = kNaN;
    bool got;
    {
      py::gil_scoped_release release;
      got = source_->Read(&grey, &t);
    }
    if (!got) {
      source_.reset();
      throw py::stop_iteration();
    }
    py::array_t<uint8_t> a({grey.rows, grey.cols});
    for (int r = 0; r < grey.rows; ++r) std::memcpy(a.mutable_data(r, 0), grey.ptr(r), static_cast<size_t>(grey.cols));
    return py::make_tuple(a, t);
  }
  int width() const { return source_or_throw()->width(); }
  int height() const { return source_or_throw()->height(); }
  double fps() const { return source_or_throw()->fps(); }
  int frame_count() const { return source_or_throw()->frame_count(); }

 private:
  const FrameSource* source_or_throw() const {
    if (!source_) throw Error("frame reader: closed (all frames read)");
    return source_.get();
  }
  std::unique_ptr<FrameSource> source_;
};

}  // namespace

void BindLocalize(py::module_& m) {
  const LocalizerOptions defaults;
  py::class_<PyLocalizer>(m, "Localizer",
                          "The per-frame localiser as panoloc runs it: track(frame) for each grey frame in order")
      .def(py::init<const py::object&, const py::object&, const std::string&, const PoseArg&, int, double, double,
                    double, double>(),
           py::arg("calibration"), py::arg("map"), py::arg("method") = "junction", py::arg("init") = py::none(),
           py::arg("num_threads") = 0, py::arg("fps") = 10.0, py::arg("search_px") = defaults.search_px,
           py::arg("min_step") = defaults.junction.min_step, py::arg("alert_fraction") = defaults.alert_fraction,
           "calibration, map: objects or file paths; method: junction or vertex; init: (x, y, theta) guess "
           "of the first pose (None: search the room); fps: for time_s when track() is given none; "
           "search_px, min_step, alert_fraction: as panoloc's --search-px, --min-step, --alert-fraction")
      .def("track", &PyLocalizer::Track, py::arg("frame"), py::arg("time_s") = py::none(),
           py::arg("details") = false,
           "Localises the next frame (uint8 H x W). Returns a dict: frame, time_s, status (ok, lost, init), "
           "x, y, theta, std_x, std_y, std_theta, quality, covariance (3 x 3, x y theta), n_landmarks, "
           "residual, relocalized, innovation, predicted (x, y, theta); NaN where not defined; unconfirmed "
           "(a pose the room-wide search found, reported lost until a later frame confirms it: the next, "
           "or for a sparse lead the one that ends its run); confirms (the dicts, ok, of the held frames "
           "this frame confirmed, in frame order) and confirms_previous (None, or the previous frame's "
           "dict among them). With "
           "details, also landmarks: what the frame's measurement saw, as panoloc's debug video draws it "
           "(per predicted landmark: ids, found, why, corner_world (K, 3), predicted_corner_px (K, 2), "
           "predicted_edge_px (K, 2, 2: the vertical edge's ends), junction_px (K, 2, NaN when not found); "
           "edge_points_px (M, 2) and edge_point_landmark (M,): the edges' points found and their landmark)")
      .def("reset", &PyLocalizer::Reset, py::arg("init") = py::none(), "Starts a new sequence (frame 0)")
      .def_property_readonly("next_frame", &PyLocalizer::next_frame)
      .def_property_readonly("calibration", &PyLocalizer::calibration)
      .def_property_readonly("map", &PyLocalizer::map)
      .def_property_readonly("method", &PyLocalizer::method);

  m.def("_localize_video", &LocalizeVideoColumns, py::arg("input"), py::arg("calibration_path"),
        py::arg("map_path"), py::arg("method"), py::arg("init"), py::arg("fps"), py::arg("num_threads"),
        py::arg("gt"), py::arg("search_px") = defaults.search_px, py::arg("min_step") = defaults.junction.min_step,
        py::arg("alert_fraction") = defaults.alert_fraction);

  m.def(
      "_format_pose_row",
      [](int frame, double time_s, const std::string& status, double x, double y, double theta, int n_landmarks,
         double residual, const std::vector<double>& extra) {
        PoseRow row;
        row.frame = frame;
        row.time_s = time_s;
        if (status == "ok") row.status = PoseStatus::kOk;
        else if (status == "lost") row.status = PoseStatus::kLost;
        else if (status == "init") row.status = PoseStatus::kInit;
        else throw Error("pose row: status: expected ok, lost or init, got '" + status + "'");
        row.pose = {x, y, theta};
        row.n_landmarks = n_landmarks;
        row.residual = residual;
        row.extra = extra;
        return FormatPoseRow(row);
      },
      py::arg("frame"), py::arg("time_s"), py::arg("status"), py::arg("x"), py::arg("y"), py::arg("theta"),
      py::arg("n_landmarks"), py::arg("residual"), py::arg("extra"),
      "The line panoloc writes to its pose CSV for one row (no newline)");
  m.def(
      "_initial_pose_beside",
      [](const py::object& input) -> py::object {
        const std::optional<Pose2> p = InitialPoseBeside(PathOf(input));
        return p ? py::object(py::make_tuple(p->x, p->y, p->theta)) : py::object(py::none());
      },
      py::arg("input"), "initial_pose of the case.yaml beside an input (or one folder up), as panoloc takes it");

  py::class_<PyFrameReader>(m, "FrameReader",
                            "Iterates over the grey frames (uint8 H x W, time_s) of a video, image folder or "
                            "printf pattern, decoded as panoloc decodes them")
      .def(py::init([](const py::object& path) { return std::make_unique<PyFrameReader>(PathOf(path)); }),
           py::arg("path"))
      .def("__iter__", [](py::object self) { return self; })
      .def("__next__", &PyFrameReader::Next)
      .def_property_readonly("width", &PyFrameReader::width)
      .def_property_readonly("height", &PyFrameReader::height)
      .def_property_readonly("fps", &PyFrameReader::fps, "0 when unknown (image folders)")
      .def_property_readonly("frame_count", &PyFrameReader::frame_count, "-1 when unknown");
}

}  // namespace pano::python
