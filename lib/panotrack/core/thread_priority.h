#pragma once

namespace pano {

// Keeps a consumer thread out of its producer's way. The thread that makes
// a LagPriority runs at idle priority (Linux's SCHED_IDLE: only on a core
// that no other thread of the machine wants) while it keeps up, that is
// while at most `idle_at_most` items wait for it, and at its normal
// priority again once `normal_from` items wait, until the backlog is worked
// off. So the producer's threads have the cores whenever they can use
// them, the consumer fills the gaps they leave, and a consumer that other
// work on the machine starves still gets its fair share after
// `normal_from` items.
//
// Threads that the consumer starts inherit the policy it has at the time
// (pthreads' default): ones that outlive a switch, such as OpenMP's pooled
// workers, keep the old one. Elsewhere than on Linux, or where the thread
// runs under a policy other than the default (set with chrt), the priority
// is left alone.
class LagPriority {
 public:
  LagPriority(int idle_at_most, int normal_from);
  ~LagPriority();  // the thread's normal priority again
  LagPriority(const LagPriority&) = delete;
  LagPriority& operator=(const LagPriority&) = delete;

  // Called by the consumer with the number of items waiting for it.
  void Update(int waiting);
  bool idle() const { return idle_; }
  int switches() const { return switches_; }  // to idle and back, counted each

 private:
  void Switch(bool to_idle);
  int idle_at_most_, normal_from_;
  long thread_ = 0;  // the consumer's thread id; 0: priority left alone
  bool idle_ = false;
  int switches_ = 0;
};

}  // namespace pano
