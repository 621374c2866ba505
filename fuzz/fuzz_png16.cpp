// Fuzz target: 16-bit PNG depth decoding (tools::decode_png16, behind read_png16).
// Contract: any byte string either decodes to a consistent image or throws std::runtime_error.
#include <cstdint>
#include <cstdlib>
#include <stdexcept>

#include "io.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    const binpick::tools::Image16 img = binpick::tools::decode_png16(data, size, "fuzz.png");
    if (img.width <= 0 || img.height <= 0 ||
        img.pixels.size() != std::size_t(img.width) * std::size_t(img.height))
      std::abort();  // a decoded image must be non-empty and hold width * height pixels
  } catch (const std::runtime_error&) {
  }
  return 0;
}
