// The command line a program was started with, as one string a POSIX shell
// reads back as the same arguments: recorded in the files the tools write so
// that a result says how it was made.
#pragma once

#include <string>
#include <vector>

namespace pano {

// Each argument as is when it is made only of characters no shell treats
// specially, otherwise in single quotes (a quote inside becomes '\'').
std::string ShellQuote(const std::string& arg);
std::string ShellCommandLine(const std::vector<std::string>& args);

}  // namespace pano
