// SVG to PNG through rsvg-convert, run as a process of its own (no shell).

#include "plot/svg_png.h"

#include <fcntl.h>
#include <fmt/format.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <vector>

#include "meshmark/core/error.h"
#include "meshmark/io/io.h"

extern char** environ;

namespace meshmark::detail {

namespace fs = std::filesystem;

namespace {

// A process's outcome: whether it could be started, its exit status and what it wrote on
// stderr (standard output discarded).
struct ProcessRun {
  int spawn_error = 0;  // errno of posix_spawnp (ENOENT: not found)
  int status = 0;       // waitpid's
  std::string errors;
};

ProcessRun run_process(const std::vector<std::string>& args) {
  std::vector<char*> argv;
  for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  int pipe_fds[2];
  if (::pipe2(pipe_fds, O_CLOEXEC) != 0)
    throw IOError(fmt::format("{}: cannot make a pipe", args[0]));
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, "/dev/null", O_WRONLY, 0);
  posix_spawn_file_actions_adddup2(&actions, pipe_fds[1], STDERR_FILENO);
  ProcessRun run;
  pid_t pid = 0;
  run.spawn_error = posix_spawnp(&pid, argv[0], &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  ::close(pipe_fds[1]);
  if (run.spawn_error == 0) {
    char buf[4096];
    for (ssize_t n; (n = ::read(pipe_fds[0], buf, sizeof buf)) != 0;) {
      if (n < 0 && errno == EINTR) continue;
      if (n < 0) break;
      if (run.errors.size() < 65536) run.errors.append(buf, static_cast<std::size_t>(n));
    }
    while (::waitpid(pid, &run.status, 0) < 0 && errno == EINTR) {
    }
  }
  ::close(pipe_fds[0]);
  return run;
}

}  // namespace

PngConversion svg_to_png(const std::string& svg_path, const std::string& png_path) {
  const std::string tmp = png_path + ".tmp";
  const ProcessRun run = run_process({"rsvg-convert", "-f", "png", "-o", tmp, svg_path});
  if (run.spawn_error == ENOENT) return PngConversion::ToolMissing;
  if (run.spawn_error != 0)
    throw IOError(
        fmt::format("{}: cannot run rsvg-convert: {}", svg_path, std::strerror(run.spawn_error)));
  if (!WIFEXITED(run.status) || WEXITSTATUS(run.status) != 0) {
    std::error_code ignored;
    fs::remove(tmp, ignored);
    const std::string first = run.errors.substr(0, run.errors.find('\n'));
    throw IOError(fmt::format("{}: rsvg-convert failed ({}){}", svg_path,
                              WIFEXITED(run.status)
                                  ? fmt::format("exit status {}", WEXITSTATUS(run.status))
                                  : fmt::format("killed by signal {}", WTERMSIG(run.status)),
                              first.empty() ? "" : ": " + printable(first)));
  }
  fs::rename(tmp, png_path);
  return PngConversion::Written;
}

bool write_figure(const std::string& out, const std::string& name, const std::string& svg) {
  const fs::path dir(out), svg_path = dir / (name + ".svg");
  write_file_atomically(svg_path.string(), svg);
  return svg_to_png(svg_path.string(), (dir / (name + ".png")).string()) == PngConversion::Written;
}

}  // namespace meshmark::detail
