// Rows of numbers in a text file (`panocalib project --points`,
// `backproject --pixels`): numbers separated by commas and/or whitespace;
// '#' starts a comment; blank lines are skipped; a first line of the
// expected field count, none of them a number, is a header and is skipped.
#pragma once

#include <cstddef>
#include <functional>
#include <string>
#include <vector>

namespace pano {

// Calls `use` with the n numbers of every data line; throws pano::Error
// "SOURCE:LINE: expected n finite numbers (what), ..." on a line that is not
// exactly n finite numbers, and on binary data (a control character), before
// `use` has seen a row of a binary file.
void ForEachNumberRow(const std::string& text, const std::string& source, size_t n, const char* what,
                      const std::function<void(const std::vector<double>&)>& use);

}  // namespace pano
