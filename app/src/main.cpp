// pvdfkit: the command line. Parses flags with CLI11, runs one subcommand, and turns every
// outcome into an exit code: 0 success, 2 bad input or usage, 3 numerical failure. Nothing
// escapes as an uncaught exception or abort.
#include "command.hpp"

#include "pvdf/core/error.hpp"
#include "pvdf/version.hpp"

#include <algorithm>
#include <csignal>
#include <cstdio>
#include <exception>
#include <iostream>
#include <new>

namespace pvdf::app {

std::vector<Command>& commands() {
  static std::vector<Command> list;
  return list;
}

void warn(const std::string& message) { std::cerr << "warning: " << message << '\n'; }

}  // namespace pvdf::app

namespace {

int fail(int code, const std::string& message) {
  std::cerr << "error: " << message << '\n';
  return code;
}

int run(int argc, char** argv) {
  CLI::App root{
      "pvdfkit " + std::string(pvdf::version_string) +
      " - finite-element prediction, mapping and lookup for PVDF piezoelectric tactile sensors"};
  root.set_version_flag("--version", std::string("pvdfkit ") + pvdf::version_string);
  root.require_subcommand(1);
  root.fallthrough(false);

  auto list = pvdf::app::commands();
  std::sort(list.begin(), list.end(), [](const auto& a, const auto& b) { return a.order < b.order; });
  std::vector<pvdf::app::Subcommand> runners;
  for (const auto& c : list) runners.push_back(c.setup(root));

  try {
    root.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return root.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return root.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return root.exit(e);
  } catch (const CLI::ParseError& e) {
    std::string what = e.what();
    if (what.empty()) what = e.get_name();
    return fail(pvdf::exit_code::bad_input, what + "; run 'pvdfkit --help' or 'pvdfkit COMMAND --help'");
  }
  for (auto& sub : runners) {
    if (sub.app != nullptr && sub.app->parsed()) return sub.run();
  }
  return fail(pvdf::exit_code::bad_input, "no command given; run 'pvdfkit --help'");
}

}  // namespace

int main(int argc, char** argv) {
  std::signal(SIGPIPE, SIG_IGN);
  try {
    return run(argc, argv);
  } catch (const pvdf::InputError& e) {
    return fail(pvdf::exit_code::bad_input, e.what());
  } catch (const pvdf::NumericalError& e) {
    return fail(pvdf::exit_code::numerical, e.what());
  } catch (const std::bad_alloc&) {
    return fail(pvdf::exit_code::numerical, "out of memory; use a coarser mesh or a smaller map");
  } catch (const std::exception& e) {
    return fail(pvdf::exit_code::internal, std::string("internal error (please report): ") + e.what());
  } catch (...) {
    return fail(pvdf::exit_code::internal, "internal error (please report): unknown exception");
  }
}
