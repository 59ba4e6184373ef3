#include <cmath>
#include <cstdio>
#include <memory>
#include <string>

#include "commands.h"
#include "panotrack/core/error.h"
#include "panotrack/core/output_check.h"
#include "panotrack/io/calibration.h"
#include "panotrack/io/map.h"
#include "panotrack/lut/radius_table.h"

namespace pano::app {

namespace {

// A comma-separated option of exactly n finite numbers ("x,y,z").
CLI::Option* AddNumbers(CLI::App* app, const std::string& name, std::vector<double>& values, int n,
                        const std::string& help) {
  return app->add_option(name, values, help)
      ->delimiter(',')
      ->expected(n)
      ->check(CLI::Validator(
          [](std::string& v) {
            char* end = nullptr;
            const double x = std::strtod(v.c_str(), &end);
            return end == v.c_str() + v.size() && !v.empty() && std::isfinite(x)
                       ? std::string()
                       : "'" + v + "' is not a finite number";
          },
          "NUMBER"))
      ->required();
}

}  // namespace

void AddProjectCommands(CLI::App& app) {
  auto calib = std::make_shared<std::string>();
  auto quiet = std::make_shared<bool>(false);
  auto point = std::make_shared<std::vector<double>>();
  auto pixel = std::make_shared<std::vector<double>>();
  CLI::App* proj = app.add_subcommand(
      "project",
      "Print the pixel 'u v' at which a point of the sensor frame appears, or 'not visible'. The "
      "sensor frame: x forward, y left, z up from the pinhole, in the calibration's units.");
  proj->add_option("--calib", *calib, "Calibration YAML")->required();
  AddNumbers(proj, "--point", *point, 3, "x,y,z in the sensor frame");
  proj->add_flag("-q,--quiet", *quiet, "No note when the pixel lies outside the image");
  proj->callback([calib, point, quiet]() {
    const Calibration c = ReadCalibration(*calib);
    const std::vector<double>& p = *point;
    Eigen::Vector2d px;
    if (!c.sensor.project({p[0], p[1], p[2]}, &px)) {
      std::printf("not visible\n");
      return;
    }
    std::printf("%.6f %.6f\n", px.x(), px.y());
    if (!*quiet && !c.sensor.inside_image(px))
      std::fprintf(stderr, "panocalib: note: the pixel lies outside the %dx%d image\n",
                   c.sensor.image_width, c.sensor.image_height);
  });

  auto calib2 = std::make_shared<std::string>();
  CLI::App* back = app.add_subcommand(
      "backproject",
      "Print the reflected ray of a pixel, or 'no mirror'. The ray: its origin on the mirror and its "
      "unit direction in the sensor frame ('ox oy oz dx dy dz'); 'no mirror' outside the mirror's "
      "visible disc.");
  back->add_option("--calib", *calib2, "Calibration YAML")->required();
  AddNumbers(back, "--pixel", *pixel, 2, "u,v (column, row; origin at the top-left pixel's centre)");
  back->callback([calib2, pixel]() {
    const Calibration c = ReadCalibration(*calib2);
    const std::vector<double>& p = *pixel;
    Eigen::Vector3d o, d;
    if (!c.sensor.backproject({p[0], p[1]}, &o, &d)) {
      std::printf("no mirror\n");
      return;
    }
    std::printf("%.9f %.9f %.9f %.9f %.9f %.9f\n", o.x(), o.y(), o.z(), d.x(), d.y(), d.z());
  });
}

void AddLutCommand(CLI::App& app) {
  struct Opts {
    std::string calib, map, out;
    int n = 1024;
    bool force = false, quiet = false;
  };
  auto o = std::make_shared<Opts>();
  CLI::App* lut = app.add_subcommand(
      "lut",
      "Build the E(D,Z) lookup table of a calibration and its inverse. E(D,Z) is the image radius "
      "of a point at horizontal distance D and height Z. Ranges come from --map when given, else "
      "from the sensor (2 to 400 mirror distances).");
  lut->add_option("--calib", o->calib, "Calibration YAML")->required();
  lut->add_option("--map", o->map, "Map YAML whose room and landmarks the table must cover");
  lut->add_option("-o,--output", o->out, "Output table file (.lut)")->required();
  lut->add_flag("--force", o->force, "Replace an existing output file");
  lut->add_option("--size", o->n, "Nodes along each axis of the forward table")->capture_default_str();
  lut->add_flag("-q,--quiet", o->quiet, "No summary line");
  lut->callback([o]() {
    if (o->n < 16 || o->n > 8192) throw Error("--size: expected 16..8192, got " + std::to_string(o->n));
    CheckPlannedOutputs({{"--calib", o->calib}, {"--map", o->map}}, {{"-o", o->out}}, o->force);
    const Calibration c = ReadCalibration(o->calib);
    LutRanges ranges = o->map.empty() ? DefaultRanges(c.sensor) : RangesForMap(ReadMap(o->map), c.sensor);
    LutSize size;
    size.n_distance = size.n_elevation = size.n_radius = o->n;
    const RadiusTable t = RadiusTable::Build(c.sensor, ranges, size);
    t.Save(o->out);
    if (!o->quiet)
      std::printf("wrote %s: D %.4g..%.4g, Z %.4g..%.4g %s, %dx%d nodes\n", o->out.c_str(), ranges.d_min,
                  ranges.d_max, ranges.z_min, ranges.z_max, c.units.c_str(), o->n, o->n);
  });
}

}  // namespace pano::app
