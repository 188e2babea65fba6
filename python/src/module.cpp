// gradraster._core: the C++ side of gradraster.torch. Functions take tensor
// addresses (data_ptr) from the Python layer, which checks types and shapes;
// gr errors become Python exceptions (ValueError, IndexError, TypeError,
// OSError, MemoryError, RuntimeError) with gradraster's message.
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include "autodiff/error.h"
#include "autodiff/memory.h"
#include "autodiff/parallel.h"
#include "python/src/antialias.h"
#include "python/src/image.h"
#include "python/src/interpolate.h"
#include "python/src/rasterize.h"
#include "python/src/texture.h"
#ifdef GRADRASTER_HAS_VULKAN
#include "raster/vulkan/device.h"
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

  py::class_<Mesh>(m, "Mesh")
      .def(py::init([](bool f64, Address pos, std::int64_t images, std::int64_t vertices, bool instanced, Address tri,
                       std::int64_t triangles, std::vector<std::pair<std::int64_t, std::int64_t>> ranges) {
        return Mesh{f64, pos, images, vertices, instanced, tri, triangles, std::move(ranges)};
      }));

  py::class_<Context>(m, "Context")
      .def(py::init<>())
      // A context whose rasterizer runs on a Vulkan device (Device::open's
      // choice); RuntimeError saying why when there is none.
      .def_static("vulkan",
                  [] {
#ifdef GRADRASTER_HAS_VULKAN
                    std::string why;
                    auto device = gr::vulkan::Device::open(&why);
                    if (!device) throw std::runtime_error("RasterizeVulkanContext: " + why);
                    Context ctx;
                    ctx.gpu = std::move(device);
                    return ctx;
#else
                    throw std::runtime_error(
                        "RasterizeVulkanContext: this build of gradraster has no GPU path (built without Vulkan: "
                        "install libvulkan-dev and glslc, then rebuild)");
                    return Context{};
#endif
                  })
      .def_property_readonly("device_name", [](const Context& ctx) -> std::string {
#ifdef GRADRASTER_HAS_VULKAN
        if (ctx.gpu) return ctx.gpu->info().name;
#endif
        return "cpu";
      });
  m.attr("HAS_VULKAN") =
#ifdef GRADRASTER_HAS_VULKAN
      true;
#else
      false;
#endif
  py::class_<PeelState>(m, "PeelState").def(py::init<>()).def_readonly("layers", &PeelState::layers);
  m.def("rasterize_forward", &rasterize_forward);
  m.def("rasterize_backward", &rasterize_backward);

  py::class_<InterpolateArgs>(m, "InterpolateArgs")
      .def(py::init([](bool f64, Address attr, std::int64_t attr_images, std::int64_t vertices, std::int64_t channels,
                       Address tri, std::int64_t triangles, Address rast, Address rast_db, std::int64_t images,
                       std::int64_t height, std::int64_t width, std::vector<std::int32_t> diff) {
        return InterpolateArgs{f64,  attr,    attr_images, vertices, channels, tri,           triangles,
                               rast, rast_db, images,      height,   width,    std::move(diff)};
      }));
  m.def("interpolate_forward", &interpolate_forward);
  m.def("interpolate_backward", &interpolate_backward);

  py::class_<Topology, std::shared_ptr<Topology>>(m, "Topology").def_readonly("triangles", &Topology::triangles);
  py::class_<AntialiasState, std::shared_ptr<AntialiasState>>(m, "AntialiasState");
  m.def("build_topology", &build_topology);
  m.def("antialias_forward", &antialias_forward);
  m.def("antialias_backward", &antialias_backward);

  py::class_<TextureArgs>(m, "TextureArgs")
      .def(py::init<>())
      .def_readwrite("f64", &TextureArgs::f64)
      .def_readwrite("tex", &TextureArgs::tex)
      .def_readwrite("tex_images", &TextureArgs::tex_images)
      .def_readwrite("height", &TextureArgs::height)
      .def_readwrite("width", &TextureArgs::width)
      .def_readwrite("channels", &TextureArgs::channels)
      .def_readwrite("pyramid", &TextureArgs::pyramid)
      .def_readwrite("levels", &TextureArgs::levels)
      .def_readwrite("user", &TextureArgs::user)
      .def_readwrite("uv", &TextureArgs::uv)
      .def_readwrite("uv_dx", &TextureArgs::uv_dx)
      .def_readwrite("uv_dy", &TextureArgs::uv_dy)
      .def_readwrite("bias", &TextureArgs::bias)
      .def_readwrite("images", &TextureArgs::images)
      .def_readwrite("samples", &TextureArgs::samples)
      .def_readwrite("filter", &TextureArgs::filter)
      .def_readwrite("wrap", &TextureArgs::wrap)
      .def_readwrite("cube", &TextureArgs::cube)
      .def_readwrite("uv_da", &TextureArgs::uv_da)
      .def_readwrite("uv_jacobian", &TextureArgs::uv_jacobian);
  m.def("mip_sizes", &mip_sizes);
  m.def("mip_build", &mip_build);
  m.def("texture_forward", &texture_forward);
  m.def("texture_backward", &texture_backward);

  m.def("write_png", &write_png);
}
