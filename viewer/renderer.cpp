#include "viewer/renderer.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdio>
#include <cstring>
#include <string>

#include <stb_easy_font.h>

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
layout(location = 3) in float a_value;
uniform mat4 u_mvp;
uniform mat4 u_view;
uniform vec4 u_clip;
uniform vec3 u_regions[4];
uniform vec3 u_wound;
uniform vec3 u_section;
uniform float u_alpha;
uniform int u_field;
out vec4 v_front;
out vec4 v_back;
out float v_value;
out vec2 v_shade;
void main() {
  gl_Position = u_mvp * vec4(a_position, 1.0);
  gl_ClipDistance[0] = dot(u_clip, vec4(a_position, 1.0));
  int region = int(floor(a_region + 0.5));
  bool wound = region < 0;
  vec3 base = wound ? u_wound : u_regions[clamp(region, 0, 3)];
  vec3 n = normalize(mat3(u_view) * a_normal);
  vec3 light = normalize(vec3(0.35, 0.55, 1.0));
  float diffuse = 0.35 + 0.65 * max(dot(n, light), 0.0);
  vec3 colour = base * diffuse;
  // The wound is wet: a small highlight.
  float highlight = wound ? 0.25 * pow(max(dot(reflect(-light, n), vec3(0.0, 0.0, 1.0)), 0.0), 24.0) : 0.0;
  colour += vec3(highlight);
  v_front = vec4(colour, wound ? 1.0 : u_alpha);
  v_back = vec4(wound ? u_section : 0.8 * base, 1.0);
  // With a field, the fragment stage looks the colour up from the interpolated value (interpolated
  // colours would blend across the map); the lighting stays per vertex.
  v_value = a_value;
  v_shade = vec2(diffuse, u_field != 0 && wound ? highlight : 0.0);
}
)";

constexpr const char* kSurfaceFragment = R"(#version 330 core
in vec4 v_front;
in vec4 v_back;
in float v_value;
in vec2 v_shade;
uniform int u_field;
uniform vec2 u_range;
uniform vec3 u_colour_map[9];
out vec4 o_colour;
vec3 colour_map(float value) {
  float t = 8.0 * clamp((value - u_range.x) / (u_range.y - u_range.x), 0.0, 1.0);
  int i = min(int(floor(t)), 7);
  return mix(u_colour_map[i], u_colour_map[i + 1], t - float(i));
}
void main() {
  if (u_field == 0) {
    o_colour = gl_FrontFacing ? v_front : v_back;
    return;
  }
  vec3 base = colour_map(v_value);
  o_colour = gl_FrontFacing ? vec4(base * v_shade.x + vec3(v_shade.y), v_front.a) : vec4(0.8 * base, 1.0);
}
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
constexpr double kMaxHandleLength = 0.04;                                              // [m]

}  // namespace

std::array<float, 3> Palette::colour(ColourMap map, double value, double lo, double hi) {
  const ColourMapStops& c = stops(map);
  const double t = 8.0 * std::clamp((value - lo) / (hi - lo), 0.0, 1.0);
  const int i = std::min(static_cast<int>(std::floor(t)), 7);
  const auto f = static_cast<float>(t - i);
  std::array<float, 3> out{};
  for (std::size_t k = 0; k < 3; ++k)
    out[k] = c[static_cast<size_t>(i)][k] * (1.0f - f) + c[static_cast<size_t>(i) + 1][k] * f;
  return out;
}

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
  glVertexAttribPointer(3, 1, GL_FLOAT, GL_FALSE, stride,
                        reinterpret_cast<void*>(offsetof(SurfaceVertex, value)));
  for (GLuint i = 0; i < 4; ++i) glEnableVertexAttribArray(i);

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
    if (!s.blade_spine.isZero()) {
      // The flats, from the edge back to the spine, which meets the edge at the tip: seen from
      // either side.
      const Vec3 a = s.blade_back, b = s.blade_tip, c = s.blade_back + s.blade_spine;
      const float shade = 0.6f + 0.4f * static_cast<float>(std::abs((b - a).cross(c - a).normalized().z()));
      for (const Vec3* p : {&a, &b, &c, &a, &c, &b})
        triangles_.push_back({to_float(*p), rgba(Palette::kBlade, 1.0f, shade)});
    }
    const Vec3 back = (s.blade_back - s.blade_tip).normalized();
    // The scenario's handle where it gives one (its contact shape, sim/tool_body.hpp), drawn no
    // longer than kMaxHandleLength so that the view stays on the tissue.
    const double radius = s.handle_radius > 0.0 ? s.handle_radius : kHandleRadius;
    const double length = s.handle_length > 0.0 ? std::min(s.handle_length, kMaxHandleLength) : kHandleLength;
    if (o.handle) prism(s.blade_back + back * length, s.blade_back, radius, Palette::kHandle);
  }
  if (o.wireframe) {
    const std::array<float, 4> colour{0.08f, 0.08f, 0.10f, 0.35f};
    for (const auto& p : s.edges) lines_.push_back({p, colour});
  }
}

void Renderer::build_legend(const FrameSnapshot::Field& field, int width, int height) {
  legend_.clear();
  auto rect = [&](float x0, float y0, float x1, float y1, const std::array<float, 4>& c) {
    const std::array<std::array<float, 3>, 4> p{{{x0, y0, 0}, {x1, y0, 0}, {x1, y1, 0}, {x0, y1, 0}}};
    for (const int k : {0, 1, 2, 0, 2, 3}) legend_.push_back({p[static_cast<size_t>(k)], c});
  };
  // stb_easy_font's glyphs are 7 pixels high at scale 1; drawn twice that size.
  constexpr float kScale = 2.0f;
  const std::array<float, 4> ink{0.92f, 0.93f, 0.95f, 1.0f};
  auto text = [&](float x, float y, const std::string& str) {
    text_.resize(str.size() * 300 + 64);
    std::vector<char> copy(str.begin(), str.end());
    copy.push_back('\0');
    const int quads =
        stb_easy_font_print(0, 0, copy.data(), nullptr, text_.data(), static_cast<int>(text_.size()));
    for (int q = 0; q < quads; ++q) {
      float v[4][2];
      for (int k = 0; k < 4; ++k) std::memcpy(v[k], text_.data() + (q * 4 + k) * 16, sizeof v[k]);
      rect(x + kScale * v[0][0], y + kScale * v[0][1], x + kScale * v[2][0], y + kScale * v[2][1], ink);
    }
  };
  auto label = [](double value) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.3g", value);
    return std::string(buf);
  };
  const auto h = static_cast<float>(height), w = static_cast<float>(width);
  const float bar_w = 0.025f * w, bar_x1 = w - 0.03f * w, bar_x0 = bar_x1 - bar_w;
  const float top = 0.22f * h, bottom = 0.78f * h;
  const float label_w = kScale * 6.0f * 8.0f;  // eight glyphs
  rect(bar_x0 - label_w - 24.0f, top - 56.0f, w - 0.01f * w, bottom + 20.0f, {0.05f, 0.06f, 0.08f, 0.75f});
  text(bar_x0 - label_w - 12.0f, top - 40.0f, field.name);
  constexpr int kSegments = 64;
  for (int k = 0; k < kSegments; ++k) {
    const float y0 = bottom - (bottom - top) * static_cast<float>(k + 1) / kSegments;
    const float y1 = bottom - (bottom - top) * static_cast<float>(k) / kSegments;
    const double v = field.lo + (field.hi - field.lo) * (k + 0.5) / kSegments;
    rect(bar_x0, y0, bar_x1, y1, rgba(Palette::colour(field.colour_map, v, field.lo, field.hi)));
  }
  for (int k = 0; k <= 4; ++k) {
    const float y = bottom - (bottom - top) * static_cast<float>(k) / 4.0f;
    rect(bar_x0 - 6.0f, y - 1.0f, bar_x0, y + 1.0f, ink);
    const std::string l = label(field.lo + (field.hi - field.lo) * k / 4.0);
    text(bar_x0 - 12.0f - kScale * 6.0f * static_cast<float>(l.size()), y - kScale * 3.5f, l);
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
  const bool field = s.field && o.field;
  glUniform1i(glGetUniformLocation(surface_program_, "u_field"), field ? 1 : 0);
  if (field) {
    const Eigen::Vector2f range(static_cast<float>(s.field->lo), static_cast<float>(s.field->hi));
    glUniform2fv(glGetUniformLocation(surface_program_, "u_range"), 1, range.data());
    glUniform3fv(glGetUniformLocation(surface_program_, "u_colour_map"), 9,
                 Palette::stops(s.field->colour_map)[0].data());
  }
  glBindVertexArray(surface_vao_);
  glBindBuffer(GL_ARRAY_BUFFER, surface_vbo_);
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(s.surface.size() * sizeof(SurfaceVertex)),
               s.surface.data(), GL_STREAM_DRAW);
  glEnable(GL_POLYGON_OFFSET_FILL);
  glPolygonOffset(1.0f, 1.0f);
  const auto wound = static_cast<GLsizei>(s.wound_vertices);
  const auto skin = static_cast<GLsizei>(s.surface.size() - s.wound_vertices);
  glUniform1f(alpha, 1.0f);
  // Without a section plane no back face can show (the surface is closed), and a crack's two lips
  // lie on one another until it gapes: drawn, the back one would fight the front one for depth.
  if (!o.clip) {
    glEnable(GL_CULL_FACE);
    glCullFace(GL_BACK);
  }
  if (!o.transparent_skin) {
    glDrawArrays(GL_TRIANGLES, 0, wound + skin);
    glDisable(GL_CULL_FACE);
  } else {
    // The wound opaque, then the skin's front faces blended over it without hiding it.
    glDrawArrays(GL_TRIANGLES, 0, wound);
    glDisable(GL_CULL_FACE);
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
  if (field && o.legend) {
    // In pixels, y down, over everything.
    build_legend(*s.field, width, height);
    Eigen::Matrix4f pixels = Eigen::Matrix4f::Identity();
    pixels(0, 0) = 2.0f / static_cast<float>(width);
    pixels(1, 1) = -2.0f / static_cast<float>(height);
    pixels(0, 3) = -1.0f;
    pixels(1, 3) = 1.0f;
    const Eigen::Vector4f none(0, 0, 0, 1);
    glUniformMatrix4fv(glGetUniformLocation(flat_program_, "u_mvp"), 1, GL_FALSE, pixels.data());
    glUniform4fv(glGetUniformLocation(flat_program_, "u_clip"), 1, none.data());
    glDisable(GL_DEPTH_TEST);
    draw_flat(GL_TRIANGLES, legend_);
    glEnable(GL_DEPTH_TEST);
  }
  glDisable(GL_BLEND);
  glDisable(GL_CLIP_DISTANCE0);
  glBindVertexArray(0);
  glUseProgram(0);
}

}  // namespace scalpel
