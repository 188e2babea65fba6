// Device selection and the queue's submission (see device.h).
#include "raster/vulkan/device.h"

#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "autodiff/base/error.h"
#include "raster/vulkan/internal/context.h"

namespace gr::vulkan {

void check(VkResult r, const char* what) {
  if (r != VK_SUCCESS) throw Error(std::string("vulkan: ") + what + " failed (VkResult " + std::to_string(r) + ")");
}

Device::Impl::~Impl() {
  if (device) {
    settle_pending([](const Pending&) { return false; });  // calls nobody finished: their outputs may be gone
    vkDeviceWaitIdle(device);
    default_frame.reset();
    texture_buffers.reset();
    kernels.reset();
    if (command_pool) vkDestroyCommandPool(device, command_pool, nullptr);
    vkDestroyDevice(device, nullptr);
  }
  if (instance) vkDestroyInstance(instance, nullptr);
}

int Device::Impl::memory_type(std::uint32_t type_bits, VkMemoryPropertyFlags flags) const {
  for (std::uint32_t i = 0; i < memory.memoryTypeCount; ++i)
    if ((type_bits & (1u << i)) && (memory.memoryTypes[i].propertyFlags & flags) == flags) return static_cast<int>(i);
  return -1;
}

VkCommandBuffer Device::Impl::begin() {
  VkCommandBufferAllocateInfo ai{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
  ai.commandPool = command_pool;
  ai.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
  ai.commandBufferCount = 1;
  VkCommandBuffer cb;
  check(vkAllocateCommandBuffers(device, &ai, &cb), "vkAllocateCommandBuffers");
  VkCommandBufferBeginInfo bi{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
  bi.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
  const VkResult r = vkBeginCommandBuffer(cb, &bi);
  if (r != VK_SUCCESS) vkFreeCommandBuffers(device, command_pool, 1, &cb);
  check(r, "vkBeginCommandBuffer");
  return cb;
}

VkFence Device::Impl::submit(VkCommandBuffer cb) {
  VkFence fence = VK_NULL_HANDLE;
  VkResult r = vkEndCommandBuffer(cb);
  if (r == VK_SUCCESS) {
    VkFenceCreateInfo fi{VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
    r = vkCreateFence(device, &fi, nullptr, &fence);
  }
  if (r == VK_SUCCESS) {
    VkSubmitInfo si{VK_STRUCTURE_TYPE_SUBMIT_INFO};
    si.commandBufferCount = 1;
    si.pCommandBuffers = &cb;
    r = vkQueueSubmit(queue, 1, &si, fence);
  }
  if (r != VK_SUCCESS) {
    if (fence) vkDestroyFence(device, fence, nullptr);
    vkFreeCommandBuffers(device, command_pool, 1, &cb);
    check(r, "submitting to the queue");
  }
  return fence;
}

void Device::Impl::submit_and_wait(VkCommandBuffer cb) {
  VkFence fence = submit(cb);
  const VkResult r = vkWaitForFences(device, 1, &fence, VK_TRUE, UINT64_MAX);
  vkDestroyFence(device, fence, nullptr);
  vkFreeCommandBuffers(device, command_pool, 1, &cb);
  check(r, "waiting for the queue");
}

void Device::Impl::submit_deferred(VkCommandBuffer cb, std::function<void()> finish) {
  pending_.reserve(pending_.size() + 1);  // no throw once submitted
  pending_.push_back({cb, submit(cb), std::move(finish), std::this_thread::get_id()});
  ++deferring_entry()->submissions;
}

const Device::Impl::Deferring* Device::Impl::deferring_entry() const {
  for (const Deferring& d : deferring_)
    if (d.thread == std::this_thread::get_id()) return &d;
  return nullptr;
}

Device::Impl::Deferring* Device::Impl::deferring_entry() {
  return const_cast<Deferring*>(static_cast<const Impl*>(this)->deferring_entry());
}

bool Device::Impl::deferring() const { return deferring_entry() != nullptr; }

std::int64_t Device::Impl::deferred_submissions() const {
  const Deferring* d = deferring_entry();
  return d ? d->submissions : 0;
}

void Device::Impl::then(std::function<void()> finish) {
  if (deferring())
    pending_.push_back({VK_NULL_HANDLE, VK_NULL_HANDLE, std::move(finish), std::this_thread::get_id()});
  else
    finish();
}

void Device::Impl::begin_deferring() {
  if (Deferring* d = deferring_entry())
    ++d->begins;
  else
    deferring_.push_back({std::this_thread::get_id(), 1, 0});
}

void Device::Impl::end_deferring() {
  Deferring* d = deferring_entry();
  if (d && --d->begins == 0) deferring_.erase(deferring_.begin() + (d - deferring_.data()));
}

template <class Run>
VkResult Device::Impl::settle_pending(Run run) {
  // Every submission is waited for (its buffers are in use until then) even
  // after one fails; the finishes stop at the first failure.
  VkResult failed = VK_SUCCESS;
  std::vector<Pending> pending;
  pending.swap(pending_);
  for (Pending& p : pending) {
    if (p.fence) {
      const VkResult r = vkWaitForFences(device, 1, &p.fence, VK_TRUE, UINT64_MAX);
      if (r != VK_SUCCESS && failed == VK_SUCCESS) failed = r;
      vkDestroyFence(device, p.fence, nullptr);
      vkFreeCommandBuffers(device, command_pool, 1, &p.cb);
    }
    if (failed == VK_SUCCESS && run(p)) p.finish();
  }
  completed_ = issued_;
  return failed;
}

void Device::Impl::complete(bool write_own_outputs) {
  const std::thread::id me = std::this_thread::get_id();
  check(settle_pending([&](const Pending& p) { return write_own_outputs || p.thread != me; }),
        "waiting for a deferred submission");
}

namespace {

// What the kernels need; empty when the device has it all, else what it lacks.
std::string missing_features(VkPhysicalDevice pd) {
  VkPhysicalDeviceProperties props;
  vkGetPhysicalDeviceProperties(pd, &props);
  if (props.apiVersion < VK_API_VERSION_1_2) return "Vulkan 1.2";
  VkPhysicalDeviceVulkan12Features f12{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES};
  VkPhysicalDeviceFeatures2 f{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2};
  f.pNext = &f12;
  vkGetPhysicalDeviceFeatures2(pd, &f);
  // The adjoints' largest magnitudes are reduced per subgroup (fixed_point.glsl).
  VkPhysicalDeviceSubgroupProperties subgroup{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_SUBGROUP_PROPERTIES};
  VkPhysicalDeviceProperties2 p2{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2};
  p2.pNext = &subgroup;
  vkGetPhysicalDeviceProperties2(pd, &p2);
  const VkSubgroupFeatureFlags ops = VK_SUBGROUP_FEATURE_BASIC_BIT | VK_SUBGROUP_FEATURE_ARITHMETIC_BIT;
  std::string lack;
  if (!f.features.shaderFloat64) lack += " float64";
  if (!f.features.shaderInt64) lack += " int64";
  if (!f12.shaderBufferInt64Atomics) lack += " 64-bit buffer atomics";
  if (!(subgroup.supportedStages & VK_SHADER_STAGE_COMPUTE_BIT) || (subgroup.supportedOperations & ops) != ops)
    lack += " subgroup arithmetic in compute shaders";
  return lack;
}

int compute_queue_family(VkPhysicalDevice pd) {
  std::uint32_t n = 0;
  vkGetPhysicalDeviceQueueFamilyProperties(pd, &n, nullptr);
  std::vector<VkQueueFamilyProperties> fam(n);
  vkGetPhysicalDeviceQueueFamilyProperties(pd, &n, fam.data());
  for (std::uint32_t i = 0; i < n; ++i)
    if (fam[i].queueFlags & VK_QUEUE_COMPUTE_BIT) return static_cast<int>(i);
  return -1;
}

int type_rank(VkPhysicalDeviceType t) {
  switch (t) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU: return 0;
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU: return 1;
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU: return 2;
    case VK_PHYSICAL_DEVICE_TYPE_CPU: return 3;
    default: return 4;
  }
}

std::unique_ptr<Device::Impl> open_impl(std::string* why) {
  auto impl = std::make_unique<Device::Impl>();
  VkApplicationInfo app{VK_STRUCTURE_TYPE_APPLICATION_INFO};
  app.pApplicationName = "gradraster";
  app.apiVersion = VK_API_VERSION_1_2;
  VkInstanceCreateInfo ici{VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO};
  ici.pApplicationInfo = &app;
  if (vkCreateInstance(&ici, nullptr, &impl->instance) != VK_SUCCESS) {
    *why = "no Vulkan driver could be loaded (vkCreateInstance failed)";
    return nullptr;
  }
  std::uint32_t n = 0;
  vkEnumeratePhysicalDevices(impl->instance, &n, nullptr);
  std::vector<VkPhysicalDevice> devices(n);
  vkEnumeratePhysicalDevices(impl->instance, &n, devices.data());
  const char* wanted = std::getenv("GRADRASTER_VULKAN_DEVICE");
  int best = -1, best_rank = 99;
  std::string rejected, found;
  for (std::uint32_t i = 0; i < n; ++i) {
    VkPhysicalDeviceProperties props;
    vkGetPhysicalDeviceProperties(devices[i], &props);
    found += std::string(found.empty() ? "" : ", ") + props.deviceName;
    if (wanted && *wanted && !std::strstr(props.deviceName, wanted)) continue;
    const std::string lack = missing_features(devices[i]);
    if (!lack.empty() || compute_queue_family(devices[i]) < 0) {
      rejected += std::string(" ") + props.deviceName + " lacks" + (lack.empty() ? " a compute queue" : lack) + ";";
      continue;
    }
    const int rank = type_rank(props.deviceType);
    if (rank < best_rank) best = static_cast<int>(i), best_rank = rank;
  }
  if (best < 0) {
    if (n == 0)
      *why = "no Vulkan device found";
    else if (rejected.empty())
      *why = std::string("no Vulkan device's name contains GRADRASTER_VULKAN_DEVICE=\"") + wanted + "\" (found: " +
             found + ")";
    else
      *why = "no Vulkan device has what the kernels need:" + rejected;
    return nullptr;
  }
  impl->physical = devices[best];
  impl->queue_family = static_cast<std::uint32_t>(compute_queue_family(impl->physical));

  const float priority = 1.0f;
  VkDeviceQueueCreateInfo qci{VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO};
  qci.queueFamilyIndex = impl->queue_family;
  qci.queueCount = 1;
  qci.pQueuePriorities = &priority;
  VkPhysicalDeviceVulkan12Features f12{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES};
  f12.shaderBufferInt64Atomics = VK_TRUE;
  VkPhysicalDeviceFeatures2 f{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2};
  f.pNext = &f12;
  f.features.shaderFloat64 = VK_TRUE;
  f.features.shaderInt64 = VK_TRUE;
  VkDeviceCreateInfo dci{VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO};
  dci.pNext = &f;
  dci.queueCreateInfoCount = 1;
  dci.pQueueCreateInfos = &qci;
  check(vkCreateDevice(impl->physical, &dci, nullptr, &impl->device), "vkCreateDevice");
  vkGetDeviceQueue(impl->device, impl->queue_family, 0, &impl->queue);
  VkCommandPoolCreateInfo pci{VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
  pci.queueFamilyIndex = impl->queue_family;
  check(vkCreateCommandPool(impl->device, &pci, nullptr, &impl->command_pool), "vkCreateCommandPool");
  vkGetPhysicalDeviceMemoryProperties(impl->physical, &impl->memory);

  VkPhysicalDeviceVulkan12Properties p12{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_PROPERTIES};
  VkPhysicalDeviceProperties2 props{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2};
  props.pNext = &p12;
  vkGetPhysicalDeviceProperties2(impl->physical, &props);
  std::uint32_t nf = 0;
  vkGetPhysicalDeviceQueueFamilyProperties(impl->physical, &nf, nullptr);
  std::vector<VkQueueFamilyProperties> fam(nf);
  vkGetPhysicalDeviceQueueFamilyProperties(impl->physical, &nf, fam.data());
  DeviceInfo& info = impl->info;
  info.name = props.properties.deviceName;
  info.driver = std::string(p12.driverName) + " " + p12.driverInfo;
  info.api_version = props.properties.apiVersion;
  info.is_cpu = props.properties.deviceType == VK_PHYSICAL_DEVICE_TYPE_CPU;
  info.timestamp_period_ns =
      fam[impl->queue_family].timestampValidBits > 0 ? props.properties.limits.timestampPeriod : 0.0;
  return impl;
}

}  // namespace

bool Device::compiled_in() { return true; }

std::shared_ptr<Device> Device::open(std::string* why_not) {
  std::string why;
  std::unique_ptr<Impl> impl = open_impl(&why);
  if (why_not) *why_not = why;
  if (!impl) return nullptr;
  return std::make_shared<Device>(std::move(impl));
}

Device::Device(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
Device::~Device() = default;
const DeviceInfo& Device::info() const { return impl_->info; }

}  // namespace gr::vulkan
