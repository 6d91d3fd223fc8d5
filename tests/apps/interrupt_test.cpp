// SIGINT / SIGTERM during `pliant run` (issue 9, item 5; docs/reliability.md): the run stops at
// the next step boundary, exits with 130, writes summary.json with "interrupted": true, leaves
// steps.csv complete (every row has every column of the header, and the step indices run 0..n-1
// without gaps) and no *.partial file. The signal is sent once the run is writing its outputs.
#include <gtest/gtest.h>

#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <thread>

namespace pliant {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;

fs::path pliant_binary() { return fs::path(PLIANT_BINARY_DIR) / "apps" / "pliant"; }

// Starts `pliant run probe.json --steps 100000 --no-frames --quiet --out OUT` as a child.
pid_t start_run(const fs::path& out) {
  const std::string binary = pliant_binary().string();
  const std::string scene = std::string(PLIANT_SOURCE_DIR) + "/assets/scenes/probe.json";
  const std::string out_dir = out.string();
  const pid_t pid = ::fork();
  if (pid == 0) {
    const int devnull = ::open("/dev/null", O_WRONLY);
    if (devnull >= 0) ::dup2(devnull, STDOUT_FILENO);
    ::execl(binary.c_str(), binary.c_str(), "run", scene.c_str(), "--steps", "100000", "--no-frames", "--quiet",
            "--out", out_dir.c_str(), static_cast<char*>(nullptr));
    ::_exit(127);
  }
  return pid;
}

// Waits up to `limit` for the child; returns its wait status or -1 on timeout (child killed).
int wait_for(pid_t pid, std::chrono::seconds limit) {
  const auto end = std::chrono::steady_clock::now() + limit;
  int status = 0;
  while (std::chrono::steady_clock::now() < end) {
    if (::waitpid(pid, &status, WNOHANG) == pid) return status;
    std::this_thread::sleep_for(20ms);
  }
  ::kill(pid, SIGKILL);
  ::waitpid(pid, &status, 0);
  return -1;
}

std::vector<std::string> lines_of(const fs::path& path) {
  std::ifstream in(path);
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

std::vector<std::string> split(const std::string& line) {
  std::vector<std::string> fields;
  std::stringstream s(line);
  for (std::string f; std::getline(s, f, ',');) fields.push_back(f);
  if (!line.empty() && line.back() == ',') fields.emplace_back();
  return fields;
}

class Interrupt : public ::testing::TestWithParam<int> {};

TEST_P(Interrupt, RunStopsWithExitCode130AndCompleteOutputs) {
  if (!fs::exists(pliant_binary())) GTEST_SKIP() << "pliant binary not built at " << pliant_binary();
  const int signal_number = GetParam();
  const fs::path out = fs::temp_directory_path() /
                       ("pliant_interrupt_" + std::to_string(::getpid()) + "_" + std::to_string(signal_number));
  fs::remove_all(out);
  const pid_t pid = start_run(out);
  ASSERT_GT(pid, 0);

  // Wait until the run is stepping (its CSV is open), then let it run about a second.
  const auto limit = std::chrono::steady_clock::now() + 60s;
  while (!fs::exists(out / "steps.csv.partial") && std::chrono::steady_clock::now() < limit) {
    int status = 0;
    ASSERT_NE(::waitpid(pid, &status, WNOHANG), pid) << "pliant exited before running";
    std::this_thread::sleep_for(20ms);
  }
  ASSERT_TRUE(fs::exists(out / "steps.csv.partial")) << "the run did not start within 60 s";
  std::this_thread::sleep_for(1s);
  ASSERT_EQ(::kill(pid, signal_number), 0);
  const int status = wait_for(pid, 60s);
  ASSERT_NE(status, -1) << "pliant did not stop within 60 s of the signal";
  ASSERT_TRUE(WIFEXITED(status)) << "killed by signal " << (WIFSIGNALED(status) ? WTERMSIG(status) : 0);
  EXPECT_EQ(WEXITSTATUS(status), 130);

  ASSERT_TRUE(fs::exists(out / "summary.json"));
  std::ifstream summary_file(out / "summary.json");
  const nlohmann::json summary = nlohmann::json::parse(summary_file);
  EXPECT_EQ(summary.at("interrupted"), true);
  const long steps = summary.at("steps").get<long>();
  EXPECT_GT(steps, 0);
  EXPECT_LT(steps, 100000);

  const auto lines = lines_of(out / "steps.csv");
  ASSERT_GE(lines.size(), 2u);
  const size_t columns = split(lines[0]).size();
  EXPECT_EQ(lines.size() - 1, static_cast<size_t>(steps)) << "one row per step done";
  for (size_t i = 1; i < lines.size(); ++i) {
    const auto fields = split(lines[i]);
    ASSERT_EQ(fields.size(), columns) << "row " << i << ": " << lines[i];
    EXPECT_EQ(std::stol(fields[0]), static_cast<long>(i - 1)) << "row " << i;
  }
  EXPECT_TRUE(fs::exists(out / "tool_forces.csv"));
  for (const auto& entry : fs::recursive_directory_iterator(out)) {
    EXPECT_NE(entry.path().extension(), ".partial") << entry.path();
  }
  fs::remove_all(out);
}

INSTANTIATE_TEST_SUITE_P(Signals, Interrupt, ::testing::Values(SIGINT, SIGTERM), [](const auto& info) {
  return info.param == SIGINT ? std::string("Sigint") : std::string("Sigterm");
});

}  // namespace
}  // namespace pliant
