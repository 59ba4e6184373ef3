#include "video/luma_decoder.h"

#include "pano/config.h"

#if PANO_WITH_FFMPEG
extern "C" {
#include <libavcodec/avcodec.h>
#include <libavformat/avformat.h>
#include <libavutil/pixdesc.h>
}
#endif

#include <cstring>

namespace pano {

#if PANO_WITH_FFMPEG

struct LumaDecoder::Impl {
  AVFormatContext* format = nullptr;
  AVCodecContext* codec = nullptr;
  AVPacket* packet = nullptr;
  AVFrame* frame = nullptr;
  int stream = -1;
  bool flushing = false, done = false;
  ~Impl() {
    if (frame) av_frame_free(&frame);
    if (packet) av_packet_free(&packet);
    if (codec) avcodec_free_context(&codec);
    if (format) avformat_close_input(&format);
  }
};

bool LumaDecoderAvailable() { return true; }

LumaDecoder::LumaDecoder() = default;
LumaDecoder::~LumaDecoder() = default;

bool LumaDecoder::Open(const std::string& path, std::string* reason) {
  impl_ = std::make_unique<Impl>();
  Impl& d = *impl_;
  if (avformat_open_input(&d.format, path.c_str(), nullptr, nullptr) < 0) {
    *reason = "FFmpeg cannot open it";
    return false;
  }
  if (avformat_find_stream_info(d.format, nullptr) < 0) {
    *reason = "no stream information";
    return false;
  }
  const AVCodec* decoder = nullptr;
  d.stream = av_find_best_stream(d.format, AVMEDIA_TYPE_VIDEO, -1, -1, &decoder, 0);
  if (d.stream < 0 || !decoder) {
    *reason = "no video stream";
    return false;
  }
  AVStream* st = d.format->streams[d.stream];
  d.codec = avcodec_alloc_context3(decoder);
  if (!d.codec || avcodec_parameters_to_context(d.codec, st->codecpar) < 0) {
    *reason = "cannot set up the decoder";
    return false;
  }
  d.codec->thread_count = 0;  // FFmpeg's choice, as OpenCV's capture does
  if (avcodec_open2(d.codec, decoder, nullptr) < 0) {
    *reason = "cannot open the decoder";
    return false;
  }
  // Formats whose first plane is 8-bit luma at full resolution.
  const AVPixFmtDescriptor* desc = av_pix_fmt_desc_get(d.codec->pix_fmt);
  if (!desc || (desc->flags & (AV_PIX_FMT_FLAG_RGB | AV_PIX_FMT_FLAG_PAL | AV_PIX_FMT_FLAG_HWACCEL)) ||
      desc->comp[0].plane != 0 || desc->comp[0].depth != 8 || desc->comp[0].step != 1) {
    *reason = std::string("pixel format ") + (desc ? desc->name : "?") + " has no 8-bit luma plane";
    return false;
  }
  const AVRational r = st->avg_frame_rate.num ? st->avg_frame_rate : st->r_frame_rate;
  fps_ = r.den ? av_q2d(r) : 0.0;
  frame_count_ = st->nb_frames > 0 ? static_cast<long>(st->nb_frames) : -1;
  d.packet = av_packet_alloc();
  d.frame = av_frame_alloc();
  return d.packet && d.frame;
}

bool LumaDecoder::Read(cv::Mat* grey) {
  Impl& d = *impl_;
  while (!d.done) {
    const int got = avcodec_receive_frame(d.codec, d.frame);
    if (got == 0) {
      grey->create(d.frame->height, d.frame->width, CV_8UC1);
      for (int y = 0; y < d.frame->height; ++y)
        std::memcpy(grey->ptr<uchar>(y), d.frame->data[0] + static_cast<ptrdiff_t>(y) * d.frame->linesize[0],
                    d.frame->width);
      av_frame_unref(d.frame);
      return true;
    }
    if (got == AVERROR_EOF) {
      d.done = true;
      break;
    }
    if (got != AVERROR(EAGAIN)) {  // a decoding error ends the stream
      d.done = true;
      break;
    }
    if (d.flushing) {
      d.done = true;
      break;
    }
    // Feed the next packet of the video stream (or flush at the end).
    int rd;
    while ((rd = av_read_frame(d.format, d.packet)) >= 0 && d.packet->stream_index != d.stream)
      av_packet_unref(d.packet);
    if (rd < 0) {
      avcodec_send_packet(d.codec, nullptr);
      d.flushing = true;
    } else {
      avcodec_send_packet(d.codec, d.packet);
      av_packet_unref(d.packet);
    }
  }
  return false;
}

#else  // !PANO_WITH_FFMPEG

struct LumaDecoder::Impl {};
bool LumaDecoderAvailable() { return false; }
LumaDecoder::LumaDecoder() = default;
LumaDecoder::~LumaDecoder() = default;
bool LumaDecoder::Open(const std::string&, std::string* reason) {
  *reason = "built without FFmpeg";
  return false;
}
bool LumaDecoder::Read(cv::Mat*) { return false; }

#endif

}  // namespace pano
