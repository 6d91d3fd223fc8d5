#include "interaction/json_reader.h"

#include <cmath>
#include <fstream>
#include <sstream>

namespace pliant {
namespace {

// JSON pointer escaping: "~" -> "~0", "/" -> "~1".
std::string escape_pointer(const std::string& key) {
  std::string out;
  for (char c : key) {
    if (c == '~') out += "~0";
    else if (c == '/') out += "~1";
    else out += c;
  }
  return out;
}

}  // namespace

nlohmann::json parse_json_text(const std::string& text, const std::string& source) {
  try {
    return nlohmann::json::parse(text);
  } catch (const nlohmann::json::parse_error& e) {
    // Byte offset -> line number.
    const size_t offset = std::min(static_cast<size_t>(e.byte), text.size());
    const long line = 1 + static_cast<long>(std::count(text.begin(), text.begin() + static_cast<long>(offset), '\n'));
    std::string message = e.what();
    const auto pos = message.find("parse error");
    if (pos != std::string::npos) message = message.substr(pos);
    throw InputError(InputErrorKind::syntax, file_line(source, line), "invalid JSON: " + message);
  } catch (const nlohmann::json::out_of_range& e) {
    // A number literal too large for a double (e.g. 1e999, error 406) is not a parse_error: name
    // the line of the literal, which the message quotes.
    const std::string message = e.what();
    long line = 0;
    const auto open = message.find('\'');
    const auto close = open == std::string::npos ? open : message.find('\'', open + 1);
    if (close != std::string::npos) {
      const auto at = text.find(message.substr(open + 1, close - open - 1));
      if (at != std::string::npos) line = 1 + static_cast<long>(std::count(text.begin(), text.begin() + static_cast<long>(at), '\n'));
    }
    throw InputError(InputErrorKind::non_finite, line > 0 ? file_line(source, line) : source,
                     "number out of range: " + message);
  }
}

nlohmann::json load_json_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(InputErrorKind::io, path, "cannot open file");
  std::stringstream buffer;
  buffer << in.rdbuf();
  return parse_json_text(buffer.str(), path);
}

void JsonReader::fail(InputErrorKind kind, const std::string& message) const {
  throw InputError(kind, where(), message);
}

std::string JsonReader::describe() const {
  std::string text = value_->dump();
  if (text.size() > 40) text = text.substr(0, 37) + "...";
  return std::string(value_->type_name()) + " " + text;
}

void JsonReader::expect_keys(std::initializer_list<const char*> allowed) const {
  if (!value_->is_object()) fail(InputErrorKind::wrong_type, "expected an object, got " + describe());
  for (const auto& item : value_->items()) {
    bool known = false;
    for (const char* k : allowed) known = known || item.key() == k;
    if (!known) {
      std::string list;
      for (const char* k : allowed) list += (list.empty() ? "" : ", ") + std::string(k);
      throw InputError(InputErrorKind::unknown_key, file_ + ": " + path_ + "/" + escape_pointer(item.key()),
                       "unknown key (expected one of: " + list + ")");
    }
  }
}

JsonReader JsonReader::at(const std::string& key) const {
  if (!value_->is_object()) fail(InputErrorKind::wrong_type, "expected an object, got " + describe());
  auto it = value_->find(key);
  if (it == value_->end()) fail(InputErrorKind::bad_value, "missing required key '" + key + "'");
  return JsonReader(*it, file_, path_ + "/" + escape_pointer(key));
}

std::optional<JsonReader> JsonReader::find(const std::string& key) const {
  if (!value_->is_object()) fail(InputErrorKind::wrong_type, "expected an object, got " + describe());
  auto it = value_->find(key);
  if (it == value_->end() || it->is_null()) return std::nullopt;
  return JsonReader(*it, file_, path_ + "/" + escape_pointer(key));
}

JsonReader JsonReader::at(size_t i) const {
  if (!value_->is_array()) fail(InputErrorKind::wrong_type, "expected an array, got " + describe());
  if (i >= value_->size()) fail(InputErrorKind::bad_value, "index " + std::to_string(i) + " out of range");
  return JsonReader((*value_)[i], file_, path_ + "/" + std::to_string(i));
}

size_t JsonReader::size() const {
  if (!value_->is_array()) fail(InputErrorKind::wrong_type, "expected an array, got " + describe());
  return value_->size();
}

double JsonReader::number() const {
  if (!value_->is_number()) fail(InputErrorKind::wrong_type, "expected a number, got " + describe());
  const double v = value_->get<double>();
  if (!std::isfinite(v)) fail(InputErrorKind::non_finite, "expected a finite number");
  return v;
}

double JsonReader::positive_number() const {
  if (!value_->is_number()) fail(InputErrorKind::wrong_type, "expected a positive number, got " + describe());
  const double v = number();
  if (!(v > 0.0)) fail(InputErrorKind::bad_value, "expected a positive number, got " + value_->dump());
  return v;
}

double JsonReader::non_negative_number() const {
  if (!value_->is_number()) fail(InputErrorKind::wrong_type, "expected a non-negative number, got " + describe());
  const double v = number();
  if (!(v >= 0.0)) fail(InputErrorKind::bad_value, "expected a non-negative number, got " + value_->dump());
  return v;
}

int JsonReader::integer() const {
  if (!value_->is_number_integer()) fail(InputErrorKind::wrong_type, "expected an integer, got " + describe());
  const auto v = value_->get<long long>();
  if (v < -2147483647LL || v > 2147483647LL) fail(InputErrorKind::bad_value, "integer out of range");
  return static_cast<int>(v);
}

bool JsonReader::boolean() const {
  if (!value_->is_boolean()) fail(InputErrorKind::wrong_type, "expected true or false, got " + describe());
  return value_->get<bool>();
}

std::string JsonReader::string() const {
  if (!value_->is_string()) fail(InputErrorKind::wrong_type, "expected a string, got " + describe());
  return value_->get<std::string>();
}

std::string JsonReader::choice(std::initializer_list<const char*> choices) const {
  const std::string s = string();
  std::string list;
  for (const char* c : choices) {
    if (s == c) return s;
    list += (list.empty() ? "" : ", ") + std::string(c);
  }
  fail(InputErrorKind::bad_value, "expected one of " + list + ", got \"" + s + "\"");
}

Vec3 JsonReader::vec3() const {
  if (!value_->is_array() || value_->size() != 3) {
    fail(InputErrorKind::wrong_type, "expected an array of 3 numbers, got " + describe());
  }
  return Vec3(at(0).number(), at(1).number(), at(2).number());
}

double JsonReader::number_or(const std::string& key, double fallback) const {
  auto r = find(key);
  return r ? r->number() : fallback;
}
double JsonReader::positive_number_or(const std::string& key, double fallback) const {
  auto r = find(key);
  return r ? r->positive_number() : fallback;
}
double JsonReader::non_negative_number_or(const std::string& key, double fallback) const {
  auto r = find(key);
  return r ? r->non_negative_number() : fallback;
}
int JsonReader::integer_or(const std::string& key, int fallback) const {
  auto r = find(key);
  return r ? r->integer() : fallback;
}
bool JsonReader::boolean_or(const std::string& key, bool fallback) const {
  auto r = find(key);
  return r ? r->boolean() : fallback;
}
std::string JsonReader::string_or(const std::string& key, const std::string& fallback) const {
  auto r = find(key);
  return r ? r->string() : fallback;
}
Vec3 JsonReader::vec3_or(const std::string& key, const Vec3& fallback) const {
  auto r = find(key);
  return r ? r->vec3() : fallback;
}

}  // namespace pliant
