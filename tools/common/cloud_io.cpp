#include "cloud_io.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "io.hpp"

namespace binpick::tools {
namespace {

[[noreturn]] void fail(const std::string& name, const std::string& why) {
  throw std::runtime_error("'" + name + "': " + why);
}

// Largest point count accepted; well above any sensor frame, well below exhausting memory.
constexpr std::size_t kMaxPoints = std::size_t(1) << 28;

enum class Type { i8, u8, i16, u16, i32, u32, f32, f64, invalid };

std::size_t type_size(Type t) {
  switch (t) {
    case Type::i8: case Type::u8: return 1;
    case Type::i16: case Type::u16: return 2;
    case Type::i32: case Type::u32: case Type::f32: return 4;
    case Type::f64: return 8;
    default: return 0;
  }
}

double read_binary(const unsigned char* p, Type t, bool swap) {
  unsigned char b[8];
  const std::size_t n = type_size(t);
  for (std::size_t i = 0; i < n; ++i) b[i] = swap ? p[n - 1 - i] : p[i];
  switch (t) {
    case Type::i8: { std::int8_t v; std::memcpy(&v, b, 1); return v; }
    case Type::u8: { std::uint8_t v; std::memcpy(&v, b, 1); return v; }
    case Type::i16: { std::int16_t v; std::memcpy(&v, b, 2); return v; }
    case Type::u16: { std::uint16_t v; std::memcpy(&v, b, 2); return v; }
    case Type::i32: { std::int32_t v; std::memcpy(&v, b, 4); return v; }
    case Type::u32: { std::uint32_t v; std::memcpy(&v, b, 4); return v; }
    case Type::f32: { float v; std::memcpy(&v, b, 4); return v; }
    case Type::f64: { double v; std::memcpy(&v, b, 8); return v; }
    default: return 0;
  }
}

// A non-negative integer header value, bounded by `max`.
std::size_t parse_count(const std::string& s, std::size_t max, const std::string& name, const std::string& what) {
  if (s.empty() || s.size() > 12 || s.find_first_not_of("0123456789") != std::string::npos)
    fail(name, what + " must be a non-negative integer, got '" + s + "'");
  const unsigned long long v = std::strtoull(s.c_str(), nullptr, 10);
  if (v > max) fail(name, what + " " + s + " is too large");
  return std::size_t(v);
}

// Splits the header (lines up to and including the one starting with `last_key`) off `bytes`.
std::vector<std::vector<std::string>> header_lines(const std::string& bytes, const std::string& name,
                                                   const std::string& last_key, std::size_t& data_offset) {
  std::vector<std::vector<std::string>> lines;
  std::size_t pos = 0;
  while (pos < bytes.size()) {
    std::size_t end = bytes.find('\n', pos);
    if (end == std::string::npos) end = bytes.size();
    if (end - pos > 4096) fail(name, "header line too long");
    std::string line = bytes.substr(pos, end - pos);
    if (!line.empty() && line.back() == '\r') line.pop_back();
    pos = end + 1;
    std::istringstream ls(line);
    std::vector<std::string> tokens;
    for (std::string t; ls >> t;) tokens.push_back(t);
    if (tokens.empty()) continue;
    lines.push_back(tokens);
    if (lines.size() > 10000) fail(name, "header has too many lines");
    if (tokens[0] == last_key) {
      data_offset = std::min(pos, bytes.size());
      return lines;
    }
  }
  fail(name, "header has no '" + last_key + "' line");
}

// Whitespace-separated numbers of an ASCII body, read one at a time.
class AsciiReader {
 public:
  AsciiReader(const std::string& bytes, std::size_t offset, const std::string& name)
      : s_(bytes), pos_(offset), name_(name) {}
  double next() {
    while (pos_ < s_.size() && std::isspace(static_cast<unsigned char>(s_[pos_]))) ++pos_;
    if (pos_ >= s_.size()) fail(name_, "data ends before the header's point count");
    std::size_t end = pos_;
    while (end < s_.size() && !std::isspace(static_cast<unsigned char>(s_[end]))) ++end;
    if (end - pos_ > 64) fail(name_, "number too long in data");
    const std::string token = s_.substr(pos_, end - pos_);
    pos_ = end;
    char* stop = nullptr;
    const double v = std::strtod(token.c_str(), &stop);
    if (stop == token.c_str() || *stop != '\0') fail(name_, "not a number in data: '" + token + "'");
    return v;
  }
  // Skips to the start of the next line (PCD ascii: one point per line; extra columns are ignored).
  void next_line() {
    while (pos_ < s_.size() && s_[pos_] != '\n') ++pos_;
    if (pos_ < s_.size()) ++pos_;
  }

 private:
  const std::string& s_;
  std::size_t pos_;
  std::string name_;
};

Type ply_type(const std::string& t) {
  if (t == "char" || t == "int8") return Type::i8;
  if (t == "uchar" || t == "uint8") return Type::u8;
  if (t == "short" || t == "int16") return Type::i16;
  if (t == "ushort" || t == "uint16") return Type::u16;
  if (t == "int" || t == "int32") return Type::i32;
  if (t == "uint" || t == "uint32") return Type::u32;
  if (t == "float" || t == "float32") return Type::f32;
  if (t == "double" || t == "float64") return Type::f64;
  return Type::invalid;
}

struct PlyProperty {
  std::string name;
  Type type = Type::invalid;
  bool list = false;
  Type count_type = Type::invalid;
};
struct PlyElement {
  std::string name;
  std::size_t count = 0;
  std::vector<PlyProperty> props;
};

// Unpacks LZF (the codec of PCD's binary_compressed); every read and write is bounds-checked.
std::string lzf_decompress(const unsigned char* in, std::size_t in_size, std::size_t out_size, const std::string& name) {
  std::string out(out_size, '\0');
  std::size_t ip = 0, op = 0;
  while (ip < in_size) {
    const unsigned ctrl = in[ip++];
    if (ctrl < 32) {  // literal run of ctrl + 1 bytes
      const std::size_t len = ctrl + 1;
      if (ip + len > in_size || op + len > out_size) fail(name, "corrupt compressed data");
      std::memcpy(&out[op], in + ip, len);
      ip += len;
      op += len;
    } else {  // back reference
      std::size_t len = ctrl >> 5;
      if (len == 7) {
        if (ip >= in_size) fail(name, "corrupt compressed data");
        len += in[ip++];
      }
      if (ip >= in_size) fail(name, "corrupt compressed data");
      const std::size_t back = ((ctrl & 0x1f) << 8) + in[ip++] + 1;
      len += 2;
      if (back > op || op + len > out_size) fail(name, "corrupt compressed data");
      for (std::size_t i = 0; i < len; ++i, ++op) out[op] = out[op - back];
    }
  }
  if (op != out_size) fail(name, "compressed data shorter than declared");
  return out;
}

}  // namespace

CloudFile parse_ply(const std::string& bytes, const std::string& name) {
  if (bytes.compare(0, 3, "ply") != 0) fail(name, "not a PLY file");
  std::size_t offset = 0;
  const auto lines = header_lines(bytes, name, "end_header", offset);
  std::string format;
  std::vector<PlyElement> elements;
  for (const auto& t : lines) {
    if (t[0] == "format") {
      if (t.size() < 2) fail(name, "bad format line");
      format = t[1];
    } else if (t[0] == "element") {
      if (t.size() != 3) fail(name, "bad element line");
      elements.push_back({t[1], parse_count(t[2], kMaxPoints, name, "element count"), {}});
    } else if (t[0] == "property") {
      if (elements.empty()) fail(name, "property before any element");
      PlyProperty p;
      if (t.size() == 5 && t[1] == "list") {
        p.list = true;
        p.count_type = ply_type(t[2]);
        p.type = ply_type(t[3]);
        p.name = t[4];
        if (p.count_type == Type::invalid || p.count_type == Type::f32 || p.count_type == Type::f64)
          fail(name, "bad list count type '" + t[2] + "'");
      } else if (t.size() == 3) {
        p.type = ply_type(t[1]);
        p.name = t[2];
      } else {
        fail(name, "bad property line");
      }
      if (p.type == Type::invalid) fail(name, "unknown property type in '" + p.name + "'");
      elements.back().props.push_back(p);
    }
  }
  const bool ascii = format == "ascii";
  const bool little = format == "binary_little_endian", big = format == "binary_big_endian";
  if (!ascii && !little && !big) fail(name, "unsupported PLY format '" + format + "'");
  const bool swap = big;  // the host is little endian (x86, ARM)

  CloudFile cloud;
  bool have_vertices = false;
  AsciiReader text(bytes, offset, name);
  std::size_t pos = offset;
  const auto* data = reinterpret_cast<const unsigned char*>(bytes.data());
  const auto binary_value = [&](Type t) {
    const std::size_t n = type_size(t);
    if (pos > bytes.size() || bytes.size() - pos < n) fail(name, "data ends before the header's element counts");
    const double v = read_binary(data + pos, t, swap);
    pos += n;
    return v;
  };
  const auto value = [&](Type t) { return ascii ? text.next() : binary_value(t); };

  for (const PlyElement& e : elements) {
    const bool vertex = e.name == "vertex";
    int ix = -1, iy = -1, iz = -1, inx = -1, iny = -1, inz = -1;
    for (std::size_t i = 0; i < e.props.size(); ++i) {
      const auto& n = e.props[i].name;
      const int k = int(i);
      if (e.props[i].list) continue;
      if (n == "x") ix = k; else if (n == "y") iy = k; else if (n == "z") iz = k;
      else if (n == "nx") inx = k; else if (n == "ny") iny = k; else if (n == "nz") inz = k;
    }
    if (vertex) {
      if (have_vertices) fail(name, "more than one vertex element");
      if (ix < 0 || iy < 0 || iz < 0) fail(name, "vertex element lacks x, y or z");
      // Every vertex takes at least one byte per property: a count beyond the bytes left is a lie.
      if (e.props.empty() || e.count > (bytes.size() - std::min(offset, bytes.size())) / e.props.size() + 1)
        fail(name, "vertex count larger than the file");
      have_vertices = true;
      cloud.points.reserve(e.count);
    }
    const bool normals = vertex && inx >= 0 && iny >= 0 && inz >= 0;
    std::vector<double> v(e.props.size());
    for (std::size_t i = 0; i < e.count; ++i) {
      for (std::size_t p = 0; p < e.props.size(); ++p) {
        const PlyProperty& prop = e.props[p];
        if (!prop.list) {
          v[p] = value(prop.type);
          continue;
        }
        const double n = value(prop.count_type);
        if (!(n >= 0 && n <= 1e6)) fail(name, "bad list length in element '" + e.name + "'");
        for (std::size_t k = 0; k < std::size_t(n); ++k) value(prop.type);
      }
      if (vertex) {
        cloud.points.emplace_back(v[std::size_t(ix)], v[std::size_t(iy)], v[std::size_t(iz)]);
        if (normals) cloud.normals.emplace_back(v[std::size_t(inx)], v[std::size_t(iny)], v[std::size_t(inz)]);
      }
    }
    if (vertex) break;  // later elements (faces) are not needed
  }
  if (!have_vertices) fail(name, "no vertex element");
  cloud.width = int(cloud.points.size());
  cloud.height = 1;
  return cloud;
}

CloudFile parse_pcd(const std::string& bytes, const std::string& name) {
  std::size_t offset = 0;
  const auto lines = header_lines(bytes, name, "DATA", offset);
  std::vector<std::string> fields, types;
  std::vector<std::size_t> sizes, counts;
  std::size_t width = 0, height = 1, points = 0;
  bool have_points = false, have_width = false;
  std::string data_kind;
  for (const auto& t : lines) {
    const std::string& k = t[0];
    if (k[0] == '#') continue;
    if (k == "FIELDS" || k == "COLUMNS") fields.assign(t.begin() + 1, t.end());
    else if (k == "SIZE") { sizes.clear(); for (std::size_t i = 1; i < t.size(); ++i) sizes.push_back(parse_count(t[i], 8, name, "SIZE")); }
    else if (k == "TYPE") types.assign(t.begin() + 1, t.end());
    else if (k == "COUNT") { counts.clear(); for (std::size_t i = 1; i < t.size(); ++i) counts.push_back(parse_count(t[i], 1 << 16, name, "COUNT")); }
    else if (k == "WIDTH" && t.size() == 2) { width = parse_count(t[1], kMaxPoints, name, "WIDTH"); have_width = true; }
    else if (k == "HEIGHT" && t.size() == 2) height = parse_count(t[1], kMaxPoints, name, "HEIGHT");
    else if (k == "POINTS" && t.size() == 2) { points = parse_count(t[1], kMaxPoints, name, "POINTS"); have_points = true; }
    else if (k == "DATA" && t.size() == 2) data_kind = t[1];
  }
  if (fields.empty()) fail(name, "no FIELDS line (not a PCD file?)");
  if (counts.empty()) counts.assign(fields.size(), 1);
  if (data_kind != "ascii" && (sizes.size() != fields.size() || types.size() != fields.size()))
    fail(name, "SIZE and TYPE must list one entry per field");
  if (counts.size() != fields.size()) fail(name, "COUNT must list one entry per field");
  if (!have_width) fail(name, "no WIDTH");
  if (height == 0 || width > kMaxPoints / height) fail(name, "WIDTH × HEIGHT out of range");
  if (!have_points) points = width * height;
  if (points != width * height) fail(name, "POINTS differs from WIDTH × HEIGHT");

  // Column of each wanted field (first element of its COUNT), and the type of every field.
  std::vector<Type> ftype(fields.size(), Type::f32);
  std::vector<std::size_t> column(fields.size(), 0);
  std::size_t record = 0, columns = 0;
  for (std::size_t f = 0; f < fields.size(); ++f) {
    if (!types.empty() && f < types.size() && f < sizes.size()) {
      const std::string& ty = types[f];
      const std::size_t sz = sizes[f];
      Type t = Type::invalid;
      if (ty == "F") t = sz == 4 ? Type::f32 : sz == 8 ? Type::f64 : Type::invalid;
      else if (ty == "I") t = sz == 1 ? Type::i8 : sz == 2 ? Type::i16 : sz == 4 ? Type::i32 : Type::invalid;
      else if (ty == "U") t = sz == 1 ? Type::u8 : sz == 2 ? Type::u16 : sz == 4 ? Type::u32 : Type::invalid;
      if (t == Type::invalid) fail(name, "unsupported TYPE/SIZE for field '" + fields[f] + "'");
      ftype[f] = t;
    }
    column[f] = columns;
    columns += counts[f];
    record += counts[f] * type_size(ftype[f]);
  }
  const auto find = [&](const char* n) -> int {
    for (std::size_t f = 0; f < fields.size(); ++f)
      if (fields[f] == n && counts[f] >= 1) return int(f);
    return -1;
  };
  const int fx = find("x"), fy = find("y"), fz = find("z");
  const int fnx = find("normal_x"), fny = find("normal_y"), fnz = find("normal_z");
  if (fx < 0 || fy < 0 || fz < 0) fail(name, "fields x, y and z are required");
  const bool normals = fnx >= 0 && fny >= 0 && fnz >= 0;
  const std::size_t remaining = bytes.size() - std::min(offset, bytes.size());

  CloudFile cloud;
  cloud.width = int(width);
  cloud.height = int(height);
  std::vector<double> v(columns);
  const auto emit = [&]() {
    cloud.points.emplace_back(v[column[std::size_t(fx)]], v[column[std::size_t(fy)]], v[column[std::size_t(fz)]]);
    if (normals) cloud.normals.emplace_back(v[column[std::size_t(fnx)]], v[column[std::size_t(fny)]], v[column[std::size_t(fnz)]]);
  };
  if (data_kind == "ascii") {
    if (points > remaining / (2 * std::max<std::size_t>(columns, 1)) + 1) fail(name, "POINTS larger than the file");
    cloud.points.reserve(points);
    AsciiReader text(bytes, offset, name);
    for (std::size_t i = 0; i < points; ++i) {
      for (std::size_t c = 0; c < columns; ++c) v[c] = text.next();
      text.next_line();
      emit();
    }
  } else if (data_kind == "binary") {
    if (record == 0 || points > remaining / record) fail(name, "binary data shorter than POINTS × record size");
    cloud.points.reserve(points);
    const auto* p = reinterpret_cast<const unsigned char*>(bytes.data()) + offset;
    for (std::size_t i = 0; i < points; ++i) {
      for (std::size_t f = 0, c = 0; f < fields.size(); ++f)
        for (std::size_t k = 0; k < counts[f]; ++k, ++c) {
          v[c] = read_binary(p, ftype[f], false);
          p += type_size(ftype[f]);
        }
      emit();
    }
  } else if (data_kind == "binary_compressed") {
    if (remaining < 8) fail(name, "compressed data header missing");
    std::uint32_t csize = 0, usize = 0;
    std::memcpy(&csize, bytes.data() + offset, 4);
    std::memcpy(&usize, bytes.data() + offset + 4, 4);
    if (csize > remaining - 8) fail(name, "compressed size larger than the file");
    if (record == 0 || points > std::numeric_limits<std::size_t>::max() / record || usize != points * record)
      fail(name, "uncompressed size differs from POINTS × record size");
    const std::string raw = lzf_decompress(reinterpret_cast<const unsigned char*>(bytes.data()) + offset + 8, csize,
                                           usize, name);
    // Column-major: all values of field 0, then field 1, ...
    std::vector<std::size_t> field_start(fields.size(), 0);
    for (std::size_t f = 1; f < fields.size(); ++f)
      field_start[f] = field_start[f - 1] + points * counts[f - 1] * type_size(ftype[f - 1]);
    cloud.points.reserve(points);
    const auto* base = reinterpret_cast<const unsigned char*>(raw.data());
    for (std::size_t i = 0; i < points; ++i) {
      for (std::size_t f = 0, c = 0; f < fields.size(); ++f)
        for (std::size_t k = 0; k < counts[f]; ++k, ++c)
          v[c] = read_binary(base + field_start[f] + (i * counts[f] + k) * type_size(ftype[f]), ftype[f], false);
      emit();
    }
  } else {
    fail(name, "unsupported DATA '" + data_kind + "'");
  }
  return cloud;
}

CloudFile read_cloud(const std::string& path) {
  const std::string bytes = read_text_file(path);
  if (bytes.compare(0, 3, "ply") == 0) return parse_ply(bytes, path);
  return parse_pcd(bytes, path);
}

}  // namespace binpick::tools
