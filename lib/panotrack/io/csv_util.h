// Small pieces of the toolkit's CSV readers (pose CSV, odometry CSV).
#pragma once

#include <string>
#include <vector>

namespace pano {

// The comma-separated fields of one line (a trailing '\r' dropped; no quoting:
// the toolkit's CSVs hold numbers and single words).
std::vector<std::string> SplitCsv(const std::string& line);

// `text` as a one-line message may quote it: printable ASCII as it is, any
// other byte as \xNN (a binary file's control characters and line breaks
// would break the message or the terminal), at most 60 characters then
// "...".
std::string QuotedText(const std::string& text);

// A finite number, or pano::Error "<where>: column <column>: expected a
// finite number, got '<s>'".
double ParseCsvDouble(const std::string& s, const std::string& where, const char* column);

}  // namespace pano
