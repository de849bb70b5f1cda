#pragma once
/// \file report_pdf.h
/// The evidence report as PDF, printed from its HTML by headless Chromium (Debian's `chromium`
/// package), the browser the report is checked in: the PDF holds what a person sees on screen.

#include <string>

namespace meshmark {

/// How the PDF is printed.
struct PdfOptions {
  std::string chromium = "chromium";  ///< the browser's program (looked up on PATH)
  int timeout_seconds = 120;          ///< the browser is stopped after this long
};

/// Prints the HTML file html to pdf (atomically: a temporary file beside it, renamed once it is
/// a whole PDF). Chromium now and then does not exit after printing; a print that ran into the
/// timeout counts when the PDF it left is whole (starts with %PDF- and ends with %%EOF).
/// \throw InvalidArgumentError when pdf is html; IOError when html does not exist; WriteError
///        when the browser cannot be run or left no whole PDF (its last output in the message).
void print_pdf(const std::string& html, const std::string& pdf, const PdfOptions& options = {});

}  // namespace meshmark
