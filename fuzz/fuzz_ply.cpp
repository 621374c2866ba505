// Fuzz target: PLY point clouds (tools::parse_ply, behind read_cloud), every encoding the reader knows.
// Contract: a consistent cloud (normals empty or one per point, width x height = point count) or
// std::runtime_error.
#include <cstdint>
#include <cstdlib>
#include <stdexcept>
#include <string>

#include "cloud_io.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string bytes(reinterpret_cast<const char*>(data), size);
  try {
    const binpick::tools::CloudFile c = binpick::tools::parse_ply(bytes, "fuzz.ply");
    if (!c.normals.empty() && c.normals.size() != c.points.size()) std::abort();
    if (c.width < 0 || c.height < 0 || std::size_t(c.width) * std::size_t(c.height) != c.points.size()) std::abort();
  } catch (const std::runtime_error&) {
  }
  return 0;
}
