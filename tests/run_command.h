// Running the built programs as users do ($PANO_BIN_DIR/<program> ARGS),
// with what they print (stdout and stderr together) and their exit code.
#pragma once

#include <catch2/catch.hpp>
#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <cstdlib>
#include <string>

namespace pano::test {

struct CommandRun {
  int code = -1;
  std::string out;  // stdout and stderr together
};

// `args` starts with the program's name; it runs through the shell.
inline CommandRun RunProgram(const std::string& args) {
  const char* dir = std::getenv("PANO_BIN_DIR");
  REQUIRE(dir != nullptr);
  const std::string cmd = std::string(dir) + "/" + args + " 2>&1";
  CommandRun r;
  FILE* p = popen(cmd.c_str(), "r");
  REQUIRE(p != nullptr);
  std::array<char, 4096> buf;
  size_t n;
  while ((n = fread(buf.data(), 1, buf.size(), p)) > 0) r.out.append(buf.data(), n);
  const int status = pclose(p);
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

inline int CountLines(const std::string& s) {
  int n = 0;
  for (char c : s) n += c == '\n';
  return n;
}

}  // namespace pano::test
