#include "sim/io/text_scanner.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <fstream>
#include <sstream>

namespace pliant {

TextScanner TextScanner::open(const std::string& path, char comment) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(InputErrorKind::io, path, "cannot open file for reading");
  std::ostringstream s;
  s << in.rdbuf();
  if (in.bad()) throw InputError(InputErrorKind::io, path, "read failed");
  return TextScanner(path, s.str(), comment);
}

TextScanner::TextScanner(std::string name, std::string text, char comment)
    : name_(std::move(name)), text_(std::move(text)) {
  const std::string_view all(text_);
  size_t pos = 0;
  long number = 0;
  while (pos < all.size()) {
    size_t end = all.find('\n', pos);
    if (end == std::string_view::npos) end = all.size();
    ++number;
    std::string_view line = all.substr(pos, end - pos);
    pos = end + 1;
    if (comment != 0) {
      const size_t c = line.find(comment);
      if (c != std::string_view::npos) line = line.substr(0, c);
    }
    while (!line.empty() && (line.back() == '\r' || line.back() == ' ' || line.back() == '\t')) line.remove_suffix(1);
    ScannedLine scanned;
    scanned.number = number;
    scanned.text = line;
    size_t i = 0;
    while (i < line.size()) {
      while (i < line.size() && (line[i] == ' ' || line[i] == '\t' || line[i] == '\r')) ++i;
      size_t j = i;
      while (j < line.size() && line[j] != ' ' && line[j] != '\t' && line[j] != '\r') ++j;
      if (j > i) scanned.tokens.push_back(line.substr(i, j - i));
      i = j;
    }
    if (!scanned.tokens.empty()) lines_.push_back(std::move(scanned));
  }
  last_line_number_ = number;
  token_line_ = lines_.size();
  tokens_before_.assign(lines_.size() + 1, 0);
  for (size_t i = 0; i < lines_.size(); ++i) tokens_before_[i + 1] = tokens_before_[i] + lines_[i].tokens.size();
}

size_t TextScanner::remaining_tokens() const {
  if (token_line_ < lines_.size()) return tokens_before_.back() - tokens_before_[token_line_] - next_token_;
  return tokens_before_.back() - tokens_before_[next_line_];
}

size_t TextScanner::reserve_hint(long records, long tokens_each) const {
  if (records <= 0) return 0;
  const size_t most = remaining_tokens() / static_cast<size_t>(std::max(1L, tokens_each));
  return std::min(static_cast<size_t>(records), most);
}

bool TextScanner::at_end() const {
  const bool tokens_left = token_line_ < lines_.size() && next_token_ < lines_[token_line_].tokens.size();
  return !tokens_left && next_line_ >= lines_.size();
}

const ScannedLine& TextScanner::next_line(const std::string& expected) {
  if (next_line_ >= lines_.size()) {
    current_line_number_ = last_line_number_;
    fail(InputErrorKind::truncated, "file ends, expected " + expected);
  }
  const ScannedLine& line = lines_[next_line_];
  token_line_ = lines_.size();
  next_token_ = 0;
  ++next_line_;
  current_line_number_ = line.number;
  return line;
}

std::string_view TextScanner::next_token(const std::string& expected) {
  while (token_line_ >= lines_.size() || next_token_ >= lines_[token_line_].tokens.size()) {
    if (next_line_ >= lines_.size()) {
      current_line_number_ = last_line_number_;
      fail(InputErrorKind::truncated, "file ends, expected " + expected);
    }
    token_line_ = next_line_++;
    next_token_ = 0;
  }
  const ScannedLine& line = lines_[token_line_];
  current_line_number_ = line.number;
  return line.tokens[next_token_++];
}

long TextScanner::parse_int(std::string_view token, const std::string& what) const {
  std::string_view t = token;
  if (!t.empty() && t.front() == '+') t.remove_prefix(1);
  long value = 0;
  const auto [end, ec] = std::from_chars(t.data(), t.data() + t.size(), value);
  if (ec != std::errc() || end != t.data() + t.size() || t.empty()) {
    fail(InputErrorKind::syntax, "expected an integer (" + what + "), got '" + std::string(token) + "'");
  }
  return value;
}

double TextScanner::parse_double(std::string_view token, const std::string& what) const {
  std::string_view t = token;
  if (!t.empty() && t.front() == '+') t.remove_prefix(1);
  double value = 0.0;
  const auto [end, ec] = std::from_chars(t.data(), t.data() + t.size(), value);
  if (ec == std::errc::result_out_of_range) {
    fail(InputErrorKind::non_finite, "number out of range (" + what + "): '" + std::string(token) + "'");
  }
  if (ec != std::errc() || end != t.data() + t.size() || t.empty()) {
    fail(InputErrorKind::syntax, "expected a number (" + what + "), got '" + std::string(token) + "'");
  }
  if (!std::isfinite(value)) {
    fail(InputErrorKind::non_finite, "expected a finite number (" + what + "), got '" + std::string(token) + "'");
  }
  return value;
}

void TextScanner::fail(InputErrorKind kind, const std::string& message) const {
  throw InputError(kind, where(), message);
}

}  // namespace pliant
