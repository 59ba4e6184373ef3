// What panoloc's tests share: a short rendered sequence, long inputs made of
// its frames, the panoloc program run as a child process, and checks of the
// rows it writes.
#pragma once

#include <sys/types.h>

#include <string>
#include <vector>

#include "panotrack/pipeline/panoloc.h"
#include "panotrack/pose/pose2.h"
#include "panotrack/pose/pose_row.h"
#include "panotrack/sensor/sensor.h"

namespace pano::test {

// paper-synthetic's first 12 frames, rendered once per test program:
// dir/seq/{video.mp4, frames/, calib.yaml, map.yaml, gt.csv, case.yaml}.
struct SmallCase {
  std::string dir;  // the case folder (dir/seq)
  std::string video, frames, calib, map, gt;
  Pose2 init;
  int n_frames = 12;
  // --calib ... --map ... --init x,y,theta
  std::string Args() const;
};
const SmallCase& GetSmallCase();

// A scratch folder of this test process (`name` made unique by the pid).
std::string Scratch(const std::string& name);
// The names of the entries of `dir`, sorted.
std::vector<std::string> FilesIn(const std::string& dir);
// panoloc's options for one input of the small case, quiet.
PanolocOptions OneInput(const std::string& input, const std::string& output);

// A folder of `n` images that are links to the case's frames, forwards then
// backwards (0..11, 11..0, ...): an input as long as needed that keeps
// tracking.
std::string LongFolder(const std::string& dir, int n);
// A folder of `n` uniform grey frames of the case's size: nothing to track.
std::string BlankFolder(const std::string& dir, int n);

// Rows 0, 1, ..., n-1, each frame once, in order; REQUIREs it.
void RequireConsecutive(const std::vector<PoseRow>& rows);

bool HaveFfmpegTool();
// ffmpeg <args>, quiet; REQUIREs success.
void RunFfmpeg(const std::string& args);

// The programs of the build (PANO_BIN_DIR).
std::string Program(const std::string& name);

// A program run as a child: stdout and stderr into files, stdin from a file
// ("" : /dev/null).
struct Child {
  pid_t pid = -1;
  std::string out_path, err_path;
  bool ended = false;  // reaped already (status holds its exit)
  int status = 0;
};
Child Spawn(const std::vector<std::string>& argv, const std::string& scratch, const std::string& stdin_path = "");
// Waits for the child: its exit status, or 128 + the signal that ended it.
int Wait(Child* c);
// Waits until `path` holds at least `lines` lines; false when the child
// ended first (or after a minute, when it hangs).
bool WaitForLines(Child* c, const std::string& path, int lines);

struct RunResult {
  int code = -1;
  std::string out, err;
};
// Runs a program to its end.
RunResult Run(const std::vector<std::string>& argv, const std::string& scratch, const std::string& stdin_path = "");

// "a b c" -> {"a", "b", "c"} (arguments without spaces).
std::vector<std::string> Words(const std::string& text);
std::string ReadText(const std::string& path);
int CountLines(const std::string& text);

}  // namespace pano::test
