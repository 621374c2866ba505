// An integrator's program: wraps its own 16-bit millimetre buffers as views (no copy) and fuses them.
#include <binpick/binpick.hpp>

#include <cstdint>
#include <cstdio>
#include <vector>

int main() {
  const binpick::PinholeCamera<float> camera(100.f, 100.f, 31.5f, 23.5f, 64, 48);
  std::vector<std::uint16_t> a(64 * 48, 300), b(64 * 48, 301);
  std::vector<binpick::DepthImageView<float>> views{{a.data(), 64, 48, 0, 0.001f}, {b.data(), 64, 48, 0, 0.001f}};
  std::vector<binpick::Isometry3f> poses(2, binpick::Isometry3f::Identity());
  const auto r = binpick::fuse(views, poses, camera);
  const float d = r.depth.at(10, 10);
#ifdef _OPENMP
  const char* openmp = "on";
#else
  const char* openmp = "off";
#endif
  std::printf("fused depth %.4f m, openmp %s\n", d, openmp);
  return (d > 0.2999f && d < 0.3011f) ? 0 : 1;
}
