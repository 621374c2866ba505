#pragma once
// File formats of the tools: 16-bit PNG depth, 4x4 pose text files, intrinsics strings, JSON lines.
// Every reader throws std::runtime_error with a message naming the file and the problem; none crash
// on malformed input (they are fuzzed).
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Geometry>

namespace binpick::tools {

struct Image16 {
  int width = 0, height = 0;
  std::vector<std::uint16_t> pixels;  // row-major
};

/// Reads a single-channel 16-bit PNG (an 8-bit one is widened). Throws std::runtime_error.
Image16 read_png16(const std::string& path);
/// Decodes a PNG held in memory (used by read_png16 and by the fuzz target).
Image16 decode_png16(const unsigned char* bytes, std::size_t size, const std::string& name);
void write_png16(const std::string& path, const Image16& image);
void write_png8(const std::string& path, int width, int height, const std::vector<std::uint8_t>& pixels);

/// Parses 16 numbers (whitespace or comma separated; '#' starts a comment) as a 4x4 row-major matrix
/// and checks it is a rigid transform. Throws std::runtime_error naming `name`.
Eigen::Isometry3d parse_pose(const std::string& text, const std::string& name);
Eigen::Isometry3d read_pose_file(const std::string& path);
std::string read_text_file(const std::string& path);

struct Intrinsics {
  double fx = 0, fy = 0, cx = 0, cy = 0;
  int width = 0, height = 0;
};
/// "fx,fy,cx,cy,width,height". Throws std::runtime_error.
Intrinsics parse_intrinsics(const std::string& text);
/// "x,y,z". Throws std::runtime_error naming `name`.
Eigen::Vector3d parse_vec3(const std::string& text, const std::string& name);
/// A finite number. Throws std::runtime_error naming `name`.
double parse_number(const std::string& text, const std::string& name);

/// Command-line options in order: `for (Args args(argc, argv); args.next();)`, then flag() is the
/// option and value() takes the word after it (std::invalid_argument when there is none).
class Args {
 public:
  Args(int argc, char** argv) : argc_(argc), argv_(argv) {}
  bool next() {
    if (++i_ >= argc_) return false;
    flag_ = argv_[i_];
    return true;
  }
  const std::string& flag() const { return flag_; }
  std::string value() {
    if (i_ + 1 >= argc_) throw std::invalid_argument("missing value after " + flag_);
    return argv_[++i_];
  }

 private:
  int argc_;
  char** argv_;
  int i_ = 0;
  std::string flag_;
};

/// Minimal JSON value formatting for one-line outputs.
std::string json_number(double v);
std::string json_string(const std::string& s);

}  // namespace binpick::tools
