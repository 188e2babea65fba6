// gradraster-render: load or build a mesh, project it with an MVP matrix,
// rasterize it to a G-buffer (timed on its own with --repeat), shade it with
// Lambert and a headlight, and write the PNG and the raw tri_id / depth
// buffers. Everything runs in float32 under a NoGradGuard: no tape is needed.
#include "examples/render/render_tool.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <iomanip>
#include <optional>
#include <sstream>

#include "autodiff/base/error.h"
#include "autodiff/base/memory.h"
#include "autodiff/base/parallel.h"
#include "autodiff/tape.h"
#include "examples/common/distinct_files.h"
#include "examples/render/render_args.h"
#include "ops/render/interpolate.h"
#include "ops/tensor/linalg.h"
#include "ops/render/rasterize.h"
#include "ops/render/transforms.h"
#include "raster/io/files.h"
#include "raster/io/image_io.h"
#include "examples/common/mesh_framing.h"
#include "raster/io/obj_io.h"
#include "raster/procedural.h"
#ifdef GRADRASTER_HAS_VULKAN
#include "raster/vulkan/backend.h"
#endif

namespace gr::render_tool {
namespace {

// --device vulkan: Device::open's choice; a usage error when there is none.
std::shared_ptr<const raster::RasterBackend> vulkan_backend() {
#ifdef GRADRASTER_HAS_VULKAN
  std::string why;
  std::shared_ptr<vulkan::Device> device = vulkan::Device::open(&why);
  if (!device) throw cli::UsageError("--device vulkan: " + why);
  return vulkan::raster_backend(device);
#else
  throw cli::UsageError("--device vulkan: this build has no GPU path (built without Vulkan)");
#endif
}

using Vec3 = std::array<double, 3>;

// A runtime failure that is not a gr::Error (e.g. a missing output folder).
struct RuntimeError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// Shading constants: albedo, ambient share, background (dark grey).
constexpr float kAlbedo[3] = {0.85f, 0.80f, 0.70f};
constexpr float kAmbient = 0.12f;
constexpr float kBackground[3] = {0.2f, 0.2f, 0.2f};

Vec3 cross3(const Vec3& a, const Vec3& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
double dot3(const Vec3& a, const Vec3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

// Restores the thread limit on scope exit (only if --threads changed it).
class ThreadLimit {
 public:
  explicit ThreadLimit(const std::optional<int>& n) : active_(n.has_value()) {
    if (!active_) return;
    previous_ = num_threads();
    set_num_threads(*n);
  }
  ~ThreadLimit() {
    if (active_) set_num_threads(previous_);
  }
  ThreadLimit(const ThreadLimit&) = delete;
  ThreadLimit& operator=(const ThreadLimit&) = delete;

 private:
  bool active_ = false;
  int previous_ = 0;
};

raster::Mesh load_mesh(const RenderArgs& a) {
  if (!a.mesh_path.empty()) {
    try {
      return raster::load_obj(a.mesh_path);
    } catch (const Error& e) {
      throw RuntimeError(std::string("--mesh: ") + e.what());
    }
  }
  switch (a.builtin) {
    case Builtin::Cube: {
      raster::Mesh m = raster::make_cube();
      for (int s = 0; s < a.subdiv.value_or(0); ++s) m = raster::subdivide(m);
      return m;
    }
    case Builtin::Sphere: return raster::make_icosphere(a.subdiv.value_or(4));
    case Builtin::Torus: {
      const int s = a.subdiv.value_or(4);
      return raster::make_torus(16 << s, 4 << s);
    }
    case Builtin::Plane: {
      const int n = 1 << a.subdiv.value_or(0);
      return raster::make_plane(n, n);
    }
    case Builtin::None: break;
  }
  throw UsageError("--mesh or --builtin: one is required");
}

// The flags (or file) that made the camera; named when its numbers overflow.
std::string camera_source(const RenderArgs& a) {
  if (a.has_mvp) return "--mvp";
  if (a.has_eye) return "--eye/--fov";
  return "--mesh '" + a.mesh_path + "' (coordinates, framed camera)";
}

// The MVP as a row-major 4x4 in double, plus a description of the camera.
// Without --mvp or --eye the mesh is framed (gr::examples::frame_mesh).
std::array<double, 16> camera_matrix(const RenderArgs& a, const raster::Mesh& mesh, std::string& facts) {
  if (a.has_mvp) {
    facts = "camera=mvp";
    return a.mvp_row_major;
  }
  Vec3 eye = a.eye, target = a.target, up = a.up;
  double fov_deg = a.fov_deg;
  std::ostringstream s;
  if (a.has_eye) {
    s << "camera=look_at";
  } else {
    gr::examples::MeshFraming f;
    try {
      f = gr::examples::frame_mesh(mesh);
    } catch (const Error& e) {
      throw RuntimeError(camera_source(a) + ": " + e.what());
    }
    eye = f.eye, target = f.centre, up = f.up, fov_deg = f.fov_y * 180.0 / M_PI;
    s << "camera=framed eye=" << eye[0] << "," << eye[1] << "," << eye[2] << " target=" << target[0] << ","
      << target[1] << "," << target[2];
  }
  Vec3 centre;
  double radius = 0;
  bounding_sphere(mesh, centre, radius);
  const auto nf = near_far_for_sphere(eye, centre, radius);
  if (!(std::isfinite(nf[0]) && std::isfinite(nf[1]) && nf[0] < nf[1]))
    throw RuntimeError(camera_source(a) + ": the eye is too far from the mesh (or the mesh too large): its "
                                          "near and far planes overflow");
  // Built with the library's own (OpenGL) camera functions, in float64.
  auto vec = [](const Vec3& v) { return Tensor::from_values({v[0], v[1], v[2]}, {3}, DType::Float64); };
  const Tensor view = look_at(vec(eye), vec(target), vec(up));
  const Tensor proj = perspective(fov_deg * M_PI / 180.0, double(a.width) / a.height, nf[0], nf[1],
                                  ClipSpace::OpenGL, DType::Float64);
  const std::vector<double> m = matmul(proj, view).to_vector();
  s << " fov=" << fov_deg << " near=" << nf[0] << " far=" << nf[1];
  facts = s.str();
  std::array<double, 16> r{};
  std::copy(m.begin(), m.end(), r.begin());
  return r;
}

// NaN or Inf in the camera or in the clip positions comes from extreme flag
// values or coordinates: reported here, naming them, instead of as rasterize's
// "clip[i]".
void check_finite_camera(const RenderArgs& a, const std::array<double, 16>& m, const Tensor& clip) {
  for (double x : m)
    if (!std::isfinite(x))
      throw RuntimeError(camera_source(a) + ": the camera matrix is not finite (the eye is too far from the mesh "
                                          "for its size, or the field of view too small)");
  const float* c = clip.data<float>();
  for (std::int64_t i = 0; i < clip.numel(); ++i)
    if (!std::isfinite(c[i]))
      throw RuntimeError(camera_source(a) + ": vertex " + std::to_string(i / 4) +
                       " has a non-finite clip position (matrix entries or coordinates too large for float32)");
}

// Memory the render needs, measured on this tool (peak RSS grows by ~46 bytes
// per pixel: G-buffer, shading, the raw and PNG outputs) plus the mesh's
// tensors and the rasterizer's per-triangle setup.
std::size_t request_bytes(const RenderArgs& a, const raster::Mesh& mesh) {
  const auto pixels = static_cast<std::size_t>(a.width) * static_cast<std::size_t>(a.height);
  return 48 * pixels + 64 * static_cast<std::size_t>(mesh.num_vertices() + mesh.num_triangles());
}

// Headlight: the model-space direction towards the viewer along the view
// axis. Rows 0 and 1 of the MVP are the planes x_clip = 0 and y_clip = 0; their
// intersection is the view axis. The sign makes w (perspective) or z_ndc
// (orthographic) decrease towards the viewer.
Vec3 headlight(const std::array<double, 16>& m) {
  const Vec3 r0 = {m[0], m[1], m[2]}, r1 = {m[4], m[5], m[6]}, r2 = {m[8], m[9], m[10]},
             r3 = {m[12], m[13], m[14]};
  Vec3 d = cross3(r0, r1);
  const double n = std::sqrt(dot3(d, d));
  if (!(n > 0) || !std::isfinite(n)) return {0, 0, 1};
  for (double& x : d) x /= n;
  const double s = dot3(r3, r3) > 1e-24 * dot3(r2, r2) ? dot3(d, r3) : dot3(d, r2);
  if (s > 0)
    for (double& x : d) x = -x;
  return d;
}

// Unit face normals (p1 - p0) x (p2 - p0) in model space ([M, 3], zero for
// degenerate triangles).
std::vector<float> face_normals(const raster::Mesh& mesh) {
  const float* p = mesh.positions.data<float>();
  const std::int32_t* t = mesh.triangles.data<std::int32_t>();
  const std::int64_t m = mesh.num_triangles();
  std::vector<float> n(static_cast<std::size_t>(3 * m), 0.0f);
  for (std::int64_t k = 0; k < m; ++k) {
    const float* a = p + 3 * t[3 * k];
    const float* b = p + 3 * t[3 * k + 1];
    const float* c = p + 3 * t[3 * k + 2];
    const Vec3 e1 = {double(b[0]) - a[0], double(b[1]) - a[1], double(b[2]) - a[2]};
    const Vec3 e2 = {double(c[0]) - a[0], double(c[1]) - a[1], double(c[2]) - a[2]};
    const Vec3 f = cross3(e1, e2);
    const double len = std::sqrt(dot3(f, f));
    if (len > 0)
      for (int i = 0; i < 3; ++i) n[3 * k + i] = static_cast<float>(f[i] / len);
  }
  return n;
}

// Lambert shading, two-sided: colour = albedo (ambient + (1 - ambient) |n . l|).
Tensor shade(const raster::Mesh& mesh, const GBuffer& gb, const Vec3& light, bool flat) {
  const std::int64_t h = gb.height(), w = gb.width();
  const std::int32_t* id = gb.tri_id.data<std::int32_t>();
  Tensor image = Tensor::empty({h, w, 3});
  float* rgb = image.data<float>();
  Tensor smooth;  // [H, W, 3] perspective-correct vertex normals, if used
  std::vector<float> faces;
  if (mesh.has_normals() && !flat)
    smooth = interpolate(mesh.normals, gb, mesh.triangles);
  else
    faces = face_normals(mesh);
  const float* sn = smooth.defined() ? smooth.data<float>() : nullptr;
  for (std::int64_t p = 0; p < h * w; ++p) {
    float* out = rgb + 3 * p;
    if (id[p] == 0) {
      std::copy(kBackground, kBackground + 3, out);
      continue;
    }
    const float* n = sn ? sn + 3 * p : faces.data() + 3 * (id[p] - 1);
    const double len = std::sqrt(double(n[0]) * n[0] + double(n[1]) * n[1] + double(n[2]) * n[2]);
    const double cosine = len > 0 ? std::abs(n[0] * light[0] + n[1] * light[1] + n[2] * light[2]) / len : 0.0;
    const float k = kAmbient + (1.0f - kAmbient) * static_cast<float>(std::min(cosine, 1.0));
    for (int c = 0; c < 3; ++c) out[c] = kAlbedo[c] * k;
  }
  return image;
}

// Little-endian byte images of the G-buffer.
std::vector<unsigned char> triid_bytes(const GBuffer& gb) {
  const std::int64_t n = gb.tri_id.numel();
  const std::int32_t* id = gb.tri_id.data<std::int32_t>();
  std::vector<unsigned char> bytes(static_cast<std::size_t>(4 * n));
  for (std::int64_t i = 0; i < n; ++i) {
    const auto v = static_cast<std::uint32_t>(id[i]);
    for (int b = 0; b < 4; ++b) bytes[4 * i + b] = static_cast<unsigned char>(v >> (8 * b));
  }
  return bytes;
}

std::vector<unsigned char> depth_bytes(const GBuffer& gb) {
  const std::int64_t n = gb.depth.numel();
  const float* z = gb.depth.data<float>();
  std::vector<unsigned char> bytes(static_cast<std::size_t>(4 * n));
  for (std::int64_t i = 0; i < n; ++i) {
    const float d = static_cast<float>(0.5 * double(z[i]) + 0.5);  // window depth, 1.0 on background
    std::uint32_t v;
    std::memcpy(&v, &d, 4);
    for (int b = 0; b < 4; ++b) bytes[4 * i + b] = static_cast<unsigned char>(v >> (8 * b));
  }
  return bytes;
}

// Fails early (before loading and rendering) if an output's folder is missing
// or its target is not a regular file.
void check_output(const std::string& flag, const std::string& path) {
  if (path.empty()) return;
  const std::filesystem::path parent = std::filesystem::path(path).parent_path();
  std::error_code ec;
  if (!parent.empty() && !std::filesystem::is_directory(parent, ec))
    throw RuntimeError(flag + ": folder '" + parent.string() + "' does not exist");
  try {
    raster::check_output_target(path);
  } catch (const Error& e) {
    throw RuntimeError(flag + ": " + e.what());
  }
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

// The outputs as named files, for cli::check_distinct_files.
std::vector<cli::NamedFile> outputs_of(const RenderArgs& a) {
  return {{"--out", a.out_png}, {"--out-triid", a.out_triid}, {"--out-depth", a.out_depth}};
}

int render(const RenderArgs& a, std::ostream& out, std::ostream& err) {
  cli::check_distinct_files({{"--mesh", a.mesh_path}}, outputs_of(a));
  check_output("--out", a.out_png);
  check_output("--out-triid", a.out_triid);
  check_output("--out-depth", a.out_depth);
  ThreadLimit threads(a.threads);
  NoGradGuard no_grad;

  raster::Mesh mesh = load_mesh(a);
  mesh.validate("gradraster-render: mesh");
  for (const std::string& w : mesh.warnings) err << "gradraster-render: warning: " << w << "\n";
  // Its MTL files and the texture they name are inputs too.
  std::vector<cli::NamedFile> read_with_mesh;
  for (const std::string& mtl : mesh.material_files)
    read_with_mesh.push_back({"the MTL file named by --mesh '" + a.mesh_path + "',", mtl});
  read_with_mesh.push_back({"the texture named by --mesh '" + a.mesh_path + "',", mesh.texture_path});
  cli::check_distinct_files(read_with_mesh, outputs_of(a));

  const std::size_t estimate = request_bytes(a, mesh);
  const std::string request = "gradraster-render " + std::to_string(a.width) + "x" + std::to_string(a.height);
  check_memory_request(estimate, request);
  std::string camera;
  const std::array<double, 16> m = camera_matrix(a, mesh, camera);
  const Tensor mvp = Tensor::from_values(std::vector<double>(m.begin(), m.end()), {4, 4}, DType::Float32);
  const Tensor clip = transform_points(mesh.positions, mvp);  // [N, 4] float32
  check_finite_camera(a, m, clip);

  // Rasterize (timed alone when --repeat is given).
  RasterizeOptions options{a.width, a.height, a.cull};
  if (a.vulkan) options.backend = vulkan_backend();
  GBuffer gb;
  std::vector<double> ms;
  for (int i = 0; i < std::max(a.repeat, 1); ++i) {
    const auto t0 = std::chrono::steady_clock::now();
    gb = rasterize(clip, mesh.triangles, options);
    const auto t1 = std::chrono::steady_clock::now();
    ms.push_back(std::chrono::duration<double, std::milli>(t1 - t0).count());
  }

  // Facts and statistics (stdout, key=value).
  const std::string source = a.mesh_path.empty() ? "builtin:" + builtin_name(a.builtin) : a.mesh_path;
  out << "mesh=" << source << " vertices=" << mesh.num_vertices() << " triangles=" << mesh.num_triangles()
      << " size=" << a.width << "x" << a.height << " threads=" << num_threads() << " " << camera
      << " memory_estimate_mib=" << (estimate + (1 << 20) - 1) / (1 << 20) << "\n";
  const raster::RasterStats& s = gb.stats;
  std::int64_t covered = 0;
  const std::int32_t* id = gb.tri_id.data<std::int32_t>();
  for (std::int64_t p = 0; p < gb.tri_id.numel(); ++p) covered += id[p] != 0;
  if (options.backend)  // a device counts no triangle classes
    out << "device=\"" << options.backend->name() << "\" covered_pixels=" << covered << "\n";
  else
    out << "triangles_in=" << s.triangles_in << " rasterized=" << s.rasterized << " clipped_near=" << s.clipped_near
        << " culled_outside=" << s.culled_outside << " culled_zero_area=" << s.culled_zero_area
        << " culled_face=" << s.culled_face << " culled_no_pixel=" << s.culled_no_pixel
        << " covered_pixels=" << covered << "\n";
  if (a.repeat > 0) out << "rasterize_ms=" << std::fixed << std::setprecision(3) << median(ms) << "\n";
  out.flush();

  // Outputs: all staged as temporaries, renamed together once all are written.
  raster::OutputSet outputs;
  auto stage = [&](const std::string& flag, const std::string& path, const std::vector<unsigned char>& bytes) {
    try {
      outputs.stage(path, bytes.data(), bytes.size());
    } catch (const Error& e) {
      throw RuntimeError(flag + ": " + e.what());
    }
  };
  if (!a.out_triid.empty()) stage("--out-triid", a.out_triid, triid_bytes(gb));
  if (!a.out_depth.empty()) stage("--out-depth", a.out_depth, depth_bytes(gb));
  if (!a.out_png.empty()) {
    const Tensor image = shade(mesh, gb, headlight(m), a.flat);
    stage("--out", a.out_png, raster::encode_png(image, "--out '" + a.out_png + "'"));
  }
  outputs.commit();
  return kExitOk;
}

}  // namespace

void bounding_sphere(const raster::Mesh& mesh, std::array<double, 3>& centre, double& radius) {
  const float* p = mesh.positions.data<float>();
  const std::int64_t n = mesh.num_vertices();
  Vec3 lo = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
  for (std::int64_t i = 0; i < n; ++i)
    for (int c = 0; c < 3; ++c) {
      lo[c] = std::min(lo[c], double(p[3 * i + c]));
      hi[c] = std::max(hi[c], double(p[3 * i + c]));
    }
  centre = {0, 0, 0};
  radius = 0;
  if (n == 0) return;
  for (int c = 0; c < 3; ++c) centre[c] = 0.5 * (lo[c] + hi[c]);
  double r2 = 0;
  for (std::int64_t i = 0; i < n; ++i) {
    const Vec3 d = {p[3 * i] - centre[0], p[3 * i + 1] - centre[1], p[3 * i + 2] - centre[2]};
    r2 = std::max(r2, dot3(d, d));
  }
  radius = std::sqrt(r2);
}

std::array<double, 2> near_far_for_sphere(const std::array<double, 3>& eye, const std::array<double, 3>& centre,
                                          double radius) {
  const Vec3 d = {centre[0] - eye[0], centre[1] - eye[1], centre[2] - eye[2]};
  const double dist = std::sqrt(dot3(d, d));
  double far = 1.01 * (dist + radius);
  if (!(far > 0) || !std::isfinite(far)) far = 1.0;
  const double near = std::max(0.99 * (dist - radius), 1e-3 * far);
  return {near, far};
}

int run_render_tool(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  RenderArgs a;
  try {
    a = parse_args(args);
  } catch (const UsageError& e) {
    err << "gradraster-render: " << e.what() << "\n(run gradraster-render --help for usage)\n";
    return kExitUsage;
  }
  if (a.help) {
    out << usage();
    return kExitOk;
  }
  try {
    return render(a, out, err);
  } catch (const UsageError& e) {
    err << "gradraster-render: " << e.what() << "\n(run gradraster-render --help for usage)\n";
    return kExitUsage;
  } catch (const std::bad_alloc&) {
    err << "gradraster-render: error: out of memory during gradraster-render " << a.width << "x" << a.height
        << "; lower the size or set GRADRASTER_MEMORY_LIMIT to refuse such requests early\n";
    return kExitRuntime;
  } catch (const std::exception& e) {
    err << "gradraster-render: error: " << e.what() << "\n";
    return kExitRuntime;
  }
}

}  // namespace gr::render_tool
