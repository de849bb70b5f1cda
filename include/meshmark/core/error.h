#pragma once
/// \file error.h
/// The exceptions meshmark throws. Bad input throws a typed exception whose message names the
/// file, the line or element, and what is wrong; solver outcomes are status values, never
/// exceptions (see separable_qp.h and embed.h).

#include <cstddef>
#include <stdexcept>
#include <string>
#include <string_view>

namespace meshmark {

/// text with every byte a terminal could act on written as an escape, so that a message quoting
/// file contents, tokens or paths can be printed safely: control characters (C0, DEL, the C1
/// range U+0080 to U+009F), bidirectional-text controls and bytes that are not valid UTF-8
/// become \xNN (each byte). Other text, UTF-8 included, is unchanged; so is a backslash, which
/// makes printable(printable(s)) == printable(s).
std::string printable(std::string_view text);

/// Base of every exception meshmark throws on purpose. Its message is stored through
/// printable(): what() never carries raw control bytes from the input it quotes.
class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& message);
  explicit Error(const char* message);
};

/// A file (or an in-memory mesh) that cannot be read as what it claims to be: truncated,
/// wrong counts, indices out of range, non-finite or non-numeric coordinates, no faces.
/// what() reads "FILE:LINE: MESSAGE" for text formats, "FILE: MESSAGE" otherwise, where the
/// message names the element (vertex 12, face 3, ...); like every Error, escaped by printable().
class InvalidInputError : public Error {
 public:
  /// \param file the path as given by the caller; \param line 1-based line, 0 when the
  /// format has no lines (binary) or the problem is not tied to one.
  InvalidInputError(std::string file, std::size_t line, const std::string& message);
  /// The file name as given (not escaped).
  const std::string& file() const { return file_; }
  std::size_t line() const { return line_; }
  /// The message without the file and line prefix (not escaped).
  const std::string& detail() const { return detail_; }

 private:
  std::string file_;
  std::size_t line_;
  std::string detail_;
};

/// The operating system refused a read or a write (missing file, permission, full disk), or a
/// database failed (registry.h). Catch it for either; ReadError and WriteError say which.
class IOError : public Error {
 public:
  using Error::Error;
};

/// A file that cannot be read at all: missing, not a regular file, unreadable, larger than the
/// most it may hold (the CLI's exit code 2, bad input). A file read but malformed is an
/// InvalidInputError instead.
class ReadError : public IOError {
 public:
  using IOError::IOError;
};

/// An output that cannot be written: no permission, no space, not a regular file, a failed
/// rename into place (the CLI's exit code 3). The destination is then untouched.
class WriteError : public IOError {
 public:
  using IOError::IOError;
};

/// A caller's argument that is out of its documented range (bits <= 0, strength outside
/// (0, 1/2), a payload that does not fit in the requested bits, ...).
class InvalidArgumentError : public Error {
 public:
  using Error::Error;
};

/// What was asked needs an optional component of meshmark (draco, 3mf, postgres, ipopt, cgal:
/// meshmark/core/components.h) that the program was linked without. Its message names the
/// component and the CMake target that brings it (meshmark::draco, ...).
class MissingComponentError : public InvalidArgumentError {
 public:
  MissingComponentError(std::string component, const std::string& message);
  /// The component's name ("draco", "cgal", ...).
  const std::string& component() const { return component_; }

 private:
  std::string component_;
};

}  // namespace meshmark
