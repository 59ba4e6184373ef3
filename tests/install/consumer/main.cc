// A program outside the toolkit, built against an installed panotrack (its
// CMake package or its pkg-config file): reads a calibration and prints the
// pixel at which a point appears, as `panocalib project` prints it.
// Usage: consumer [CALIBRATION.yaml [X Y Z]]; by default the installed
// calibration of the paper's real sensor and the point (200, 50, 30).
#include <cstdio>
#include <cstdlib>
#include <string>

#include <panotrack/config.h>
#include <panotrack/core/error.h>
#include <panotrack/io/calibration.h>
#include <panotrack/sensor/sensor.h>

int main(int argc, char** argv) {
  const std::string path = argc > 1 ? argv[1] : std::string(PANOTRACK_CALIB_DIR) + "/paper-real.yaml";
  Eigen::Vector3d point(200.0, 50.0, 30.0);
  if (argc == 5) point = {std::atof(argv[2]), std::atof(argv[3]), std::atof(argv[4])};
  try {
    const pano::Calibration calib = pano::ReadCalibration(path);
    Eigen::Vector2d pixel;
    if (!calib.sensor.project(point, &pixel)) {
      std::printf("not visible\n");
      return 1;
    }
    std::printf("%.6f %.6f\n", pixel.x(), pixel.y());
  } catch (const pano::Error& e) {
    std::fprintf(stderr, "consumer (panotrack %s): %s\n", PANO_VERSION, e.what());
    return 1;
  }
  return 0;
}
