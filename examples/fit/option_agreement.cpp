#include "examples/fit/option_agreement.h"

namespace fit {
namespace {

const char* mode_name(Mode m) { return m == Mode::Pose ? "pose" : "shape"; }

// [entries, then per entry: length, bytes..., length, bytes...] as doubles.
void encode(const std::string& text, std::vector<double>& out) {
  out.push_back(static_cast<double>(text.size()));
  for (unsigned char c : text) out.push_back(c);
}

bool decode(const std::vector<double>& in, std::size_t& at, std::string& text) {
  if (at >= in.size()) return false;
  const auto n = static_cast<std::size_t>(in[at++]);
  if (n > in.size() - at) return false;
  text.clear();
  for (std::size_t i = 0; i < n; ++i) text.push_back(static_cast<char>(in[at++]));
  return true;
}

}  // namespace

OptionList run_shaping_options(const CommandLine& cl) {
  if (cl.action == CommandLine::Action::Error)
    return {{"the command line", "the error '" + cl.error + "'"}};
  if (cl.action == CommandLine::Action::Help) return {{"the command line", "--help"}};
  const FitOptions& o = cl.options;
  const bool pose = o.mode == Mode::Pose;
  const int iterations = o.iterations > 0 ? o.iterations : pose ? kDefaultPoseIterations : kDefaultShapeIterations;
  return {{"the command line", "valid"},
          {"--mode", mode_name(o.mode)},
          {"--iterations", std::to_string(iterations)},
          {"--size", std::to_string(o.size)},
          {"--views", std::to_string(o.views)},
          {"--subdivisions", std::to_string(o.start_subdivisions)},
          {"--fit", o.appearance == Appearance::Texture ? "texture" : "colours"},
          {"--fit-camera", o.fit_camera ? "on" : "off"},
          {"--seed", std::to_string(o.seed)},
          {"--mesh", o.mesh_path.empty() ? "(built-in object)" : "'" + o.mesh_path + "'"},
          {"--texture", o.texture_path.empty() ? "(none)" : "'" + o.texture_path + "'"}};
}

std::string first_difference(const std::vector<OptionList>& per_process) {
  if (per_process.empty()) return "";
  const OptionList& root = per_process[0];
  for (std::size_t p = 1; p < per_process.size(); ++p) {
    const OptionList& other = per_process[p];
    if (other == root) continue;
    std::size_t i = 0;
    while (i < root.size() && i < other.size() && root[i] == other[i]) ++i;
    const std::string there = " on process " + std::to_string(p) + " but ";
    const std::string suffix = " on process 0; every process of an MPI job needs the same options (only --out "
                               "and --threads may differ)";
    if (i < root.size() && i < other.size() && root[i].first == other[i].first)
      return "the processes were started with different options: " + root[i].first + " is " + other[i].second +
             there + root[i].second + suffix;
    return "the processes were started with different options" + suffix;  // lists of another shape
  }
  return "";
}

std::string option_disagreement(gr::Communicator& comm, const OptionList& mine) {
  std::vector<double> encoded{static_cast<double>(mine.size())};
  for (const auto& [name, value] : mine) {
    encode(name, encoded);
    encode(value, encoded);
  }
  std::vector<double> all;
  comm.all_gather(encoded, all);
  std::vector<OptionList> lists;
  std::size_t at = 0;
  for (int p = 0; p < comm.size(); ++p) {
    OptionList list;
    const auto n = at < all.size() ? static_cast<std::size_t>(all[at++]) : 0;
    std::string name, value;
    for (std::size_t i = 0; i < n && decode(all, at, name) && decode(all, at, value); ++i) list.emplace_back(name, value);
    lists.push_back(std::move(list));
  }
  return first_difference(lists);
}

}  // namespace fit
