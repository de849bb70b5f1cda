// Printing the evidence report to PDF with headless Chromium (report_pdf.h).

#include "meshmark/forensics/report_pdf.h"

#include <fmt/format.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cctype>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>

#include "meshmark/core/error.h"
#include "meshmark/io/io.h"

namespace meshmark {

namespace {

namespace fs = std::filesystem;

// A word for /bin/sh: single-quoted, a quote inside written '\''.
std::string quoted(const std::string& word) {
  std::string q = "'";
  for (const char c : word) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

// Whether bytes are a whole PDF: the header, and the end-of-file marker near the end.
bool whole_pdf(const std::string& bytes) {
  if (bytes.rfind("%PDF-", 0) != 0) return false;
  const std::size_t tail = bytes.size() > 64 ? bytes.size() - 64 : 0;
  return bytes.find("%%EOF", tail) != std::string::npos;
}

}  // namespace

void print_pdf(const std::string& html, const std::string& pdf, const PdfOptions& options) {
  std::error_code ec;
  if (fs::equivalent(html, pdf, ec) || html == pdf)
    throw InvalidArgumentError(fmt::format("{}: the PDF would overwrite its HTML", pdf));
  const fs::path source = fs::absolute(html, ec);
  if (!fs::is_regular_file(source, ec)) throw IOError(fmt::format("{}: no such file", html));
  // A private folder for the browser's profile, its log and the PDF being printed.
  std::string work = (fs::temp_directory_path(ec) / "meshmark-pdf-XXXXXX").string();
  if (!mkdtemp(work.data()))
    throw WriteError(fmt::format("{}: cannot make a temporary folder for the browser", pdf));
  const std::string printed = work + "/report.pdf", log = work + "/chromium.log";
  const std::string command = fmt::format(
      "timeout -k 5 {} {} --headless --no-sandbox --disable-gpu --no-first-run "
      "--user-data-dir={} --no-pdf-header-footer --print-to-pdf-no-header --print-to-pdf={} {} > "
      "{} 2>&1",
      options.timeout_seconds, quoted(options.chromium), quoted(work + "/profile"), quoted(printed),
      quoted("file://" + source.string()), quoted(log));
  const int status = std::system(command.c_str());
  const std::string bytes = slurp(printed);
  if (!whole_pdf(bytes)) {
    std::string said = slurp(log);
    while (!said.empty() && std::isspace(static_cast<unsigned char>(said.back()))) said.pop_back();
    if (said.size() > 600) said = "..." + said.substr(said.size() - 600);
    fs::remove_all(work, ec);
    throw WriteError(fmt::format(
        "{}: {} printed no whole PDF of {} (exit status {}){}{}", pdf, options.chromium, html,
        WIFEXITED(status) ? WEXITSTATUS(status) : status, said.empty() ? "" : ": ",
        said.empty() ? "; is it installed (Debian: chromium)?" : said));
  }
  fs::remove_all(work, ec);
  write_file_atomically(pdf, bytes);
}

}  // namespace meshmark
