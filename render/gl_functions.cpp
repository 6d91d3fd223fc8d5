#include "render/gl_functions.h"

namespace pliant::gl {

const char* Functions::load() {
#define PLIANT_GL_LOAD(ret, name, params)                                                    \
  name = reinterpret_cast<ret(GLAPIENTRY*) params>(OSMesaGetProcAddress("gl" #name));        \
  if (name == nullptr) return "gl" #name;
  PLIANT_GL_FUNCTIONS(PLIANT_GL_LOAD)
#undef PLIANT_GL_LOAD
  return nullptr;
}

}  // namespace pliant::gl
