// GL entry points used by the renderer, loaded once per context through OSMesaGetProcAddress.
// libOSMesa exports only the OSMesa* functions; every gl* function (core profile 3.3 or later)
// comes from the loader, so nothing links against a system libGL. Internal to render/.
#pragma once

#include <GL/osmesa.h>
#include <GL/glext.h>

namespace pliant::gl {

// X-macro list: return type, name, parameters. One place to add a function.
#define PLIANT_GL_FUNCTIONS(X)                                                                      \
  X(void, Viewport, (GLint, GLint, GLsizei, GLsizei))                                               \
  X(void, ClearColor, (GLfloat, GLfloat, GLfloat, GLfloat))                                         \
  X(void, Clear, (GLbitfield))                                                                      \
  X(void, Enable, (GLenum))                                                                         \
  X(void, Disable, (GLenum))                                                                        \
  X(void, DepthFunc, (GLenum))                                                                      \
  X(void, PolygonOffset, (GLfloat, GLfloat))                                                        \
  X(void, LineWidth, (GLfloat))                                                                     \
  X(void, Finish, (void))                                                                           \
  X(GLenum, GetError, (void))                                                                       \
  X(const GLubyte*, GetString, (GLenum))                                                            \
  X(void, PixelStorei, (GLenum, GLint))                                                             \
  X(void, GetFloatv, (GLenum, GLfloat*))                                                            \
  X(void, ReadPixels, (GLint, GLint, GLsizei, GLsizei, GLenum, GLenum, void*))                      \
  X(GLuint, CreateShader, (GLenum))                                                                 \
  X(void, ShaderSource, (GLuint, GLsizei, const GLchar* const*, const GLint*))                      \
  X(void, CompileShader, (GLuint))                                                                  \
  X(void, GetShaderiv, (GLuint, GLenum, GLint*))                                                    \
  X(void, GetShaderInfoLog, (GLuint, GLsizei, GLsizei*, GLchar*))                                   \
  X(void, DeleteShader, (GLuint))                                                                   \
  X(GLuint, CreateProgram, (void))                                                                  \
  X(void, AttachShader, (GLuint, GLuint))                                                           \
  X(void, LinkProgram, (GLuint))                                                                    \
  X(void, GetProgramiv, (GLuint, GLenum, GLint*))                                                   \
  X(void, GetProgramInfoLog, (GLuint, GLsizei, GLsizei*, GLchar*))                                  \
  X(void, DeleteProgram, (GLuint))                                                                  \
  X(void, UseProgram, (GLuint))                                                                     \
  X(GLint, GetUniformLocation, (GLuint, const GLchar*))                                             \
  X(void, UniformMatrix4fv, (GLint, GLsizei, GLboolean, const GLfloat*))                            \
  X(void, Uniform1i, (GLint, GLint))                                                                \
  X(void, Uniform1f, (GLint, GLfloat))                                                              \
  X(void, Uniform3f, (GLint, GLfloat, GLfloat, GLfloat))                                            \
  X(void, GenVertexArrays, (GLsizei, GLuint*))                                                      \
  X(void, BindVertexArray, (GLuint))                                                                \
  X(void, DeleteVertexArrays, (GLsizei, const GLuint*))                                             \
  X(void, GenBuffers, (GLsizei, GLuint*))                                                           \
  X(void, BindBuffer, (GLenum, GLuint))                                                             \
  X(void, BufferData, (GLenum, GLsizeiptr, const void*, GLenum))                                    \
  X(void, DeleteBuffers, (GLsizei, const GLuint*))                                                  \
  X(void, VertexAttribPointer, (GLuint, GLint, GLenum, GLboolean, GLsizei, const void*))            \
  X(void, EnableVertexAttribArray, (GLuint))                                                        \
  X(void, DrawArrays, (GLenum, GLint, GLsizei))                                                     \
  X(void, DrawElements, (GLenum, GLsizei, GLenum, const void*))                                     \
  X(void, GenFramebuffers, (GLsizei, GLuint*))                                                      \
  X(void, BindFramebuffer, (GLenum, GLuint))                                                        \
  X(void, DeleteFramebuffers, (GLsizei, const GLuint*))                                             \
  X(GLenum, CheckFramebufferStatus, (GLenum))                                                       \
  X(void, GenRenderbuffers, (GLsizei, GLuint*))                                                     \
  X(void, BindRenderbuffer, (GLenum, GLuint))                                                       \
  X(void, DeleteRenderbuffers, (GLsizei, const GLuint*))                                            \
  X(void, RenderbufferStorageMultisample, (GLenum, GLsizei, GLenum, GLsizei, GLsizei))              \
  X(void, FramebufferRenderbuffer, (GLenum, GLenum, GLenum, GLuint))                                \
  X(void, BlitFramebuffer, (GLint, GLint, GLint, GLint, GLint, GLint, GLint, GLint, GLbitfield, GLenum)) \
  X(void, GetIntegerv, (GLenum, GLint*))

/// Function pointers of one context.
struct Functions {
#define PLIANT_GL_MEMBER(ret, name, params) ret(GLAPIENTRY* name) params = nullptr;
  PLIANT_GL_FUNCTIONS(PLIANT_GL_MEMBER)
#undef PLIANT_GL_MEMBER

  /// Loads every entry point from the current OSMesa context; returns the name of the first
  /// missing one, or nullptr when all were found.
  const char* load();
};

}  // namespace pliant::gl
