// A campaign's journals: whole-line appends, a cut last line repaired, the lines read back.

#include "campaign/campaign_journal.h"

#include <fcntl.h>
#include <fmt/format.h>
#include <unistd.h>

#include <filesystem>

#include "meshmark/core/error.h"
#include "meshmark/io/io.h"

namespace meshmark::detail {

namespace fs = std::filesystem;

Journal::Journal(const std::string& path) : path_(path) {
  fd_ = ::open(path.c_str(), O_WRONLY | O_APPEND | O_CREAT | O_CLOEXEC, 0644);
  if (fd_ < 0) throw IOError(fmt::format("{}: cannot open for appending", path));
}

Journal::~Journal() {
  if (fd_ >= 0) ::close(fd_);
}

void Journal::append(const std::string& line) {
  const std::string text = line + "\n";
  std::lock_guard<std::mutex> lock(mutex_);
  std::size_t done = 0;
  while (done < text.size()) {
    const ssize_t n = ::write(fd_, text.data() + done, text.size() - done);
    if (n < 0) throw IOError(fmt::format("{}: write failed", path_));
    done += static_cast<std::size_t>(n);
  }
}

std::size_t repair_journal(const std::string& path) {
  if (!fs::exists(path)) return 0;
  const std::string text = read_file(path);
  if (text.empty() || text.back() == '\n') return 0;
  const std::size_t nl = text.rfind('\n');
  const std::size_t keep = nl == std::string::npos ? 0 : nl + 1;
  fs::resize_file(path, keep);
  return text.size() - keep;
}

std::vector<std::string> journal_lines(const std::string& path) {
  std::vector<std::string> lines;
  if (!fs::exists(path)) return lines;
  const std::string text = read_file(path);
  std::size_t start = 0;
  for (std::size_t nl; (nl = text.find('\n', start)) != std::string::npos; start = nl + 1)
    if (nl > start) lines.push_back(text.substr(start, nl - start));
  return lines;
}

}  // namespace meshmark::detail
