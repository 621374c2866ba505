// binpick_plan: plans the sensing path of Alg. 2 (paper §III.C) from numbers on the command line and
// prints it as one JSON object; optionally draws it as an SVG side view in the plane P.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include "binpick/active_vision.hpp"
#include "io.hpp"

namespace {

using binpick::tools::json_number;
using Eigen::Vector2d;
using Eigen::Vector3d;

constexpr double kPi = 3.14159265358979323846;

const char* kUsage =
    "usage: binpick_plan --target x,y,z --radius r --grasp x,y,z --lift x,y,z --drop x,y,z\n"
    "                    [--gamma-deg g] --beta-deg b --views n [--min-elevation-deg e]\n"
    "                    [--svg path.svg] [--bin-min x,y,z --bin-max x,y,z]\n"
    "\n"
    "Plans the sensing path of the next cycle (Alg. 2): start M and end N on the arc L = S(T, r) ∩ P(A, B, C)\n"
    "with the coverage angle beta at T, and n capture poses between them, all looking at T.\n"
    "  --target   T, the target center (Eq. 1)            metres, robot base frame\n"
    "  --radius   r, the sensor's best working distance   metres\n"
    "  --grasp    A, grasp point; --lift B, lift point above A; --drop C, drop point (metres, base frame)\n"
    "  --gamma-deg  tilt of AB toward C [deg], default 5;  --beta-deg coverage angle at T [deg]\n"
    "  --views    n >= 2 capture poses (M and N included)\n"
    "  --min-elevation-deg  lowest sensor elevation seen from T [deg], default 0\n"
    "  --svg      also write a side view in the plane P; --bin-min/--bin-max: the bin as an axis-aligned\n"
    "             box in the base frame (otherwise a schematic bin around A and T is drawn)\n"
    "Output (stdout, one line): {\"start\": [x,y,z], \"end\": [x,y,z], \"captures\": [{\"position\": [x,y,z],\n"
    "\"z_axis\": [x,y,z]}, ...], \"length_bmnc\": m, \"length_bc\": m, ...}. Positions in metres in the base\n"
    "frame; z_axis is the camera's optical axis (unit, base frame). Camera poses follow T_base_camera with\n"
    "x along the travel on the arc. Bad input or degenerate geometry: a message on stderr, exit code 1.\n";

std::string json_vec(const Vector3d& v) {
  return "[" + json_number(v.x()) + ", " + json_number(v.y()) + ", " + json_number(v.z()) + "]";
}

struct Options {
  std::map<std::string, std::string> values;
  bool has(const std::string& key) const { return values.count(key) != 0; }
  const std::string& get(const std::string& key) const {
    const auto it = values.find(key);
    if (it == values.end()) throw std::runtime_error("missing required option --" + key);
    return it->second;
  }
};

Options parse_args(int argc, char** argv) {
  static const char* known[] = {"target", "radius", "grasp", "lift", "drop", "gamma-deg", "beta-deg",
                                "views", "min-elevation-deg", "svg", "bin-min", "bin-max"};
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") {
      std::fputs(kUsage, stdout);
      std::exit(0);
    }
    if (a.rfind("--", 0) != 0) throw std::runtime_error("unexpected argument '" + a + "'");
    const std::string key = a.substr(2);
    if (std::find_if(std::begin(known), std::end(known), [&](const char* k) { return key == k; }) == std::end(known))
      throw std::runtime_error("unknown option '" + a + "'");
    if (i + 1 >= argc) throw std::runtime_error("missing value after '" + a + "'");
    if (o.has(key)) throw std::runtime_error("option '" + a + "' given twice");
    o.values[key] = argv[++i];
  }
  return o;
}

// ---- SVG side view in P ---------------------------------------------------------------------------

// Coordinates in P: origin B, horizontal w (toward the drop), vertical u (the lift direction).
struct PlaneFrame {
  Vector3d origin, w, u;
  Vector2d operator()(const Vector3d& p) const { return {w.dot(p - origin), u.dot(p - origin)}; }
  Vector2d dir(const Vector3d& d) const { return {w.dot(d), u.dot(d)}; }
};

// The polygon where the plane (point, unit normal) cuts the box [lo, hi], in plane coordinates.
std::vector<Vector2d> box_section(const Vector3d& lo, const Vector3d& hi, const Vector3d& point, const Vector3d& normal,
                                  const PlaneFrame& frame) {
  std::vector<Vector3d> corners;
  for (int i = 0; i < 8; ++i)
    corners.emplace_back(i & 1 ? hi.x() : lo.x(), i & 2 ? hi.y() : lo.y(), i & 4 ? hi.z() : lo.z());
  std::vector<Vector2d> pts;
  for (int i = 0; i < 8; ++i)
    for (int bit = 1; bit < 8; bit <<= 1) {
      if (i & bit) continue;
      const Vector3d& p = corners[std::size_t(i)];
      const Vector3d& q = corners[std::size_t(i | bit)];
      const double dp = normal.dot(p - point), dq = normal.dot(q - point);
      if (std::abs(dp) < 1e-12) pts.push_back(frame(p));
      else if (dp * dq < 0) pts.push_back(frame(p + (q - p) * (dp / (dp - dq))));
    }
  if (pts.size() < 3) return {};
  Vector2d centroid = Vector2d::Zero();
  for (const auto& p : pts) centroid += p / double(pts.size());
  std::sort(pts.begin(), pts.end(), [&](const Vector2d& a, const Vector2d& b) {
    return std::atan2(a.y() - centroid.y(), a.x() - centroid.x()) < std::atan2(b.y() - centroid.y(), b.x() - centroid.x());
  });
  return pts;
}

void write_svg(const std::string& path, const binpick::active_vision::SensingPath<double>& plan, const Vector3d& A,
               const Vector3d& B, const Vector3d& C, const Vector3d& T, const Options& options) {
  const Vector3d u = (B - A).normalized();
  const Vector3d k = plan.plane.normal;
  const PlaneFrame f{B, k.cross(u), u};
  const Vector3d foot = plan.arc.center;  // T projected onto P
  const double h = k.dot(T - foot);
  std::vector<Vector2d> bin;
  if (options.has("bin-min") && options.has("bin-max")) {
    const Vector3d lo = binpick::tools::parse_vec3(options.get("bin-min"), "--bin-min");
    const Vector3d hi = binpick::tools::parse_vec3(options.get("bin-max"), "--bin-max");
    bin = box_section(lo.cwiseMin(hi), lo.cwiseMax(hi), A, k, f);
  } else {  // schematic: around A and T's foot, rim halfway up to B
    const Vector2d a = f(A), t = f(foot);
    const double x0 = std::min(a.x(), t.x()) - 0.08, x1 = std::max(a.x(), t.x()) + 0.08;
    const double y0 = std::min(a.y(), t.y()) - 0.03, y1 = 0.5 * (std::max(a.y(), t.y()) + f(B).y());
    bin = {{x0, y1}, {x0, y0}, {x1, y0}, {x1, y1}};
  }
  // Everything that is drawn, for the view box.
  std::vector<Vector2d> all{f(A), f(B), f(C), f(foot), f(plan.start), f(plan.end)};
  const Vector2d c2 = f(plan.arc.center);
  const double rho = plan.arc.radius;
  all.push_back(c2 + Vector2d(rho, rho));
  all.push_back(c2 - Vector2d(rho, rho));
  for (const auto& p : bin) all.push_back(p);
  Vector2d lo = all[0], hi = all[0];
  for (const auto& p : all) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
  const double margin = 0.05 * std::max(hi.x() - lo.x(), hi.y() - lo.y()) + 0.02;
  lo -= Vector2d(margin, margin);
  hi += Vector2d(margin, margin);
  const double scale = 800.0 / std::max(hi.x() - lo.x(), 1e-9);  // px per metre
  const double width = 800, height = std::max(1.0, (hi.y() - lo.y()) * scale);
  auto X = [&](const Vector2d& p) { return (p.x() - lo.x()) * scale; };
  auto Y = [&](const Vector2d& p) { return (hi.y() - p.y()) * scale; };
  auto pt = [&](const Vector2d& p) { return json_number(X(p)) + "," + json_number(Y(p)); };

  std::ofstream out(path);
  if (!out) throw std::runtime_error("cannot write '" + path + "'");
  out << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << width << "\" height=\"" << json_number(height)
      << "\" viewBox=\"0 0 " << width << " " << json_number(height) << "\" font-family=\"sans-serif\" font-size=\"13\">\n";
  out << "<title>binpick sensing path: side view in the plane P (horizontal: toward the drop point, vertical: lift"
         " direction; metres x " << json_number(scale) << " px)</title>\n";
  out << "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n";
  if (!bin.empty()) {
    out << "<polyline points=\"";
    for (const auto& p : bin) out << pt(p) << " ";
    if (options.has("bin-min")) out << pt(bin.front());
    out << "\" fill=\"#f3efe6\" stroke=\"#8a7a5a\" stroke-width=\"3\"/>\n";
  }
  // The full circle L (thin, dashed) and the sensing arc M..N (bold).
  out << "<circle cx=\"" << json_number(X(c2)) << "\" cy=\"" << json_number(Y(c2)) << "\" r=\"" << json_number(rho * scale)
      << "\" fill=\"none\" stroke=\"#9ab\" stroke-dasharray=\"6 4\"/>\n";
  const Vector2d m2 = f(plan.start), n2 = f(plan.end);
  // Sweep positive about k; in (w, u) coordinates with y up that is clockwise, i.e. SVG sweep flag 1.
  out << "<path d=\"M " << pt(m2) << " A " << json_number(rho * scale) << " " << json_number(rho * scale) << " 0 "
      << (plan.central_angle > kPi ? 1 : 0) << " 1 " << pt(n2) << "\" fill=\"none\" stroke=\"#1565c0\" stroke-width=\"4\"/>\n";
  auto line = [&](const Vector3d& p, const Vector3d& q, const char* style) {
    out << "<line x1=\"" << json_number(X(f(p))) << "\" y1=\"" << json_number(Y(f(p))) << "\" x2=\"" << json_number(X(f(q)))
        << "\" y2=\"" << json_number(Y(f(q))) << "\" " << style << "/>\n";
  };
  line(A, B, "stroke=\"#444\" stroke-width=\"2\"");
  line(B, plan.start, "stroke=\"#444\" stroke-width=\"2\"");
  line(plan.end, C, "stroke=\"#444\" stroke-width=\"2\"");
  line(B, C, "stroke=\"#aaa\" stroke-dasharray=\"3 3\"");
  line(plan.start, foot, "stroke=\"#1565c0\" stroke-dasharray=\"2 4\"");
  line(plan.end, foot, "stroke=\"#1565c0\" stroke-dasharray=\"2 4\"");
  // Capture poses with their viewing directions (projected into P).
  for (const auto& pose : plan.T_base_captures) {
    const Vector3d p = pose.translation();
    const Vector3d q = p + 0.25 * plan.arc.radius * pose.linear().col(2);
    out << "<circle cx=\"" << json_number(X(f(p))) << "\" cy=\"" << json_number(Y(f(p)))
        << "\" r=\"4\" fill=\"#e65100\"/>\n";
    line(p, q, "stroke=\"#e65100\" stroke-width=\"2\"");
  }
  auto label = [&](const Vector3d& p, const std::string& text, const char* color) {
    out << "<circle cx=\"" << json_number(X(f(p))) << "\" cy=\"" << json_number(Y(f(p))) << "\" r=\"5\" fill=\"" << color
        << "\"/>\n<text x=\"" << json_number(X(f(p)) + 8) << "\" y=\"" << json_number(Y(f(p)) - 8) << "\" fill=\"" << color
        << "\">" << text << "</text>\n";
  };
  label(A, "A grasp", "#222");
  label(B, "B lift", "#222");
  label(C, "C drop", "#222");
  label(plan.start, "M start", "#1565c0");
  label(plan.end, "N end", "#1565c0");
  label(foot, "T" + std::string(std::abs(h) > 1e-9 ? " (" + json_number(h * 1000) + " mm off P)" : ""), "#c62828");
  out << "<text x=\"10\" y=\"20\">beta " << json_number(plan.coverage_angle * 180 / kPi) << " deg, "
      << plan.T_base_captures.size() << " views, B-M-N-C " << json_number(plan.length_bmnc) << " m vs B-C "
      << json_number(plan.length_bc) << " m</text>\n";
  out << "</svg>\n";
  if (!out) throw std::runtime_error("cannot write '" + path + "'");
}

int run(int argc, char** argv) {
  using binpick::tools::parse_number;
  using binpick::tools::parse_vec3;
  const Options o = parse_args(argc, argv);
  if (o.values.empty()) throw std::runtime_error("no arguments (see --help)");
  const Vector3d T = parse_vec3(o.get("target"), "--target");
  const double radius = parse_number(o.get("radius"), "--radius");
  const Vector3d A = parse_vec3(o.get("grasp"), "--grasp");
  const Vector3d B = parse_vec3(o.get("lift"), "--lift");
  const Vector3d C = parse_vec3(o.get("drop"), "--drop");
  const double gamma_deg = o.has("gamma-deg") ? parse_number(o.get("gamma-deg"), "--gamma-deg") : 5.0;
  const double beta_deg = parse_number(o.get("beta-deg"), "--beta-deg");
  const double views = parse_number(o.get("views"), "--views");
  if (!(views >= 2 && views <= 100000 && views == std::floor(views)))
    throw std::runtime_error("'--views': expected a whole number >= 2");
  const double min_elevation_deg =
      o.has("min-elevation-deg") ? parse_number(o.get("min-elevation-deg"), "--min-elevation-deg") : 0.0;
  if (o.has("bin-min") != o.has("bin-max")) throw std::runtime_error("give both --bin-min and --bin-max, or neither");

  const auto plan = binpick::active_vision::plan_sensing_path<double>(
      T, radius, A, B, C, gamma_deg * kPi / 180, beta_deg * kPi / 180, int(views), min_elevation_deg * kPi / 180);
  if (!plan.ok()) {
    std::fprintf(stderr, "binpick_plan: cannot plan the sensing path: %s\n",
                 binpick::active_vision::to_string(plan.status));
    return 1;
  }
  std::string json = "{\"start\": " + json_vec(plan.start) + ", \"end\": " + json_vec(plan.end) + ", \"captures\": [";
  for (std::size_t i = 0; i < plan.T_base_captures.size(); ++i) {
    const auto& pose = plan.T_base_captures[i];
    json += std::string(i ? ", " : "") + "{\"position\": " + json_vec(pose.translation()) +
            ", \"z_axis\": " + json_vec(pose.linear().col(2)) + "}";
  }
  json += "], \"length_bmnc\": " + json_number(plan.length_bmnc) + ", \"length_bc\": " + json_number(plan.length_bc) +
          ", \"central_angle_deg\": " + json_number(plan.central_angle * 180 / kPi) +
          ", \"coverage_angle_deg\": " + json_number(plan.coverage_angle * 180 / kPi) +
          ", \"arc_radius\": " + json_number(plan.arc.radius) + "}";
  if (o.has("svg")) write_svg(o.get("svg"), plan, A, B, C, T, o);
  std::printf("%s\n", json.c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "binpick_plan: error: %s\n", e.what());
    return 1;
  }
}
