// Atomic writes that leave special files and symbolic links what they are,
// and reads that stop at a bound whatever the file turns out to be.
#include <catch2/catch.hpp>

#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "panotrack/core/atomic_file.h"
#include "panotrack/core/error.h"
#include "core/test_fifo.h"
#include "test_paths.h"
#include "test_skip.h"

namespace pano {
namespace {

namespace fs = std::filesystem;

size_t FilesIn(const std::string& dir) {
  size_t n = 0;
  for (auto it = fs::recursive_directory_iterator(dir); it != fs::recursive_directory_iterator(); ++it) ++n;
  return n;
}

std::string Slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

TEST_CASE("a FIFO target is written in place, not replaced by a regular file", "[atomic_special]") {
  const std::string dir = test::ScratchDir("core_atomic_fifo");
  test::DrainedFifo fifo(dir + "/out.yaml");
  // More than a pipe holds, so that the writer depends on the reader thread.
  std::string text;
  for (int i = 0; text.size() < (1u << 20); ++i) text += "line " + std::to_string(i) + "\n";
  {
    AtomicFile probe(fifo.path());
    CHECK(probe.in_place());
    CHECK(probe.temp_path() == fifo.path());
  }
  WriteFileAtomic(fifo.path(), text);
  CHECK(fifo.Finish() == text);
  CHECK(fs::is_fifo(fs::symlink_status(fifo.path())));
  CHECK(FilesIn(dir) == 1);  // no temporary left beside it
}

TEST_CASE("/dev/null stays a character device after a write", "[atomic_special]") {
  const std::string null = "/dev/null";
  if (!fs::is_character_file(null) || ::access(null.c_str(), W_OK) != 0) {
    test::Skip("/dev/null is not a writable character device here");
    return;
  }
  // Checked first: a writer that would rename over /dev/null must not get to try.
  REQUIRE(AtomicFile(null).in_place());
  WriteFileAtomic(null, "discarded\n");
  {
    AtomicFile f(null);
    f.Write("more\n");
    // Destroyed without Commit(): an in-place target is never removed.
  }
  CHECK(fs::is_character_file(null));
  CHECK(fs::exists(null));
}

TEST_CASE("a symbolic link stays a link; the file it points to is replaced", "[atomic_special]") {
  const std::string dir = test::ScratchDir("core_atomic_link");
  fs::create_directories(dir + "/real");
  std::ofstream(dir + "/real/calib.yaml") << "old\n";
  fs::create_symlink("real/calib.yaml", dir + "/calib.yaml");
  fs::create_symlink("calib.yaml", dir + "/link_to_link.yaml");
  WriteFileAtomic(dir + "/calib.yaml", "new\n");
  CHECK(fs::is_symlink(dir + "/calib.yaml"));
  CHECK(fs::read_symlink(dir + "/calib.yaml") == "real/calib.yaml");
  CHECK(Slurp(dir + "/real/calib.yaml") == "new\n");
  WriteFileAtomic(dir + "/link_to_link.yaml", "newer\n");
  CHECK(fs::is_symlink(dir + "/link_to_link.yaml"));
  CHECK(fs::is_symlink(dir + "/calib.yaml"));
  CHECK(Slurp(dir + "/real/calib.yaml") == "newer\n");
  // A dangling link: the file it names is created.
  fs::create_symlink("real/later.yaml", dir + "/later.yaml");
  WriteFileAtomic(dir + "/later.yaml", "created\n");
  CHECK(fs::is_symlink(dir + "/later.yaml"));
  CHECK(Slurp(dir + "/real/later.yaml") == "created\n");
  // Links, the two real files and the folder: no temporary left anywhere.
  CHECK(FilesIn(dir) == 6);
  // A loop of links is an error naming the path, not a hang.
  fs::create_symlink("loop_b", dir + "/loop_a");
  fs::create_symlink("loop_a", dir + "/loop_b");
  CHECK_THROWS_WITH(WriteFileAtomic(dir + "/loop_a", "x"), Catch::Contains(dir + "/loop_a"));
}

TEST_CASE("a folder as the target is an error naming it", "[atomic_special]") {
  const std::string dir = test::ScratchDir("core_atomic_folder");
  fs::create_directories(dir + "/out.yaml");
  CHECK_THROWS_WITH(WriteFileAtomic(dir + "/out.yaml", "x"),
                    Catch::Contains(dir + "/out.yaml") && Catch::Contains("folder"));
  CHECK(fs::is_directory(dir + "/out.yaml"));
}

TEST_CASE("ReadFile stops at its bound: folders, endless streams, large files", "[read_bounds]") {
  const std::string dir = test::ScratchDir("core_read_bounds");
  std::ofstream(dir + "/small.txt") << "0123456789";
  CHECK(ReadFile(dir + "/small.txt", 10) == "0123456789");
  CHECK_THROWS_WITH(ReadFile(dir + "/small.txt", 9),
                    Catch::Contains(dir + "/small.txt") && Catch::Contains("too large"));
  CHECK_THROWS_WITH(ReadFile(dir, 100), Catch::Contains(dir) && Catch::Contains("folder"));
  CHECK_THROWS_WITH(ReadFile(dir + "/absent.txt"), Catch::Contains("cannot open"));
  {
    test::EndlessFifo fifo(dir + "/endless", "head\n", std::string(4096, 'x'));
    CHECK_THROWS_WITH(ReadFile(fifo.path(), 1 << 20),
                      Catch::Contains(fifo.path()) && Catch::Contains("1 MiB"));
  }
  if (fs::is_character_file("/dev/zero"))
    CHECK_THROWS_WITH(ReadFile("/dev/zero", 1 << 20),
                      Catch::Contains("/dev/zero") && Catch::Contains("1 MiB"));
}

}  // namespace
}  // namespace pano
