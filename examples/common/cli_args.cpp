#include "examples/common/cli_args.h"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "raster/io/files.h"

namespace gr::cli {

void fail(const std::string& flag, const std::string& what) { throw UsageError(flag + ": " + what); }

std::string quoted(const std::string& text) { return raster::quote_for_message(text); }

std::string mib(std::size_t bytes) { return std::to_string((bytes + (std::size_t(1) << 20) - 1) >> 20) + " MiB"; }

double parse_number(const std::string& flag, const std::string& text) {
  const char* begin = text.c_str();
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(begin, &end);
  if (text.empty() || end != begin + text.size() || errno == ERANGE || !std::isfinite(v))
    fail(flag, "expected a finite number, got " + quoted(text));
  return v;
}

long long parse_integer(const std::string& flag, const std::string& text, long long lo, long long hi) {
  const char* begin = text.c_str();
  char* end = nullptr;
  errno = 0;
  const long long v = std::strtoll(begin, &end, 10);
  if (text.empty() || end != begin + text.size() || errno == ERANGE)
    fail(flag, "expected an integer, got " + quoted(text));
  if (v < lo || v > hi)
    fail(flag, "must lie in " + std::to_string(lo) + ".." + std::to_string(hi) + ", got " + text);
  return v;
}

int parse_int(const std::string& flag, const std::string& text, int lo, int hi) {
  return static_cast<int>(parse_integer(flag, text, lo, hi));
}

bool for_each_flag(const std::vector<std::string>& args, const Flags& flags,
                   const std::function<void(const std::string& flag, const std::string& value)>& on_flag,
                   std::set<std::string>& seen) {
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string& arg = args[i];
    if (arg == "--help" || arg == "-h") return false;
    if (arg.rfind("--", 0) != 0 || arg.size() == 2) throw UsageError("unexpected argument " + quoted(arg));
    // --flag=value or --flag value.
    const std::size_t eq = arg.find('=');
    const std::string flag = arg.substr(0, eq);
    const bool is_switch = flags.switches.count(flag) > 0;
    if (!is_switch && !flags.valued.count(flag)) throw UsageError("unknown option " + quoted(flag));
    if (!seen.insert(flag).second) fail(flag, "given more than once");
    if (is_switch) {
      if (eq != std::string::npos) fail(flag, "takes no value");
      on_flag(flag, "");
      continue;
    }
    if (eq != std::string::npos) {
      on_flag(flag, arg.substr(eq + 1));
      continue;
    }
    // A following "--..." is the next flag, not a value; negative numbers
    // ("-1,0,0") start with a single dash and are fine.
    if (i + 1 >= args.size() || args[i + 1].rfind("--", 0) == 0) fail(flag, "missing value");
    on_flag(flag, args[++i]);
  }
  return true;
}

void parse_flags_or_exit(const char* program, const char* usage, int argc, char** argv, const Flags& flags,
                         const std::function<void(const std::string& flag, const std::string& value)>& on_flag) {
  try {
    std::set<std::string> seen;
    if (for_each_flag(std::vector<std::string>(argv + 1, argv + argc), flags, on_flag, seen)) return;
    std::fputs(usage, stdout);
    std::exit(0);
  } catch (const UsageError& e) {
    std::fprintf(stderr, "%s: %s\n\n%s", program, e.what(), usage);
    std::exit(2);
  }
}

}  // namespace gr::cli
