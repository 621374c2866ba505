#include "io.hpp"

#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <limits>
#include <sstream>
#include <stdexcept>

#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmissing-field-initializers"
#pragma GCC diagnostic ignored "-Wsign-compare"
#pragma GCC diagnostic ignored "-Wunused-parameter"
#pragma GCC diagnostic ignored "-Wunused-function"
#define STB_IMAGE_IMPLEMENTATION
#define STBI_ONLY_PNG
#define STBI_MAX_DIMENSIONS (1 << 15)
#include <stb_image.h>
#define STB_IMAGE_WRITE_IMPLEMENTATION
#include <stb_image_write.h>
#pragma GCC diagnostic pop

namespace binpick::tools {

namespace {
[[noreturn]] void fail(const std::string& what) { throw std::runtime_error(what); }
}  // namespace

std::string read_text_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) fail("cannot open '" + path + "'");
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

namespace {
std::uint32_t be32(const unsigned char* p) {
  return (std::uint32_t(p[0]) << 24) | (std::uint32_t(p[1]) << 16) | (std::uint32_t(p[2]) << 8) | std::uint32_t(p[3]);
}

// Largest depth image accepted [pixels]: 64 Mpx, far above any depth sensor, well below what
// would exhaust memory.
constexpr std::uint64_t kMaxPngPixels = std::uint64_t(1) << 26;

// stb_image trusts the sizes a PNG declares: it grows its IDAT buffer to a chunk's stated length and
// allocates width x height before it checks that the data exist, so a 90-byte file could make it
// allocate 750 MB (found by fuzz_png16). Walk the chunk list first: every chunk must fit in the
// file, the image must be at most kMaxPngPixels, and the compressed data must be able to hold it
// (deflate expands at most ~1032:1). A leading empty IDAT chunk is refused too (see below).
void check_png_structure(const unsigned char* b, std::size_t n, const std::string& name) {
  static const unsigned char kSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
  if (n < 8 || std::memcmp(b, kSignature, 8) != 0) fail("'" + name + "': not a PNG file");
  std::uint64_t width = 0, height = 0, bits_per_pixel = 0, idat_bytes = 0;
  bool have_header = false;
  for (std::size_t pos = 8; pos < n;) {
    // A partial chunk header at the end is read by stb as a chunk too (zeros past the end).
    if (n - pos < 12) fail("'" + name + "': PNG ends inside a chunk header (truncated)");
    const std::uint64_t length = be32(b + pos);
    if (length > n - pos - 12) fail("'" + name + "': a PNG chunk is longer than the file (truncated or corrupt)");
    const unsigned char* type = b + pos + 4;
    const unsigned char* payload = b + pos + 8;
    if (std::memcmp(type, "IHDR", 4) == 0 && length >= 13) {
      width = be32(payload);
      height = be32(payload + 4);
      const unsigned depth = payload[8], color = payload[9];
      const unsigned channels = color == 2 ? 3 : color == 4 ? 2 : color == 6 ? 4 : 1;
      bits_per_pixel = std::uint64_t(depth) * channels;
      have_header = true;
    } else if (std::memcmp(type, "IDAT", 4) == 0) {
      // stb copies a first, empty IDAT through a null pointer (UB; found by fuzz_png16).
      if (length == 0 && idat_bytes == 0) fail("'" + name + "': PNG starts its image data with an empty chunk");
      idat_bytes += length;
    }
    pos += std::size_t(length) + 12;
    if (std::memcmp(type, "IEND", 4) == 0) break;
  }
  if (!have_header) fail("'" + name + "': PNG without a header chunk");
  if (width == 0 || height == 0 || width * height > kMaxPngPixels)
    fail("'" + name + "': PNG size " + std::to_string(width) + "x" + std::to_string(height) +
         " is empty or above the 64 Mpx limit");
  const std::uint64_t min_raw_bytes = height * ((width * bits_per_pixel + 7) / 8);
  if (idat_bytes * 1032 + 1024 < min_raw_bytes) fail("'" + name + "': PNG image data too short for its size");
}
}  // namespace

Image16 decode_png16(const unsigned char* bytes, std::size_t size, const std::string& name) {
  if (size > std::size_t(std::numeric_limits<int>::max())) fail("'" + name + "': file too large");
  check_png_structure(bytes, size, name);
  int w = 0, h = 0, channels = 0;
  stbi_us* data = stbi_load_16_from_memory(bytes, int(size), &w, &h, &channels, 1);
  if (!data) fail("'" + name + "': not a readable PNG (" + std::string(stbi_failure_reason()) + ")");
  Image16 img;
  img.width = w;
  img.height = h;
  img.pixels.assign(data, data + std::size_t(w) * std::size_t(h));
  stbi_image_free(data);
  if (channels != 1) fail("'" + name + "': expected a single-channel depth PNG, got " + std::to_string(channels) + " channels");
  return img;
}

Image16 read_png16(const std::string& path) {
  const std::string bytes = read_text_file(path);
  return decode_png16(reinterpret_cast<const unsigned char*>(bytes.data()), bytes.size(), path);
}

namespace {
// stb writes 8-bit PNGs only; a 16-bit PNG is written here with zlib-free stored (uncompressed)
// deflate blocks so the output keeps full depth precision without another dependency.
void put32(std::string& s, std::uint32_t v) {
  for (int i = 3; i >= 0; --i) s.push_back(char((v >> (8 * i)) & 0xFF));
}
std::uint32_t crc32(const std::string& s, std::size_t begin) {
  static std::uint32_t table[256];
  static bool init = false;
  if (!init) {
    for (std::uint32_t n = 0; n < 256; ++n) {
      std::uint32_t c = n;
      for (int k = 0; k < 8; ++k) c = (c & 1) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
      table[n] = c;
    }
    init = true;
  }
  std::uint32_t c = 0xFFFFFFFFu;
  for (std::size_t i = begin; i < s.size(); ++i) c = table[(c ^ std::uint8_t(s[i])) & 0xFF] ^ (c >> 8);
  return c ^ 0xFFFFFFFFu;
}
void chunk(std::string& out, const char* type, const std::string& payload) {
  put32(out, std::uint32_t(payload.size()));
  const std::size_t start = out.size();
  out.append(type, 4);
  out += payload;
  put32(out, crc32(out, start));
}
}  // namespace

void write_png16(const std::string& path, const Image16& image) {
  if (image.width <= 0 || image.height <= 0 || image.pixels.size() != std::size_t(image.width) * image.height)
    fail("'" + path + "': invalid image to write");
  std::string raw;  // filter byte 0 + big-endian samples per row
  raw.reserve(std::size_t(image.height) * (1 + 2 * image.width));
  for (int v = 0; v < image.height; ++v) {
    raw.push_back(0);
    for (int u = 0; u < image.width; ++u) {
      const std::uint16_t p = image.pixels[std::size_t(v) * image.width + u];
      raw.push_back(char(p >> 8));
      raw.push_back(char(p & 0xFF));
    }
  }
  std::string z;  // zlib stream with stored blocks
  z.push_back(char(0x78));
  z.push_back(char(0x01));
  std::uint32_t a = 1, b = 0;
  for (unsigned char c : raw) {
    a = (a + c) % 65521;
    b = (b + a) % 65521;
  }
  for (std::size_t pos = 0; pos < raw.size() || pos == 0;) {
    const std::size_t n = std::min<std::size_t>(65535, raw.size() - pos);
    const bool last = pos + n >= raw.size();
    z.push_back(char(last ? 1 : 0));
    z.push_back(char(n & 0xFF));
    z.push_back(char(n >> 8));
    z.push_back(char(~n & 0xFF));
    z.push_back(char((~n >> 8) & 0xFF));
    z.append(raw, pos, n);
    pos += n;
    if (last) break;
  }
  put32(z, (b << 16) | a);
  std::string out("\x89PNG\r\n\x1a\n", 8);
  std::string ihdr;
  put32(ihdr, std::uint32_t(image.width));
  put32(ihdr, std::uint32_t(image.height));
  ihdr += std::string("\x10\x00\x00\x00\x00", 5);  // 16-bit, greyscale, deflate, no filter, no interlace
  chunk(out, "IHDR", ihdr);
  chunk(out, "IDAT", z);
  chunk(out, "IEND", "");
  std::ofstream f(path, std::ios::binary);
  if (!f || !f.write(out.data(), std::streamsize(out.size()))) fail("cannot write '" + path + "'");
}

void write_png8(const std::string& path, int width, int height, const std::vector<std::uint8_t>& pixels) {
  if (width <= 0 || height <= 0 || pixels.size() != std::size_t(width) * height) fail("'" + path + "': invalid image to write");
  if (!stbi_write_png(path.c_str(), width, height, 1, pixels.data(), width)) fail("cannot write '" + path + "'");
}

namespace {
std::vector<double> parse_numbers(const std::string& text, const std::string& name) {
  std::vector<double> values;
  std::string cleaned;
  cleaned.reserve(text.size());
  bool comment = false;
  for (char c : text) {
    if (c == '#') comment = true;
    if (c == '\n') comment = false;
    cleaned.push_back(comment || c == ',' || c == '[' || c == ']' || c == ';' ? ' ' : c);
  }
  std::istringstream in(cleaned);
  std::string tok;
  while (in >> tok) {
    char* end = nullptr;
    const double v = std::strtod(tok.c_str(), &end);
    if (end == tok.c_str() || *end != '\0') fail("'" + name + "': '" + tok.substr(0, 40) + "' is not a number");
    if (!std::isfinite(v)) fail("'" + name + "': non-finite number");
    values.push_back(v);
  }
  return values;
}
}  // namespace

Eigen::Isometry3d parse_pose(const std::string& text, const std::string& name) {
  const std::vector<double> v = parse_numbers(text, name);
  if (v.size() != 16) fail("'" + name + "': expected 16 numbers (4x4 row-major), got " + std::to_string(v.size()));
  Eigen::Matrix4d m;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) m(r, c) = v[std::size_t(4 * r + c)];
  const Eigen::Matrix3d R = m.topLeftCorner<3, 3>();
  if ((R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() > 1e-4 || R.determinant() <= 0)
    fail("'" + name + "': rotation part is not orthonormal");
  if (std::abs(m(3, 0)) + std::abs(m(3, 1)) + std::abs(m(3, 2)) + std::abs(m(3, 3) - 1) > 1e-9)
    fail("'" + name + "': last row must be 0 0 0 1");
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  // Re-orthonormalize so the library's strict pose check accepts text rounded to a few digits.
  T.linear() = Eigen::Quaterniond(R).normalized().toRotationMatrix();
  T.translation() = m.topRightCorner<3, 1>();
  return T;
}

Eigen::Isometry3d read_pose_file(const std::string& path) { return parse_pose(read_text_file(path), path); }

Intrinsics parse_intrinsics(const std::string& text) {
  const std::vector<double> v = parse_numbers(text, "--intrinsics");
  if (v.size() != 6) fail("'--intrinsics': expected fx,fy,cx,cy,width,height");
  // Range-check before converting: casting a double outside int's range is UB (UBSan float-cast-overflow).
  if (!(v[4] >= 1 && v[4] <= 1e5 && v[5] >= 1 && v[5] <= 1e5) || v[4] != std::floor(v[4]) || v[5] != std::floor(v[5]))
    fail("'--intrinsics': width and height must be positive integers");
  Intrinsics k{v[0], v[1], v[2], v[3], int(v[4]), int(v[5])};
  if (!(k.fx > 0) || !(k.fy > 0)) fail("'--intrinsics': focal lengths must be > 0");
  return k;
}

Eigen::Vector3d parse_vec3(const std::string& text, const std::string& name) {
  const std::vector<double> v = parse_numbers(text, name);
  if (v.size() != 3) fail("'" + name + "': expected x,y,z");
  return Eigen::Vector3d(v[0], v[1], v[2]);
}

double parse_number(const std::string& text, const std::string& name) {
  const std::vector<double> v = parse_numbers(text, name);
  if (v.size() != 1) fail("'" + name + "': expected one number");
  return v[0];
}

std::string json_number(double v) {
  if (!std::isfinite(v)) return "null";
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.9g", v);
  return buf;
}

std::string json_string(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') out += '\\', out += c;
    else if (std::uint8_t(c) < 0x20) {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\u%04x", c);
      out += buf;
    } else out += c;
  }
  return out + "\"";
}

}  // namespace binpick::tools
