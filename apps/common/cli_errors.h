// CLI11's parse errors in the programs' one-line form: "tool: --flag: problem".
// CLI11 prints two lines without the tool's name, "Could not convert" for a
// value it cannot read, and the bounds of its range validators with "%f"
// (308 digits for the largest double); these rewrite its messages so that
// each names the flag, says what was expected, and shows the text typed.
#pragma once

#include <CLI/CLI.hpp>

#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

namespace pano::app {

namespace cli_errors_internal {

// The option called `name` (as CLI11's messages name it: "--init", "-j",
// a positional's name) in `app` or its subcommands, those given first.
inline const CLI::Option* FindOption(const CLI::App& app, const std::string& name) {
  for (const CLI::App* sub : app.get_subcommands())
    if (const CLI::Option* o = FindOption(*sub, name)) return o;
  for (const CLI::Option* o : app.get_options())
    if (o->check_name(name)) return o;
  for (const CLI::App* sub : app.get_subcommands({}))
    for (const CLI::Option* o : sub->get_options())
      if (o->check_name(name)) return o;
  return nullptr;
}

inline std::string Lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

inline std::string Upper(std::string s) {
  for (char& c : s) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return s;
}

// What `count` values of `option` are, in words: "a number", "3 numbers
// x,y,theta" (a list option whose type name is its form, X,Y,THETA).
inline std::string Noun(const CLI::Option* option, int count) {
  // The type name before the validators' descriptions ("FLOAT:POSITIVE").
  std::string type = option ? option->get_type_name() : "";
  type = type.substr(0, type.find(':'));
  const std::string n = std::to_string(count);
  if (type.find(',') != std::string::npos) return n + " numbers " + Lower(type);
  const bool one = count == 1;
  if (type == "FLOAT" || type == "NUMBER") return one ? "a number" : n + " numbers";
  if (type == "INT" || type == "UINT") return one ? "an integer" : n + " integers";
  return one ? "a value" : n + " values";
}

// A bound of a CLI11 range validator as a person writes it.
inline std::string Bound(double v) {
  char text[32];
  std::snprintf(text, sizeof(text), "%g", v);
  return text;
}

// "Value TEXT not in range LO to HI" (CLI::Range, PositiveNumber,
// NonNegativeNumber; of `option`) as what the flag expects; other messages
// unchanged.
inline std::string RangeMessage(const std::string& message, const CLI::Option* option) {
  static const std::regex range("Value (.*) not in range (\\S+) to (\\S+)");
  std::smatch m;
  if (!std::regex_match(message, m, range)) return message;
  const double lo = std::strtod(m[2].str().c_str(), nullptr);
  const double hi = std::strtod(m[3].str().c_str(), nullptr);
  const std::string got = ", got " + m[1].str();
  const bool unbounded = hi >= std::numeric_limits<double>::max() / 2;
  // PositiveNumber's lower bound, the smallest normal double, reads as 0: its
  // name among the option's validators tells it from NonNegativeNumber.
  const bool positive = option && option->get_type_name().find(":POSITIVE") != std::string::npos;
  if (unbounded && positive) return "expected a positive number" + got;
  if (unbounded) return "expected " + Bound(lo) + " or more" + got;
  return "expected a value from " + Bound(lo) + " to " + Bound(hi) + got;
}

// The subcommands of `app`, for a message: "check, refine, build".
inline std::string SubcommandNames(const CLI::App& app) {
  std::string names;
  for (const CLI::App* sub : app.get_subcommands({})) names += (names.empty() ? "" : ", ") + sub->get_name();
  return names;
}

// A message "NAME: REST" split at its first ": ".
inline bool SplitName(const std::string& message, std::string* name, std::string* rest) {
  const size_t colon = message.find(": ");
  if (colon == std::string::npos) return false;
  *name = message.substr(0, colon);
  *rest = message.substr(colon + 2);
  return true;
}

inline std::string ArgumentMismatchMessage(const CLI::App& app, const std::string& message) {
  static const std::regex count("(.*): At (least|Most) (\\d+) required but received (\\d+)");
  static const std::regex missing("(.*): (\\d+) required (.*) missing");
  static const std::regex exact("Expected (exactly|at least) (\\d+) arguments to (.*), got (\\d+)");
  std::smatch m;
  if (std::regex_match(message, m, count)) {
    const CLI::Option* o = FindOption(app, m[1]);
    return m[1].str() + ": expected " + Noun(o, std::stoi(m[3])) + ", got " + m[4].str();
  }
  if (std::regex_match(message, m, missing))
    return m[1].str() + ": expected " + Noun(FindOption(app, m[1]), std::stoi(m[2])) + ", got none";
  if (std::regex_match(message, m, exact)) {
    const std::string least = m[1] == "at least" ? "at least " : "";
    return m[3].str() + ": expected " + least + Noun(FindOption(app, m[3]), std::stoi(m[2])) + ", got " +
           m[4].str();
  }
  return message;
}

inline std::string ConversionMessage(const CLI::App& app, const std::string& message) {
  static const std::regex could_not("Could not convert: (.*) = (.*)");
  static const std::regex not_allowed("The value (.*) is not an allowed value for (.*)");
  static const std::regex integer("[+-]?[0-9]+");
  std::smatch m;
  if (std::regex_match(message, m, could_not)) {
    const CLI::Option* o = FindOption(app, m[1]);
    const std::string text = m[2];
    // An integer too long for the option's type reads as a failed conversion.
    if (std::regex_match(text, integer)) return m[1].str() + ": " + text + " is out of range";
    const int count = o && o->get_expected_min() > 1 ? o->get_expected_min() : 1;
    return m[1].str() + ": expected " + Noun(o, count) + ", got '" + text + "'";
  }
  if (std::regex_match(message, m, not_allowed)) return m[2].str() + ": '" + m[1].str() + "' is not allowed";
  return message;
}

inline std::string ExtrasMessage(const CLI::App& app, const std::string& message, const char* tool) {
  static const std::regex extras("The following arguments? (was|were) not expected: (.*)");
  std::smatch m;
  if (!std::regex_match(message, m, extras)) return message;
  // CLI11 lists them last first.
  std::vector<std::string> words;
  std::istringstream list(m[2].str());
  for (std::string w; list >> w;) words.insert(words.begin(), w);
  const std::string first = words.empty() ? "" : words.front();
  std::string args;
  for (const std::string& w : words) args += (args.empty() ? "" : " ") + w;
  std::string command = tool;
  for (const CLI::App* sub : app.get_subcommands()) command += " " + sub->get_name();
  const std::string help = " (see " + command + " --help)";
  if (app.get_require_subcommand_min() > 0 && app.get_subcommands().empty())
    return "unknown subcommand '" + first + "' (one of: " + SubcommandNames(app) + ")";
  if (!first.empty() && first[0] == '-') return first + ": unknown option" + help;
  return "unexpected argument" + std::string(first == args ? " '" : "s '") + args + "'" + help;
}

// An unknown option among the arguments left over, as ExtrasMessage names
// it; "" when none. CLI11 checks the required options before the unknown
// ones, but a mistyped option is the likelier mistake ("--otput x": "--output
// is required").
inline std::string UnknownOptionLeft(const CLI::App& app, const char* tool) {
  for (const std::string& arg : app.remaining(true)) {
    const bool option = arg.size() > 1 && arg[0] == '-' && !std::isdigit(static_cast<unsigned char>(arg[1])) &&
                        arg[1] != '.';
    if (!option) continue;
    std::string command = tool;
    for (const CLI::App* sub : app.get_subcommands()) command += " " + sub->get_name();
    return arg.substr(0, arg.find('=')) + ": unknown option (see " + command + " --help)";
  }
  return "";
}

inline std::string RequiredMessage(const CLI::App& app, const std::string& message, const char* tool) {
  if (message == "A subcommand is required") {
    const std::vector<std::string> left = app.remaining();
    const std::string names = " (one of: " + SubcommandNames(app) + ")";
    if (!left.empty() && !left.front().empty() && left.front()[0] != '-')
      return "unknown subcommand '" + left.front() + "'" + names;
    const std::string unknown = UnknownOptionLeft(app, tool);
    return unknown.empty() ? "a subcommand is required" + names : unknown;
  }
  const std::string unknown = UnknownOptionLeft(app, tool);
  if (!unknown.empty()) return unknown;
  static const std::regex required("(.*) is required");
  std::smatch m;
  if (std::regex_match(message, m, required)) return m[1].str() + ": required";
  return message;
}

}  // namespace cli_errors_internal

// CLI11's message for `e` (a failed parse of `app`, the program `tool`) as
// one line naming the flag, without the tool's name.
inline std::string ParseErrorMessage(const CLI::App& app, const CLI::ParseError& e, const char* tool) {
  namespace in = cli_errors_internal;
  // By type: CLI11 names some errors after the app rather than their kind.
  const std::string message = e.what();
  if (dynamic_cast<const CLI::ArgumentMismatch*>(&e)) return in::ArgumentMismatchMessage(app, message);
  if (dynamic_cast<const CLI::ConversionError*>(&e)) return in::ConversionMessage(app, message);
  if (dynamic_cast<const CLI::ExtrasError*>(&e)) return in::ExtrasMessage(app, message, tool);
  if (dynamic_cast<const CLI::RequiredError*>(&e)) return in::RequiredMessage(app, message, tool);
  std::string name, rest;
  if (dynamic_cast<const CLI::ValidationError*>(&e) && in::SplitName(message, &name, &rest))
    return name + ": " + in::RangeMessage(rest, in::FindOption(app, name));
  return message;
}

// Throws CLI::ValidationError naming the flag when a number option of `app`
// or of a subcommand given was set to NaN or an infinity ("nan", "inf",
// "1e999"): no flag of the programs means anything by them, and CLI11's
// range validators let NaN through (every comparison with it is false).
// Number options are those whose type is FLOAT or NUMBER or a list form of
// numbers (X,Y,THETA); each comma-separated value is checked.
inline void RefuseNonFiniteNumbers(const CLI::App& app) {
  for (const CLI::Option* o : app.get_options()) {
    if (o->count() == 0) continue;
    std::string type = o->get_type_name();
    type = type.substr(0, type.find(':'));
    const bool number = type == "FLOAT" || type == "NUMBER" ||
                        (type.find(',') != std::string::npos && type == cli_errors_internal::Upper(type));
    if (!number) continue;
    for (const std::string& given : o->results()) {
      std::istringstream list(given);
      for (std::string value; std::getline(list, value, ',');) {
        char* end = nullptr;
        const double v = std::strtod(value.c_str(), &end);
        if (end != value.c_str() && *end == '\0' && !std::isfinite(v))
          throw CLI::ValidationError(o->get_name(), "expected a finite number, got '" + given + "'");
      }
    }
  }
  for (const CLI::App* sub : app.get_subcommands()) RefuseNonFiniteNumbers(*sub);
}

// What main() does with a failed parse: help and version printed as CLI11
// prints them (exit 0); anything else one line "tool: ..." on stderr, exit 1
// (bad options exit like bad files).
inline int ExitOnParseError(const CLI::App& app, const CLI::ParseError& e, const char* tool) {
  if (e.get_exit_code() == static_cast<int>(CLI::ExitCodes::Success)) return app.exit(e);
  std::fprintf(stderr, "%s: %s\n", tool, ParseErrorMessage(app, e, tool).c_str());
  return 1;
}

// A pose option: x,y,theta (map units, radians) as three comma-separated
// numbers in one token (a positional argument after it stays positional),
// shown as X,Y,THETA, so that its messages read "expected 3 numbers
// x,y,theta".
inline CLI::Option* AddPoseOption(CLI::App* app, const std::string& name, std::vector<double>* values,
                                  const std::string& help) {
  return app->add_option(name, *values, help)
      ->delimiter(',')
      ->allow_extra_args(false)
      ->expected(3)
      ->type_name("X,Y,THETA")
      ->default_str("");
}

}  // namespace pano::app
