// Shared by the libFuzzer targets: runs a parser on fuzz input and treats pliant::InputError as
// the only acceptable failure. Any other exception escaping a parser is a bug (docs/reliability.md),
// so it aborts and libFuzzer records the input as a crash.
#pragma once

#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>
#include <typeinfo>

#include "sim/input_error.h"

namespace pliant::fuzz {

/// Calls `parse()`; returns normally on success or InputError, aborts on anything else.
template <class Parse>
void expect_only_input_errors(const char* target, Parse&& parse) {
  try {
    parse();
  } catch (const InputError&) {
    // Bad input reported the documented way.
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s: exception other than InputError escaped: %s: %s\n", target, typeid(e).name(), e.what());
    std::abort();
  } catch (...) {
    std::fprintf(stderr, "%s: non-std exception escaped\n", target);
    std::abort();
  }
}

/// The fuzz input as text.
inline std::string as_text(const unsigned char* data, size_t size) {
  return std::string(reinterpret_cast<const char*>(data), size);
}

}  // namespace pliant::fuzz
