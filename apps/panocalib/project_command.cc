#include <cctype>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>

#include "commands.h"
#include "panotrack/core/error.h"
#include "panotrack/core/output_check.h"
#include "panotrack/io/calibration.h"
#include "panotrack/pipeline/panocalib.h"

namespace pano::app {

namespace {

// A comma-separated option of exactly n finite numbers, its form ("x,y,z")
// the first word of its help: its type name, which its parse errors quote.
CLI::Option* AddNumbers(CLI::App* app, const std::string& name, std::vector<double>& values, int n,
                        const std::string& help) {
  std::string form = help.substr(0, help.find(' '));
  for (char& c : form) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return app->add_option(name, values, help)
      ->delimiter(',')
      ->allow_extra_args(false)  // one token: a positional after it stays positional
      ->expected(n)
      ->type_name(form)
      ->check(CLI::Validator(
          [](std::string& v) {
            char* end = nullptr;
            const double x = std::strtod(v.c_str(), &end);
            return end == v.c_str() + v.size() && !v.empty() && std::isfinite(x)
                       ? std::string()
                       : "'" + v + "' is not a finite number";
          },
          "NUMBER"));
}

// Exactly one of the single-input option and the batch file.
void RequireOne(const CLI::Option* single, const CLI::Option* batch) {
  if (single->count() == 0 && batch->count() == 0)
    throw Error(single->get_name() + " or " + batch->get_name() + ": one is required");
}

// The batch form: checks the output, runs the library's file form, notes
// the nan lines on stderr.
struct BatchOpts {
  std::string input, out;
  bool force = false;
};
void AddBatchOptions(CLI::App* cmd, BatchOpts& b, const std::string& name, const std::string& help,
                     CLI::Option* single) {
  CLI::Option* in = cmd->add_option(name, b.input, help)->excludes(single);
  cmd->add_option("-o,--output", b.out, "Write the batch's lines here instead of standard output (atomically)")
      ->needs(in);
  cmd->add_flag("--force", b.force, "Replace an existing -o file")->needs(in);
}

}  // namespace


void AddProjectCommands(CLI::App& app) {
  auto calib = std::make_shared<std::string>();
  auto quiet = std::make_shared<bool>(false);
  auto point = std::make_shared<std::vector<double>>();
  auto pixel = std::make_shared<std::vector<double>>();
  auto points = std::make_shared<BatchOpts>();
  CLI::App* proj = app.add_subcommand(
      "project",
      "Print the pixel 'u v' at which a point of the sensor frame appears, or 'not visible'. The "
      "sensor frame: x forward, y left, z up from the pinhole, in the calibration's units. With "
      "--points: one 'u v' line per point of the file, 'nan nan' for a point that is not visible or "
      "falls outside the image (counted on stderr).");
  proj->add_option("--calib", *calib, "Calibration YAML")->required();
  CLI::Option* point_opt = AddNumbers(proj, "--point", *point, 3, "x,y,z in the sensor frame");
  AddBatchOptions(proj, *points, "--points",
                  "File of points, one 'x y z' or 'x,y,z' a line ('#' comments, an optional header line; "
                  "- reads standard input)",
                  point_opt);
  proj->add_flag("-q,--quiet", *quiet, "No note when the pixel lies outside the image, or on nan lines");
  proj->callback([calib, point, points, quiet, point_opt, proj]() {
    RequireOne(point_opt, proj->get_option("--points"));
    if (!points->input.empty()) {
      const BatchProjection b = RunProjectPoints({*calib, points->input, points->out, points->force});
      const std::string note = BatchNote(b, false);
      if (!*quiet && !note.empty()) std::fprintf(stderr, "panocalib: note: %s\n", note.c_str());
      return;
    }
    const Calibration c = ReadCalibration(*calib);
    const std::vector<double>& p = *point;
    Eigen::Vector2d px;
    if (!c.sensor.project({p[0], p[1], p[2]}, &px)) {
      std::printf("not visible\n");
      return;
    }
    std::printf("%s\n", FormatPixel(px).c_str());
    if (!*quiet && !c.sensor.inside_image(px))
      std::fprintf(stderr, "panocalib: note: the pixel lies outside the %dx%d image\n",
                   c.sensor.image_width, c.sensor.image_height);
  });

  auto calib2 = std::make_shared<std::string>();
  auto quiet2 = std::make_shared<bool>(false);
  auto pixels = std::make_shared<BatchOpts>();
  CLI::App* back = app.add_subcommand(
      "backproject",
      "Print the reflected ray of a pixel, or 'no mirror'. The ray: its origin on the mirror and its "
      "unit direction in the sensor frame ('ox oy oz dx dy dz'); 'no mirror' outside the mirror's "
      "visible disc. With --pixels: one such line per pixel of the file, six 'nan' for a pixel off the "
      "mirror or outside the image (counted on stderr).");
  back->add_option("--calib", *calib2, "Calibration YAML")->required();
  CLI::Option* pixel_opt =
      AddNumbers(back, "--pixel", *pixel, 2, "u,v (column, row; origin at the top-left pixel's centre)");
  AddBatchOptions(back, *pixels, "--pixels",
                  "File of pixels, one 'u v' or 'u,v' a line ('#' comments, an optional header line; "
                  "- reads standard input)",
                  pixel_opt);
  back->add_flag("-q,--quiet", *quiet2, "No note on nan lines (--pixels)");
  back->callback([calib2, pixel, pixels, quiet2, pixel_opt, back]() {
    RequireOne(pixel_opt, back->get_option("--pixels"));
    if (!pixels->input.empty()) {
      const BatchProjection b = RunBackprojectPixels({*calib2, pixels->input, pixels->out, pixels->force});
      const std::string note = BatchNote(b, true);
      if (!*quiet2 && !note.empty()) std::fprintf(stderr, "panocalib: note: %s\n", note.c_str());
      return;
    }
    const Calibration c = ReadCalibration(*calib2);
    const std::vector<double>& p = *pixel;
    Eigen::Vector3d o, d;
    if (!c.sensor.backproject({p[0], p[1]}, &o, &d)) {
      std::printf("no mirror\n");
      return;
    }
    std::printf("%s\n", FormatRay(o, d).c_str());
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
      "from the sensor (1 to 400 mirror distances).");
  lut->add_option("--calib", o->calib, "Calibration YAML")->required();
  lut->add_option("--map", o->map, "Map YAML whose room and landmarks the table must cover");
  lut->add_option("-o,--output", o->out, "Output table file (.lut)")->required();
  lut->add_flag("--force", o->force, "Replace an existing output file");
  lut->add_option("--size", o->n, "Nodes along each axis of the forward table")->capture_default_str();
  lut->add_flag("-q,--quiet", o->quiet, "No summary line");
  lut->callback([o]() {
    if (o->n < 16 || o->n > 8192) throw Error("--size: expected 16..8192, got " + std::to_string(o->n));
    const LutResult r = RunLut({o->calib, o->map, o->out, o->n, o->force});
    const LutRanges& ranges = r.ranges;
    if (!o->quiet)
      std::printf("wrote %s: D %.4g..%.4g, Z %.4g..%.4g %s, %dx%d nodes\n", o->out.c_str(), ranges.d_min,
                  ranges.d_max, ranges.z_min, ranges.z_max, r.units.c_str(), o->n, o->n);
  });
}

}  // namespace pano::app
