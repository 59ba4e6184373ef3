#include "panotrack/video/luma_decoder.h"

#include "panotrack/core/error.h"
#include "panotrack/config.h"
#include "panotrack/video/logging.h"

#if PANO_WITH_FFMPEG
extern "C" {
#include <libavcodec/avcodec.h>
#include <libavformat/avformat.h>
#include <libavutil/hwcontext.h>
#include <libavutil/pixdesc.h>
#include <libavutil/time.h>
}
#include <poll.h>
#include <unistd.h>
#if PANO_WITH_CUDA
#include "panotrack/video/cuda_download.h"
#endif
#endif

#include <algorithm>
#include <array>
#include <atomic>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <condition_variable>
#include <cstring>
#include <deque>
#include <limits>
#include <mutex>
#include <new>
#include <numeric>
#include <thread>
#include <vector>

namespace pano {

std::string InputName(const std::string& path) { return path == "-" ? "standard input" : path; }

HardwareDecoding ParseHardwareDecoding(const std::string& name) {
  if (name == "none") return HardwareDecoding::kNone;
  if (name == "cuda") return HardwareDecoding::kCuda;
  if (name == "auto") return HardwareDecoding::kAuto;
  throw Error("hardware decoding: expected none, cuda or auto, got '" + name + "'");
}

namespace detail {

long FirstTailSegment(const std::vector<double>& segment_costs) {
  // Twice the threads decode a stream about 1.6 times as fast (FFmpeg's
  // frame threads, 1 -> 2 on two cores: 1.6 - 1.8).
  constexpr double kTailSpeedup = 1.6;
  // The frame threads' hand-overs cost CPU: a tail only for a clear gain.
  constexpr double kWorthwhile = 0.95;
  const long n = static_cast<long>(segment_costs.size());
  // The two decoders' shares of the segments before each one, and the rest.
  std::vector<std::array<double, kGopDecoderCount>> shares(static_cast<size_t>(n) + 1);
  for (long s = 0; s < n; ++s) {
    shares[static_cast<size_t>(s) + 1] = shares[static_cast<size_t>(s)];
    shares[static_cast<size_t>(s) + 1][static_cast<size_t>(s % kGopDecoderCount)] += segment_costs[static_cast<size_t>(s)];
  }
  const double total = std::accumulate(segment_costs.begin(), segment_costs.end(), 0.0);
  // The decoders' segments end with the longer share; the tail's after them.
  auto makespan = [&](long tail_from) {
    const std::array<double, kGopDecoderCount>& share = shares[static_cast<size_t>(tail_from)];
    const double before = std::accumulate(share.begin(), share.end(), 0.0);
    return *std::max_element(share.begin(), share.end()) + (total - before) / kTailSpeedup;
  };
  long best = -1;
  double best_span = kWorthwhile * makespan(n);
  for (long from = n - 1; from >= 0; --from) {
    const double span = makespan(from);
    if (span < best_span) {
      best = from;
      best_span = span;
    }
  }
  return best;
}

}  // namespace detail

#if PANO_WITH_FFMPEG

namespace {

// A truncated file whose container states its duration but no frame count
// (Matroska) is caught when its packets end this much short of the duration.
constexpr double kDurationSlackS = 0.5;

std::string AvError(int code) {
  char text[AV_ERROR_MAX_STRING_SIZE] = {0};
  av_strerror(code, text, sizeof(text));
  return text;
}

std::string Format(const char* fmt, double value) {
  char text[64];
  std::snprintf(text, sizeof(text), fmt, value);
  return text;
}

// Formats whose first plane is 8-bit luma at full resolution.
bool HasLumaPlane(int format) {
  const AVPixFmtDescriptor* desc = av_pix_fmt_desc_get(static_cast<AVPixelFormat>(format));
  return desc && !(desc->flags & (AV_PIX_FMT_FLAG_RGB | AV_PIX_FMT_FLAG_PAL | AV_PIX_FMT_FLAG_HWACCEL)) &&
         desc->comp[0].plane == 0 && desc->comp[0].depth == 8 && desc->comp[0].step == 1;
}

std::string NoLumaPlane(int format) {
  const char* name = av_get_pix_fmt_name(static_cast<AVPixelFormat>(format));
  return std::string("pixel format ") + (name ? name : "unknown") + " has no 8-bit luma plane";
}

// Lets a cv::Mat own a reference to a decoded AVFrame: OpenCV calls
// deallocate() when the last Mat sharing the plane lets go of it. Only the
// UMatData made by WrapLuma() name it, so OpenCV allocates nothing with it.
class FrameAllocator : public cv::MatAllocator {
 public:
  cv::UMatData* allocate(int, const int*, int, void*, size_t*, cv::AccessFlag, cv::UMatUsageFlags) const override {
    return nullptr;
  }
  bool allocate(cv::UMatData*, cv::AccessFlag, cv::UMatUsageFlags) const override { return false; }
  void deallocate(cv::UMatData* u) const override {
    if (!u) return;
    auto* frame = static_cast<AVFrame*>(u->userdata);
    av_frame_free(&frame);
    delete u;
  }
};

const FrameAllocator& FrameRefs() {
  static const FrameAllocator* allocator = new FrameAllocator;  // never destroyed: Mats may outlive statics
  return *allocator;
}

// *grey = the decoded frame's luma plane, sharing the frame's buffer: the
// reference to it moves from `decoded` into the cv::Mat. False when out of
// memory.
bool WrapLuma(AVFrame* decoded, cv::Mat* grey) {
  if (decoded->linesize[0] < decoded->width) {  // a bottom-up plane: copied, as OpenCV has no such layout
    cv::Mat copy(decoded->height, decoded->width, CV_8UC1);
    for (int y = 0; y < decoded->height; ++y)
      std::memcpy(copy.ptr<uchar>(y), decoded->data[0] + static_cast<ptrdiff_t>(y) * decoded->linesize[0],
                  decoded->width);
    av_frame_unref(decoded);
    *grey = std::move(copy);
    return true;
  }
  AVFrame* held = av_frame_alloc();
  auto* u = held ? new (std::nothrow) cv::UMatData(&FrameRefs()) : nullptr;
  if (!u) {
    av_frame_free(&held);
    av_frame_unref(decoded);
    return false;
  }
  av_frame_move_ref(held, decoded);
  cv::Mat view(held->height, held->width, CV_8UC1, held->data[0], static_cast<size_t>(held->linesize[0]));
  u->data = u->origdata = held->data[0];
  u->size = static_cast<size_t>(held->linesize[0]) * static_cast<size_t>(held->height);
  u->userdata = held;
  u->refcount = 1;
  view.u = u;  // the view and its copies now own the reference (view.allocator stays the default: for create())
  *grey = std::move(view);
  return true;
}

// Thrown inside the decoder where a file decoded on frame threads reported
// damage before a frame or an error is handed out: Read() decodes it again
// without them (RedecodeWithoutFrameThreads).
struct RedecodeRequest {};

// A segment decoded on its own starts at an IDR picture and holds at least
// this many packets: fewer would make the decoders wait on each other.
constexpr long kMinSegmentPackets = 16;
// The decoded frames of the segment being read wait up to this many bytes.
constexpr size_t kReadAheadBytes = size_t(16) << 20;
// Decoders of GOP mode, each on a segment of its own, and the tail's,
// which decodes the last segments on all their threads.
constexpr int kGopDecoders = detail::kGopDecoderCount;
constexpr size_t kTailDecoder = kGopDecoders;
#if PANO_WITH_CUDA
// Page-locked buffers NVDEC's frames keep: a FrameSource's queue holds 8 or more.
constexpr size_t kNvdecBuffers = 12;
#endif

// What a packet of an H.264 or HEVC stream holds, from its NAL units'
// headers. `length_size`: the bytes of each unit's length prefix (avcC and
// hvcC packets, as MP4 and Matroska store them).
struct NalContents {
  bool idr = false;             // an IDR picture: nothing after it refers to what came before
  bool parameter_sets = false;  // SPS or PPS (and VPS for HEVC)
};
NalContents ScanNals(const AVPacket& packet, AVCodecID codec, int length_size) {
  NalContents c;
  const uint8_t* data = packet.data;
  const long size = packet.size;
  for (long pos = 0; pos + length_size < size;) {
    unsigned long n = 0;
    for (int i = 0; i < length_size; ++i) n = (n << 8) | data[pos + i];
    pos += length_size;
    if (n == 0 || n > static_cast<unsigned long>(size - pos)) break;
    const uint8_t header = data[pos];
    if (codec == AV_CODEC_ID_H264) {
      const int type = header & 0x1f;
      c.idr |= type == 5;
      c.parameter_sets |= type == 7 || type == 8;
    } else {
      const int type = (header >> 1) & 0x3f;
      c.idr |= type == 19 || type == 20;  // IDR_W_RADL, IDR_N_LP (not CRA: its leading pictures look back)
      c.parameter_sets |= type >= 32 && type <= 34;
    }
    pos += static_cast<long>(n);
  }
  return c;
}

// The NAL length prefix of avcC / hvcC extradata; 0 for other streams
// (start codes, other codecs), which are decoded in one piece.
int NalLengthSize(const AVCodecParameters& par) {
  const uint8_t* x = par.extradata;
  if (!x || par.extradata_size < 1 || x[0] != 1) return 0;
  if (par.codec_id == AV_CODEC_ID_H264 && par.extradata_size >= 7) return (x[4] & 3) + 1;
  if (par.codec_id == AV_CODEC_ID_HEVC && par.extradata_size >= 23) return (x[21] & 3) + 1;
  return 0;
}

// The longest group of pictures, in frames, from a container index that
// lists every frame (MP4, MOV); 0 when it does not.
long LongestGop(AVStream* st) {
#if LIBAVFORMAT_VERSION_INT >= AV_VERSION_INT(58, 78, 100)
  const int n = avformat_index_get_entries_count(st);
  if (n < 2 || st->nb_frames != n) return 0;
  long longest = 0, since_key = 0, keys = 0;
  for (int i = 0; i < n; ++i) {
    const AVIndexEntry* e = avformat_index_get_entry(st, i);
    if (e && (e->flags & AVINDEX_KEYFRAME) && i > 0) {
      longest = std::max(longest, since_key);
      since_key = 0;
    }
    keys += e && (e->flags & AVINDEX_KEYFRAME);
    ++since_key;
  }
  return keys >= 2 ? std::max(longest, since_key) : 0;
#else
  (void)st;
  return 0;
#endif
}

// The bytes of each segment DemuxFor will cut the stream into, from a
// container index that lists every frame (its keyframes taken for IDR
// pictures); empty when the index does not.
std::vector<double> PredictedSegmentBytes(AVStream* st) {
  std::vector<double> bytes;
#if LIBAVFORMAT_VERSION_INT >= AV_VERSION_INT(58, 78, 100)
  const int n = avformat_index_get_entries_count(st);
  if (n < 2 || st->nb_frames != n) return bytes;
  long packets = 0;
  for (int i = 0; i < n; ++i) {
    const AVIndexEntry* e = avformat_index_get_entry(st, i);
    if (!e) return {};
    if (bytes.empty() || ((e->flags & AVINDEX_KEYFRAME) && packets >= kMinSegmentPackets)) {
      bytes.push_back(0.0);
      packets = 0;
    }
    bytes.back() += e->size;
    ++packets;
  }
#else
  (void)st;
#endif
  return bytes;
}

// Copies the decoded frame's luma plane into *copy (rows packed), which
// has its size.
void CopyLuma(const AVFrame& decoded, cv::Mat* copy) {
  for (int y = 0; y < decoded.height; ++y)
    std::memcpy(copy->ptr<uchar>(y), decoded.data[0] + static_cast<ptrdiff_t>(y) * decoded.linesize[0],
                static_cast<size_t>(decoded.width));
}

// Buffers for frames handed out as cv::Mat, used again once every cv::Mat
// sharing one is released: a fresh allocation of a frame's size per frame
// costs page faults on every frame. At most `max_bytes` are kept.
class BufferPool {
 public:
  // `allocator`: where the buffers' memory comes from (null: OpenCV's).
  // At least `min_buffers` are kept whatever their bytes.
  explicit BufferPool(size_t max_bytes, cv::MatAllocator* allocator = nullptr, size_t min_buffers = 0)
      : max_bytes_(max_bytes), min_buffers_(min_buffers), allocator_(allocator) {}
  // A buffer of rows x cols bytes that nothing else holds now. Thread-safe
  // against the release of buffers handed out, not against other Take()s.
  cv::Mat Take(int rows, int cols) {
    for (const cv::Mat& b : buffers_)
      if (b.rows == rows && b.cols == cols && __atomic_load_n(&b.u->refcount, __ATOMIC_ACQUIRE) == 1) return b;
    cv::Mat fresh;
    fresh.allocator = allocator_;  // null: OpenCV's
    fresh.create(rows, cols, CV_8UC1);
    // The buffer goes back through its own UMatData; a header handed out
    // must not call the allocator again (create() on it after the decoder
    // and its allocator are gone).
    fresh.allocator = nullptr;
    if (bytes_ + fresh.total() <= max_bytes_ || buffers_.size() < min_buffers_) {
      buffers_.push_back(fresh);
      bytes_ += fresh.total();
    }
    return fresh;
  }

 private:
  size_t max_bytes_, min_buffers_, bytes_ = 0;
  cv::MatAllocator* allocator_;
  std::vector<cv::Mat> buffers_;
};

}  // namespace

struct LumaDecoder::Impl {
  AVFormatContext* format = nullptr;
  AVCodecContext* codec = nullptr;
  AVPacket* packet = nullptr;
  AVFrame* frame = nullptr;
  int stream = -1;
  std::string name;  // the input as errors name it
  bool flushing = false, done = false;
  // A problem found by the demuxer ahead of the decoder's output: reported
  // once the frames decoded before it are handed out.
  std::string pending;
  long frames_out = 0, packets_in = 0, listed_frames = -1;
  int checked_format = AV_PIX_FMT_NONE;
  // Damage its decoders reported (CountDecoderDamage), and whether it makes
  // Read() decode the file again on one thread: a file, decoded on the CPU
  // with frame threads.
  std::atomic<int> damage_reports{0};
  bool redecodable = false;
  bool RedecodeWanted() const { return redecodable && damage_reports.load() > 0; }
  AVRational time_base{0, 1};
  double fps = 0.0;
  int64_t first_timestamp = AV_NOPTS_VALUE;
  int64_t data_end = AV_NOPTS_VALUE;  // latest end of a packet of any stream, AV_TIME_BASE units
  // Blocked input gives up at the deadline (streams) or on Abort().
  int64_t timeout_us = 0;
  std::atomic<int64_t> deadline_us{0};  // 0: none
  std::atomic<bool> aborted{false}, timed_out{false};
  AVIOContext* stdin_io = nullptr;  // standard input, read by ReadStdin

  // What Read() checks of a decoded frame before handing it out.
  struct FrameInfo {
    bool damaged = false;
    int format = AV_PIX_FMT_NONE;
    int64_t timestamp = AV_NOPTS_VALUE;  // best effort
  };
  static FrameInfo InfoOf(const AVFrame& f) {
    return {(f.flags & AV_FRAME_FLAG_CORRUPT) || f.decode_error_flags != 0, f.format, f.best_effort_timestamp};
  }

  // Groups of pictures decoded in parallel (see Open): the stream cut into
  // segments that each start at an IDR picture, segment s decoded by
  // gop_codecs[s % size] on a thread of its own (no frame threads'
  // hand-over per frame), the frames handed out in order. A frame waits as
  // a packed copy of its luma plane: the decoders' own buffers (with their
  // chroma planes and borders, about twice the size) go back to them at once.
  struct DecodedFrame {
    cv::Mat luma;  // empty for a frame Read() will refuse
    FrameInfo info;
    bool after_damage = false;  // a decoder had reported damage when it came out
  };
  struct Segment {
    std::deque<AVPacket*> packets;  // demuxed, not decoded yet
    long n_packets = 0;
    bool closed = false;               // all its packets are demuxed
    std::deque<DecodedFrame> frames;  // decoded, waiting for Read()
    size_t frame_bytes = 0;
    bool decoded = false;  // its decoder is through with it
    std::string error;     // why its decoding stopped early (after `frames`)
  };
  bool gop = false;
  bool demand_cuda = false;  // HardwareDecoding::kCuda: no fallback to the CPU
  AVCodecID codec_id = AV_CODEC_ID_NONE;
  int nal_length_size = 0;
  bool inband_parameter_sets = false;  // seen in a packet so far
  size_t segment_bytes = 0;            // the decoded frames a segment may hold
  std::unique_ptr<BufferPool> luma_buffers;  // for the frames' luma copies
  std::vector<AVCodecContext*> gop_codecs;  // [0] is `codec`; [kTailDecoder] the tail's, where it has one
  std::vector<std::thread> gop_threads;
  // The first segment the tail decoder takes (detail::FirstTailSegment);
  // the others take the segments before it.
  long tail_from = std::numeric_limits<long>::max();
  size_t DecoderOf(long s) const { return s >= tail_from ? kTailDecoder : static_cast<size_t>(s % kGopDecoders); }
  // NVDEC: the CUDA device FFmpeg decodes on, and the copies of its luma
  // planes into page-locked buffers (luma_buffers).
  AVBufferRef* cuda_device = nullptr;
  // FFmpeg offered no CUDA format for the stream (set on the decoding
  // thread, read by hardware()).
  std::atomic<bool> cuda_declined{false};
#if PANO_WITH_CUDA
  std::unique_ptr<detail::CudaLumaDownload> cuda_download;
#endif
  // Guards the demuxer and everything below (in GOP mode). Each waiting
  // thread has a condition of its own, so that a frame wakes only the
  // thread it concerns (a shared one woke every waiter for every frame).
  std::mutex gop_mu;
  std::condition_variable read_cv;                   // Read(): a frame or a segment's end
  std::condition_variable decoder_cv[kGopDecoders + 1];  // a decoder: room for frames, its turn
  bool decoder_wants_room[kGopDecoders + 1] = {};        // waiting for Read() to take frames
  std::deque<Segment> segments;  // from the one Read() takes frames from
  long first_segment = 0;        // its index
  bool demux_ended = false, gop_stop = false;

  void NotifyAll() {
    read_cv.notify_all();
    for (std::condition_variable& c : decoder_cv) c.notify_all();
  }

  ~Impl() {
    if (!gop_threads.empty()) {
      {
        std::lock_guard<std::mutex> lock(gop_mu);
        gop_stop = true;
      }
      NotifyAll();
      for (std::thread& t : gop_threads) t.join();
    }
    for (Segment& seg : segments)
      for (AVPacket* p : seg.packets) av_packet_free(&p);
    for (size_t i = 1; i < gop_codecs.size(); ++i) avcodec_free_context(&gop_codecs[i]);
    if (frame) av_frame_free(&frame);
    if (packet) av_packet_free(&packet);
    if (codec) avcodec_free_context(&codec);
    av_buffer_unref(&cuda_device);
    if (format) avformat_close_input(&format);
    if (stdin_io) {
      av_freep(&stdin_io->buffer);
      avio_context_free(&stdin_io);
    }
    StopCountingDecoderDamage(this);  // its decoders and their threads are gone
  }

  // FFmpeg's pipe protocol blocks in read() regardless of the interrupt
  // callback: standard input is read here instead, waiting with poll() in
  // short steps so that a deadline or Abort() ends the wait.
  static int ReadStdin(void* opaque, uint8_t* buf, int size) {
    for (;;) {
      if (Interrupt(opaque)) return AVERROR_EXIT;
      pollfd in{0, POLLIN, 0};
      const int ready = poll(&in, 1, 100);
      if (ready < 0 && errno != EINTR) return AVERROR(errno);
      if (ready <= 0) continue;
      const ssize_t n = read(0, buf, static_cast<size_t>(size));
      if (n > 0) return static_cast<int>(n);
      if (n == 0) return AVERROR_EOF;
      if (errno != EINTR && errno != EAGAIN) return AVERROR(errno);
    }
  }
  bool UseStdin() {
    constexpr int kBufferBytes = 1 << 16;
    auto* buffer = static_cast<unsigned char*>(av_malloc(kBufferBytes));
    if (buffer) stdin_io = avio_alloc_context(buffer, kBufferBytes, 0, this, &ReadStdin, nullptr, nullptr);
    if (!stdin_io) {
      av_free(buffer);
      return false;
    }
    format->pb = stdin_io;
    return true;
  }

  static int Interrupt(void* opaque) {
    Impl& d = *static_cast<Impl*>(opaque);
    if (d.aborted) return 1;
    const int64_t deadline = d.deadline_us;
    if (deadline != 0 && av_gettime_relative() > deadline) {
      d.timed_out = true;
      return 1;
    }
    return 0;
  }
  void ArmTimeout() {
    if (timeout_us > 0) deadline_us = av_gettime_relative() + timeout_us;
  }
  std::string NoData() const { return Format("no data for %g s", timeout_us / 1e6); }

  [[noreturn]] void Fail(const std::string& why) {
    if (RedecodeWanted()) throw RedecodeRequest();
    done = true;
    std::string reason = why;
    {
      std::unique_lock<std::mutex> lock(gop_mu, std::defer_lock);
      if (gop) lock.lock();  // the demuxer may be setting `pending`
      if (!pending.empty()) reason = pending;
    }
    throw Error(name + ": decode error at frame " + std::to_string(frames_out) + ": " + reason);
  }

  std::string Truncated() const {
    if (listed_frames > 0)
      return "truncated file (container lists " + std::to_string(listed_frames) + " frames)";
    return "truncated file (its last packet is cut short)";
  }

  void NoteDataEnd(const AVPacket& p) {
    int64_t t = p.pts != AV_NOPTS_VALUE ? p.pts : p.dts;
    if (t == AV_NOPTS_VALUE) return;
    t += std::max<int64_t>(p.duration, 0);
    const AVRational microseconds{1, AV_TIME_BASE};  // AV_TIME_BASE_Q is a C compound literal
    const int64_t end = av_rescale_q(t, format->streams[p.stream_index]->time_base, microseconds);
    if (data_end == AV_NOPTS_VALUE || end > data_end) data_end = end;
  }

  void StartFlush() {
    avcodec_send_packet(codec, nullptr);
    flushing = true;
  }

  enum class PacketRead { kPacket, kEnd, kAborted };
  // The next packet of the video stream into `packet`. kEnd at the end of
  // the input or at a damaged packet (`pending` names a problem).
  PacketRead ReadPacket() {
    int rd;
    ArmTimeout();
    while ((rd = av_read_frame(format, packet)) >= 0) {
      NoteDataEnd(*packet);
      if (packet->stream_index == stream) break;
      av_packet_unref(packet);
      ArmTimeout();
    }
    deadline_us = 0;
    if (aborted) {
      if (rd >= 0) av_packet_unref(packet);
      return PacketRead::kAborted;
    }
    if (rd >= 0 && (timed_out || (format->pb && format->pb->error < 0))) {
      // The demuxer hands out what it had buffered when the input stalled or
      // failed (a stream's partial last packet): its frame would be damaged.
      av_packet_unref(packet);
      pending = timed_out ? NoData() : "read failed (" + AvError(format->pb->error) + ")";
      return PacketRead::kEnd;
    }
    if (rd >= 0 && (packet->flags & AV_PKT_FLAG_CORRUPT)) {
      av_packet_unref(packet);
      pending = format->pb && avio_feof(format->pb) ? Truncated() : "damaged packet in the container";
      return PacketRead::kEnd;
    }
    if (rd < 0) {
      // Input errors may surface as an early end of file.
      const int io_error = format->pb ? format->pb->error : 0;
      if (timed_out) pending = NoData();
      else if (rd != AVERROR_EOF) pending = "read failed (" + AvError(rd) + ")";
      else if (io_error < 0) pending = "read failed (" + AvError(io_error) + ")";
      return PacketRead::kEnd;
    }
    ++packets_in;
    return PacketRead::kPacket;
  }

  // Sends the next packet of the video stream to the decoder, or starts
  // flushing it at the end of the input or at a damaged packet.
  void Feed() {
    const PacketRead read = ReadPacket();
    if (read == PacketRead::kAborted) {
      done = true;
      return;
    }
    if (read == PacketRead::kEnd) {
      StartFlush();
      return;
    }
    const int sent = avcodec_send_packet(codec, packet);
    av_packet_unref(packet);
    // With frame threads the error belongs to the oldest packet in the
    // decoder, the one whose frame is due next: the frames after it are not
    // to be handed out in its place.
    if (sent < 0) Fail("corrupt data (" + AvError(sent) + ")");
  }

  // At the decoder's end: the demuxer's pending problem, or fewer packets
  // or seconds than the container lists.
  void CheckComplete() {
    if (!pending.empty()) Fail(pending);
    if (listed_frames > 0 && packets_in < listed_frames) Fail(Truncated());
    if (listed_frames <= 0 && format->duration > 0 &&
        format->duration_estimation_method != AVFMT_DURATION_FROM_BITRATE && data_end != AV_NOPTS_VALUE) {
      const int64_t start = format->start_time != AV_NOPTS_VALUE ? format->start_time : 0;
      const double listed_s = format->duration / 1e6, reached_s = (data_end - start) / 1e6;
      if (reached_s < listed_s - kDurationSlackS)
        Fail(Format("truncated or damaged file (container lists %.2f s, ", listed_s) +
             Format("data ends at %.2f s)", reached_s));
    }
  }

  double FrameTime(int64_t ts) {
    if (ts == AV_NOPTS_VALUE) return fps > 0.0 ? frames_out / fps : std::nan("");
    if (first_timestamp == AV_NOPTS_VALUE) first_timestamp = ts;
    return static_cast<double>(ts - first_timestamp) * av_q2d(time_base);
  }

  // NVDEC for `decoder` on CUDA device 0; false with the reason (and
  // nothing of it left set up) when FFmpeg has no CUDA hwaccel for the codec
  // or no device can be used.
  bool SetUpNvdec(const AVCodec* decoder, std::string* why) {
#if PANO_WITH_CUDA
    if (TrySetUpNvdec(decoder, why)) return true;
    luma_buffers.reset();
    cuda_download.reset();
    av_buffer_unref(&cuda_device);
    return false;
#else
    (void)decoder;
    *why = "built without CUDA";
    return false;
#endif
  }
#if PANO_WITH_CUDA
  bool TrySetUpNvdec(const AVCodec* decoder, std::string* why) {
    bool has_hwaccel = false;
    for (int i = 0;; ++i) {
      const AVCodecHWConfig* config = avcodec_get_hw_config(decoder, i);
      if (!config) break;
      has_hwaccel |= (config->methods & AV_CODEC_HW_CONFIG_METHOD_HW_DEVICE_CTX) &&
                     config->device_type == AV_HWDEVICE_TYPE_CUDA;
    }
    if (!has_hwaccel) {
      *why = std::string("FFmpeg has no NVDEC decoder for ") + avcodec_get_name(decoder->id);
      return false;
    }
    // The device's primary context, which every decoder of the process
    // shares: contexts of their own would take turns on the GPU.
    // One at a time: FFmpeg sets the primary context's flags when it finds
    // it inactive, which fails once another decoder has activated it.
    static std::mutex creation_mu;
    AVDictionary* device_options = nullptr;
    av_dict_set(&device_options, "primary_ctx", "1", 0);
    DecoderErrorCapture ffmpeg_said;
    int r;
    {
      std::lock_guard<std::mutex> lock(creation_mu);
      r = av_hwdevice_ctx_create(&cuda_device, AV_HWDEVICE_TYPE_CUDA, nullptr, device_options, 0);
    }
    av_dict_free(&device_options);
    if (r < 0) {
      *why = !ffmpeg_said.last().empty() ? ffmpeg_said.last() : AvError(r);
      return false;
    }
    cuda_download = std::make_unique<detail::CudaLumaDownload>();
    if (!cuda_download->Init(cuda_device, why)) return false;
    // The frames of a FrameSource's queue (at least 8), and some more:
    // page-locked memory is slow to allocate and to free.
    luma_buffers = std::make_unique<BufferPool>(2 * kReadAheadBytes, cuda_download->allocator(), kNvdecBuffers);
    codec->hw_device_ctx = av_buffer_ref(cuda_device);
    if (!codec->hw_device_ctx) {
      *why = "out of memory";
      return false;
    }
    codec->opaque = this;
    codec->get_format = &PickCudaFormat;
    return true;
  }
#endif
  // FFmpeg's choice of output format: CUDA surfaces where the hwaccel takes
  // the stream (it can refuse a profile or a size), else the CPU's format.
  // Streams without an 8-bit luma plane (10-bit) are left to the CPU,
  // which refuses them as it does without NVDEC.
  static AVPixelFormat PickCudaFormat(AVCodecContext* c, const AVPixelFormat* formats) {
    for (const AVPixelFormat* f = formats; *f != AV_PIX_FMT_NONE; ++f)
      if (*f == AV_PIX_FMT_CUDA && HasLumaPlane(c->sw_pix_fmt)) return *f;
    static_cast<Impl*>(c->opaque)->cuda_declined = true;
    return avcodec_default_get_format(c, formats);
  }
  std::string CudaDeclined() const {
    return std::string("NVDEC cannot decode this stream (") + avcodec_get_name(codec->codec_id) + ", " +
           std::to_string(codec->width) + " x " + std::to_string(codec->height) + ")";
  }

  // A frame on the device: its luma plane copied into a page-locked buffer
  // of the pool (the chroma planes stay on the device).
  void DeliverFromDevice(cv::Mat* grey, double* time_s) {
    FrameInfo info = InfoOf(*frame);
    cv::Mat luma;
    std::string why;
    bool copied = false;
    if (!info.damaged) {
      info.format = AV_PIX_FMT_GRAY8;
      // FFmpeg crops a device frame's right and bottom by its size alone,
      // and leaves the left and top to the copy.
      luma = luma_buffers->Take(frame->height - static_cast<int>(frame->crop_top),
                                frame->width - static_cast<int>(frame->crop_left));
#if PANO_WITH_CUDA
      copied = cuda_download->Copy(*frame, &luma, &why);
#endif
    }
    av_frame_unref(frame);
    if (!info.damaged && !copied) Fail("NVDEC: " + why);
    Check(info, time_s);
    *grey = std::move(luma);
    ++frames_out;
  }

  // Hands out the decoded frame's luma plane without copying it: *grey
  // wraps the plane (with its row stride) and holds a reference to the
  // frame, which goes back to the decoder's pool when the last cv::Mat
  // sharing it is released.
  void Deliver(cv::Mat* grey, double* time_s) {
    if (frame->format == AV_PIX_FMT_CUDA) return DeliverFromDevice(grey, time_s);
    if (cuda_declined && demand_cuda) {
      av_frame_unref(frame);
      Fail(CudaDeclined());
    }
    const FrameInfo info = InfoOf(*frame);
    if (!Usable(info)) av_frame_unref(frame);
    Check(info, time_s);
    if (!WrapLuma(frame, grey)) Fail("out of memory");
    ++frames_out;
  }

  bool Usable(const FrameInfo& info) const {
    return !info.damaged && (info.format == checked_format || HasLumaPlane(info.format));
  }
  // Throws for a frame that is not to be handed out; else gives its time.
  void Check(const FrameInfo& info, double* time_s) {
    if (!Usable(info))
      Fail(info.damaged ? "damaged frame (the decoder concealed errors in it)" : NoLumaPlane(info.format));
    checked_format = info.format;
    if (time_s) *time_s = FrameTime(info.timestamp);
  }

  // GOP mode: with gop_mu held (by `lock`), demuxes until segment s has a
  // packet waiting or all its packets are out; null when the input ended
  // before segment s began. A packet goes to the segment being demuxed; an
  // IDR picture starts a new one once that has enough packets, unless the
  // stream sent parameter sets of its own earlier and this picture does not
  // repeat them (a decoder starting there would lack them).
  Segment* DemuxFor(long s) {
    for (;;) {
      const long have = first_segment + static_cast<long>(segments.size());
      if (s < have) {
        Segment& seg = segments[static_cast<size_t>(s - first_segment)];
        if (!seg.packets.empty() || seg.closed) return &seg;
      } else if (demux_ended) {
        return nullptr;
      }
      if (ReadPacket() != PacketRead::kPacket) {
        demux_ended = true;
        if (!segments.empty()) segments.back().closed = true;
        read_cv.notify_all();
        continue;
      }
      const NalContents nals = ScanNals(*packet, codec_id, nal_length_size);
      const bool parameter_sets_before = inband_parameter_sets;
      inband_parameter_sets = inband_parameter_sets || nals.parameter_sets;
      if ((packet->flags & AV_PKT_FLAG_KEY) && nals.idr && segments.back().n_packets >= kMinSegmentPackets &&
          (nals.parameter_sets || !parameter_sets_before)) {
        segments.back().closed = true;
        segments.emplace_back();
      }
      AVPacket* queued = av_packet_alloc();
      if (!queued) throw std::bad_alloc();
      av_packet_move_ref(queued, packet);
      segments.back().packets.push_back(queued);
      ++segments.back().n_packets;
    }
  }

  // GOP mode: decodes segment s (gop_mu held by `lock`, released while
  // decoding) and leaves the decoder ready for another; what went wrong, or "".
  std::string DecodeSegment(AVCodecContext* c, long s, AVFrame* out, std::unique_lock<std::mutex>& lock) {
    // The decoder drained (error ""), or stopped by an error: reset for the next segment.
    auto finish = [&](const std::string& error) {
      avcodec_flush_buffers(c);
      if (!lock.owns_lock()) lock.lock();
      return error;
    };
    for (bool draining = false;;) {
      AVPacket* p = nullptr;
      if (!draining) {
        Segment* seg = DemuxFor(s);
        if (!seg->packets.empty()) {
          p = seg->packets.front();
          seg->packets.pop_front();
        }
        draining = p == nullptr;  // its packets are all out: drain the decoder
      }
      lock.unlock();
      const int sent = avcodec_send_packet(c, p);
      av_packet_free(&p);
      if (sent < 0) return finish("corrupt data (" + AvError(sent) + ")");
      for (;;) {
        const int got = avcodec_receive_frame(c, out);
        if (got == AVERROR(EAGAIN)) break;
        if (got == AVERROR_EOF) return finish("");
        if (got < 0) return finish("corrupt data (" + AvError(got) + ")");
        DecodedFrame decoded{cv::Mat(), InfoOf(*out), damage_reports.load() > 0};
        const bool copied = !decoded.info.damaged && HasLumaPlane(decoded.info.format);
        lock.lock();
        if (copied) decoded.luma = luma_buffers->Take(out->height, out->width);
        lock.unlock();
        if (copied) CopyLuma(*out, &decoded.luma);
        av_frame_unref(out);
        const size_t bytes = decoded.luma.total();
        lock.lock();
        Segment* seg = &segments[static_cast<size_t>(s - first_segment)];
        // The next segment holds at most segment_bytes of frames (Open chose
        // GOP mode because a group of pictures fits); the one Read() takes
        // frames from runs ahead of it by no more than a single decoder would.
        const size_t worker = DecoderOf(s);
        decoder_wants_room[worker] = true;
        decoder_cv[worker].wait(lock, [&] {
          const size_t limit = s == first_segment ? std::min(segment_bytes, kReadAheadBytes) : segment_bytes;
          return gop_stop || seg->frames.empty() || seg->frame_bytes + bytes <= limit;
        });
        decoder_wants_room[worker] = false;
        if (gop_stop) return "";
        seg->frames.push_back(std::move(decoded));
        seg->frame_bytes += bytes;
        if (s == first_segment) read_cv.notify_one();
        lock.unlock();
      }
      lock.lock();
      if (gop_stop) return "";
    }
  }

  // GOP mode: decoder `worker`'s thread, decoding segments worker, worker +
  // n, ... before tail_from (the tail decoder: tail_from, tail_from + 1, ...),
  // each once Read() has reached the segment before it.
  void DecodeSegments(size_t worker) {
    AVCodecContext* c = gop_codecs[worker];
    const long n = kGopDecoders;
    const bool tail = worker == kTailDecoder;
    AVFrame* out = av_frame_alloc();
    std::unique_lock<std::mutex> lock(gop_mu);
    for (long s = tail ? tail_from : static_cast<long>(worker); tail || s < tail_from; s += tail ? 1 : n) {
      decoder_cv[worker].wait(lock, [&] { return gop_stop || s < first_segment + n; });
      if (gop_stop) break;
      std::string error;
      Segment* seg = nullptr;
      try {
        seg = DemuxFor(s);
        if (!seg) break;
        error = out ? DecodeSegment(c, s, out, lock) : "out of memory";
      } catch (const std::exception& e) {  // the thread's boundary (an allocation failed)
        if (!lock.owns_lock()) lock.lock();
        const std::string what = e.what();
        error = what.substr(0, what.find('\n'));
        if (seg) avcodec_flush_buffers(c);
        if (!seg) {
          demux_ended = true;
          pending = error;
          if (!segments.empty()) segments.back().closed = true;
        }
      }
      if (seg) {
        seg = &segments[static_cast<size_t>(s - first_segment)];
        seg->error = error;
        seg->decoded = true;
      }
      read_cv.notify_one();
      if (gop_stop || !seg) break;
    }
    av_frame_free(&out);
  }

  // GOP mode: Read().
  bool ReadInOrder(cv::Mat* grey, double* time_s) {
    std::unique_lock<std::mutex> lock(gop_mu);
    for (;;) {
      read_cv.wait(lock, [&] {
        return aborted || (segments.empty() ? demux_ended
                                            : !segments.front().frames.empty() || segments.front().decoded);
      });
      if (aborted) {
        done = true;
        return false;
      }
      if (segments.empty()) {
        lock.unlock();
        done = true;
        CheckComplete();
        return false;
      }
      Segment& seg = segments.front();
      if (!seg.frames.empty()) {
        DecodedFrame next = std::move(seg.frames.front());
        seg.frames.pop_front();
        seg.frame_bytes -= next.luma.total();
        const size_t worker = DecoderOf(first_segment);
        if (decoder_wants_room[worker]) decoder_cv[worker].notify_one();
        lock.unlock();
        if (redecodable && next.after_damage) throw RedecodeRequest();
        Check(next.info, time_s);
        *grey = std::move(next.luma);
        ++frames_out;
        return true;
      }
      if (!seg.error.empty()) {
        const std::string error = seg.error;
        lock.unlock();
        Fail(error);
      }
      segments.pop_front();
      ++first_segment;
      for (std::condition_variable& c : decoder_cv) c.notify_one();  // a decoder's turn, or more room
    }
  }

  // Open's steps. The container (a file, standard input or a stream; its
  // stream info read under the I/O timeout).
  bool OpenContainer(const std::string& path, double io_timeout_s, std::string* reason) {
    CountDecoderDamage(this, &damage_reports);
    name = InputName(path);
    timeout_us = io_timeout_s > 0.0 ? static_cast<int64_t>(io_timeout_s * 1e6) : 0;
    format = avformat_alloc_context();
    if (!format) {
      *reason = "out of memory";
      return false;
    }
    format->interrupt_callback.callback = &Impl::Interrupt;
    format->interrupt_callback.opaque = this;
    if (path == "-" && !UseStdin()) {
      *reason = "out of memory";
      return false;
    }
    DecoderErrorCapture ffmpeg_said;
    ArmTimeout();
    int r = avformat_open_input(&format, path == "-" ? "pipe:0" : path.c_str(), nullptr, nullptr);
    if (r >= 0) r = avformat_find_stream_info(format, nullptr);
    deadline_us = 0;
    if (r < 0) {
      *reason = timed_out ? NoData() : !ffmpeg_said.last().empty() ? ffmpeg_said.last() : AvError(r);
      return false;
    }
    return true;
  }

  // The best video stream, its rate and frame count, and its decoder's
  // context (on NVDEC where asked and possible).
  bool OpenStream(const LumaDecoderOptions& options, const AVCodec** decoder, std::string* reason) {
    stream = av_find_best_stream(format, AVMEDIA_TYPE_VIDEO, -1, -1, decoder, 0);
    if (stream < 0) {
      *reason = "no video stream";
      return false;
    }
    AVStream* st = format->streams[stream];
    const AVRational r = st->avg_frame_rate.num ? st->avg_frame_rate : st->r_frame_rate;
    fps = r.den ? av_q2d(r) : 0.0;
    listed_frames = st->nb_frames > 0 ? static_cast<long>(st->nb_frames) : -1;
    time_base = st->time_base;
    if (!*decoder) {
      *reason = std::string("no decoder for ") + avcodec_get_name(st->codecpar->codec_id);
      return false;
    }
    codec = avcodec_alloc_context3(*decoder);
    if (!codec || avcodec_parameters_to_context(codec, st->codecpar) < 0) {
      *reason = "cannot set up the decoder";
      return false;
    }
    codec->opaque = this;  // the key its damage is counted by
    if (options.hardware != HardwareDecoding::kNone) {
      std::string why;
      if (!SetUpNvdec(*decoder, &why) && options.hardware == HardwareDecoding::kCuda) {
        *reason = "NVDEC: " + why;
        return false;
      }
      demand_cuda = options.hardware == HardwareDecoding::kCuda;
    }
    return true;
  }

  // Two groups of pictures at a time, each decoder single-threaded where
  // there are two cores: FFmpeg's frame threads hand every frame over
  // between threads, which costs a fifth more CPU on a cheap stream. Only
  // files (the segments' frames wait in memory: a group of pictures must
  // fit in gop_parallel_bytes, known from an index of every frame), H.264 or
  // HEVC with their parameter sets out of band (length-prefixed NAL units).
  bool GopParallel(const std::string& path, const LumaDecoderOptions& options, int threads) const {
    const size_t gop_parallel_bytes = cuda_device ? 0 : options.gop_parallel_bytes;
    AVStream* st = format->streams[stream];
    const AVCodecParameters& par = *st->codecpar;
    const double luma_bytes = static_cast<double>(par.width) * par.height;  // what a waiting frame keeps
    const long longest_gop = LongestGop(st);
    return gop_parallel_bytes > 0 && options.io_timeout_s == 0.0 && path != "-" && threads >= 2 &&
           NalLengthSize(par) > 0 && luma_bytes > 0 && longest_gop > 0 &&
           longest_gop * luma_bytes <= static_cast<double>(gop_parallel_bytes);
  }

  // The decoders (kGopDecoders of them `in_segments`, and the tail's where
  // tail_from says), opened with their thread counts (NVDEC: one; frame
  // threads measured no faster, and each holds some of the video engine's
  // decode surfaces; the tail's: all of them).
  bool OpenDecoders(const AVCodec* decoder, bool in_segments, int threads, int num_threads, std::string* reason) {
    AVStream* st = format->streams[stream];
    gop_codecs.push_back(codec);
    const bool with_tail = tail_from != std::numeric_limits<long>::max();
    const size_t wanted = !in_segments ? 1 : with_tail ? kGopDecoders + 1 : kGopDecoders;
    while (gop_codecs.size() < wanted) {
      AVCodecContext* c = avcodec_alloc_context3(decoder);
      if (!c) {
        *reason = "cannot set up the decoder";
        return false;
      }
      gop_codecs.push_back(c);  // freed with the others
      c->opaque = this;
      if (avcodec_parameters_to_context(c, st->codecpar) < 0) {
        *reason = "cannot set up the decoder";
        return false;
      }
    }
    for (size_t i = 0; i < gop_codecs.size(); ++i) {
      AVCodecContext* c = gop_codecs[i];
      c->thread_count = cuda_device                          ? 1
                        : in_segments && i != kTailDecoder ? std::max(1, threads / kGopDecoders)
                        : num_threads > 0 || in_segments   ? threads
                                                           : 0;
      if (avcodec_open2(c, decoder, nullptr) >= 0) continue;
      if (i != kTailDecoder) {
        *reason = "cannot open the decoder";
        return false;
      }
      avcodec_free_context(&gop_codecs.back());  // the two decoders take every segment
      gop_codecs.pop_back();
      tail_from = std::numeric_limits<long>::max();
    }
    return true;
  }

  // A stream may state its pixel format only with its first frame: Read()
  // checks every frame's. A decoder that chose its output format when
  // opened (VC-1) may have chosen NVDEC's: the stream's own format is then
  // sw_pix_fmt. Then the packet and frame.
  bool CheckFormatAndAllocate(std::string* reason) {
    const AVPixelFormat stream_format = codec->pix_fmt == AV_PIX_FMT_CUDA ? codec->sw_pix_fmt : codec->pix_fmt;
    if (stream_format != AV_PIX_FMT_NONE && !HasLumaPlane(stream_format)) {
      *reason = NoLumaPlane(stream_format);
      return false;
    }
    packet = av_packet_alloc();
    frame = av_frame_alloc();
    if (!packet || !frame) {
      *reason = "out of memory";
      return false;
    }
    return true;
  }

  // The groups of pictures decoded on threads of their own.
  void StartGopDecoding(size_t gop_parallel_bytes) {
    const AVCodecParameters& par = *format->streams[stream]->codecpar;
    gop = true;
    codec_id = par.codec_id;
    nal_length_size = NalLengthSize(par);
    segment_bytes = gop_parallel_bytes;
    // The frames of two segments and of a FrameSource's queue.
    luma_buffers = std::make_unique<BufferPool>(gop_parallel_bytes + 2 * kReadAheadBytes);
    segments.emplace_back();
    for (size_t i = 0; i < gop_codecs.size(); ++i) gop_threads.emplace_back([this, i] { DecodeSegments(i); });
  }
};

bool LumaDecoderAvailable() { return true; }

LumaDecoder::LumaDecoder() = default;
LumaDecoder::~LumaDecoder() = default;

bool LumaDecoder::Open(const std::string& path, std::string* reason, const LumaDecoderOptions& options) {
  UseDefaultDecoderLogging();
  static std::once_flag network_once;
  std::call_once(network_once, [] { avformat_network_init(); });
  impl_ = std::make_unique<Impl>();
  path_ = path;
  options_ = options;
  Impl& d = *impl_;
  if (!d.OpenContainer(path, options.io_timeout_s, reason)) return false;
  container_opened_ = true;
  const AVCodec* decoder = nullptr;
  const bool stream_ok = d.OpenStream(options, &decoder, reason);
  if (d.stream >= 0) {
    fps_ = d.fps;
    frame_count_ = d.listed_frames;
  }
  if (!stream_ok) return false;
  // FFmpeg's own choice stops at 16 frame threads: more decode no faster,
  // and each holds frames of its own (a thousand run out of memory).
  constexpr int kMaxDecoderThreads = 16;
  const int asked =
      options.num_threads > 0 ? options.num_threads : static_cast<int>(std::thread::hardware_concurrency());
  const int threads = std::min(kMaxDecoderThreads, asked);
  const bool gop = d.GopParallel(path, options, threads);
  // A tail where each of the two decoders has one thread (two or three in
  // all): the speed-up its plan counts on is measured there; more frame
  // threads gain less from each doubling.
  if (gop && options.gop_tail && threads / kGopDecoders == 1) {
    const long tail = detail::FirstTailSegment(PredictedSegmentBytes(d.format->streams[d.stream]));
    if (tail >= 0) d.tail_from = tail;
  }
  if (!d.OpenDecoders(decoder, gop, threads, options.num_threads, reason)) return false;
  if (!d.CheckFormatAndAllocate(reason)) return false;
  bool frame_threads = false;
  for (const AVCodecContext* c : d.gop_codecs)
    frame_threads = frame_threads || ((c->active_thread_type & FF_THREAD_FRAME) && c->thread_count > 1);
  d.redecodable = frame_threads && !d.cuda_device && options.io_timeout_s == 0.0 && path != "-";
  gop_ = gop;
  if (gop) d.StartGopDecoding(d.cuda_device ? 0 : options.gop_parallel_bytes);
  return true;
}

bool LumaDecoder::Read(cv::Mat* grey, double* time_s) {
  try {
    return ReadDecoded(grey, time_s);
  } catch (const RedecodeRequest&) {
    RedecodeWithoutFrameThreads();
    return ReadDecoded(grey, time_s);
  }
}

// FFmpeg's frame threads decode the same pixels as one thread does, but
// copy a frame's error flags before its thread has set them, now and then:
// the frames after the damage would come out as they happen to be flagged.
// Decoded again from the start without frame threads (GOP mode: a decoder
// of one thread per group of pictures and no tail, as with two threads;
// otherwise one decoder of one thread), the frames handed out come again
// (and are dropped), and the rest, and the error, are those decoders'.
void LumaDecoder::RedecodeWithoutFrameThreads() {
  const long handed_out = impl_->frames_out;
  LumaDecoderOptions again = options_;
  again.hardware = HardwareDecoding::kNone;  // NVDEC's decoders are never decoded again
  again.gop_tail = false;
  again.num_threads = gop_ ? detail::kGopDecoderCount : 1;
  if (!gop_) again.gop_parallel_bytes = 0;
  auto serial = std::make_unique<LumaDecoder>();
  std::string why;
  bool opened = serial->Open(path_, &why, again);
  if (opened && serial->impl_->redecodable) {  // not GOP mode after all: one thread
    again.num_threads = 1;
    again.gop_parallel_bytes = 0;
    serial = std::make_unique<LumaDecoder>();
    opened = serial->Open(path_, &why, again);
  }
  if (!opened)
    throw Error(impl_->name + ": decode error at frame " + std::to_string(handed_out) +
                ": damaged, and cannot be opened again to decode it without frame threads (" + why + ")");
  {
    std::lock_guard<std::mutex> lock(impl_mu_);
    std::swap(impl_, serial->impl_);
    impl_->aborted = aborted_;
  }
  serial.reset();  // the threads that decoded until now stop before the others start again
  cv::Mat frame;
  double time_s;
  for (long i = 0; i < handed_out; ++i)
    if (!ReadDecoded(&frame, &time_s)) return;  // aborted (no fewer frames come without frame threads)
}

bool LumaDecoder::ReadDecoded(cv::Mat* grey, double* time_s) {
  Impl& d = *impl_;
  if (d.gop) return !d.done && d.ReadInOrder(grey, time_s);
  while (!d.done) {
    const int got = avcodec_receive_frame(d.codec, d.frame);
    if (got == 0) {
      if (d.RedecodeWanted()) {
        av_frame_unref(d.frame);
        throw RedecodeRequest();
      }
      d.Deliver(grey, time_s);
      return true;
    }
    if (got == AVERROR(EAGAIN) && !d.flushing) {
      d.Feed();
      continue;
    }
    if (d.aborted) break;
    if (got != AVERROR_EOF && got != AVERROR(EAGAIN)) d.Fail("corrupt data (" + AvError(got) + ")");
    d.done = true;
    d.CheckComplete();
  }
  return false;
}

void LumaDecoder::Abort() {
  std::lock_guard<std::mutex> swap_lock(impl_mu_);
  aborted_ = true;
  if (!impl_) return;
  impl_->aborted = true;
  if (impl_->gop) {
    std::lock_guard<std::mutex> lock(impl_->gop_mu);
    impl_->read_cv.notify_all();
  }
}

bool LumaDecoder::gop_parallel() const { return gop_; }

bool LumaDecoder::gop_tail() const {
  std::lock_guard<std::mutex> lock(impl_mu_);
  return gop_ && impl_ && impl_->tail_from != std::numeric_limits<long>::max();
}

// Never decoded again (RedecodeWithoutFrameThreads): NVDEC's decoder stays.
bool LumaDecoder::hardware() const {
  std::lock_guard<std::mutex> lock(impl_mu_);
  return impl_ && impl_->cuda_device && !impl_->cuda_declined;
}

int LumaDecoder::frames_waiting() {
  std::lock_guard<std::mutex> swap_lock(impl_mu_);
  if (!impl_ || !impl_->gop) return 0;
  std::lock_guard<std::mutex> lock(impl_->gop_mu);
  return impl_->segments.empty() ? 0 : static_cast<int>(impl_->segments.front().frames.size());
}

#else  // !PANO_WITH_FFMPEG

struct LumaDecoder::Impl {};
bool LumaDecoderAvailable() { return false; }
LumaDecoder::LumaDecoder() = default;
LumaDecoder::~LumaDecoder() = default;
bool LumaDecoder::Open(const std::string&, std::string* reason, const LumaDecoderOptions&) {
  *reason = "built without FFmpeg";
  return false;
}
bool LumaDecoder::Read(cv::Mat*, double*) { return false; }
void LumaDecoder::Abort() {}
bool LumaDecoder::gop_parallel() const { return false; }
bool LumaDecoder::gop_tail() const { return false; }
int LumaDecoder::frames_waiting() { return 0; }
bool LumaDecoder::hardware() const { return false; }

#endif

}  // namespace pano
