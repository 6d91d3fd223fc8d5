#include "render/offscreen_renderer.h"

#include <algorithm>
#include <cfenv>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <numbers>
#include <string>
#include <utility>
#include <vector>

#include "render/bitmap_font.h"
#include "render/colour_map.h"
#include "render/gl_functions.h"
#include "render/render_error.h"

namespace pliant {
namespace {

// Holds the caller's floating-point environment (and traps) while Mesa runs, and restores it.
class FpEnvironmentHold {
 public:
  FpEnvironmentHold() { feholdexcept(&saved_); }
  ~FpEnvironmentHold() {
    feclearexcept(FE_ALL_EXCEPT);
    fesetenv(&saved_);
  }
  FpEnvironmentHold(const FpEnvironmentHold&) = delete;
  FpEnvironmentHold& operator=(const FpEnvironmentHold&) = delete;

 private:
  fenv_t saved_;
};

// One vertex of every primitive: position relative to the scene centre, normal, colour.
struct Vertex {
  float position[3];
  float normal[3];
  float colour[3];
};

Vertex make_vertex(const Vec3& p, const Vec3& n, Rgba8 c) {
  return {{static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z())},
          {static_cast<float>(n.x()), static_cast<float>(n.y()), static_cast<float>(n.z())},
          {c.r / 255.0f, c.g / 255.0f, c.b / 255.0f}};
}

constexpr const char* kVertexShader = R"(#version 330 core
layout(location = 0) in vec3 a_position;
layout(location = 1) in vec3 a_normal;
layout(location = 2) in vec3 a_colour;
uniform mat4 u_view_projection;
uniform mat4 u_view;
uniform float u_point_size;
out vec3 v_position_eye;
out vec3 v_normal_eye;
out vec3 v_colour;
void main() {
  gl_Position = u_view_projection * vec4(a_position, 1.0);
  v_position_eye = (u_view * vec4(a_position, 1.0)).xyz;
  v_normal_eye = mat3(u_view) * a_normal;
  v_colour = a_colour;
  gl_PointSize = u_point_size;
}
)";

// Two-sided Blinn-Phong with one key light fixed to the camera (up and to the right of the eye).
constexpr const char* kFragmentShader = R"(#version 330 core
in vec3 v_position_eye;
in vec3 v_normal_eye;
in vec3 v_colour;
uniform int u_lit;
uniform int u_use_uniform_colour;
uniform vec3 u_colour;
out vec4 fragment_colour;
void main() {
  vec3 base = u_use_uniform_colour == 1 ? u_colour : v_colour;
  if (u_lit == 0) {
    fragment_colour = vec4(base, 1.0);
    return;
  }
  vec3 n = normalize(v_normal_eye);
  vec3 to_eye = normalize(-v_position_eye);
  if (dot(n, to_eye) < 0.0) n = -n;
  vec3 light = normalize(vec3(0.35, 0.45, 1.0));
  float diffuse = max(dot(n, light), 0.0);
  float specular = pow(max(dot(n, normalize(light + to_eye)), 0.0), 40.0);
  vec3 c = base * (0.28 + 0.72 * diffuse) + vec3(0.15 * specular);
  fragment_colour = vec4(min(c, vec3(1.0)), 1.0);
}
)";

// A unit vector perpendicular to d (|d| > 0).
Vec3 any_perpendicular(const Vec3& d) {
  const Vec3 axis = std::abs(d.x()) < 0.9 * d.norm() ? Vec3::UnitX() : Vec3::UnitY();
  return d.cross(axis).normalized();
}

std::string format_value(double v) {
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%.3g", v);
  return buffer;
}

}  // namespace

struct OffscreenRenderer::Impl {
  int width = 0;
  int height = 0;
  OSMesaContext context = nullptr;
  std::vector<std::uint8_t> colour_buffer;  // OSMesa's window-system framebuffer
  gl::Functions gl;
  GLuint program = 0, vao = 0, vbo = 0, ebo = 0;
  int samples = 1;
  GLuint msaa_framebuffer = 0, msaa_colour = 0, msaa_depth = 0;  // only when samples > 1
  GLint u_view_projection = -1, u_view = -1, u_lit = -1, u_use_uniform_colour = -1, u_colour = -1,
        u_point_size = -1;
  float max_line_width = 1.0f;
  std::string version, renderer;
  bool core = false;

  // Per-frame scratch, kept to avoid reallocations.
  std::vector<Vertex> vertices;
  std::vector<std::uint32_t> indices;
  std::vector<std::uint8_t> pixels;
  std::vector<Vec3> normals;
  std::vector<std::pair<int, int>> edges;

  void make_current() {
    if (OSMesaMakeCurrent(context, colour_buffer.data(), GL_UNSIGNED_BYTE, width, height) == 0) {
      throw RenderError("OSMesa: cannot bind a " + std::to_string(width) + "x" + std::to_string(height) +
                        " off-screen buffer (OSMesaMakeCurrent failed; size above the driver's maximum?)");
    }
  }
  static void release() { OSMesaMakeCurrent(nullptr, nullptr, 0, 0, 0); }

  void check_gl(const char* what) {
    const GLenum error = gl.GetError();
    if (error != GL_NO_ERROR) {
      char code[16];
      std::snprintf(code, sizeof(code), "0x%04X", error);
      throw RenderError(std::string("OpenGL error ") + code + " while " + what);
    }
  }

  GLuint compile(GLenum kind, const char* source) {
    const GLuint shader = gl.CreateShader(kind);
    gl.ShaderSource(shader, 1, &source, nullptr);
    gl.CompileShader(shader);
    GLint ok = 0;
    gl.GetShaderiv(shader, GL_COMPILE_STATUS, &ok);
    if (ok == 0) {
      char log[1024] = {};
      gl.GetShaderInfoLog(shader, sizeof(log), nullptr, log);
      gl.DeleteShader(shader);
      throw RenderError(std::string("OSMesa: shader does not compile: ") + log);
    }
    return shader;
  }

  void create_pipeline() {
    const GLuint vs = compile(GL_VERTEX_SHADER, kVertexShader);
    const GLuint fs = compile(GL_FRAGMENT_SHADER, kFragmentShader);
    program = gl.CreateProgram();
    gl.AttachShader(program, vs);
    gl.AttachShader(program, fs);
    gl.LinkProgram(program);
    gl.DeleteShader(vs);
    gl.DeleteShader(fs);
    GLint ok = 0;
    gl.GetProgramiv(program, GL_LINK_STATUS, &ok);
    if (ok == 0) {
      char log[1024] = {};
      gl.GetProgramInfoLog(program, sizeof(log), nullptr, log);
      throw RenderError(std::string("OSMesa: shader program does not link: ") + log);
    }
    u_view_projection = gl.GetUniformLocation(program, "u_view_projection");
    u_view = gl.GetUniformLocation(program, "u_view");
    u_lit = gl.GetUniformLocation(program, "u_lit");
    u_use_uniform_colour = gl.GetUniformLocation(program, "u_use_uniform_colour");
    u_colour = gl.GetUniformLocation(program, "u_colour");
    u_point_size = gl.GetUniformLocation(program, "u_point_size");

    gl.GenVertexArrays(1, &vao);
    gl.BindVertexArray(vao);
    gl.GenBuffers(1, &vbo);
    gl.GenBuffers(1, &ebo);
    gl.BindBuffer(GL_ARRAY_BUFFER, vbo);
    gl.BindBuffer(GL_ELEMENT_ARRAY_BUFFER, ebo);
    const auto stride = static_cast<GLsizei>(sizeof(Vertex));
    gl.VertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, stride, reinterpret_cast<const void*>(offsetof(Vertex, position)));
    gl.VertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, stride, reinterpret_cast<const void*>(offsetof(Vertex, normal)));
    gl.VertexAttribPointer(2, 3, GL_FLOAT, GL_FALSE, stride, reinterpret_cast<const void*>(offsetof(Vertex, colour)));
    gl.EnableVertexAttribArray(0);
    gl.EnableVertexAttribArray(1);
    gl.EnableVertexAttribArray(2);

    // Multisampled framebuffer, resolved into OSMesa's buffer after drawing.
    if (samples > 1) {
      GLint max_samples = 1;
      gl.GetIntegerv(GL_MAX_SAMPLES, &max_samples);
      samples = std::min(samples, std::max(1, static_cast<int>(max_samples)));
    }
    if (samples > 1) {
      gl.GenRenderbuffers(1, &msaa_colour);
      gl.BindRenderbuffer(GL_RENDERBUFFER, msaa_colour);
      gl.RenderbufferStorageMultisample(GL_RENDERBUFFER, samples, GL_RGBA8, width, height);
      gl.GenRenderbuffers(1, &msaa_depth);
      gl.BindRenderbuffer(GL_RENDERBUFFER, msaa_depth);
      gl.RenderbufferStorageMultisample(GL_RENDERBUFFER, samples, GL_DEPTH_COMPONENT24, width, height);
      gl.GenFramebuffers(1, &msaa_framebuffer);
      gl.BindFramebuffer(GL_FRAMEBUFFER, msaa_framebuffer);
      gl.FramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, msaa_colour);
      gl.FramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, msaa_depth);
      if (gl.CheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE) {
        throw RenderError("OSMesa: the " + std::to_string(samples) + "-sample framebuffer is incomplete");
      }
      gl.BindFramebuffer(GL_FRAMEBUFFER, 0);
    }

    GLfloat range[2] = {1.0f, 1.0f};
    gl.GetFloatv(GL_ALIASED_LINE_WIDTH_RANGE, range);
    max_line_width = std::max(1.0f, range[1]);
    check_gl("creating the shader pipeline");
  }

  void build_geometry(const RenderSnapshot& snap, const ViewSettings& view, const Vec3& origin,
                      size_t& triangle_index_count, size_t& edge_index_count, size_t& point_first,
                      size_t& point_count, size_t& line_first, size_t& line_vertex_count);
  void draw_overlays(Image& image, const RenderSnapshot& snap, const ViewSettings& view) const;
};

void OffscreenRenderer::Impl::build_geometry(const RenderSnapshot& snap, const ViewSettings& view, const Vec3& origin,
                                             size_t& triangle_index_count, size_t& edge_index_count,
                                             size_t& point_first, size_t& point_count, size_t& line_first,
                                             size_t& line_vertex_count) {
  vertices.clear();
  indices.clear();

  // Surfaces: one vertex per triangle corner, so a corner can take its own normal: the
  // area-weighted sum of the normals of the triangles around the vertex that lie within the crease
  // angle of this triangle. Smooth over gentle curvature (tissue), sharp at box edges.
  const double cos_crease = std::cos(std::clamp(view.crease_angle_deg, 0.0, 180.0) * std::numbers::pi / 180.0);
  for (const BodySnapshot& body : snap.bodies) {
    if (!body.mesh) continue;
    const TetMesh& mesh = *body.mesh;
    const auto& triangles = mesh.surface_triangles();
    const auto& x = body.positions;
    normals.resize(triangles.size());  // area-weighted face normals (length = 2 * area)
    for (size_t t = 0; t < triangles.size(); ++t) {
      const TriIndices& tri = triangles[t];
      normals[t] = (x[static_cast<size_t>(tri[1])] - x[static_cast<size_t>(tri[0])])
                       .cross(x[static_cast<size_t>(tri[2])] - x[static_cast<size_t>(tri[0])]);
    }
    const bool mapped = !body.scalar_field.empty() && body.scalar_field.size() == x.size();
    for (size_t t = 0; t < triangles.size(); ++t) {
      const double face_length = normals[t].norm();
      const Vec3 face_unit = face_length > 0.0 ? Vec3(normals[t] / face_length) : Vec3::UnitZ();
      for (int v : triangles[t]) {
        Vec3 n = Vec3::Zero();
        for (int s : mesh.vertex_surface_triangles(v)) {
          const Vec3& other = normals[static_cast<size_t>(s)];
          const double other_length = other.norm();
          if (other_length > 0.0 && other.dot(face_unit) >= cos_crease * other_length) n += other;
        }
        const double len = n.norm();
        const Rgba8 c = mapped ? colour_map(normalised(body.scalar_field[static_cast<size_t>(v)], snap.field_min,
                                                       snap.field_max))
                               : body.colour;
        indices.push_back(static_cast<std::uint32_t>(vertices.size()));
        vertices.push_back(make_vertex(x[static_cast<size_t>(v)] - origin, len > 0.0 ? Vec3(n / len) : face_unit, c));
      }
    }
  }
  triangle_index_count = indices.size();

  // Wireframe: every surface edge once, over a shared-vertex copy of the positions.
  if (view.wireframe) {
    for (const BodySnapshot& body : snap.bodies) {
      if (!body.mesh) continue;
      const auto base = static_cast<std::uint32_t>(vertices.size());
      for (const Vec3& p : body.positions) vertices.push_back(make_vertex(p - origin, Vec3::UnitZ(), view.wireframe_colour));
      edges.clear();
      for (const TriIndices& t : body.mesh->surface_triangles()) {
        for (int k = 0; k < 3; ++k) {
          const int a = t[static_cast<size_t>(k)];
          const int b = t[static_cast<size_t>((k + 1) % 3)];
          edges.emplace_back(std::min(a, b), std::max(a, b));
        }
      }
      std::sort(edges.begin(), edges.end());
      edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
      for (const auto& [a, b] : edges) {
        indices.push_back(base + static_cast<std::uint32_t>(a));
        indices.push_back(base + static_cast<std::uint32_t>(b));
      }
    }
  }
  edge_index_count = indices.size() - triangle_index_count;

  // Contact points.
  point_first = vertices.size();
  if (view.contact_points) {
    for (const Vec3& p : snap.contact_points) vertices.push_back(make_vertex(p - origin, Vec3::UnitZ(), view.contact_point_colour));
  }
  point_count = vertices.size() - point_first;

  // Arrows: a shaft and a four-line head, a quarter of the length.
  line_first = vertices.size();
  if (view.arrows) {
    for (const ForceArrow& arrow : snap.arrows) {
      const double length = arrow.vector.norm();
      if (!(length > 0.0)) continue;
      const Vec3 from = arrow.origin - origin;
      const Vec3 tip = from + arrow.vector;
      const Vec3 d = arrow.vector / length;
      const Vec3 u = any_perpendicular(d);
      const Vec3 w = d.cross(u);
      const double head = 0.25 * length;
      const Vec3 back = tip - head * d;
      const Vec3 ends[4] = {back + 0.4 * head * u, back - 0.4 * head * u, back + 0.4 * head * w, back - 0.4 * head * w};
      vertices.push_back(make_vertex(from, d, arrow.colour));
      vertices.push_back(make_vertex(tip, d, arrow.colour));
      for (const Vec3& e : ends) {
        vertices.push_back(make_vertex(tip, d, arrow.colour));
        vertices.push_back(make_vertex(e, d, arrow.colour));
      }
    }
  }
  line_vertex_count = vertices.size() - line_first;
}

void OffscreenRenderer::Impl::draw_overlays(Image& image, const RenderSnapshot& snap, const ViewSettings& view) const {
  const int scale = view.text_scale > 0 ? view.text_scale : (height >= 720 ? 2 : 1);
  const Rgba8 ink{240, 240, 240, 255};
  const Rgba8 shadow{0, 0, 0, 255};
  const auto shadowed_text = [&](int x, int y, const std::string& s) {
    draw_text(image, x + scale, y + scale, s, shadow, scale);
    draw_text(image, x, y, s, ink, scale);
  };

  if (view.text) {
    int y = 3 * scale;
    for (const std::string& line : snap.overlay_lines) {
      shadowed_text(3 * scale, y, line);
      y += kLineHeight * scale;
    }
  }

  // Legend: a vertical colour bar on the right, max at the top, min at the bottom.
  if (view.legend && snap.has_scalar_field()) {
    const int bar_width = std::max(4, width / 40);
    const int right = width - 3 * scale - 1;
    const int left = right - bar_width + 1;
    const int top = std::max(kLineHeight * scale * 2, height / 5);
    const int bottom = height - std::max(kLineHeight * scale, height / 10);
    if (bottom > top) {
      for (int y = top; y <= bottom; ++y) {
        const Rgba8 c = colour_map(static_cast<double>(bottom - y) / static_cast<double>(bottom - top));
        for (int x = left; x <= right; ++x) image.set_pixel(x, y, c);
      }
      const std::string hi = format_value(snap.field_max);
      const std::string lo = format_value(snap.field_min);
      shadowed_text(left - 2 * scale - text_width(hi, scale), top, hi);
      shadowed_text(left - 2 * scale - text_width(lo, scale), bottom - kGlyphHeight * scale + 1, lo);
      if (!snap.field_name.empty()) {
        shadowed_text(right - text_width(snap.field_name, scale), top - kLineHeight * scale, snap.field_name);
      }
    }
  }
}

OffscreenRenderer::OffscreenRenderer(int width, int height, int samples) : impl_(std::make_unique<Impl>()) {
  if (width <= 0 || height <= 0) {
    throw RenderError("OffscreenRenderer: image size must be positive, got " + std::to_string(width) + "x" +
                      std::to_string(height));
  }
  FpEnvironmentHold hold;
  Impl& r = *impl_;
  r.width = width;
  r.height = height;
  r.samples = std::max(1, samples);
  r.colour_buffer.assign(static_cast<size_t>(width) * static_cast<size_t>(height) * 4u, 0);

  // Core profile 3.3 first, then a 3.3 compatibility context, then whatever legacy OSMesa gives.
  const int core_attribs[] = {OSMESA_FORMAT, OSMESA_RGBA, OSMESA_DEPTH_BITS, 24, OSMESA_STENCIL_BITS, 0,
                              OSMESA_ACCUM_BITS, 0, OSMESA_PROFILE, OSMESA_CORE_PROFILE,
                              OSMESA_CONTEXT_MAJOR_VERSION, 3, OSMESA_CONTEXT_MINOR_VERSION, 3, 0};
  r.context = OSMesaCreateContextAttribs(core_attribs, nullptr);
  r.core = r.context != nullptr;
  if (r.context == nullptr) {
    const int compat_attribs[] = {OSMESA_FORMAT, OSMESA_RGBA, OSMESA_DEPTH_BITS, 24, OSMESA_PROFILE,
                                  OSMESA_COMPAT_PROFILE, OSMESA_CONTEXT_MAJOR_VERSION, 3,
                                  OSMESA_CONTEXT_MINOR_VERSION, 3, 0};
    r.context = OSMesaCreateContextAttribs(compat_attribs, nullptr);
  }
  if (r.context == nullptr) r.context = OSMesaCreateContextExt(OSMESA_RGBA, 24, 0, 0, nullptr);
  if (r.context == nullptr) {
    throw RenderError(
        "OSMesa: cannot create an off-screen OpenGL context (tried core 3.3, compatibility 3.3 and legacy); "
        "check that libOSMesa with the llvmpipe driver is installed and GALLIUM_DRIVER is unset or 'llvmpipe'");
  }
  try {
    r.make_current();
    GLint max_width = 0, max_height = 0;
    OSMesaGetIntegerv(OSMESA_MAX_WIDTH, &max_width);
    OSMesaGetIntegerv(OSMESA_MAX_HEIGHT, &max_height);
    if ((max_width > 0 && width > max_width) || (max_height > 0 && height > max_height)) {
      throw RenderError("OSMesa: a " + std::to_string(width) + "x" + std::to_string(height) +
                        " image exceeds the largest off-screen buffer, " + std::to_string(max_width) + "x" +
                        std::to_string(max_height));
    }
    if (const char* missing = r.gl.load(); missing != nullptr) {
      throw RenderError(std::string("OSMesa: the context lacks ") + missing + " (OpenGL 3.3 required)");
    }
    const auto* version = reinterpret_cast<const char*>(r.gl.GetString(GL_VERSION));
    const auto* renderer = reinterpret_cast<const char*>(r.gl.GetString(GL_RENDERER));
    r.version = version != nullptr ? version : "";
    r.renderer = renderer != nullptr ? renderer : "";
    int major = 0, minor = 0;
    if (std::sscanf(r.version.c_str(), "%d.%d", &major, &minor) != 2 || major * 10 + minor < 33) {
      throw RenderError("OSMesa: OpenGL 3.3 required, the context offers '" + r.version + "' (" + r.renderer + ")");
    }
    r.create_pipeline();
  } catch (...) {
    Impl::release();
    OSMesaDestroyContext(r.context);
    r.context = nullptr;
    throw;
  }
  Impl::release();
}

OffscreenRenderer::~OffscreenRenderer() {
  if (!impl_ || impl_->context == nullptr) return;
  FpEnvironmentHold hold;
  Impl& r = *impl_;
  if (OSMesaMakeCurrent(r.context, r.colour_buffer.data(), GL_UNSIGNED_BYTE, r.width, r.height) != 0) {
    r.gl.DeleteBuffers(1, &r.vbo);
    r.gl.DeleteBuffers(1, &r.ebo);
    r.gl.DeleteVertexArrays(1, &r.vao);
    r.gl.DeleteProgram(r.program);
    if (r.msaa_framebuffer != 0) {
      r.gl.DeleteFramebuffers(1, &r.msaa_framebuffer);
      r.gl.DeleteRenderbuffers(1, &r.msaa_colour);
      r.gl.DeleteRenderbuffers(1, &r.msaa_depth);
    }
    Impl::release();
  }
  OSMesaDestroyContext(r.context);
}

int OffscreenRenderer::width() const { return impl_->width; }
int OffscreenRenderer::height() const { return impl_->height; }
const std::string& OffscreenRenderer::gl_version() const { return impl_->version; }
const std::string& OffscreenRenderer::gl_renderer() const { return impl_->renderer; }
bool OffscreenRenderer::core_profile() const { return impl_->core; }
int OffscreenRenderer::samples() const { return impl_->samples; }

Image OffscreenRenderer::render(const RenderSnapshot& snapshot, const ViewSettings& view) {
  FpEnvironmentHold hold;
  Impl& r = *impl_;
  r.make_current();
  struct Release {
    ~Release() { Impl::release(); }
  } release_on_exit;
  auto& gl = r.gl;

  // Camera and clip distances from the scene's box (positions relative to its centre).
  const double aspect = static_cast<double>(r.width) / static_cast<double>(r.height);
  const Aabb box = snapshot.bounds();
  const Camera camera = view.camera ? *view.camera : frame_bounds(box, aspect);
  const Vec3 origin = box.empty() ? Vec3::Zero() : box.center();
  double nearest = std::numeric_limits<double>::infinity();
  double farthest = 0.0;
  if (!box.empty()) {
    for (int corner = 0; corner < 8; ++corner) {
      const Vec3 p((corner & 1) ? box.max.x() : box.min.x(), (corner & 2) ? box.max.y() : box.min.y(),
                   (corner & 4) ? box.max.z() : box.min.z());
      const double depth = camera.depth_of(p);
      nearest = std::min(nearest, depth);
      farthest = std::max(farthest, depth);
    }
  }
  if (!(farthest > 0.0)) farthest = 1.0;
  const double far_clip = 1.05 * farthest + 1e-6;
  const double near_clip = std::max({0.95 * nearest, 1e-4 * far_clip});
  Camera relative = camera;
  relative.position -= origin;
  relative.target -= origin;
  const auto view_projection = relative.view_projection(aspect, near_clip, far_clip);
  const auto view_matrix = relative.view();

  size_t triangle_index_count = 0, edge_index_count = 0, point_first = 0, point_count = 0, line_first = 0,
         line_vertex_count = 0;
  r.build_geometry(snapshot, view, origin, triangle_index_count, edge_index_count, point_first, point_count,
                   line_first, line_vertex_count);

  gl.BindFramebuffer(GL_FRAMEBUFFER, r.msaa_framebuffer);
  gl.Viewport(0, 0, r.width, r.height);
  gl.ClearColor(view.background.r / 255.0f, view.background.g / 255.0f, view.background.b / 255.0f, 1.0f);
  gl.Enable(GL_DEPTH_TEST);
  gl.DepthFunc(GL_LESS);
  gl.Clear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);

  gl.UseProgram(r.program);
  gl.BindVertexArray(r.vao);
  gl.BindBuffer(GL_ARRAY_BUFFER, r.vbo);
  gl.BufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(r.vertices.size() * sizeof(Vertex)), r.vertices.data(),
                GL_STREAM_DRAW);
  gl.BufferData(GL_ELEMENT_ARRAY_BUFFER, static_cast<GLsizeiptr>(r.indices.size() * sizeof(std::uint32_t)),
                r.indices.data(), GL_STREAM_DRAW);
  gl.UniformMatrix4fv(r.u_view_projection, 1, GL_FALSE, view_projection.data());
  gl.UniformMatrix4fv(r.u_view, 1, GL_FALSE, view_matrix.data());
  gl.Uniform1f(r.u_point_size, view.contact_point_size);
  gl.Uniform1i(r.u_use_uniform_colour, 0);

  // Shaded surfaces, pushed back a little so the wireframe wins the depth test.
  if (triangle_index_count > 0) {
    gl.Uniform1i(r.u_lit, 1);
    gl.Enable(GL_POLYGON_OFFSET_FILL);
    gl.PolygonOffset(1.0f, 1.0f);
    gl.DrawElements(GL_TRIANGLES, static_cast<GLsizei>(triangle_index_count), GL_UNSIGNED_INT, nullptr);
    gl.Disable(GL_POLYGON_OFFSET_FILL);
  }
  gl.Uniform1i(r.u_lit, 0);
  if (edge_index_count > 0) {
    gl.Uniform1i(r.u_use_uniform_colour, 1);
    gl.Uniform3f(r.u_colour, view.wireframe_colour.r / 255.0f, view.wireframe_colour.g / 255.0f,
                 view.wireframe_colour.b / 255.0f);
    gl.LineWidth(1.0f);
    gl.DrawElements(GL_LINES, static_cast<GLsizei>(edge_index_count), GL_UNSIGNED_INT,
                    reinterpret_cast<const void*>(triangle_index_count * sizeof(std::uint32_t)));
    gl.Uniform1i(r.u_use_uniform_colour, 0);
  }
  // Instruments of measurement (contacts, forces) stay visible through the tissue.
  gl.Disable(GL_DEPTH_TEST);
  if (point_count > 0) {
    gl.Enable(GL_PROGRAM_POINT_SIZE);
    gl.DrawArrays(GL_POINTS, static_cast<GLint>(point_first), static_cast<GLsizei>(point_count));
  }
  if (line_vertex_count > 0) {
    gl.LineWidth(std::clamp(view.arrow_width, 1.0f, r.max_line_width));
    gl.DrawArrays(GL_LINES, static_cast<GLint>(line_first), static_cast<GLsizei>(line_vertex_count));
    gl.LineWidth(1.0f);
  }

  // Resolve the samples into OSMesa's buffer.
  if (r.msaa_framebuffer != 0) {
    gl.BindFramebuffer(GL_READ_FRAMEBUFFER, r.msaa_framebuffer);
    gl.BindFramebuffer(GL_DRAW_FRAMEBUFFER, 0);
    gl.BlitFramebuffer(0, 0, r.width, r.height, 0, 0, r.width, r.height, GL_COLOR_BUFFER_BIT, GL_NEAREST);
    gl.BindFramebuffer(GL_FRAMEBUFFER, 0);
  }

  // Read back (GL rows are bottom-up) and flip into a top-down image.
  r.pixels.resize(static_cast<size_t>(r.width) * static_cast<size_t>(r.height) * 4u);
  gl.PixelStorei(GL_PACK_ALIGNMENT, 1);
  gl.ReadPixels(0, 0, r.width, r.height, GL_RGBA, GL_UNSIGNED_BYTE, r.pixels.data());
  r.check_gl("drawing a frame");
  Image image(r.width, r.height);
  const size_t row_bytes = static_cast<size_t>(r.width) * 4u;
  for (int y = 0; y < r.height; ++y) {
    std::copy_n(r.pixels.begin() + static_cast<std::ptrdiff_t>(static_cast<size_t>(r.height - 1 - y) * row_bytes),
                row_bytes, image.rgba.begin() + static_cast<std::ptrdiff_t>(static_cast<size_t>(y) * row_bytes));
  }
  for (size_t i = 3; i < image.rgba.size(); i += 4) image.rgba[i] = 255;

  r.draw_overlays(image, snapshot, view);
  return image;
}

}  // namespace pliant
