// Command-line handling shared by the example tools (gradraster-render,
// gradraster-ssr, gradraster-fit): flags take their value as the next argument or after '='
// (--width=512), every value is checked whole ("64abc" is not 64), a flag
// given twice, an unknown flag or a stray argument is an error, and every
// message starts with the flag it is about.
#pragma once

#include <cstddef>
#include <functional>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

namespace gr::cli {

// A command-line mistake: tools report it with a usage hint and exit code 2.
struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

[[noreturn]] void fail(const std::string& flag, const std::string& what);

// `text` quoted for a message (bounded and printable, raster::quote_for_message).
std::string quoted(const std::string& text);

// A finite number filling the whole string.
double parse_number(const std::string& flag, const std::string& text);
// An integer in [lo, hi] filling the whole string.
long long parse_integer(const std::string& flag, const std::string& text, long long lo, long long hi);
int parse_int(const std::string& flag, const std::string& text, int lo, int hi);

// Bytes as "N MiB", rounded up (so a small request is not shown as 0 MiB).
std::string mib(std::size_t bytes);

struct Flags {
  std::set<std::string> valued;    // flags that take a value
  std::set<std::string> switches;  // flags without a value
};

// Walks `args` (without the program name) and calls on_flag(flag, value) for
// each flag, value "" for a switch. Returns false, without calling on_flag
// any further, at --help or -h. Returns the flags seen in `seen`. Throws
// UsageError for an unknown flag, a stray argument, a flag given twice, a
// missing value (a following "--flag" is not a value; "-1,0,0" is) or a value
// given to a switch.
bool for_each_flag(const std::vector<std::string>& args, const Flags& flags,
                   const std::function<void(const std::string& flag, const std::string& value)>& on_flag,
                   std::set<std::string>& seen);

// For a program whose command line is only flags: for_each_flag over argv; at
// --help prints `usage` to stdout and exits 0, on a UsageError prints
// "program: message" and `usage` to stderr and exits 2.
void parse_flags_or_exit(const char* program, const char* usage, int argc, char** argv, const Flags& flags,
                         const std::function<void(const std::string& flag, const std::string& value)>& on_flag);

}  // namespace gr::cli
