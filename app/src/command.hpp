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

/// Prints a warning line on stderr ("warning: ..."), control bytes escaped.
void warn(const std::string& message);

// Flag checks, applied where CLI11 parses the flag (before any work) with the same rule as the
// scene key the flag overrides. A failed check is one line `error: --flag: VALUE must ...`, exit 2.

/// A finite number in [lo, hi] (in (lo, hi] when `lo_open`); `why` ends the message.
CLI::Validator number_in(double lo, double hi, const std::string& why = "", bool lo_open = false);
/// A whole number in [lo, hi].
CLI::Validator integer_in(long long lo, long long hi, const std::string& why = "");
/// An output file: its folder exists and is writable, and the path is not a folder, a symbolic
/// link or a device (pvdf::output_path_problem). Options checked by it are the command's outputs:
/// after parsing, none may name an input file of the command or another output.
CLI::Validator output_file();
/// A figure file: as output_file, and the name ends in .png, .svg or .pdf (checked before any work).
CLI::Validator figure_file();
/// An output folder: missing (it will be created inside an existing folder) or a writable folder,
/// never an existing file.
CLI::Validator output_folder();
/// Throws InputError naming `flag` when `path` could not be written as an output file (the
/// same rule as output_file) or is one of the command's input files, for paths derived from
/// other flags (a default checkpoint, a preview beside the output).
void check_output_file(const std::string& path, const std::string& flag);

/// Force levels F1,F2,... (N) from a flag: each in [1e-9, 1e4] N (the rule of loads[].force_N)
/// and no two within a relative 1e-6 of each other (such "levels" are one level, and the map's
/// log-force axis would divide by their difference). InputError naming `flag` otherwise.
std::vector<double> parse_force_levels(const std::string& text, const std::string& flag);

/// A flag and the path it names.
struct NamedPath {
  std::string flag, path;
};
/// Run by main after parsing and before the command: refuses (InputError) an output that is an
/// input file of the command (same inode: hard and symbolic links included) or another output.
void check_outputs_against_inputs(CLI::App* app);

/// An advisory lock (flock) on PATH.lock beside an output, held for the object's life: a second
/// pvdfkit writing the same output refuses at once (InputError naming `flag` and the holder's
/// process id) instead of doing the work twice. The lock file is removed on release.
class OutputLock {
 public:
  OutputLock(const std::string& path, const std::string& flag);
  ~OutputLock();
  OutputLock(const OutputLock&) = delete;
  OutputLock& operator=(const OutputLock&) = delete;

 private:
  std::string lock_path_;
  int fd_ = -1;
};

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
