#include "sim/input_error.h"

namespace pliant {

const char* to_string(InputErrorKind kind) {
  switch (kind) {
    case InputErrorKind::io: return "io";
    case InputErrorKind::syntax: return "syntax";
    case InputErrorKind::truncated: return "truncated";
    case InputErrorKind::count_mismatch: return "count_mismatch";
    case InputErrorKind::index_out_of_range: return "index_out_of_range";
    case InputErrorKind::non_finite: return "non_finite";
    case InputErrorKind::degenerate_element: return "degenerate_element";
    case InputErrorKind::unknown_key: return "unknown_key";
    case InputErrorKind::wrong_type: return "wrong_type";
    case InputErrorKind::bad_value: return "bad_value";
    case InputErrorKind::unsupported: return "unsupported";
    case InputErrorKind::topology: return "topology";
  }
  return "unknown";
}

}  // namespace pliant
