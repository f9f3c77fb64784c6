#include "viewer/renderer.hpp"

#include <cmath>
#include <cstddef>
#include <string>

#include <Eigen/Geometry>

#include "viewer/gl.hpp"

namespace scalpel {

namespace {

// Skin and wound: one light from above the eye's right shoulder, fixed to the camera, and an
// ambient term. Every triangle carries its own face normal, so lighting at the vertices is exact and
// the fragment stage only picks a colour: software rasterisers spend their time per fragment. A
// back face is the inside of the tissue, seen only where a section plane opens it: flat and darker,
// in the colour of the face's region, so the layers show in the section.
constexpr const char* kSurfaceVertex = R"(#version 330 core
layout(location = 0) in vec3 a_position;
layout(location = 1) in vec3 a_normal;
layout(location = 2) in float a_region;
uniform mat4 u_mvp;
uniform mat4 u_view;
uniform vec4 u_clip;
uniform vec3 u_regions[4];
uniform vec3 u_wound;
uniform vec3 u_section;
uniform float u_alpha;
out vec4 v_front;
out vec4 v_back;
void main() {
  gl_Position = u_mvp * vec4(a_position, 1.0);
  gl_ClipDistance[0] = dot(u_clip, vec4(a_position, 1.0));
  int region = int(floor(a_region + 0.5));
  bool wound = region < 0;
  vec3 base = wound ? u_wound : u_regions[clamp(region, 0, 3)];
  vec3 n = normalize(mat3(u_view) * a_normal);
  vec3 light = normalize(vec3(0.35, 0.55, 1.0));
  vec3 colour = base * (0.35 + 0.65 * max(dot(n, light), 0.0));
  // The wound is wet: a small highlight.
  if (wound) colour += vec3(0.25) * pow(max(dot(reflect(-light, n), vec3(0.0, 0.0, 1.0)), 0.0), 24.0);
  v_front = vec4(colour, wound ? 1.0 : u_alpha);
  v_back = vec4(wound ? u_section : 0.8 * base, 1.0);
}
)";

constexpr const char* kSurfaceFragment = R"(#version 330 core
in vec4 v_front;
in vec4 v_back;
out vec4 o_colour;
void main() { o_colour = gl_FrontFacing ? v_front : v_back; }
)";

constexpr const char* kFlatVertex = R"(#version 330 core
layout(location = 0) in vec3 a_position;
layout(location = 1) in vec4 a_colour;
uniform mat4 u_mvp;
uniform vec4 u_clip;
out vec4 v_colour;
void main() {
  gl_Position = u_mvp * vec4(a_position, 1.0);
  gl_ClipDistance[0] = dot(u_clip, vec4(a_position, 1.0));
  v_colour = a_colour;
}
)";

constexpr const char* kFlatFragment = R"(#version 330 core
in vec4 v_colour;
out vec4 o_colour;
void main() { o_colour = v_colour; }
)";

unsigned compile(GLenum kind, const char* source) {
  const GLuint s = glCreateShader(kind);
  glShaderSource(s, 1, &source, nullptr);
  glCompileShader(s);
  GLint ok = 0;
  glGetShaderiv(s, GL_COMPILE_STATUS, &ok);
  if (!ok) {
    char log[2048] = {};
    glGetShaderInfoLog(s, sizeof log, nullptr, log);
    glDeleteShader(s);
    throw RenderError(std::string("renderer: a shader does not compile: ") + log);
  }
  return s;
}

unsigned link(const char* vertex, const char* fragment) {
  const GLuint v = compile(GL_VERTEX_SHADER, vertex), f = compile(GL_FRAGMENT_SHADER, fragment);
  const GLuint p = glCreateProgram();
  glAttachShader(p, v);
  glAttachShader(p, f);
  glLinkProgram(p);
  glDeleteShader(v);
  glDeleteShader(f);
  GLint ok = 0;
  glGetProgramiv(p, GL_LINK_STATUS, &ok);
  if (!ok) {
    char log[2048] = {};
    glGetProgramInfoLog(p, sizeof log, nullptr, log);
    glDeleteProgram(p);
    throw RenderError(std::string("renderer: a shader program does not link: ") + log);
  }
  return p;
}

std::array<float, 3> to_float(const Vec3& v) {
  return {static_cast<float>(v.x()), static_cast<float>(v.y()), static_cast<float>(v.z())};
}

std::array<float, 4> rgba(const std::array<float, 3>& c, float alpha = 1.0f, float shade = 1.0f) {
  return {c[0] * shade, c[1] * shade, c[2] * shade, alpha};
}

// Target overlays float this far above the rest surface, so the skin does not cover them [m].
constexpr double kOverlayLift = 0.15e-3;
constexpr double kLineWidth = 0.2e-3;            // [m] target line and band edges
constexpr double kDash = 1.0e-3, kGap = 0.6e-3;  // [m] the target line's dashes
constexpr double kBladeRadius = 0.3e-3, kHandleRadius = 1.2e-3, kHandleLength = 0.02;  // [m]

}  // namespace

Renderer::Renderer() {
  surface_program_ = link(kSurfaceVertex, kSurfaceFragment);
  flat_program_ = link(kFlatVertex, kFlatFragment);

  glGenVertexArrays(1, &surface_vao_);
  glGenBuffers(1, &surface_vbo_);
  glBindVertexArray(surface_vao_);
  glBindBuffer(GL_ARRAY_BUFFER, surface_vbo_);
  constexpr auto stride = static_cast<GLsizei>(sizeof(SurfaceVertex));
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, stride,
                        reinterpret_cast<void*>(offsetof(SurfaceVertex, position)));
  glVertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, stride,
                        reinterpret_cast<void*>(offsetof(SurfaceVertex, normal)));
  glVertexAttribPointer(2, 1, GL_FLOAT, GL_FALSE, stride,
                        reinterpret_cast<void*>(offsetof(SurfaceVertex, region)));
  for (GLuint i = 0; i < 3; ++i) glEnableVertexAttribArray(i);

  glGenVertexArrays(1, &flat_vao_);
  glGenBuffers(1, &flat_vbo_);
  glBindVertexArray(flat_vao_);
  glBindBuffer(GL_ARRAY_BUFFER, flat_vbo_);
  constexpr auto flat_stride = static_cast<GLsizei>(sizeof(FlatVertex));
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, flat_stride,
                        reinterpret_cast<void*>(offsetof(FlatVertex, position)));
  glVertexAttribPointer(1, 4, GL_FLOAT, GL_FALSE, flat_stride,
                        reinterpret_cast<void*>(offsetof(FlatVertex, colour)));
  glEnableVertexAttribArray(0);
  glEnableVertexAttribArray(1);
  glBindVertexArray(0);
}

Renderer::~Renderer() {
  glDeleteBuffers(1, &surface_vbo_);
  glDeleteBuffers(1, &flat_vbo_);
  glDeleteVertexArrays(1, &surface_vao_);
  glDeleteVertexArrays(1, &flat_vao_);
  glDeleteProgram(surface_program_);
  glDeleteProgram(flat_program_);
}

void Renderer::build_overlays(const FrameSnapshot& s, const RenderOptions& o) {
  triangles_.clear();
  lines_.clear();
  auto quad = [&](const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d,
                  const std::array<float, 4>& colour) {
    for (const Vec3* p : {&a, &b, &c, &a, &c, &d}) triangles_.push_back({to_float(*p), colour});
  };
  // A ribbon of `width` on the surface from a to b.
  auto ribbon = [&](Vec3 a, Vec3 b, double width, const std::array<float, 4>& colour) {
    const Vec3 d = Vec3(b.x() - a.x(), b.y() - a.y(), 0.0).normalized();
    const Vec3 side = Vec3(-d.y(), d.x(), 0.0) * (width / 2);
    a.z() += kOverlayLift;
    b.z() += kOverlayLift;
    quad(a - side, b - side, b + side, a + side, colour);
  };
  for (const FrameSnapshot::Target& target : s.targets) {
    if (!o.target || target.path.size() < 2) continue;
    const auto colour = rgba(Palette::kTarget);
    const double tol = target.tolerance;
    for (std::size_t i = 0; i + 1 < target.path.size(); ++i) {
      const Vec3 a = target.path[i], b = target.path[i + 1];
      const double length = (b - a).head<2>().norm();
      if (length == 0.0) continue;
      const Vec3 d = (b - a) / length;
      const Vec3 side = Vec3(-d.y(), d.x(), 0.0).normalized() * tol;
      for (double u = 0; u < length; u += kDash + kGap)  // the target line, dashed
        ribbon(a + d * u, a + d * std::min(u + kDash, length), kLineWidth, colour);
      ribbon(a + side, b + side, kLineWidth, colour);  // the tolerance band's edges
      ribbon(a - side, b - side, kLineWidth, colour);
    }
    // The incision's ends, across the band.
    for (const std::size_t i : {std::size_t{0}, target.path.size() - 1}) {
      const Vec3 p = target.path[i];
      const Vec3 d = (target.path[i == 0 ? 1 : i] - target.path[i == 0 ? 0 : i - 1]).normalized();
      const Vec3 side = Vec3(-d.y(), d.x(), 0.0).normalized() * tol;
      ribbon(p - side, p + side, kLineWidth, colour);
    }
  }
  if (o.blade && s.has_blade && (s.blade_tip - s.blade_back).norm() > 0.0) {
    // The blade: a thin prism along its edge; the handle: a wider one behind it.
    auto prism = [&](const Vec3& from, const Vec3& to, double radius, const std::array<float, 3>& colour) {
      const Vec3 axis = (to - from).normalized();
      const Vec3 u = axis.unitOrthogonal(), v = axis.cross(u);
      constexpr int kSides = 8;
      for (int k = 0; k < kSides; ++k) {
        const double a0 = 2 * M_PI * k / kSides, a1 = 2 * M_PI * (k + 1) / kSides;
        const Vec3 r0 = radius * (std::cos(a0) * u + std::sin(a0) * v);
        const Vec3 r1 = radius * (std::cos(a1) * u + std::sin(a1) * v);
        // Shade each side by how it faces up, so the round shape reads.
        const float shade = 0.65f + 0.35f * static_cast<float>(std::abs((r0 + r1).normalized().z()));
        quad(from + r0, to + r0, to + r1, from + r1, rgba(colour, 1.0f, shade));
      }
    };
    prism(s.blade_back, s.blade_tip, kBladeRadius, Palette::kBlade);
    const Vec3 back = (s.blade_back - s.blade_tip).normalized();
    if (o.handle) prism(s.blade_back + back * kHandleLength, s.blade_back, kHandleRadius, Palette::kHandle);
  }
  if (o.wireframe) {
    const std::array<float, 4> colour{0.08f, 0.08f, 0.10f, 0.35f};
    for (const auto& p : s.edges) lines_.push_back({p, colour});
  }
}

void Renderer::draw_flat(unsigned mode, const std::vector<FlatVertex>& vertices) {
  if (vertices.empty()) return;
  glBindVertexArray(flat_vao_);
  glBindBuffer(GL_ARRAY_BUFFER, flat_vbo_);
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(vertices.size() * sizeof(FlatVertex)),
               vertices.data(), GL_STREAM_DRAW);
  glDrawArrays(mode, 0, static_cast<GLsizei>(vertices.size()));
}

void Renderer::draw(const FrameSnapshot& s, const Camera& camera, const RenderOptions& o, int width,
                    int height) {
  glViewport(0, 0, width, height);
  const auto& bg = Palette::kBackground;
  glClearColor(bg[0], bg[1], bg[2], 1.0f);
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LEQUAL);
  glDisable(GL_CULL_FACE);
  glBlendFunc(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA);

  const Eigen::Matrix4d view = camera.view();
  const Eigen::Matrix4f mvp = (camera.projection(static_cast<double>(width) / height) * view).cast<float>();
  const Eigen::Matrix4f view_f = view.cast<float>();
  const Eigen::Vector4f clip = o.clip ? o.clip->cast<float>() : Eigen::Vector4f(0, 0, 0, 1);
  if (o.clip)
    glEnable(GL_CLIP_DISTANCE0);
  else
    glDisable(GL_CLIP_DISTANCE0);

  // The surface, pushed back a little so lines on it win the depth test.
  glUseProgram(surface_program_);
  glUniformMatrix4fv(glGetUniformLocation(surface_program_, "u_mvp"), 1, GL_FALSE, mvp.data());
  glUniformMatrix4fv(glGetUniformLocation(surface_program_, "u_view"), 1, GL_FALSE, view_f.data());
  glUniform4fv(glGetUniformLocation(surface_program_, "u_clip"), 1, clip.data());
  glUniform3fv(glGetUniformLocation(surface_program_, "u_regions"), 4, Palette::kRegions[0].data());
  glUniform3fv(glGetUniformLocation(surface_program_, "u_wound"), 1, Palette::kWound.data());
  glUniform3fv(glGetUniformLocation(surface_program_, "u_section"), 1, Palette::kSection.data());
  const GLint alpha = glGetUniformLocation(surface_program_, "u_alpha");
  glBindVertexArray(surface_vao_);
  glBindBuffer(GL_ARRAY_BUFFER, surface_vbo_);
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(s.surface.size() * sizeof(SurfaceVertex)),
               s.surface.data(), GL_STREAM_DRAW);
  glEnable(GL_POLYGON_OFFSET_FILL);
  glPolygonOffset(1.0f, 1.0f);
  const auto wound = static_cast<GLsizei>(s.wound_vertices);
  const auto skin = static_cast<GLsizei>(s.surface.size() - s.wound_vertices);
  glUniform1f(alpha, 1.0f);
  if (!o.transparent_skin) {
    glDrawArrays(GL_TRIANGLES, 0, wound + skin);
  } else {
    // The wound opaque, then the skin's front faces blended over it without hiding it.
    glDrawArrays(GL_TRIANGLES, 0, wound);
    glUniform1f(alpha, 0.25f);
    glEnable(GL_BLEND);
    glEnable(GL_CULL_FACE);
    glCullFace(GL_BACK);
    glDepthMask(GL_FALSE);
    glDrawArrays(GL_TRIANGLES, wound, skin);
    glDepthMask(GL_TRUE);
    glDisable(GL_CULL_FACE);
    glDisable(GL_BLEND);
  }
  glDisable(GL_POLYGON_OFFSET_FILL);

  build_overlays(s, o);
  glUseProgram(flat_program_);
  glUniformMatrix4fv(glGetUniformLocation(flat_program_, "u_mvp"), 1, GL_FALSE, mvp.data());
  glUniform4fv(glGetUniformLocation(flat_program_, "u_clip"), 1, clip.data());
  glEnable(GL_BLEND);
  draw_flat(GL_LINES, lines_);
  draw_flat(GL_TRIANGLES, triangles_);
  glDisable(GL_BLEND);
  glDisable(GL_CLIP_DISTANCE0);
  glBindVertexArray(0);
  glUseProgram(0);
}

}  // namespace scalpel
