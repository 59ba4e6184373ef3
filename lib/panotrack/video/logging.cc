#include "panotrack/video/logging.h"

#include <atomic>
#include <cstdarg>
#include <cstdio>
#include <cstring>
#include <map>
#include <mutex>
#include <opencv2/core/utils/logger.hpp>

#include "panotrack/config.h"
#if PANO_WITH_FFMPEG
extern "C" {
#include <libavcodec/avcodec.h>
#include <libavutil/log.h>
}
#endif

namespace pano {

namespace {
std::atomic<bool> g_chosen{false};
std::atomic<bool> g_verbose{false};
thread_local DecoderErrorCapture* g_capture = nullptr;

struct DamageCounters {
  std::mutex mu;
  std::map<const void*, std::atomic<int>*> by_key;
};
DamageCounters& Counters() {
  static DamageCounters counters;
  return counters;
}

#if PANO_WITH_FFMPEG
// A decoder's message that says its frame holds damage: an error, or error
// resilience's note (at info level) that it concealed some.
bool ReportsDamage(void* avcl, int level, const char* fmt) {
  if (!avcl || *static_cast<const AVClass**>(avcl) != avcodec_get_class()) return false;
  return level <= AV_LOG_ERROR || std::strncmp(fmt, "concealing ", 11) == 0;
}

void CountDamage(void* avcl) {
  const void* key = static_cast<AVCodecContext*>(avcl)->opaque;
  if (!key) return;
  DamageCounters& c = Counters();
  std::lock_guard<std::mutex> lock(c.mu);
  const auto it = c.by_key.find(key);
  if (it != c.by_key.end()) ++*it->second;
}

// Installed instead of FFmpeg's default: OpenCV's FFmpeg backend sets FFmpeg's
// level to "error" when it starts, so the level alone cannot keep it quiet.
void LogCallback(void* avcl, int level, const char* fmt, va_list args) {
  if (ReportsDamage(avcl, level, fmt)) CountDamage(avcl);
  if (g_capture && level <= AV_LOG_ERROR) {
    char text[512];
    va_list copy;
    va_copy(copy, args);
    std::vsnprintf(text, sizeof(text), fmt, copy);
    va_end(copy);
    g_capture->Append(text);
  }
  if (g_verbose && level <= AV_LOG_INFO) av_log_default_callback(avcl, level, fmt, args);
}
#endif
}  // namespace

void CountDecoderDamage(const void* key, std::atomic<int>* count) {
  DamageCounters& c = Counters();
  std::lock_guard<std::mutex> lock(c.mu);
  c.by_key[key] = count;
}

void StopCountingDecoderDamage(const void* key) {
  DamageCounters& c = Counters();
  std::lock_guard<std::mutex> lock(c.mu);
  c.by_key.erase(key);
}

void DecoderErrorCapture::Append(const char* text) {
  partial_ += text;
  if (!partial_.empty() && partial_.back() == '\n') {
    partial_.pop_back();
    last_ = partial_;
    partial_.clear();
  }
}

DecoderErrorCapture::DecoderErrorCapture() : outer_(g_capture) { g_capture = this; }
DecoderErrorCapture::~DecoderErrorCapture() { g_capture = outer_; }

void SetDecoderLogging(bool verbose) {
  g_chosen = true;
  g_verbose = verbose;
  cv::utils::logging::setLogLevel(verbose ? cv::utils::logging::LOG_LEVEL_INFO
                                          : cv::utils::logging::LOG_LEVEL_SILENT);
#if PANO_WITH_FFMPEG
  av_log_set_level(verbose ? AV_LOG_INFO : AV_LOG_QUIET);
  av_log_set_callback(&LogCallback);
#endif
}

void UseDefaultDecoderLogging() {
  if (!g_chosen) SetDecoderLogging(false);
}

}  // namespace pano
