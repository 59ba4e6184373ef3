// FIFOs for tests of readers and writers: one fed without end (an input that
// never finishes), one drained by a reader thread (an output that is not a
// regular file).
#pragma once

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <csignal>
#include <stdexcept>
#include <string>
#include <thread>

namespace pano::test {

// A FIFO at `path` that a thread feeds with `head` and then `chunk` over and
// over until the object is destroyed. A keeper descriptor holds the FIFO open
// for reading, so that neither side ever blocks in open().
class EndlessFifo {
 public:
  EndlessFifo(const std::string& path, const std::string& head, const std::string& chunk) : path_(path) {
    std::signal(SIGPIPE, SIG_IGN);  // the writer learns from EPIPE that the readers are gone
    if (::mkfifo(path.c_str(), 0600) != 0) throw std::runtime_error(path + ": mkfifo failed");
    keeper_ = ::open(path.c_str(), O_RDWR | O_CLOEXEC);
    if (keeper_ < 0) throw std::runtime_error(path + ": cannot open the FIFO");
    writer_ = std::thread([this, head, chunk] {
      try {
        const int fd = ::open(path_.c_str(), O_WRONLY | O_CLOEXEC);
        if (fd < 0) return;
        bool ok = WriteAll(fd, head);
        while (ok && !stop_) ok = WriteAll(fd, chunk);
        ::close(fd);
      } catch (const std::exception&) {
      }
    });
  }
  ~EndlessFifo() {
    stop_ = true;
    ::close(keeper_);  // the last reader gone: a blocked write fails with EPIPE
    writer_.join();
    ::unlink(path_.c_str());
  }
  EndlessFifo(const EndlessFifo&) = delete;
  EndlessFifo& operator=(const EndlessFifo&) = delete;
  const std::string& path() const { return path_; }

 private:
  static bool WriteAll(int fd, const std::string& s) {
    size_t done = 0;
    while (done < s.size()) {
      const ssize_t n = ::write(fd, s.data() + done, s.size() - done);
      if (n <= 0) return false;
      done += static_cast<size_t>(n);
    }
    return true;
  }
  std::string path_;
  int keeper_ = -1;
  std::atomic<bool> stop_{false};
  std::thread writer_;
};

// A FIFO at `path` drained by a thread; Finish() returns what was written
// to it. A keeper descriptor holds it open for writing until then, so that
// the reader sees the end only after the code under test has had its turn.
class DrainedFifo {
 public:
  explicit DrainedFifo(const std::string& path) : path_(path) {
    if (::mkfifo(path.c_str(), 0600) != 0) throw std::runtime_error(path + ": mkfifo failed");
    reader_ = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
    if (reader_ < 0) throw std::runtime_error(path + ": cannot open the FIFO");
    ::fcntl(reader_, F_SETFL, ::fcntl(reader_, F_GETFL) & ~O_NONBLOCK);
    keeper_ = ::open(path.c_str(), O_WRONLY | O_CLOEXEC);
    if (keeper_ < 0) throw std::runtime_error(path + ": cannot open the FIFO for writing");
    drain_ = std::thread([this] {
      try {
        char buf[65536];
        for (;;) {
          const ssize_t n = ::read(reader_, buf, sizeof buf);
          if (n <= 0) break;
          data_.append(buf, static_cast<size_t>(n));
        }
      } catch (const std::exception&) {
      }
    });
  }
  ~DrainedFifo() {
    Finish();
    ::close(reader_);
    ::unlink(path_.c_str());
  }
  DrainedFifo(const DrainedFifo&) = delete;
  DrainedFifo& operator=(const DrainedFifo&) = delete;
  const std::string& path() const { return path_; }
  // Everything written so far, once the writers have closed.
  const std::string& Finish() {
    if (keeper_ >= 0) ::close(keeper_);
    keeper_ = -1;
    if (drain_.joinable()) drain_.join();
    return data_;
  }

 private:
  std::string path_;
  int reader_ = -1;
  int keeper_ = -1;
  std::string data_;
  std::thread drain_;
};

}  // namespace pano::test
