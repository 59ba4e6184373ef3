#include "video/logging.h"

#include <opencv2/core/utils/logger.hpp>

#include "pano/config.h"
#if PANO_WITH_FFMPEG
extern "C" {
#include <libavutil/log.h>
}
#endif

namespace pano {

void SetDecoderLogging(bool verbose) {
  cv::utils::logging::setLogLevel(verbose ? cv::utils::logging::LOG_LEVEL_INFO
                                          : cv::utils::logging::LOG_LEVEL_ERROR);
#if PANO_WITH_FFMPEG
  av_log_set_level(verbose ? AV_LOG_INFO : AV_LOG_QUIET);
#endif
}

}  // namespace pano
