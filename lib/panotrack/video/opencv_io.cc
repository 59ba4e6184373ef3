#include "panotrack/video/opencv_io.h"

#include <dlfcn.h>

#include <cstdlib>
#include <filesystem>
#include <mutex>

#include "panotrack/core/error.h"

namespace fs = std::filesystem;

namespace pano::opencv_io {

namespace {

constexpr const char* kModuleName = "libpanotrack_opencv_io.so";
constexpr const char* kEntryPoint = "pano_opencv_io_backend";

std::mutex g_mutex;
const Backend* g_backend = nullptr;
std::string g_path;

// The folder of the program or shared library that holds this code.
fs::path OwnFolder() {
  Dl_info info;
  if (dladdr(reinterpret_cast<void*>(&LoadBackend), &info) == 0 || !info.dli_fname) return {};
  std::error_code ec;
  const fs::path self = fs::canonical(info.dli_fname, ec);
  return ec ? fs::path(info.dli_fname).parent_path() : self.parent_path();
}

std::vector<std::string> Candidates() {
  if (const char* env = std::getenv("PANOTRACK_OPENCV_IO"); env && *env) return {env};
  std::vector<std::string> out;
  const fs::path own = OwnFolder();
  if (!own.empty()) {
    out.push_back((own / kModuleName).string());
    out.push_back((own / ".." / "lib" / "panotrack" / kModuleName).string());
    out.push_back((own / ".." / PANO_INSTALL_LIBDIR / "panotrack" / kModuleName).string());
  }
  out.push_back(PANO_OPENCV_IO_BUILD_PATH);
  out.push_back(PANO_OPENCV_IO_INSTALL_PATH);
  return out;
}

}  // namespace

const Backend& LoadBackend() {
  std::lock_guard<std::mutex> lock(g_mutex);
  if (g_backend) return *g_backend;
  std::string why = "not found";
  for (const std::string& path : Candidates()) {
    std::error_code ec;
    if (!fs::exists(path, ec)) {
      why = path + ": no such file";
      continue;
    }
    // Never closed: objects it made may live until the process ends.
    void* handle = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (!handle) {
      const char* e = dlerror();
      why = e ? e : path + ": cannot load";
      continue;
    }
    using Entry = const Backend* (*)();
    auto entry = reinterpret_cast<Entry>(dlsym(handle, kEntryPoint));
    if (!entry) {
      why = path + ": no entry point " + kEntryPoint;
      continue;
    }
    g_backend = entry();
    g_path = path;
    return *g_backend;
  }
  throw Error(std::string("OpenCV's image and video I/O (") + kModuleName +
              ") could not be loaded: " + why +
              "; image folders, cameras and debug videos need it (PANOTRACK_OPENCV_IO may name its path)");
}

std::string BackendPath() {
  std::lock_guard<std::mutex> lock(g_mutex);
  return g_path;
}

namespace {

// The module, or pano::Error naming `path`, the file that needed it.
const Backend& BackendFor(const std::string& path) {
  try {
    return LoadBackend();
  } catch (const Error& e) {
    throw Error(path + ": " + e.what());
  }
}

}  // namespace

cv::Mat imread(const std::string& path, int flags) { return BackendFor(path).imread(path, flags); }

bool imencode(const std::string& ext, const cv::Mat& image, std::vector<uchar>& buffer,
              const std::vector<int>& params) {
  return LoadBackend().imencode(ext, image, buffer, params);
}

bool VideoCapture::open(const std::string& path, int api, const std::vector<int>& params) {
  backend_ = BackendFor(path).NewCapture();
  return backend_->open(path, api, params);
}

bool VideoWriter::open(const std::string& path, int fourcc, double fps, cv::Size size, bool color) {
  backend_ = BackendFor(path).NewWriter();
  return backend_->open(path, fourcc, fps, size, color);
}

}  // namespace pano::opencv_io
