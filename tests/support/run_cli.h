// Runs the built `pliant` command line from a test and captures its exit code and output.
#pragma once

#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <string>

namespace pliant::testing {

/// The `pliant` binary of this build tree.
inline std::filesystem::path pliant_binary() { return std::filesystem::path(PLIANT_BINARY_DIR) / "apps" / "pliant"; }

struct CliResult {
  int exit_code = -1;
  std::string output;  ///< stdout and stderr
};

/// Runs `pliant ARGS` through the shell, stderr merged into stdout.
inline CliResult run_cli(const std::string& args) {
  const std::string command = pliant_binary().string() + " " + args + " 2>&1";
  CliResult result;
  FILE* pipe = ::popen(command.c_str(), "r");
  if (pipe == nullptr) return result;
  char buffer[4096];
  size_t n = 0;
  while ((n = std::fread(buffer, 1, sizeof buffer, pipe)) > 0) result.output.append(buffer, n);
  const int status = ::pclose(pipe);
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return result;
}

/// A fresh, empty folder for a test's outputs: TMP/pliant_<prefix>_<pid>/<name> (removed if there).
inline std::filesystem::path scratch_dir(const std::string& prefix, const std::string& name) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("pliant_" + prefix + "_" + std::to_string(::getpid())) / name;
  std::filesystem::remove_all(dir);
  return dir;
}

}  // namespace pliant::testing
