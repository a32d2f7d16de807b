// How a subcommand joins the `pvdfkit` command: each app/src/cmd_*.cpp registers itself with
// PVDF_COMMAND, so modules add commands without editing main.cpp.
#pragma once

#include <CLI/CLI.hpp>

#include <functional>
#include <string>
#include <vector>

namespace pvdf::app {

/// What `setup` returns: the subcommand it added, and the function that runs it after
/// parsing (returning the process exit code).
struct Subcommand {
  CLI::App* app = nullptr;
  std::function<int()> run;
};

/// A subcommand: `setup` adds it (with its flags and `--help`) to the root app.
struct Command {
  int order;  ///< position in `pvdfkit --help`
  std::function<Subcommand(CLI::App& root)> setup;
};

/// All registered commands (filled during static initialization, read-only afterwards).
std::vector<Command>& commands();

struct CommandRegistrar {
  CommandRegistrar(int order, std::function<Subcommand(CLI::App&)> setup) {
    commands().push_back(Command{order, std::move(setup)});
  }
};

/// Prints a warning line on stderr ("warning: ...").
void warn(const std::string& message);

}  // namespace pvdf::app

#define PVDF_COMMAND_CAT2(a, b) a##b
#define PVDF_COMMAND_CAT(a, b) PVDF_COMMAND_CAT2(a, b)
/// Registers a subcommand:
///   PVDF_COMMAND(10, [](CLI::App& root) {
///     auto* sub = root.add_subcommand("name", "what it does");
///     auto opts = std::make_shared<Options>(); sub->add_option(...);
///     return pvdf::app::Subcommand{sub, [opts] { return run(*opts); }};
///   });
#define PVDF_COMMAND(order, ...) \
  static const ::pvdf::app::CommandRegistrar PVDF_COMMAND_CAT(pvdf_command_registrar_, __LINE__)(order, __VA_ARGS__)
