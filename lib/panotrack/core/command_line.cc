#include "panotrack/core/command_line.h"

#include <cctype>

namespace pano {

namespace {

bool ShellSafe(char c) {
  return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.' || c == '/' ||
         c == ',' || c == ':' || c == '=' || c == '+' || c == '@' || c == '%';
}

}  // namespace

std::string ShellQuote(const std::string& arg) {
  bool safe = !arg.empty();
  for (char c : arg) safe = safe && ShellSafe(c);
  if (safe) return arg;
  std::string out = "'";
  for (char c : arg) {
    if (c == '\'') out += "'\\''";
    else out += c;
  }
  return out + "'";
}

std::string ShellCommandLine(const std::vector<std::string>& args) {
  std::string line;
  for (const std::string& arg : args) {
    if (!line.empty()) line += ' ';
    line += ShellQuote(arg);
  }
  return line;
}

}  // namespace pano
