// Replays every input a fuzz target ever crashed on (regressions/<target>/*) through the same reader,
// under the same contract as the fuzz target: a consistent result or std::runtime_error, nothing else.
// Under the ASan/UBSan build this also catches the memory errors and UB the fuzzer found.
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#ifdef BINPICK_HAVE_TOOLS_IO
#include "io.hpp"
#endif

namespace fs = std::filesystem;

namespace {

std::vector<fs::path> inputs_of(const std::string& target) {
  std::vector<fs::path> files;
  const fs::path dir = fs::path(BINPICK_REGRESSIONS_DIR) / target;
  if (fs::is_directory(dir))
    for (const auto& e : fs::directory_iterator(dir))
      if (e.is_regular_file()) files.push_back(e.path());
  std::sort(files.begin(), files.end());
  return files;
}

std::string bytes_of(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

}  // namespace

#ifdef BINPICK_HAVE_TOOLS_IO
namespace tools = binpick::tools;

TEST(FuzzRegressions, Png16) {
  const auto files = inputs_of("fuzz_png16");
  EXPECT_FALSE(files.empty());
  for (const auto& f : files) {
    SCOPED_TRACE(f.filename().string());
    const std::string b = bytes_of(f);
    // Each of these crashed or exhausted memory in stb_image before the header check in decode_png16.
    EXPECT_THROW(tools::decode_png16(reinterpret_cast<const unsigned char*>(b.data()), b.size(), f.string()),
                 std::runtime_error);
  }
}

TEST(FuzzRegressions, Intrinsics) {
  const auto files = inputs_of("fuzz_intrinsics");
  EXPECT_FALSE(files.empty());
  for (const auto& f : files) {
    SCOPED_TRACE(f.filename().string());
    EXPECT_THROW(tools::parse_intrinsics(bytes_of(f)), std::runtime_error);  // UB (float -> int) before the fix
  }
}

TEST(FuzzRegressions, Pose) {
  for (const auto& f : inputs_of("fuzz_pose")) {
    SCOPED_TRACE(f.filename().string());
    try {
      const Eigen::Isometry3d T = tools::parse_pose(bytes_of(f), f.string());
      EXPECT_TRUE(T.matrix().allFinite());
    } catch (const std::runtime_error&) {
    }
  }
}

// The 16-bit writer and reader still agree after the header checks (the check must not refuse the
// files the tools write).
TEST(FuzzRegressions, Png16RoundTripStillWorks) {
  const fs::path p = fs::temp_directory_path() / ("binpick_reliability_" + std::to_string(::getpid()) + ".png");
  for (auto [w, h] : {std::pair{1, 1}, {640, 3}, {7, 480}}) {
    tools::Image16 img;
    img.width = w;
    img.height = h;
    for (int i = 0; i < w * h; ++i) img.pixels.push_back(std::uint16_t((i * 2654435761u) >> 16));
    tools::write_png16(p.string(), img);
    const tools::Image16 back = tools::read_png16(p.string());
    EXPECT_EQ(back.width, w);
    EXPECT_EQ(back.height, h);
    EXPECT_EQ(back.pixels, img.pixels);
  }
  fs::remove(p);
}
#endif
