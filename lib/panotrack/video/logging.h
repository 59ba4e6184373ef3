// What the decoding libraries (FFmpeg, OpenCV) print on their own. Called
// once from a program's main: quiet by default, everything with --verbose.
// Decoding problems reach the caller as pano::Error, never as library output.
#pragma once

#include <atomic>
#include <string>

namespace pano {

// verbose = false: FFmpeg and OpenCV print nothing (also after OpenCV's
// FFmpeg backend resets FFmpeg's log level). verbose = true: their own
// messages at info level and above.
void SetDecoderLogging(bool verbose);

// Applies SetDecoderLogging(false) unless a program chose already; the frame
// sources call it, so that a library user gets quiet decoders by default.
void UseDefaultDecoderLogging();

// Counts into *count the damage that FFmpeg's decoders report for the
// AVCodecContexts whose `opaque` is `key` (their frame threads' copies
// included), whatever the verbosity and the thread that logs it: its error
// messages and its notes of concealed errors. Frame threads flag a damaged
// frame only now and then (FFmpeg copies a frame's error flags before its
// thread has set them); the messages come every time, from the thread that
// decodes the damage. Needs the programs' logging (SetDecoderLogging);
// counted until StopCountingDecoderDamage(key).
void CountDecoderDamage(const void* key, std::atomic<int>* count);
void StopCountingDecoderDamage(const void* key);

// Collects the error messages FFmpeg logs on the calling thread while it is
// alive (whatever the verbosity), so that an error can say what FFmpeg saw,
// e.g. "moov atom not found".
class DecoderErrorCapture {
 public:
  DecoderErrorCapture();
  ~DecoderErrorCapture();
  DecoderErrorCapture(const DecoderErrorCapture&) = delete;
  DecoderErrorCapture& operator=(const DecoderErrorCapture&) = delete;
  // The last complete error line, without its trailing newline; "" if none.
  const std::string& last() const { return last_; }
  void Append(const char* text);  // from the log callback: a line or a piece of one

 private:
  std::string last_, partial_;
  DecoderErrorCapture* outer_;
};

}  // namespace pano
