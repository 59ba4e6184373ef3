// Bad options and files are refused with one line naming the field or file;
// panocalib unwarp writes atomically and never replaces a file without --force.
#include <catch2/catch.hpp>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>

#include "expect_error.h"
#include "panotrack/io/calibration.h"
#include "panotrack/render/presets.h"
#include "panotrack/pipeline/unwarp_files.h"
#include "run_command.h"
#include "test_paths.h"

namespace pano {
namespace {

using test::ErrorOf;

std::string CheckError(void (*edit)(UnwarpOptions*)) {
  UnwarpOptions o;
  edit(&o);
  return ErrorOf([&] { o.Check(); });
}

TEST_CASE("bad options name the field", "[bad_input]") {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  (void)nan;
  CHECK_THAT(CheckError([](UnwarpOptions* o) { o->width = 1; }), Catch::Contains("unwarp width"));
  CHECK_THAT(CheckError([](UnwarpOptions* o) { o->height = -3; }), Catch::Contains("unwarp height"));
  CHECK_THAT(CheckError([](UnwarpOptions* o) { o->width = o->height = 60000; }), Catch::Contains("unwarp size"));
  CHECK_THAT(CheckError([](UnwarpOptions* o) { o->distance = -1; }), Catch::Contains("unwarp distance"));
  CHECK_THAT(CheckError([](UnwarpOptions* o) { o->distance = std::numeric_limits<double>::infinity(); }),
             Catch::Contains("unwarp distance"));
  CHECK_THAT(CheckError([](UnwarpOptions* o) { o->eye_height = std::numeric_limits<double>::infinity(); }),
             Catch::Contains("unwarp eye_height"));
  CHECK_THAT(CheckError([](UnwarpOptions* o) { o->max_elevation_deg = 90; }), Catch::Contains("max_elevation_deg"));
  CHECK_THAT(CheckError([](UnwarpOptions* o) {
               o->min_elevation_deg = 10;
               o->max_elevation_deg = 5;
             }),
             Catch::Contains("min_elevation_deg < max_elevation_deg"));
  CHECK_THAT(CheckError([](UnwarpOptions* o) { o->pitch_deg = 91; }), Catch::Contains("unwarp pitch_deg"));
  CHECK_THAT(CheckError([](UnwarpOptions* o) { o->fov_deg = 0; }), Catch::Contains("unwarp fov_deg"));
  CHECK_THAT(CheckError([](UnwarpOptions* o) { o->fov_deg = 180; }), Catch::Contains("unwarp fov_deg"));
  CHECK_THAT(CheckError([](UnwarpOptions* o) { o->yaw_deg = std::numeric_limits<double>::quiet_NaN(); }),
             Catch::Contains("unwarp yaw_deg"));
  CHECK_THAT(CheckError([](UnwarpOptions* o) { o->interpolation = 99; }), Catch::Contains("unwarp interpolation"));
  CHECK_THAT(CheckError([](UnwarpOptions* o) { o->threads = -1; }), Catch::Contains("unwarp threads"));
  CHECK(CheckError([](UnwarpOptions*) {}).empty());

  const Sensor sensor = PaperSyntheticCalibration().sensor;
  // One end of the range given, the other from the mirror, the two crossing.
  UnwarpOptions high;
  high.min_elevation_deg = 60;
  CHECK_THAT(ErrorOf([&] { UnwarpView(sensor, high); }), Catch::Contains("is empty"));
  const cv::Mat small(100, 100, CV_8UC1, cv::Scalar(0));
  CHECK_THAT(ErrorOf([&] { UnwarpImage(small, sensor, UnwarpOptions{}); }),
             Catch::Contains("the image is 100x100, the calibration's 500x500"));
  CHECK_THAT(ErrorOf([&] { UnwarpImage(cv::Mat(), sensor, UnwarpOptions{}); }), Catch::Contains("empty image"));
  Sensor broken = sensor;
  broken.params.focal_px = -1;
  CHECK_THAT(ErrorOf([&] { UnwarpView(broken, UnwarpOptions{}); }), Catch::Contains("unwarp sensor"));
}

TEST_CASE("unwarp files: atomic, never replacing without overwrite", "[bad_input]") {
  const std::string dir = test::ScratchDir("unwarp_files");
  const std::string calib = dir + "/calib.yaml", raw = dir + "/raw.png", out = dir + "/out.png";
  WriteCalibration(calib, PaperSyntheticCalibration());
  REQUIRE(cv::imwrite(raw, cv::Mat(500, 500, CV_8UC1, cv::Scalar(77))));
  const UnwarpView v = UnwarpImageFile(calib, raw, out, UnwarpOptions{}, false);
  const cv::Mat written = cv::imread(out, cv::IMREAD_UNCHANGED);
  CHECK(written.size() == cv::Size(v.width(), v.height()));
  CHECK(written.type() == CV_8UC1);
  CHECK(ErrorOf([&] { UnwarpImageFile(calib, raw, out, UnwarpOptions{}, false); }) ==
        out + " exists (use --force to replace it)");
  UnwarpOptions p;
  p.kind = UnwarpKind::kPerspective;
  UnwarpImageFile(calib, raw, out, p, true);
  CHECK(cv::imread(out, cv::IMREAD_UNCHANGED).size() == cv::Size(640, 480));

  std::ofstream(dir + "/not-an-image.png") << "text";
  CHECK_THAT(ErrorOf([&] { UnwarpImageFile(calib, dir + "/not-an-image.png", dir + "/o2.png", p, false); }),
             Catch::Contains("not-an-image.png: cannot read the image"));
  CHECK_THAT(ErrorOf([&] { UnwarpImageFile(calib, dir, dir + "/o3.png", p, false); }), Catch::Contains("folder"));
  {  // A PNG cut short: named as such (not libpng's line on stderr and "not an image format").
    std::ifstream in(raw, std::ios::binary);
    const std::string png((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    std::ofstream(dir + "/torn.png", std::ios::binary) << png.substr(0, png.size() / 2);
  }
  CHECK(ErrorOf([&] { UnwarpImageFile(calib, dir + "/torn.png", dir + "/o6.png", p, false); }) ==
        dir + "/torn.png: a PNG cut short (its last chunk, IEND, is missing; " +
            std::to_string(std::filesystem::file_size(dir + "/torn.png")) + " bytes)");
  CHECK_THAT(ErrorOf([&] { UnwarpImageFile(calib, raw, dir + "/o4.unknown-extension", p, false); }),
             Catch::Contains("o4.unknown-extension: cannot write"));
  CHECK_THAT(ErrorOf([&] { UnwarpImageFile(dir + "/missing.yaml", raw, dir + "/o5.png", p, false); }),
             Catch::Contains("missing.yaml"));
  // Nothing half-written left behind.
  int files = 0;
  for (const auto& e : std::filesystem::directory_iterator(dir)) {
    (void)e;
    ++files;
  }
  CHECK(files == 5);  // calib.yaml, raw.png, out.png, not-an-image.png, torn.png
}

TEST_CASE("panocalib unwarp", "[cli]") {
  const std::string dir = test::ScratchDir("unwarp_cli");
  const std::string calib = dir + "/calib.yaml", raw = dir + "/raw.png", out = dir + "/pano.png";
  WriteCalibration(calib, PaperSyntheticCalibration());
  REQUIRE(cv::imwrite(raw, cv::Mat(500, 500, CV_8UC1, cv::Scalar(77))));
  const std::string base = "panocalib unwarp --calib " + calib + " " + raw;

  test::CommandRun r = test::RunProgram(base + " -o " + out);
  CHECK(r.code == 0);
  CHECK_THAT(r.out, Catch::Contains("panorama 1272x347"));
  CHECK(cv::imread(out, cv::IMREAD_UNCHANGED).size() == cv::Size(1272, 347));

  r = test::RunProgram(base + " -o " + out + " --size 400x100");
  CHECK(r.code == 1);
  CHECK(r.out == "panocalib: " + out + " exists (use --force to replace it)\n");
  CHECK(cv::imread(out, cv::IMREAD_UNCHANGED).size() == cv::Size(1272, 347));

  r = test::RunProgram(base + " -o " + out + " --size 400x100 --elevation -20,20 --distance 70 --clockwise --force");
  CHECK(r.code == 0);
  CHECK_THAT(r.out, Catch::Contains("elevation -20.00..20.00 deg"));
  CHECK(cv::imread(out, cv::IMREAD_UNCHANGED).size() == cv::Size(400, 100));

  r = test::RunProgram(base + " -o " + dir + "/view.png --perspective --yaw 90 --pitch -10 --fov 70 --size 320x240");
  CHECK(r.code == 0);
  CHECK_THAT(r.out, Catch::Contains("perspective 320x240, yaw 90.00 pitch -10.00 fov 70.00"));

  r = test::RunProgram(base + " -o " + dir + "/x.png --size 300");
  CHECK(r.code == 1);
  CHECK(r.out == "panocalib: --size: expected WxH (e.g. 1600x400, each side at least 2), got '300'\n");
  r = test::RunProgram(base + " -o " + dir + "/x.png --perspective --fov 200");
  CHECK(r.code == 1);
  CHECK(r.out == "panocalib: --fov: expected 0 < fov <= 170 degrees, got 200\n");
  for (const char* wrong : {" --perspective --panorama", " --yaw 30", " --perspective --clockwise",
                            " --perspective --elevation -10,10"}) {
    INFO(wrong);
    r = test::RunProgram(base + " -o " + dir + "/x.png" + wrong);
    CHECK(r.code == 1);
    CHECK(test::CountLines(r.out) >= 1);
  }
  CHECK(!std::filesystem::exists(dir + "/x.png"));
}

TEST_CASE("unwarp videos: every frame, even sizes", "[video]") {
  const std::string dir = test::ScratchDir("unwarp_video");
  const std::string calib = dir + "/calib.yaml", in = dir + "/in.avi", out = dir + "/pano.mp4";
  WriteCalibration(calib, PaperSyntheticCalibration());
  {
    cv::VideoWriter w(in, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 5.0, cv::Size(500, 500), true);
    REQUIRE(w.isOpened());
    for (int i = 0; i < 4; ++i) {
      cv::Mat f(500, 500, CV_8UC3, cv::Scalar::all(40 + 40 * i));
      w.write(f);
    }
  }
  CHECK(IsVideoPath(out));
  CHECK(IsVideoPath("a/B.MKV"));
  CHECK(!IsVideoPath("a.mp4/b.png"));
  int frames = 0;
  const UnwarpView v = UnwarpVideoFile(calib, in, out, UnwarpOptions{}, false, &frames);
  CHECK(frames == 4);
  CHECK(v.width() == 1272);
  CHECK(v.height() == 348);  // 347 made even
  cv::VideoCapture cap(out);
  REQUIRE(cap.isOpened());
  int read = 0;
  cv::Mat f;
  while (cap.read(f)) {
    CHECK(f.size() == cv::Size(1272, 348));
    ++read;
  }
  CHECK(read == 4);
  CHECK(ErrorOf([&] { UnwarpVideoFile(calib, in, out, UnwarpOptions{}, false); }) ==
        out + " exists (use --force to replace it)");
  UnwarpOptions odd;
  odd.width = 301;
  odd.height = 100;
  CHECK(ErrorOf([&] { UnwarpVideoFile(calib, in, dir + "/o.mp4", odd, false); }) ==
        "unwarp size: a video needs even sides, got 301x100");
  CHECK_THAT(ErrorOf([&] { UnwarpVideoFile(dir + "/missing.yaml", in, dir + "/o.mp4", UnwarpOptions{}, false); }),
             Catch::Contains("missing.yaml"));
  CHECK_THAT(ErrorOf([&] { UnwarpVideoFile(calib, dir + "/none.avi", dir + "/o.mp4", UnwarpOptions{}, false); }),
             Catch::Contains("none.avi"));
  CHECK(!std::filesystem::exists(dir + "/o.mp4"));
}

}  // namespace
}  // namespace pano
