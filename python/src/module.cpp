// gradraster._core: the C++ side of gradraster.torch. Functions take tensors
// (objects exporting DLPack: detached torch tensors, numpy arrays) and view
// and check them themselves (python/src/array.h), holding them until the
// kernels are done; gr errors become Python exceptions (ValueError,
// IndexError, TypeError, OSError, MemoryError, RuntimeError) with
// gradraster's message.
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <optional>
#include <string>

#include "autodiff/base/error.h"
#include "autodiff/base/memory.h"
#include "autodiff/base/parallel.h"
#include "python/src/antialias.h"
#include "python/src/backend.h"
#include "python/src/fingerprint.h"
#include "python/src/image.h"
#include "python/src/interpolate.h"
#include "python/src/rasterize.h"
#include "python/src/texture.h"
#include "raster/mesh_checks.h"
#ifdef GRADRASTER_HAS_VULKAN
#include "raster/vulkan/backend.h"
#include "raster/vulkan/device.h"
#include "raster/vulkan/texture.h"
#endif

namespace py = pybind11;
using namespace gr::python;

PYBIND11_MODULE(_core, m) {
  m.doc() = "gradraster's C++ kernels for gradraster.torch (internal; use gradraster.torch)";

  py::register_exception_translator([](std::exception_ptr e) {
    try {
      if (e) std::rethrow_exception(e);
    } catch (const gr::ShapeError& x) {
      PyErr_SetString(PyExc_ValueError, x.what());
    } catch (const gr::ValueError& x) {
      PyErr_SetString(PyExc_ValueError, x.what());
    } catch (const gr::IndexError& x) {
      PyErr_SetString(PyExc_IndexError, x.what());
    } catch (const gr::DTypeError& x) {
      PyErr_SetString(PyExc_TypeError, x.what());
    } catch (const gr::IOError& x) {
      PyErr_SetString(PyExc_OSError, x.what());
    } catch (const gr::MemoryError& x) {
      PyErr_SetString(PyExc_MemoryError, x.what());
    } catch (const gr::Error& x) {
      PyErr_SetString(PyExc_RuntimeError, x.what());
    }
  });

  // Keep freed memory for reuse (gr::tune_malloc, docs/python.md "Memory");
  // returns whether glibc's malloc is tuned (False with GRADRASTER_MALLOC_DEFAULTS=1).
  m.def("keep_freed_memory", &gr::tune_malloc);
  m.attr("MAX_THREADS") = gr::kMaxThreads;
  m.attr("MAX_SIDE") = gr::raster::kMaxSide;  // pixels per image side
  m.attr("__version__") = GRADRASTER_VERSION;  // the CMake project VERSION (python/CMakeLists.txt)

  py::class_<Context>(m, "Context")
      .def(py::init<>())
      // A context whose rasterizer runs on a Vulkan device (Device::open's
      // choice), keeping up to `frames` G-buffers there at once (None: as
      // many as the largest minibatch rasterized, at least
      // vulkan::kResidentGBuffers); RuntimeError saying why when there is no device.
      .def_static(
          "vulkan",
          [](std::optional<int> frames) {
#ifdef GRADRASTER_HAS_VULKAN
            if (frames && *frames < 1)
              throw gr::ValueError("RasterizeVulkanContext: 'frames' must be at least 1, got " +
                                   std::to_string(*frames));
            std::string why;
            auto device = gr::vulkan::Device::open(&why);
            if (!device) throw std::runtime_error("RasterizeVulkanContext: " + why);
            Context ctx;
            ctx.backend = gr::vulkan::raster_backend(device, frames.value_or(gr::vulkan::kResidentGBuffers));
            ctx.grow_frames = !frames;
            ctx.gpu = std::move(device);
            return ctx;
#else
            (void)frames;
            throw std::runtime_error(
                "RasterizeVulkanContext: this build of gradraster has no GPU path (built without Vulkan: "
                "install libvulkan-dev and glslc, then rebuild)");
            return Context{};
#endif
          },
          py::arg("frames") = py::none())
      .def_property_readonly("device_name", [](const Context& ctx) -> std::string {
#ifdef GRADRASTER_HAS_VULKAN
        if (ctx.gpu) return ctx.gpu->info().name;
#endif
        return "cpu";
      })
      // Per-image kernel calls its device has run (0 for a CPU context).
      .def_readonly("device_calls", &Context::device_calls)
      // What its backend did with the G-buffers (vulkan::residency_stats;
      // all 0 for a CPU context): made and kept, calls that read a kept one,
      // calls that uploaded one, frames made; antialias calls that uploaded
      // the edge topology, and its bytes; triangle lists uploaded, and their bytes;
      // adjoints that read their forward's pairs or attributes; calls submitted
      // without waiting (a minibatch's, finished together).
      .def_property_readonly("residency", [](const Context& ctx) {
        py::dict out;
        std::int64_t gbuffers = 0, resident_calls = 0, uploads = 0, frames = 0, topology_uploads = 0,
                     topology_bytes = 0, triangle_uploads = 0, triangle_bytes = 0, antialias_reused = 0,
                     interpolate_reused = 0, deferred_calls = 0;
#ifdef GRADRASTER_HAS_VULKAN
        if (ctx.gpu) {
          const gr::vulkan::ResidencyStats s = gr::vulkan::residency_stats(*ctx.backend);
          gbuffers = s.gbuffers, resident_calls = s.resident_calls, uploads = s.uploads, frames = s.frames;
          topology_uploads = s.topology_uploads, topology_bytes = s.topology_bytes;
          triangle_uploads = s.triangle_uploads, triangle_bytes = s.triangle_bytes;
          antialias_reused = s.antialias_reused, interpolate_reused = s.interpolate_reused;
          deferred_calls = s.deferred_calls;
        }
#endif
        out["gbuffers"] = gbuffers;
        out["resident_calls"] = resident_calls;
        out["uploads"] = uploads;
        out["frames"] = frames;
        out["topology_uploads"] = topology_uploads;
        out["topology_bytes"] = topology_bytes;
        out["triangle_uploads"] = triangle_uploads;
        out["triangle_bytes"] = triangle_bytes;
        out["antialias_reused"] = antialias_reused;
        out["interpolate_reused"] = interpolate_reused;
        out["deferred_calls"] = deferred_calls;
        return out;
      })
      // What its device did with the textures' texels (vulkan::texture_residency;
      // all 0 for a CPU context): calls that uploaded them, their bytes, calls
      // that read a kept copy, the copies kept now and their bytes.
      .def_property_readonly("texture_residency", [](const Context& ctx) {
        py::dict out;
        std::int64_t uploads = 0, upload_bytes = 0, resident_calls = 0, kept = 0, kept_bytes = 0;
#ifdef GRADRASTER_HAS_VULKAN
        if (ctx.gpu) {
          const gr::vulkan::TextureResidency s = gr::vulkan::texture_residency(*ctx.gpu);
          uploads = s.uploads, upload_bytes = s.upload_bytes, resident_calls = s.resident_calls;
          kept = s.kept, kept_bytes = static_cast<std::int64_t>(s.kept_bytes);
        }
#endif
        out["uploads"] = uploads;
        out["upload_bytes"] = upload_bytes;
        out["resident_calls"] = resident_calls;
        out["kept"] = kept;
        out["kept_bytes"] = kept_bytes;
        return out;
      });
  // rasterize_forward's handles of the G-buffers it kept on the device
  // (python/src/backend.h), opaque; gradraster.torch passes them on.
  py::class_<DeviceGBuffers, std::shared_ptr<DeviceGBuffers>>(m, "DeviceGBuffers");
  m.attr("HAS_VULKAN") =
#ifdef GRADRASTER_HAS_VULKAN
      true;
#else
      false;
#endif
  py::class_<gr::raster::DepthPeelState>(m, "PeelState")
      .def(py::init<>())
      .def_property_readonly("layers", &gr::raster::DepthPeelState::layers);
  // rasterize_forward returns the DeviceGBuffers it kept (None: a CPU call).
  m.def("rasterize_forward", &rasterize_forward, py::arg("ctx"), py::arg("pos"), py::arg("tri"), py::arg("ranges"),
        py::arg("rast"), py::arg("rast_db"), py::arg("peel"), py::arg("threads"));
  // kept: None, or rasterize_forward's DeviceGBuffers for these very tensors, unchanged since.
  m.def("rasterize_backward", &rasterize_backward, py::arg("ctx"), py::arg("pos"), py::arg("tri"),
        py::arg("ranges"), py::arg("rast"), py::arg("grad_rast"), py::arg("grad_db"), py::arg("grad_pos"),
        py::arg("threads"), py::arg("kept") = py::none());

  // ctx: None, or the context whose device runs the call (python/src/backend.h).
  // interpolate_forward returns what the device kept for the adjoint (None: a CPU call), which
  // interpolate_backward takes as `forward` for the very same inputs.
  py::class_<InterpolateKept, std::shared_ptr<InterpolateKept>>(m, "InterpolateKept");
  m.def("interpolate_forward", &interpolate_forward, py::arg("ctx"), py::arg("attr"), py::arg("rast"),
        py::arg("tri"), py::arg("rast_db"), py::arg("diff"), py::arg("out"), py::arg("out_da"), py::arg("threads"),
        py::arg("kept") = py::none());
  m.def("interpolate_backward", &interpolate_backward, py::arg("ctx"), py::arg("attr"), py::arg("rast"),
        py::arg("tri"), py::arg("rast_db"), py::arg("diff"), py::arg("grad_out"), py::arg("grad_da"),
        py::arg("grad_attr"), py::arg("grad_rast"), py::arg("grad_db"), py::arg("threads"),
        py::arg("kept") = py::none(), py::arg("forward") = py::none());

  py::class_<Topology, std::shared_ptr<Topology>>(m, "Topology")
      .def_readonly("triangles", &Topology::triangles)
      .def_readonly("vertices_needed", &Topology::vertices_needed);
  py::class_<AntialiasState, std::shared_ptr<AntialiasState>>(m, "AntialiasState");
  m.def("build_topology", &build_topology, py::arg("tri"), py::arg("vertices"), py::arg("op"));
  m.def("antialias_forward", &antialias_forward, py::arg("ctx"), py::arg("pos"), py::arg("tri"), py::arg("ranges"),
        py::arg("topology"), py::arg("color"), py::arg("rast"), py::arg("out"), py::arg("visibility"),
        py::arg("threads"), py::arg("kept") = py::none());
  m.def("antialias_backward", &antialias_backward, py::arg("ctx"), py::arg("pos"), py::arg("tri"),
        py::arg("ranges"), py::arg("topology"), py::arg("state"), py::arg("color"), py::arg("rast"),
        py::arg("grad_out"), py::arg("grad_color"), py::arg("grad_pos"), py::arg("pos_gradient_boost"),
        py::arg("threads"));

  py::class_<TextureMode>(m, "TextureMode")
      .def(py::init<>())
      .def_readwrite("levels", &TextureMode::levels)
      .def_readwrite("user", &TextureMode::user)
      .def_readwrite("filter", &TextureMode::filter)
      .def_readwrite("wrap", &TextureMode::wrap)
      .def_readwrite("cube", &TextureMode::cube)
      .def_readwrite("device_levels", &TextureMode::device_levels);
  m.def("mip_sizes", &mip_sizes);
  m.def("mip_build", &mip_build, py::arg("mode"), py::arg("tex"), py::arg("pyramid"), py::arg("threads"));
  m.def("texture_forward", &texture_forward, py::arg("ctx"), py::arg("mode"), py::arg("tex"), py::arg("uv"),
        py::arg("uv_dx"), py::arg("uv_dy"), py::arg("bias"), py::arg("pyramid"), py::arg("out"),
        py::arg("uv_jacobian"), py::arg("threads"), py::arg("kept") = py::none());
  py::class_<DeviceTextures, std::shared_ptr<DeviceTextures>>(m, "DeviceTextures");
  m.def("texture_backward", &texture_backward, py::arg("ctx"), py::arg("mode"), py::arg("tex"), py::arg("uv"),
        py::arg("uv_dx"), py::arg("uv_dy"), py::arg("bias"), py::arg("pyramid"), py::arg("uv_jacobian"),
        py::arg("grad_out"), py::arg("grad_tex"), py::arg("grad_uv"), py::arg("grad_uv_dx"), py::arg("grad_uv_dy"),
        py::arg("grad_bias"), py::arg("grad_pyramid"), py::arg("threads"), py::arg("kept") = py::none());

  // A 64-bit fingerprint of a contiguous tensor's bytes, the same for any
  // thread count (python/src/fingerprint.h): KeptTextures checks with it
  // that a kept texture's texels are unchanged.
  m.def("fingerprint", &fingerprint, py::arg("tensor"), py::arg("threads"));

  m.def("write_png", &write_png, py::arg("path"), py::arg("image"));
}
