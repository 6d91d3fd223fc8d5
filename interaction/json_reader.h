// Reading JSON inputs (scenes, tool scripts) with errors that name the file and the JSON path,
// e.g. "probe.json: /bodies/1/material/young_modulus: expected a positive number, got -3".
#pragma once

#include <initializer_list>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "sim/input_error.h"
#include "sim/math_types.h"

namespace pliant {

/// Parses a JSON file; a syntax error names the file and line. Throws InputError.
nlohmann::json load_json_file(const std::string& path);
/// Parses JSON text; `source` names it in errors.
nlohmann::json parse_json_text(const std::string& text, const std::string& source);

/// A view of one JSON value with its file and path, for reading with good errors.
class JsonReader {
 public:
  JsonReader(const nlohmann::json& value, std::string file, std::string path = "")
      : value_(&value), file_(std::move(file)), path_(std::move(path)) {}

  const nlohmann::json& value() const { return *value_; }
  const std::string& file() const { return file_; }
  /// JSON pointer of this value, "" for the root.
  const std::string& path() const { return path_; }
  /// "file: /path" for error messages.
  std::string where() const { return file_ + ": " + (path_.empty() ? std::string("/") : path_); }
  [[noreturn]] void fail(InputErrorKind kind, const std::string& message) const;

  bool is_object() const { return value_->is_object(); }
  bool is_array() const { return value_->is_array(); }
  bool is_string() const { return value_->is_string(); }
  bool is_number() const { return value_->is_number(); }
  bool has(const std::string& key) const { return value_->is_object() && value_->contains(key); }

  /// Fails unless this is an object; then fails on any key not in `allowed`.
  void expect_keys(std::initializer_list<const char*> allowed) const;
  /// Member `key` of an object; fails if missing.
  JsonReader at(const std::string& key) const;
  /// Member `key`, or nullopt.
  std::optional<JsonReader> find(const std::string& key) const;
  /// Element i of an array.
  JsonReader at(size_t i) const;
  /// Number of array elements (fails unless an array).
  size_t size() const;

  double number() const;           ///< finite number
  double positive_number() const;  ///< finite, > 0
  double non_negative_number() const;
  int integer() const;
  bool boolean() const;
  std::string string() const;
  /// A string that must be one of `choices`.
  std::string choice(std::initializer_list<const char*> choices) const;
  Vec3 vec3() const;  ///< [x, y, z], finite

  // Optional members with defaults.
  double number_or(const std::string& key, double fallback) const;
  double positive_number_or(const std::string& key, double fallback) const;
  double non_negative_number_or(const std::string& key, double fallback) const;
  int integer_or(const std::string& key, int fallback) const;
  bool boolean_or(const std::string& key, bool fallback) const;
  std::string string_or(const std::string& key, const std::string& fallback) const;
  Vec3 vec3_or(const std::string& key, const Vec3& fallback) const;

 private:
  std::string describe() const;
  const nlohmann::json* value_;
  std::string file_;
  std::string path_;
};

}  // namespace pliant
