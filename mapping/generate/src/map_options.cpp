// The names of MapOptions' choices (pvdf/mapping/generate.hpp): one table per enum, read by the
// command line, the checkpoint hash and the error messages alike.
#include "pvdf/core/error.hpp"
#include "pvdf/core/io.hpp"
#include "pvdf/mapping/generate.hpp"

#include <array>
#include <string>
#include <utility>

namespace pvdf::mapping {
namespace {

template <typename E, std::size_t N>
std::string name_of(const std::array<std::pair<E, const char*>, N>& table, E value) {
  for (const auto& [v, n] : table)
    if (v == value) return n;
  return "?";
}

template <typename E, std::size_t N>
E parse(const std::array<std::pair<E, const char*>, N>& table, const std::string& text, const std::string& flag) {
  std::string choices;
  for (std::size_t k = 0; k < N; ++k) {
    if (text == table[k].second) return table[k].first;
    choices += (k == 0 ? "" : k + 1 == N ? " or " : ", ") + std::string(table[k].second);
  }
  throw InputError(flag + " " + escape_control_bytes(text) + ": use " + choices);
}

const std::array<std::pair<RimModel, const char*>, 3> rim_names{
    {{RimModel::by_estimate, "by-estimate"}, {RimModel::never, "never"}, {RimModel::always, "always"}}};
const std::array<std::pair<DirectSolves, const char*>, 2> direct_names{
    {{DirectSolves::by_estimate, "by-estimate"}, {DirectSolves::never, "never"}}};
const std::array<std::pair<ProbeRefinement, const char*>, 2> probe_names{
    {{ProbeRefinement::footprint, "footprint"}, {ProbeRefinement::none, "none"}}};

}  // namespace

std::string option_name(RimModel value) { return name_of(rim_names, value); }
std::string option_name(DirectSolves value) { return name_of(direct_names, value); }
std::string option_name(ProbeRefinement value) { return name_of(probe_names, value); }

RimModel parse_rim_model(const std::string& text, const std::string& flag) { return parse(rim_names, text, flag); }
DirectSolves parse_direct_solves(const std::string& text, const std::string& flag) {
  return parse(direct_names, text, flag);
}
ProbeRefinement parse_probe_refinement(const std::string& text, const std::string& flag) {
  return parse(probe_names, text, flag);
}

}  // namespace pvdf::mapping
