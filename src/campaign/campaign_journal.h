#pragma once
// Internal: a campaign's journals (rows.jsonl, calibration.jsonl), append-only files of JSON
// lines that a restarted campaign reads to skip what is done.

#include <cstddef>
#include <mutex>
#include <string>
#include <vector>

namespace meshmark::detail {

/// An append-only file of lines, each written whole by one write(2) on a file opened with
/// O_APPEND: lines of several threads and processes never interleave, and a kill cuts at most
/// the last line. \throw IOError naming the file when it cannot be opened or written.
class Journal {
 public:
  explicit Journal(const std::string& path);
  ~Journal();
  Journal(const Journal&) = delete;
  Journal& operator=(const Journal&) = delete;
  /// Appends line and a newline (thread-safe).
  void append(const std::string& line);

 private:
  std::string path_;
  int fd_ = -1;
  std::mutex mutex_;
};

/// Cuts a last line left without its newline by a kill off the file at path; returns the
/// number of bytes cut (0 when the file ends in a newline, is empty or does not exist).
std::size_t repair_journal(const std::string& path);

/// The complete, non-empty lines of a journal (a last line without its newline is left out);
/// none when the file does not exist.
std::vector<std::string> journal_lines(const std::string& path);

}  // namespace meshmark::detail
