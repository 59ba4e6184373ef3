#include "panotrack/pose/pose_row.h"

namespace pano {

const char* PoseStatusName(PoseStatus s) {
  switch (s) {
    case PoseStatus::kOk: return "ok";
    case PoseStatus::kLost: return "lost";
    case PoseStatus::kInit: return "init";
  }
  return "?";
}

}  // namespace pano
