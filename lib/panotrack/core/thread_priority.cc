#include "panotrack/core/thread_priority.h"

#include "panotrack/core/error.h"

#ifdef __linux__
#include <sched.h>
#include <sys/syscall.h>
#include <unistd.h>
#endif

namespace pano {

LagPriority::LagPriority(int idle_at_most, int normal_from)
    : idle_at_most_(idle_at_most), normal_from_(normal_from) {
  if (idle_at_most < 0 || normal_from <= idle_at_most)
    throw Error("lag priority: expected 0 <= idle_at_most < normal_from");
#ifdef __linux__
  // The thread id, not 0 ("the caller"): the destructor may run elsewhere.
  const long self = syscall(SYS_gettid);
  if (sched_getscheduler(static_cast<pid_t>(self)) == SCHED_OTHER) thread_ = self;
#endif
}

LagPriority::~LagPriority() {
  if (idle_) Switch(false);
}

void LagPriority::Update(int waiting) {
  if (thread_ == 0) return;
  if (!idle_ && waiting <= idle_at_most_) Switch(true);
  else if (idle_ && waiting >= normal_from_) Switch(false);
}

void LagPriority::Switch([[maybe_unused]] bool to_idle) {
#ifdef __linux__
  // Back from SCHED_IDLE to SCHED_OTHER at the same nice value needs no
  // privilege (sched(7)).
  const sched_param param{};
  if (sched_setscheduler(static_cast<pid_t>(thread_), to_idle ? SCHED_IDLE : SCHED_OTHER, &param) == 0) {
    idle_ = to_idle;
    ++switches_;
  } else if (to_idle) {
    thread_ = 0;  // refused (a sandbox's seccomp filter): stay at the normal priority
  }
#endif
}

}  // namespace pano
