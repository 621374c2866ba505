// Fuzz target: command-line number strings (tools::parse_intrinsics, parse_vec3, parse_number).
// Contract: either values the library accepts (finite, focal lengths > 0, sizes > 0) or
// std::runtime_error.
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <stdexcept>
#include <string>

#include "io.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const binpick::tools::Intrinsics k = binpick::tools::parse_intrinsics(text);
    if (!(k.fx > 0) || !(k.fy > 0) || !std::isfinite(k.fx) || !std::isfinite(k.fy) || !std::isfinite(k.cx) ||
        !std::isfinite(k.cy) || k.width <= 0 || k.height <= 0)
      std::abort();
  } catch (const std::runtime_error&) {
  }
  try {
    if (!binpick::tools::parse_vec3(text, "--point").allFinite()) std::abort();
  } catch (const std::runtime_error&) {
  }
  try {
    if (!std::isfinite(binpick::tools::parse_number(text, "--number"))) std::abort();
  } catch (const std::runtime_error&) {
  }
  return 0;
}
