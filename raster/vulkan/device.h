// A Vulkan compute device for the raster kernels (the GPU path, issue 33).
//
// Device::open() picks a device with what the kernels need (Vulkan 1.2,
// float64, int64 and 64-bit buffer atomics): the one whose name contains
// $GRADRASTER_VULKAN_DEVICE when that is set, else the first discrete GPU,
// else the first integrated or virtual GPU, else a CPU device (Mesa's
// lavapipe). It returns nullptr, with the reason in *why_not, when the build
// has no Vulkan or no device qualifies, so callers and tests can skip.
//
// Calls on one Device are serialized (one queue); separate Devices run
// independently. Nothing here includes <vulkan/vulkan.h>.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace gr::vulkan {

struct DeviceInfo {
  std::string name;            // e.g. "NVIDIA H200", "llvmpipe (LLVM 15.0.6, 256 bits)"
  std::string driver;          // driver name and version string
  std::uint32_t api_version = 0;
  bool is_cpu = false;         // a software device (lavapipe)
  double timestamp_period_ns = 0.0;  // 0: the queue has no timestamps
};

class Device {
 public:
  struct Impl;  // raster/vulkan/internal/context.h

  static std::shared_ptr<Device> open(std::string* why_not = nullptr);
  // True when this build was compiled with Vulkan (GRADRASTER_WITH_VULKAN).
  static bool compiled_in();

  const DeviceInfo& info() const;
  Impl& impl() { return *impl_; }

  explicit Device(std::unique_ptr<Impl> impl);
  ~Device();
  Device(const Device&) = delete;
  Device& operator=(const Device&) = delete;

 private:
  std::unique_ptr<Impl> impl_;
};

// Where the time of one GPU call went, from the device's timestamps
// (milliseconds; all 0 where the queue has no timestamps).
struct GpuTimes {
  double upload_ms = 0.0;    // host -> device copies
  double kernels_ms = 0.0;   // the compute passes
  double download_ms = 0.0;  // device -> host copies
  // kernels_ms by pass, in the order the call's header lists them.
  std::vector<double> pass_ms;
};

}  // namespace gr::vulkan
