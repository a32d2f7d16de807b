// pvdfkit: the command line. Parses flags with CLI11, runs one subcommand, and turns every
// outcome into an exit code: 0 success, 2 bad input or usage (also: standard output could not be
// written), 3 numerical failure. Nothing escapes as an uncaught exception or abort; messages
// never carry raw control bytes.
#include "command.hpp"

#include "pvdf/core/error.hpp"
#include "pvdf/core/io.hpp"
#include "pvdf/version.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <filesystem>
#include <iostream>
#include <new>

#include <poll.h>
#include <sys/stat.h>
#include <unistd.h>

namespace pvdf::app {

std::vector<Command>& commands() {
  static std::vector<Command> list;
  return list;
}

void warn(const std::string& message) { std::cerr << "warning: " << escape_control_bytes(message) << '\n'; }

namespace {

std::string range_text(double lo, double hi, bool lo_open) {
  return std::string(lo_open ? "(" : "[") + format_g(lo) + ", " + format_g(hi) + "]";
}

/// Why `path` cannot be an output file, or "".
std::string output_file_problem(const std::string& path) {
  namespace fs = std::filesystem;
  if (path.empty()) return "is empty; give a file name";
  std::error_code ec;
  if (fs::is_directory(path, ec)) return "is a folder; give a file name";
  const fs::path parent = fs::path(path).parent_path();
  const fs::path folder = parent.empty() ? fs::path(".") : parent;
  if (!fs::is_directory(folder, ec)) {
    return "cannot be written: folder " + folder.string() + " does not exist; create it or choose another path";
  }
  if (::access(folder.c_str(), W_OK) != 0) return "cannot be written: folder " + folder.string() + " is not writable";
  return "";
}

}  // namespace

CLI::Validator number_in(double lo, double hi, const std::string& why, bool lo_open) {
  const std::string desc = "in " + range_text(lo, hi, lo_open);
  return CLI::Validator(
      [lo, hi, why, lo_open](std::string& text) -> std::string {
        double x = 0;
        if (!parse_finite(text, x)) return escape_control_bytes(text) + " is not a finite number";
        if ((lo_open ? x > lo : x >= lo) && x <= hi) return "";
        return format_g(x) + " must lie in " + range_text(lo, hi, lo_open) + (why.empty() ? "" : " " + why);
      },
      desc);
}

CLI::Validator integer_in(long long lo, long long hi, const std::string& why) {
  const std::string desc = "in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]";
  return CLI::Validator(
      [lo, hi, why](std::string& text) -> std::string {
        char* end = nullptr;
        errno = 0;
        const long long x = std::strtoll(text.c_str(), &end, 10);
        if (text.empty() || *end != '\0' || errno == ERANGE) return escape_control_bytes(text) + " is not a whole number";
        if (x >= lo && x <= hi) return "";
        return std::to_string(x) + " must lie in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]" +
               (why.empty() ? "" : " " + why);
      },
      desc);
}

CLI::Validator output_file() {
  return CLI::Validator(
      [](std::string& path) -> std::string {
        const std::string problem = output_file_problem(path);
        return problem.empty() ? "" : escape_control_bytes(path) + " " + problem;
      },
      "FILE");
}

CLI::Validator output_folder() {
  return CLI::Validator(
      [](std::string& path) -> std::string {
        namespace fs = std::filesystem;
        std::error_code ec;
        if (fs::is_directory(path, ec)) {
          return ::access(path.c_str(), W_OK) == 0 ? "" : escape_control_bytes(path) + " is a folder that is not writable";
        }
        if (fs::exists(path, ec)) return escape_control_bytes(path) + " is a file, not a folder; choose a folder name";
        const std::string problem = output_file_problem(path);
        return problem.empty() ? "" : escape_control_bytes(path) + " " + problem;
      },
      "DIR");
}

void check_output_file(const std::string& path, const std::string& flag) {
  const std::string problem = output_file_problem(path);
  if (!problem.empty()) throw InputError(flag + ": " + escape_control_bytes(path) + " " + problem);
}

}  // namespace pvdf::app

namespace {

int fail(int code, const std::string& message) {
  std::cerr << "error: " << pvdf::escape_control_bytes(message) << '\n';
  return code;
}

/// True when standard output is a pipe whose reader has gone (`pvdfkit ... | head -2`).
bool stdout_reader_gone(int write_errno) {
  if (write_errno == EPIPE) return true;
  struct stat st {};
  if (::fstat(STDOUT_FILENO, &st) != 0 || !S_ISFIFO(st.st_mode)) return false;
  pollfd p{STDOUT_FILENO, POLLOUT, 0};
  return ::poll(&p, 1, 0) == 1 && (p.revents & POLLERR) != 0;
}

/// Flushes standard output and turns a write error into exit 2: a result that did not reach
/// its reader is not a success. A closed pipe ends the run quietly (the reader asked for less).
int finish_stdout(int code) {
  errno = 0;
  std::cout.flush();  // synced with stdio: this is where buffered output is written
  const bool flush_failed = std::fflush(stdout) != 0;
  const int write_errno = errno;
  if (!flush_failed && !std::ferror(stdout) && !std::cout.bad()) return code;
  if (code != pvdf::exit_code::success) return code;
  if (stdout_reader_gone(write_errno)) return pvdf::exit_code::bad_input;
  const std::string why = write_errno != 0 ? std::strerror(write_errno) : "write error";
  return fail(pvdf::exit_code::bad_input, "stdout: writing the output failed (" + why +
                                              "); it is incomplete: check the disk space or the redirection");
}

/// The registered subcommand names, for the "unknown command" message.
std::string command_list(const CLI::App& root) {
  std::string out;
  for (const auto* sub : root.get_subcommands([](const CLI::App* a) { return !a->get_group().empty(); })) {
    out += (out.empty() ? "" : ", ") + sub->get_name();
  }
  return out;
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

  if (argc < 2) {
    return fail(pvdf::exit_code::bad_input, "no command given; the commands are: " + command_list(root) +
                                                " (run 'pvdfkit --help')");
  }
  if (argv[1][0] != '-') {
    const std::string name = argv[1];
    bool known = false;
    for (const auto* sub : root.get_subcommands([](const CLI::App*) { return true; })) known = known || sub->check_name(name);
    if (!known) {
      return fail(pvdf::exit_code::bad_input, "unknown command '" + name + "'; the commands are: " +
                                                  command_list(root) + " (run 'pvdfkit --help')");
    }
  }
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
    if (sub.app != nullptr && sub.app->parsed()) return finish_stdout(sub.run());
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
