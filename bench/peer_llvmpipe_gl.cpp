#include "peer_llvmpipe_gl.h"

#include <GL/osmesa.h>
#include <GL/gl.h>
#include <GL/glext.h>

#include <cstdlib>
#include <cstring>

namespace peer {
namespace {

// Full G-buffer: de-indexed vertices, so vertex 3t+k is corner k of triangle
// t and the noperspective varying (k == 1, k == 2) interpolates to exactly the
// screen-space barycentrics (u, v) of corners 1 and 2, as in our G-buffer.
const char* kGBufferVS = R"(#version 330 core
layout(location = 0) in vec4 clip;
noperspective out vec2 bary;
void main() {
  int k = gl_VertexID % 3;
  bary = vec2(k == 1 ? 1.0 : 0.0, k == 2 ? 1.0 : 0.0);
  gl_Position = clip;
})";
const char* kGBufferFS = R"(#version 330 core
noperspective in vec2 bary;
layout(location = 0) out int tri_id;
layout(location = 1) out vec2 uv;
void main() {
  tri_id = gl_PrimitiveID + 1;
  uv = bary;
})";
// Id-only pass on the indexed mesh (shared vertices, no barycentrics).
const char* kIdVS = R"(#version 330 core
layout(location = 0) in vec4 clip;
void main() { gl_Position = clip; })";
const char* kIdFS = R"(#version 330 core
layout(location = 0) out int tri_id;
void main() { tri_id = gl_PrimitiveID + 1; })";

GLuint compile(GLenum kind, const char* source, std::string* error) {
  GLuint shader = glCreateShader(kind);
  glShaderSource(shader, 1, &source, nullptr);
  glCompileShader(shader);
  GLint ok = 0;
  glGetShaderiv(shader, GL_COMPILE_STATUS, &ok);
  if (!ok) {
    char log[2048] = {0};
    glGetShaderInfoLog(shader, sizeof log, nullptr, log);
    *error += std::string("shader compile failed: ") + log;
    return 0;
  }
  return shader;
}

GLuint link(const char* vs_source, const char* fs_source, std::string* error) {
  GLuint vs = compile(GL_VERTEX_SHADER, vs_source, error);
  GLuint fs = compile(GL_FRAGMENT_SHADER, fs_source, error);
  if (!vs || !fs) return 0;
  GLuint program = glCreateProgram();
  glAttachShader(program, vs);
  glAttachShader(program, fs);
  glLinkProgram(program);
  glDeleteShader(vs);
  glDeleteShader(fs);
  GLint ok = 0;
  glGetProgramiv(program, GL_LINK_STATUS, &ok);
  if (!ok) {
    char log[2048] = {0};
    glGetProgramInfoLog(program, sizeof log, nullptr, log);
    *error += std::string("program link failed: ") + log;
    return 0;
  }
  return program;
}

}  // namespace

struct LlvmpipeRasterizer::State {
  OSMesaContext context = nullptr;
  std::vector<unsigned char> default_buffer;  // OSMesa needs one; we draw into the FBO
  std::string kind;
  int width = 0, height = 0;
  GLuint fbo = 0, rb_id = 0, rb_uv = 0, rb_depth = 0;
  GLuint gbuffer_program = 0, id_program = 0;
  GLuint vao_flat = 0, vbo_flat = 0, vao_indexed = 0, vbo_indexed = 0, ebo = 0;
  GLsizei flat_vertices = 0, index_count = 0;
  bool last_was_id_only = false;
};

std::unique_ptr<LlvmpipeRasterizer> LlvmpipeRasterizer::create(int width, int height,
                                                               int lp_threads, std::string* error) {
  // Read by llvmpipe when its screen is created, i.e. before the first context.
  setenv("LP_NUM_THREADS", std::to_string(lp_threads).c_str(), 1);
  setenv("GALLIUM_DRIVER", "llvmpipe", 1);
  std::unique_ptr<LlvmpipeRasterizer> r(new LlvmpipeRasterizer());
  r->s_ = std::make_unique<State>();
  if (!r->init(width, height, error)) return nullptr;
  return r;
}

bool LlvmpipeRasterizer::init(int width, int height, std::string* error) {
  State& s = *s_;
  s.width = width;
  s.height = height;
  const int core_attribs[] = {OSMESA_FORMAT, OSMESA_RGBA, OSMESA_DEPTH_BITS, 0,
                              OSMESA_STENCIL_BITS, 0, OSMESA_ACCUM_BITS, 0,
                              OSMESA_PROFILE, OSMESA_CORE_PROFILE,
                              OSMESA_CONTEXT_MAJOR_VERSION, 3, OSMESA_CONTEXT_MINOR_VERSION, 3, 0};
  s.context = OSMesaCreateContextAttribs(core_attribs, nullptr);
  s.kind = "OSMesa core profile context";
  if (!s.context) {
    s.context = OSMesaCreateContextExt(OSMESA_RGBA, 0, 0, 0, nullptr);
    s.kind = "OSMesa legacy context";
  }
  if (!s.context) {
    *error = "OSMesa context creation failed";
    return false;
  }
  s.default_buffer.assign(16 * 16 * 4, 0);
  if (!OSMesaMakeCurrent(s.context, s.default_buffer.data(), GL_UNSIGNED_BYTE, 16, 16)) {
    *error = "OSMesaMakeCurrent failed";
    return false;
  }
  s.gbuffer_program = link(kGBufferVS, kGBufferFS, error);
  s.id_program = link(kIdVS, kIdFS, error);
  if (!s.gbuffer_program || !s.id_program) return false;

  auto renderbuffer = [&](GLenum format, GLenum attachment) {
    GLuint rb = 0;
    glGenRenderbuffers(1, &rb);
    glBindRenderbuffer(GL_RENDERBUFFER, rb);
    glRenderbufferStorage(GL_RENDERBUFFER, format, width, height);
    glFramebufferRenderbuffer(GL_FRAMEBUFFER, attachment, GL_RENDERBUFFER, rb);
    return rb;
  };
  glGenFramebuffers(1, &s.fbo);
  glBindFramebuffer(GL_FRAMEBUFFER, s.fbo);
  s.rb_id = renderbuffer(GL_R32I, GL_COLOR_ATTACHMENT0);
  s.rb_uv = renderbuffer(GL_RG32F, GL_COLOR_ATTACHMENT1);
  s.rb_depth = renderbuffer(GL_DEPTH_COMPONENT32F, GL_DEPTH_ATTACHMENT);
  if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE) {
    *error = "FBO incomplete (R32I + RG32F + DEPTH_COMPONENT32F)";
    return false;
  }
  glViewport(0, 0, width, height);
  glDisable(GL_CULL_FACE);
  glDisable(GL_BLEND);
  glDisable(GL_DITHER);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LESS);
  glDepthMask(GL_TRUE);
  if (GLenum e = glGetError(); e != GL_NO_ERROR) {
    *error = "GL error during setup: " + std::to_string(e);
    return false;
  }
  return true;
}

LlvmpipeRasterizer::~LlvmpipeRasterizer() {
  if (s_ && s_->context) OSMesaDestroyContext(s_->context);
}

std::string LlvmpipeRasterizer::description() const {
  auto str = [](GLenum name) {
    const GLubyte* v = glGetString(name);
    return v ? std::string(reinterpret_cast<const char*>(v)) : std::string("?");
  };
  return str(GL_RENDERER) + " | GL " + str(GL_VERSION) + " | " + s_->kind;
}

void LlvmpipeRasterizer::upload(const float* clip, std::int64_t num_vertices,
                                const std::int32_t* tris, std::int64_t num_tris) {
  State& s = *s_;
  std::vector<float> flat(static_cast<std::size_t>(num_tris) * 12);
  for (std::int64_t t = 0; t < num_tris; ++t)
    for (int k = 0; k < 3; ++k)
      std::memcpy(&flat[(t * 3 + k) * 4], clip + 4 * tris[t * 3 + k], 4 * sizeof(float));
  if (!s.vao_flat) {
    glGenVertexArrays(1, &s.vao_flat);
    glGenBuffers(1, &s.vbo_flat);
    glGenVertexArrays(1, &s.vao_indexed);
    glGenBuffers(1, &s.vbo_indexed);
    glGenBuffers(1, &s.ebo);
  }
  glBindVertexArray(s.vao_flat);
  glBindBuffer(GL_ARRAY_BUFFER, s.vbo_flat);
  glBufferData(GL_ARRAY_BUFFER, flat.size() * sizeof(float), flat.data(), GL_STATIC_DRAW);
  glVertexAttribPointer(0, 4, GL_FLOAT, GL_FALSE, 0, nullptr);
  glEnableVertexAttribArray(0);

  glBindVertexArray(s.vao_indexed);
  glBindBuffer(GL_ARRAY_BUFFER, s.vbo_indexed);
  glBufferData(GL_ARRAY_BUFFER, num_vertices * 4 * sizeof(float), clip, GL_STATIC_DRAW);
  glVertexAttribPointer(0, 4, GL_FLOAT, GL_FALSE, 0, nullptr);
  glEnableVertexAttribArray(0);
  glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, s.ebo);
  glBufferData(GL_ELEMENT_ARRAY_BUFFER, num_tris * 3 * sizeof(std::int32_t), tris, GL_STATIC_DRAW);
  glBindVertexArray(0);
  s.flat_vertices = static_cast<GLsizei>(num_tris * 3);
  s.index_count = static_cast<GLsizei>(num_tris * 3);
  glFinish();
}

void LlvmpipeRasterizer::clear() {
  const GLint zero_id[4] = {0, 0, 0, 0};
  const GLfloat zero_uv[4] = {0, 0, 0, 0};
  const GLfloat far_depth = 1.0f;
  glClearBufferiv(GL_COLOR, 0, zero_id);
  glClearBufferfv(GL_COLOR, 1, zero_uv);
  glClearBufferfv(GL_DEPTH, 0, &far_depth);
}

void LlvmpipeRasterizer::draw_gbuffer() {
  State& s = *s_;
  const GLenum both[2] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1};
  glDrawBuffers(2, both);
  clear();
  glUseProgram(s.gbuffer_program);
  glBindVertexArray(s.vao_flat);
  glDrawArrays(GL_TRIANGLES, 0, s.flat_vertices);
  glFinish();
  s.last_was_id_only = false;
}

void LlvmpipeRasterizer::draw_id_only() {
  State& s = *s_;
  const GLenum both[2] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1};
  glDrawBuffers(2, both);
  clear();  // also zeroes uv, so read_back shows (0, 0) there
  const GLenum id_only[2] = {GL_COLOR_ATTACHMENT0, GL_NONE};
  glDrawBuffers(2, id_only);
  glUseProgram(s.id_program);
  glBindVertexArray(s.vao_indexed);
  glDrawElements(GL_TRIANGLES, s.index_count, GL_UNSIGNED_INT, nullptr);
  glFinish();
  s.last_was_id_only = true;
}

void LlvmpipeRasterizer::clear_only() {
  const GLenum both[2] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1};
  glDrawBuffers(2, both);
  clear();
  glFinish();
}

GlGBuffer LlvmpipeRasterizer::read_back() const {
  const State& s = *s_;
  const std::size_t w = s.width, h = s.height;
  GlGBuffer raw, out;
  raw.tri_id.resize(w * h);
  raw.uv.resize(w * h * 2);
  raw.depth.resize(w * h);
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadBuffer(GL_COLOR_ATTACHMENT0);
  glReadPixels(0, 0, s.width, s.height, GL_RED_INTEGER, GL_INT, raw.tri_id.data());
  glReadBuffer(GL_COLOR_ATTACHMENT1);
  glReadPixels(0, 0, s.width, s.height, GL_RG, GL_FLOAT, raw.uv.data());
  glReadPixels(0, 0, s.width, s.height, GL_DEPTH_COMPONENT, GL_FLOAT, raw.depth.data());
  out = raw;
  // GL row 0 is the bottom row; ours is the top row. Window depth -> z_ndc.
  for (std::size_t r = 0; r < h; ++r) {
    const std::size_t src = (h - 1 - r) * w, dst = r * w;
    for (std::size_t c = 0; c < w; ++c) {
      out.tri_id[dst + c] = raw.tri_id[src + c];
      out.uv[2 * (dst + c)] = raw.uv[2 * (src + c)];
      out.uv[2 * (dst + c) + 1] = raw.uv[2 * (src + c) + 1];
      out.depth[dst + c] = 2.0f * raw.depth[src + c] - 1.0f;
    }
  }
  return out;
}

}  // namespace peer
