// What the decoding libraries (FFmpeg, OpenCV) print on their own. Called
// once from a program's main: quiet by default, everything with --verbose.
#pragma once

namespace pano {

void SetDecoderLogging(bool verbose);

}  // namespace pano
