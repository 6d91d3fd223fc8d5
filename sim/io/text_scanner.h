// TextScanner: the shared tokenizer of the mesh readers. It reads a whole text file, strips
// comments and blank lines, and hands out lines or whitespace-separated tokens together with their
// 1-based line numbers, so every parse error can name "file:line" and what was expected.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "sim/input_error.h"

namespace pliant {

/// One non-blank line of a text file, split at whitespace.
struct ScannedLine {
  long number = 0;                       ///< line number in the file, counted from 1
  std::string_view text;                 ///< the line without comment and end of line
  std::vector<std::string_view> tokens;  ///< whitespace-separated words of `text`
};

class TextScanner {
 public:
  /// Reads `path`; throws InputError(io) when it cannot be read. `comment` (0 for none) starts a
  /// comment that runs to the end of the line.
  static TextScanner open(const std::string& path, char comment = 0);
  /// Scans `text` in memory; `name` is used in messages.
  TextScanner(std::string name, std::string text, char comment = 0);

  /// Name used in messages (the path as given).
  const std::string& name() const { return name_; }
  /// True when no lines and no tokens are left.
  bool at_end() const;
  /// Next non-blank line (tokens of the current line not yet taken are dropped); throws
  /// InputError(truncated) at the end of the file, naming what was `expected`.
  const ScannedLine& next_line(const std::string& expected);
  /// Next token, continuing on following lines; throws InputError(truncated) at end of file.
  std::string_view next_token(const std::string& expected);
  /// Number of tokens not yet handed out (tokens of a line returned by next_line count as taken).
  size_t remaining_tokens() const;
  /// How many of `records` (tokens_each tokens each) the rest of the file can hold at most: a safe
  /// size to reserve for a count read from a header (which may be garbage).
  size_t reserve_hint(long records, long tokens_each) const;
  /// Line number of the last line or token handed out (0 before the first).
  long line() const { return current_line_number_; }
  /// "file:line" of the last line or token handed out.
  std::string where() const { return file_line(name_, current_line_number_); }

  /// Parses a whole token as an integer; InputError(syntax) naming `what` otherwise.
  long parse_int(std::string_view token, const std::string& what) const;
  /// Parses a whole token as a finite double; InputError(syntax) or (non_finite) naming `what`.
  double parse_double(std::string_view token, const std::string& what) const;
  /// Throws InputError(kind) at the current line.
  [[noreturn]] void fail(InputErrorKind kind, const std::string& message) const;

 private:
  std::string name_;
  std::string text_;
  std::vector<ScannedLine> lines_;
  std::vector<size_t> tokens_before_;  // tokens in lines_[0, i), size lines_ + 1
  size_t next_line_ = 0;         // index into lines_ of the next line to hand out
  size_t token_line_ = 0;        // line whose tokens next_token() walks (lines_.size() = none)
  size_t next_token_ = 0;        // index of the next token in lines_[token_line_]
  long current_line_number_ = 0;
  long last_line_number_ = 0;    // number of lines in the file
};

}  // namespace pliant
