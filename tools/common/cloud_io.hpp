#pragma once
// Point-cloud files of the tools: PLY (ascii, binary little/big endian) and PCD (ascii, binary,
// binary_compressed), x y z and optional normals (PLY nx ny nz, PCD normal_x normal_y normal_z).
// Every count and size in a header is checked against the bytes actually present, so a malformed or
// truncated file raises std::runtime_error naming the file and the problem; nothing crashes (the
// readers are fuzzed).
#include <cstddef>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace binpick::tools {

struct CloudFile {
  std::vector<Eigen::Vector3d> points;   // [file units, metres for binpick's tools]; may hold NaN
  std::vector<Eigen::Vector3d> normals;  // empty, or one per point
  /// Organized layout (PCD with HEIGHT > 1): points are row-major width × height. Unorganized clouds
  /// have height 1 and width = points.size().
  int width = 0, height = 0;
  bool organized() const { return height > 1; }
};

/// Reads a .ply or .pcd file (chosen by the first bytes: "ply" or a PCD header). Throws std::runtime_error.
CloudFile read_cloud(const std::string& path);
/// Parses file bytes held in memory (used by read_cloud and by the fuzz targets); `name` is used in messages.
CloudFile parse_ply(const std::string& bytes, const std::string& name);
CloudFile parse_pcd(const std::string& bytes, const std::string& name);

}  // namespace binpick::tools
