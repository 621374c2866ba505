// Writes the seed corpora of the fuzz targets into <out-dir>/<target>/ (scripts/fuzz.sh calls it):
// small valid inputs of every reader plus near-misses, so the fuzzer starts from the formats' shape.
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <algorithm>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "io.hpp"

namespace fs = std::filesystem;
namespace tools = binpick::tools;

namespace {
void write(const fs::path& dir, const std::string& name, const std::string& bytes) {
  fs::create_directories(dir);
  std::ofstream(dir / name, std::ios::binary).write(bytes.data(), std::streamsize(bytes.size()));
}
std::string slurp(const fs::path& p) { return tools::read_text_file(p.string()); }

void png_seeds(const fs::path& dir) {
  const fs::path tmp = dir / "tmp.png";
  fs::create_directories(dir);
  int n = 0;
  for (auto [w, h] : {std::pair{1, 1}, {4, 3}, {16, 16}, {33, 2}}) {
    tools::Image16 img;
    img.width = w;
    img.height = h;
    for (int i = 0; i < w * h; ++i) img.pixels.push_back(std::uint16_t(i % 7 == 0 ? 0 : 500 + 37 * i));
    tools::write_png16(tmp.string(), img);
    write(dir, "png16_" + std::to_string(n++), slurp(tmp));
  }
  // 8-bit PNGs from stb: compressed (Huffman) IDAT and row filters, which the 16-bit writer never emits.
  std::vector<std::uint8_t> px(12 * 9);
  for (std::size_t i = 0; i < px.size(); ++i) px[i] = std::uint8_t((i * 29) & 0xFF);
  tools::write_png8(tmp.string(), 12, 9, px);
  write(dir, "png8_0", slurp(tmp));
  fs::remove(tmp);
  write(dir, "not_png", "P5\n2 2\n255\n\x01\x02\x03\x04");
}

void pose_seeds(const fs::path& dir) {
  write(dir, "identity", "1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n");
  write(dir, "rotated", "# camera-to-world\n0.7071068,-0.7071068,0,0.1\n0.7071068,0.7071068,0,-0.25\n0,0,1,1.5\n0,0,0,1\n");
  write(dir, "brackets", "[[0, 0, 1, 1e-3]; [1, 0, 0, 2.5E+1]; [0, 1, 0, -0.0]; [0, 0, 0, 1]]");
  write(dir, "short", "1 0 0 0 0 1 0 0 0 0 1 0 0 0 0");
  write(dir, "scaled", "2 0 0 0\n0 2 0 0\n0 0 2 0\n0 0 0 1\n");
  write(dir, "mirror", "-1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n");
}

void intrinsics_seeds(const fs::path& dir) {
  write(dir, "redwood", "525,525,319.5,239.5,640,480");
  write(dir, "spaces", " 1000.5 , 999.25,  640 ,512,1280,1024 ");
  write(dir, "vec3", "0.1,-0.2,1.5");
  write(dir, "number", "1e-3");
  write(dir, "bad", "525,525,319.5,239.5,640.5,480");
}

#ifdef BINPICK_FUZZ_CLOUDS
// A few points with normals in every encoding: ascii, binary little/big endian (PLY); ascii, binary,
// binary_compressed with literal-only LZF runs (PCD).
const float kPts[4][6] = {{0.1f, 0.2f, 0.5f, 0, 0, -1}, {-0.1f, 0.2f, 0.6f, 0, 0.6f, -0.8f},
                          {0.0f, -0.3f, 0.7f, 0.6f, 0, -0.8f}, {0.25f, 0.0f, 0.55f, 0, 0, -1}};
std::string float_bytes(float f, bool big) {
  std::string b(4, '\0');
  std::memcpy(&b[0], &f, 4);
  if (big) std::swap(b[0], b[3]), std::swap(b[1], b[2]);
  return b;
}
void ply_seeds(const fs::path& dir) {
  for (const char* fmt : {"ascii", "binary_little_endian", "binary_big_endian"})
    for (bool normals : {false, true}) {
      std::string s = std::string("ply\nformat ") + fmt + " 1.0\ncomment seed\nelement vertex 4\n"
                      "property float x\nproperty float y\nproperty float z\n";
      if (normals) s += "property float nx\nproperty float ny\nproperty float nz\n";
      s += "element face 0\nproperty list uchar int vertex_indices\nend_header\n";
      for (const auto& p : kPts)
        for (int i = 0; i < (normals ? 6 : 3); ++i) {
          if (std::string(fmt) == "ascii") s += std::to_string(p[i]) + (i + 1 == (normals ? 6 : 3) ? "\n" : " ");
          else s += float_bytes(p[i], std::string(fmt) == "binary_big_endian");
        }
      write(dir, std::string(fmt) + (normals ? "_normals" : ""), s);
    }
  write(dir, "double_props", "ply\nformat ascii 1.0\nelement vertex 2\nproperty double x\nproperty double y\n"
                             "property double z\nproperty uchar red\nend_header\n0 0 1 255\n1e-3 2 3 0\n");
}
void pcd_seeds(const fs::path& dir) {
  for (const char* data : {"ascii", "binary", "binary_compressed"})
    for (bool normals : {false, true}) {
      const int nf = normals ? 6 : 3;
      std::string s = std::string("# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS x y z") +
                      (normals ? " normal_x normal_y normal_z" : "") + "\nSIZE" + std::string(normals ? " 4 4 4 4 4 4" : " 4 4 4") +
                      "\nTYPE" + (normals ? " F F F F F F" : " F F F") + "\nCOUNT" + (normals ? " 1 1 1 1 1 1" : " 1 1 1") +
                      "\nWIDTH 2\nHEIGHT 2\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 4\nDATA " + data + "\n";
      const std::string mode = data;
      if (mode == "ascii") {
        for (const auto& p : kPts)
          for (int i = 0; i < nf; ++i) s += std::to_string(p[i]) + (i + 1 == nf ? "\n" : " ");
      } else if (mode == "binary") {
        for (const auto& p : kPts)
          for (int i = 0; i < nf; ++i) s += float_bytes(p[i], false);
      } else {
        std::string raw;  // structure of arrays
        for (int i = 0; i < nf; ++i)
          for (const auto& p : kPts) raw += float_bytes(p[i], false);
        std::string lzf;  // literal runs of at most 32 bytes: control byte = run length - 1
        for (std::size_t pos = 0; pos < raw.size(); pos += 32) {
          const std::size_t n = std::min<std::size_t>(32, raw.size() - pos);
          lzf.push_back(char(n - 1));
          lzf.append(raw, pos, n);
        }
        auto u32 = [](std::uint32_t v) { std::string b(4, '\0'); std::memcpy(&b[0], &v, 4); return b; };
        s += u32(std::uint32_t(lzf.size())) + u32(std::uint32_t(raw.size())) + lzf;
      }
      write(dir, std::string(data) + (normals ? "_normals" : ""), s);
    }
}
void cloud_seeds(const fs::path& dir, const std::string& ext) {
  if (ext == "ply") ply_seeds(dir);
  else pcd_seeds(dir);
}
#endif
}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: binpick_fuzz_seeds <out-dir>\n");
    return 2;
  }
  const fs::path out = argv[1];
  png_seeds(out / "fuzz_png16");
  pose_seeds(out / "fuzz_pose");
  intrinsics_seeds(out / "fuzz_intrinsics");
#ifdef BINPICK_FUZZ_CLOUDS
  cloud_seeds(out / "fuzz_ply", "ply");
  cloud_seeds(out / "fuzz_pcd", "pcd");
#endif
  return 0;
}
