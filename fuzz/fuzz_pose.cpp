// Fuzz target: pose files (tools::parse_pose, behind read_pose_file).
// Contract: either a finite rigid transform (orthonormal rotation, det +1) or std::runtime_error.
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <stdexcept>
#include <string>

#include "io.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const Eigen::Isometry3d T = binpick::tools::parse_pose(text, "fuzz_pose.txt");
    const Eigen::Matrix3d R = T.linear();
    if (!T.matrix().allFinite()) std::abort();
    if ((R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() > 1e-9) std::abort();
    if (std::abs(R.determinant() - 1.0) > 1e-9) std::abort();
  } catch (const std::runtime_error&) {
  }
  return 0;
}
