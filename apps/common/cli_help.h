// The programs' shared help layout (CLI11): long descriptions wrapped, and
// each subcommand's description split into the one line its parent lists and
// the rest at the foot of its own help, above the exit codes.
#pragma once

#include <CLI/CLI.hpp>

#include <sstream>
#include <string>

namespace pano::app {

// `text` broken into lines of at most `width` characters at spaces.
inline std::string Wrapped(const std::string& text, size_t width = 96) {
  std::string out, line;
  std::istringstream words(text);
  for (std::string w; words >> w;) {
    if (!line.empty() && line.size() + 1 + w.size() > width) out += line + "\n", line.clear();
    line += (line.empty() ? "" : " ") + w;
  }
  return out + line;
}

inline void SplitDescriptions(CLI::App& app, const std::string& exit_codes) {
  for (CLI::App* sub : app.get_subcommands({})) {
    const std::string d = sub->get_description();
    const size_t end = d.find(". ");
    if (end == std::string::npos) {
      sub->footer(exit_codes);
      continue;
    }
    sub->description(d.substr(0, end + 1));
    sub->footer(Wrapped(d.substr(end + 2)) + "\n\n" + exit_codes);
  }
}

}  // namespace pano::app
