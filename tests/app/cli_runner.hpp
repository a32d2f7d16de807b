// Runs the pvdfkit executable from a test and captures exit code, stdout and stderr.
#pragma once

#include <array>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <sys/wait.h>

namespace pvdf::test {

struct CliResult {
  int exit_code = -1;
  std::string out, err;
};

/// Runs `pvdfkit <args>` through the shell (args are passed verbatim), stdin from /dev/null.
inline CliResult run_pvdfkit(const std::string& args) {
  namespace fs = std::filesystem;
  static int counter = 0;
  const fs::path dir = fs::temp_directory_path();
  const std::string tag = std::to_string(::getpid()) + "_" + std::to_string(counter++);
  const fs::path out = dir / ("pvdf_cli_out_" + tag), err = dir / ("pvdf_cli_err_" + tag);
  const std::string cmd = std::string("'") + PVDFKIT_EXE + "' " + args + " </dev/null >'" + out.string() + "' 2>'" +
                          err.string() + "'";
  const int status = std::system(cmd.c_str());
  CliResult r;
  if (WIFEXITED(status)) r.exit_code = WEXITSTATUS(status);
  else if (WIFSIGNALED(status)) r.exit_code = 128 + WTERMSIG(status);
  auto slurp = [](const fs::path& p) {
    std::ifstream in(p);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
  };
  r.out = slurp(out);
  r.err = slurp(err);
  fs::remove(out);
  fs::remove(err);
  return r;
}

/// Number of lines in a string (a trailing newline does not start a new line).
inline std::size_t line_count(const std::string& s) {
  std::size_t n = 0;
  for (char c : s) n += (c == '\n');
  if (!s.empty() && s.back() != '\n') ++n;
  return n;
}

}  // namespace pvdf::test
