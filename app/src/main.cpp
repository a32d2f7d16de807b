// pvdfkit: the command line. Parses flags with CLI11, runs one subcommand, and turns every
// outcome into an exit code: 0 success, 2 bad input or usage (also: standard output could not be
// written), 3 numerical failure. Nothing escapes as an uncaught exception or abort; messages
// never carry raw control bytes.
#include "command.hpp"

#include "pvdf/core/error.hpp"
#include "pvdf/core/io.hpp"
#include "pvdf/core/scene_geometry.hpp"
#include "pvdf/version.hpp"

#include <algorithm>
#include <cctype>
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
#include <utility>

#include <fcntl.h>
#include <poll.h>
#include <sys/file.h>
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

/// Validator names that mark an option as an output (file or folder): after parsing, main finds
/// the outputs by them and checks them against the command's inputs and against each other.
const char* const output_file_validator = "pvdf-output-file";
const char* const output_folder_validator = "pvdf-output-folder";

/// The command's input files (every option value naming an existing regular file that is not an
/// output), recorded once after parsing for check_output_file's paths derived later.
std::vector<NamedPath>& recorded_inputs() {
  static std::vector<NamedPath> inputs;
  return inputs;
}

bool has_validator(CLI::Option* opt, const char* name) {
  try {
    opt->get_validator(name);
    return true;
  } catch (const CLI::OptionNotFound&) {
    return false;
  }
}

std::string flag_name(const CLI::Option* opt) {
  const std::string name = opt->get_name(false, false);
  return name.empty() ? opt->get_name(true, false) : name;
}

/// Same file: the same inode when both exist (symbolic and hard links included), else the same
/// absolute path after resolving its folder.
bool same_file(const std::string& a, const std::string& b) {
  struct stat sa {}, sb {};
  const bool ea = ::stat(a.c_str(), &sa) == 0, eb = ::stat(b.c_str(), &sb) == 0;
  if (ea && eb) return sa.st_dev == sb.st_dev && sa.st_ino == sb.st_ino;
  if (ea != eb) return false;
  std::error_code ec;
  namespace fs = std::filesystem;
  const fs::path ca = fs::weakly_canonical(fs::absolute(a), ec), cb = fs::weakly_canonical(fs::absolute(b), ec);
  return !ec && ca == cb;
}

bool is_regular_file(const std::string& path) {
  struct stat st {};
  return ::stat(path.c_str(), &st) == 0 && S_ISREG(st.st_mode);
}

/// Throws when `output` is one of `inputs`: writing it would destroy the input.
void check_not_an_input(const NamedPath& output, const std::vector<NamedPath>& inputs) {
  for (const NamedPath& in : inputs) {
    if (same_file(output.path, in.path)) {
      throw InputError(output.flag + ": " + quote_cell(output.path) + " is the input " + in.flag + " (" +
                       quote_cell(in.path) + "); writing it would destroy that input: choose another output name");
    }
  }
}

/// Every option value of `app` and its parsed subcommands, sorted into outputs and input files.
void collect_paths(CLI::App* app, std::vector<NamedPath>& outputs, std::vector<NamedPath>& inputs) {
  for (CLI::Option* opt : app->get_options()) {
    if (opt->count() == 0) continue;
    const bool is_output = has_validator(opt, output_file_validator);
    if (has_validator(opt, output_folder_validator)) continue;
    for (const std::string& value : opt->results()) {
      if (is_output) {
        outputs.push_back({flag_name(opt), value});
      } else if (is_regular_file(value)) {
        inputs.push_back({flag_name(opt), value});
      }
    }
  }
  for (CLI::App* sub : app->get_subcommands()) collect_paths(sub, outputs, inputs);
}

/// An option that takes a value refuses an empty one (`--seed ''`, `--params=`): CLI11 would
/// otherwise leave the default in place and the user's intent silently unmet (issue 30).
void check_no_empty_values(CLI::App* app) {
  for (CLI::Option* opt : app->get_options()) {
    if (opt->count() == 0 || opt->get_expected_min() == 0 || opt->get_positional()) continue;
    for (const std::string& value : opt->results()) {
      if (value.empty()) {
        throw InputError(flag_name(opt) + " is given an empty value ''; give a value (see --help) or leave the option out");
      }
    }
  }
  for (CLI::App* sub : app->get_subcommands()) check_no_empty_values(sub);
}

}  // namespace

void check_outputs_against_inputs(CLI::App* app) {
  check_no_empty_values(app);
  std::vector<NamedPath> outputs, inputs;
  collect_paths(app, outputs, inputs);
  for (std::size_t i = 0; i < outputs.size(); ++i) {
    check_not_an_input(outputs[i], inputs);
    for (std::size_t j = 0; j < i; ++j) {
      if (same_file(outputs[i].path, outputs[j].path)) {
        throw InputError(outputs[i].flag + ": " + quote_cell(outputs[i].path) + " is also the output " + outputs[j].flag +
                         "; one would overwrite the other: give them different names");
      }
    }
  }
  recorded_inputs() = inputs;
}

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

/// A file name the system cannot create (longer than a path component may be, with room for the
/// ".tmp.NNNNNN" of the atomic write) refused at parse time, not by the writer after the work.
std::string name_length_problem(const std::string& path) {
  constexpr std::size_t max_name = 200;
  const std::string name = std::filesystem::path(path).filename().string();
  if (name.size() <= max_name && path.size() < 3800) return "";
  return quote_cell(path) + " has a file name of " + std::to_string(name.size()) + " characters; give one of at most " +
         std::to_string(max_name);
}

CLI::Validator output_file() {
  return CLI::Validator(
             [](std::string& path) -> std::string {
               if (const std::string too_long = name_length_problem(path); !too_long.empty()) return too_long;
               const std::string problem = output_path_problem(path);
               return problem.empty() ? "" : quote_cell(path) + " " + problem;
             },
             "FILE")
      .name(output_file_validator);
}

CLI::Validator figure_file() {
  return CLI::Validator(
             [](std::string& path) -> std::string {
               if (const std::string too_long = name_length_problem(path); !too_long.empty()) return too_long;
               const std::string problem = output_path_problem(path);
               if (!problem.empty()) return quote_cell(path) + " " + problem;
               std::string ext = std::filesystem::path(path).extension().string();
               std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
               if (ext == ".png" || ext == ".svg" || ext == ".pdf") return "";
               return quote_cell(path) + ": figure format '" + (ext.empty() ? std::string("(no extension)") : quote_cell(ext)) +
                      "' is not supported; end the file name in .png, .svg or .pdf";
             },
             "FILE.png|.svg|.pdf")
      .name(output_file_validator);
}

CLI::Validator output_folder() {
  return CLI::Validator(
             [](std::string& path) -> std::string {
               namespace fs = std::filesystem;
               if (const std::string too_long = name_length_problem(path); !too_long.empty()) return too_long;
               struct stat st {};
               if (::lstat(path.c_str(), &st) == 0 && S_ISLNK(st.st_mode)) {
                 return quote_cell(path) + " is a symbolic link; give the folder's real path";
               }
               std::error_code ec;
               if (fs::is_directory(path, ec)) {
                 return ::access(path.c_str(), W_OK) == 0 ? "" : quote_cell(path) + " is a folder that is not writable";
               }
               if (fs::exists(path, ec)) return quote_cell(path) + " is a file, not a folder; choose a folder name";
               const std::string problem = output_path_problem(path);
               return problem.empty() ? "" : quote_cell(path) + " " + problem;
             },
             "DIR")
      .name(output_folder_validator);
}

void check_output_file(const std::string& path, const std::string& flag) {
  check_output_path(path, flag);
  check_not_an_input({flag, path}, recorded_inputs());
}

std::vector<double> parse_force_levels(const std::string& text, const std::string& flag) {
  std::vector<double> forces = parse_number_list(text, flag);
  std::size_t index = 0;
  const std::string problem = pvdf::force_levels_problem(forces, index);  // the rule Python applies too
  if (!problem.empty()) throw InputError(flag + " " + quote_cell(text) + ": " + problem);
  return forces;
}

OutputLock::OutputLock(const std::string& path, const std::string& flag) : lock_path_(path + ".lock") {
  // The lock file may be unlinked by its previous holder between our open and flock: then the
  // lock we hold is on a file no one else can find, so open again until the path is ours.
  for (int attempt = 0; attempt < 100; ++attempt) {
    // O_NOFOLLOW, and a regular file only: the lock file is truncated once held, so it must never
    // be a link to (or a device standing for) something else.
    fd_ = ::open(lock_path_.c_str(), O_RDWR | O_CREAT | O_CLOEXEC | O_NOFOLLOW, 0644);
    if (fd_ < 0) {
      throw InputError(flag + ": cannot create the lock file " + quote_cell(lock_path_) + " (" + std::strerror(errno) +
                       "); remove it if it is a link, or choose a writable folder");
    }
    struct stat kind {};
    if (::fstat(fd_, &kind) != 0 || !S_ISREG(kind.st_mode)) {
      ::close(fd_);
      fd_ = -1;
      throw InputError(flag + ": the lock file " + quote_cell(lock_path_) + " is not a regular file; remove it");
    }
    if (::flock(fd_, LOCK_EX | LOCK_NB) != 0) {
      const int why = errno;
      char holder[32] = {0};
      const ssize_t n = ::pread(fd_, holder, sizeof holder - 1, 0);
      ::close(fd_);
      fd_ = -1;
      if (why == EWOULDBLOCK) {
        std::string pid = n > 0 ? std::string(holder, static_cast<std::size_t>(n)) : std::string("?");
        pid.erase(std::remove_if(pid.begin(), pid.end(), [](char c) { return c < '0' || c > '9'; }), pid.end());
        throw InputError(flag + ": " + quote_cell(path) + " is being written by another pvdfkit (process " +
                         (pid.empty() ? std::string("?") : pid) + " holds " + quote_cell(lock_path_) +
                         "); wait for it to finish or choose another output");
      }
      throw InputError(flag + ": cannot lock " + quote_cell(lock_path_) + " (" + std::strerror(why) + ")");
    }
    struct stat held {}, now {};
    if (::fstat(fd_, &held) == 0 && ::stat(lock_path_.c_str(), &now) == 0 && held.st_ino == now.st_ino &&
        held.st_dev == now.st_dev) {
      const std::string pid = std::to_string(::getpid()) + "\n";
      if (::ftruncate(fd_, 0) == 0 && ::pwrite(fd_, pid.data(), pid.size(), 0) < 0) {
        // The pid is only for the other process's message; the lock holds without it.
      }
      return;
    }
    ::close(fd_);
    fd_ = -1;
  }
  throw InputError(flag + ": could not take the lock " + quote_cell(lock_path_) + "; another process keeps replacing it");
}

OutputLock::~OutputLock() {
  if (fd_ < 0) return;
  ::unlink(lock_path_.c_str());  // while still held: a waiting opener sees the path vanish and retries
  ::close(fd_);
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

// The command line's deepest command that was given ("pvdfkit restore scan"), and its app.
std::pair<std::string, const CLI::App*> given_command(const CLI::App& root) {
  std::string command = "pvdfkit";
  const CLI::App* given = &root;
  for (bool deeper = true; deeper;) {
    deeper = false;
    for (const auto* sub : given->get_subcommands([](const CLI::App*) { return true; }))
      if (sub->parsed()) {
        command += " " + sub->get_name();
        given = sub;
        deeper = true;
        break;
      }
  }
  return {command, given};
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
    return finish_stdout(root.exit(e));
  } catch (const CLI::CallForAllHelp& e) {
    return finish_stdout(root.exit(e));
  } catch (const CLI::CallForVersion& e) {
    return finish_stdout(root.exit(e));
  } catch (const CLI::ExtrasError&) {
    // CLI11 lists the arguments it did not expect last first ("1 --threads"): name them in the
    // order typed, with the command they were given to and where its options are listed.
    std::vector<std::string> extras = root.remaining(true), typed;
    for (int i = 1; i < argc; ++i) {
      const auto it = std::find(extras.begin(), extras.end(), std::string(argv[i]));
      if (it == extras.end()) continue;
      typed.push_back(*it);
      extras.erase(it);
    }
    typed.insert(typed.end(), extras.begin(), extras.end());
    const auto [command, given] = given_command(root);
    std::string list, guess;
    for (const auto& t : typed) {
      list += (list.empty() ? "" : " ") + (t.find(' ') == std::string::npos ? pvdf::quote_cell(t) : "'" + pvdf::quote_cell(t) + "'");
      // An option typed short of its name (--spacing for --spacing-m): name the ones it begins.
      if (t.size() > 2 && t.compare(0, 2, "--") == 0 && guess.empty()) {
        for (const auto* opt : given->get_options())
          for (const auto& name : opt->get_lnames())
            if (name.compare(0, t.size() - 2, t, 2) == 0) guess += (guess.empty() ? "" : " or ") + ("--" + name);
        if (!guess.empty()) guess = " (" + t + " is short for " + guess + "?)";
      }
    }
    return fail(pvdf::exit_code::bad_input, "'" + command + "' does not take " + list +
                                                ": not one of its options or arguments" + guess + "; run '" + command +
                                                " --help' for those it takes");
  } catch (const CLI::RequiredError& e) {
    // Name the command that lacks something ("A subcommand is required" alone does not say whose).
    const auto [command, given] = given_command(root);
    std::string what = e.what();
    if (what.find("subcommand") != std::string::npos) {
      std::string names;
      for (const auto* sub : given->get_subcommands([](const CLI::App* a) { return !a->get_group().empty(); }))
        names += (names.empty() ? "" : ", ") + sub->get_name();
      what = "'" + command + "' needs a command first: one of " + names;
      const std::vector<std::string> extras = root.remaining(true);
      for (int i = 1; i < argc; ++i)  // the first typed of those CLI11 did not take
        if (std::find(extras.begin(), extras.end(), std::string(argv[i])) != extras.end()) {
          what += " (" + pvdf::quote_cell(argv[i]) + " is not one of them)";
          break;
        }
    } else {
      what = "'" + command + "': " + what;
    }
    return fail(pvdf::exit_code::bad_input, what + "; run '" + command + " --help'");
  } catch (const CLI::ParseError& e) {
    std::string what = e.what();
    if (what.empty()) what = e.get_name();
    // A single-value flag given twice: CLI11 says "--start: At Most 1 required but received 2".
    const std::string at_most = ": At Most 1 required but received ";
    const auto at = what.find(at_most);
    if (at != std::string::npos) {
      what = what.substr(0, at) + " is given " + what.substr(at + at_most.size()) +
             " times; it takes one value: give it once";
    }
    return fail(pvdf::exit_code::bad_input, what + "; run 'pvdfkit --help' or 'pvdfkit COMMAND --help'");
  }
  for (auto& sub : runners) {
    if (sub.app == nullptr || !sub.app->parsed()) continue;
    // Before any work: no output may be an input or another output of the same command.
    pvdf::app::check_outputs_against_inputs(sub.app);
    return finish_stdout(sub.run());
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
