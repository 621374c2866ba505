#pragma once
// Pictures of one cycle: fused depth and votes (PNG), the sensing path (SVG, side view in the plane of
// A, B, C), and the cycle timeline (SVG: robot segments vs capture and processing stages).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include "binpick/cycle/pipeline.hpp"
#include "io.hpp"

namespace binpick::simcell {

inline void write_fused_pngs(const std::string& dir, const DepthImage<float>& depth, const std::vector<std::uint8_t>& votes) {
  const int w = depth.width(), h = depth.height();
  tools::Image16 img;
  img.width = w;
  img.height = h;
  img.pixels.resize(std::size_t(w) * std::size_t(h));
  float lo = 1e9f, hi = 0;
  for (std::size_t i = 0; i < img.pixels.size(); ++i) {
    const float z = depth.data()[i];
    img.pixels[i] = z > 0 && std::isfinite(z) ? std::uint16_t(std::min(65535.0f, std::round(z * 1000.0f))) : 0;
    if (z > 0 && std::isfinite(z)) lo = std::min(lo, z), hi = std::max(hi, z);
  }
  tools::write_png16(dir + "/fused_depth_mm.png", img);
  // 8-bit view: near = bright, no measurement = black.
  std::vector<std::uint8_t> v8(img.pixels.size(), 0);
  for (std::size_t i = 0; i < v8.size(); ++i) {
    const float z = depth.data()[i];
    if (z > 0 && std::isfinite(z) && hi > lo) v8[i] = std::uint8_t(40 + 215 * (hi - z) / (hi - lo));
  }
  tools::write_png8(dir + "/fused_depth.png", w, h, v8);
  if (votes.size() == v8.size()) {
    int vmax = 1;
    for (auto v : votes) vmax = std::max(vmax, int(v));
    std::vector<std::uint8_t> g(votes.size());
    for (std::size_t i = 0; i < g.size(); ++i) g[i] = std::uint8_t(255 * int(votes[i]) / vmax);
    tools::write_png8(dir + "/votes.png", w, h, g);
  }
}

/// Side view of the sensing path: horizontal axis along B→C (projected on the floor), vertical = z.
inline void write_path_svg(const std::string& path, const cycle::CycleResult<float>& r, const cycle::PipelineSettings<float>& s) {
  using V = Eigen::Vector3f;
  V u = r.drop - r.pull_up;
  u.z() = 0;
  if (u.norm() < 1e-6f) u = V::UnitX();
  u.normalize();
  const V o = r.target;
  auto X = [&](const V& p) { return 60.0 + 500.0 * double((p - o).dot(u) + 0.35f); };
  auto Y = [&](const V& p) { return 440.0 - 500.0 * double(p.z() - o.z() + 0.08f); };
  std::ofstream f(path);
  f << "<svg xmlns='http://www.w3.org/2000/svg' width='800' height='480' font-family='sans-serif' font-size='12'>\n"
    << "<rect width='800' height='480' fill='white'/>\n";
  // Bin cross-section along u.
  const double half = 0.5 * double(std::abs(u.x()) * s.bin_length + std::abs(u.y()) * s.bin_width);
  const V c = s.bin_center;
  const double bx0 = X(c) - 500 * half, bx1 = X(c) + 500 * half, by0 = Y(c), by1 = Y(c + V(0, 0, s.bin_height));
  f << "<polyline points='" << bx0 << "," << by1 << " " << bx0 << "," << by0 << " " << bx1 << "," << by0 << " " << bx1 << "," << by1
    << "' fill='none' stroke='#777' stroke-width='3'/>\n";
  for (const auto& p : r.objects_base)
    f << "<circle cx='" << X(p) << "' cy='" << Y(p) << "' r='4' fill='#e69b00'/>\n";
  auto dot = [&](const V& p, const char* col, const char* label) {
    f << "<circle cx='" << X(p) << "' cy='" << Y(p) << "' r='5' fill='" << col << "'/><text x='" << X(p) + 7 << "' y='" << Y(p) - 7
      << "'>" << label << "</text>\n";
  };
  dot(r.target, "#d00", "T");
  dot(r.pull_up, "#333", "B (camera)");
  dot(r.drop, "#00a", "C");
  // Planned capture poses (red) with their optical axes, read poses (green).
  std::string line;
  for (std::size_t i = 0; i < r.T_base_captures_planned.size(); ++i) {
    const V p = r.T_base_captures_planned[i].translation();
    const V z = r.T_base_captures_planned[i].linear().col(2);
    line += std::to_string(X(p)) + "," + std::to_string(Y(p)) + " ";
    f << "<line x1='" << X(p) << "' y1='" << Y(p) << "' x2='" << X(p + 0.06f * z) << "' y2='" << Y(p + 0.06f * z)
      << "' stroke='#d00' stroke-dasharray='3,2'/>\n";
    f << "<circle cx='" << X(p) << "' cy='" << Y(p) << "' r='4' fill='none' stroke='#d00'/>\n";
  }
  f << "<polyline points='" << X(r.pull_up) << "," << Y(r.pull_up) << " " << line << "' fill='none' stroke='#d00' stroke-width='2'/>\n";
  if (!r.T_base_captures_planned.empty()) {
    const V n = r.T_base_captures_planned.back().translation();
    f << "<line x1='" << X(n) << "' y1='" << Y(n) << "' x2='" << X(r.drop) << "' y2='" << Y(r.drop)
      << "' stroke='#00a' stroke-width='2'/>\n";
  }
  for (const auto& T : r.T_base_captures_read)
    f << "<circle cx='" << X(T.translation()) << "' cy='" << Y(T.translation()) << "' r='2.5' fill='#080'/>\n";
  f << "<text x='20' y='20'>Sensing path (side view along B-C): red = planned views looking at T (Alg. 2), green = poses read "
       "(late while moving), blue = dropping path, orange = recognized objects. Path source: "
    << cycle::to_string(r.path_source) << "</text>\n</svg>\n";
}

/// Timeline of one cycle: one row per lane, entries as bars.
inline void write_timeline_svg(const std::string& path, const cycle::CycleResult<float>& r) {
  const auto& tl = r.timeline;
  const double t0 = tl.begin(), t1 = std::max(tl.end(), t0 + 1e-3);
  const double W = 1100, left = 110;
  auto X = [&](double t) { return left + (W - left - 20) * (t - t0) / (t1 - t0); };
  std::ofstream f(path);
  f << "<svg xmlns='http://www.w3.org/2000/svg' width='" << W << "' height='330' font-family='sans-serif' font-size='11'>\n"
    << "<rect width='100%' height='100%' fill='white'/>\n";
  const char* lanes[3] = {"robot", "capture", "processing"};
  const double ys[3] = {50, 150, 220};
  for (int l = 0; l < 3; ++l) f << "<text x='10' y='" << ys[l] + 18 << "' font-size='13'>" << lanes[l] << "</text>\n";
  int k = 0;
  for (const auto& e : tl.entries()) {
    const int l = int(e.lane);
    const double x0 = X(e.start), x1 = std::max(X(e.end), x0 + 1.5);
    const char* col = e.lane == cycle::Lane::robot ? (e.name.find("wait") != std::string::npos ? "#c33" : (e.name.find("sensing") != std::string::npos || e.name.find("stop") != std::string::npos ? "#e77" : (e.name.find("drop") != std::string::npos ? "#77e" : "#7b7")))
                      : e.lane == cycle::Lane::capture ? "#999" : (e.measured ? "#f90" : "#fc7");
    const double y = ys[l] + (e.lane == cycle::Lane::capture ? (e.name.rfind("kin", 0) == 0 ? 14 : 0) : 0);
    const double hgt = e.lane == cycle::Lane::capture ? 12 : 28;
    f << "<rect x='" << x0 << "' y='" << y << "' width='" << x1 - x0 << "' height='" << hgt << "' fill='" << col
      << "' stroke='white'><title>" << e.name << ": " << (e.start - t0) * 1e3 << " - " << (e.end - t0) * 1e3 << " ms</title></rect>\n";
    if (e.lane != cycle::Lane::capture && x1 - x0 > 30)
      f << "<text x='" << x0 + 2 << "' y='" << y + (k++ % 2 ? 40 : -4) << "'>" << e.name << "</text>\n";
  }
  for (double t = 0; t <= t1 - t0 + 1e-9; t += 0.5)
    f << "<line x1='" << X(t0 + t) << "' y1='280' x2='" << X(t0 + t) << "' y2='286' stroke='black'/><text x='" << X(t0 + t) - 8
      << "' y='300'>" << t << " s</text>\n";
  f << "<text x='10' y='322'>Cycle " << r.index << " (" << cycle::to_string(r.status) << "): sensing in takt " << r.takt.sensing_in_takt()
    << " s (detour " << r.takt.detour << " s + wait " << r.takt.robot_wait << " s), processing " << r.takt.processing
    << " s; light orange = Table I hardware time, orange = measured compute</text>\n</svg>\n";
}

}  // namespace binpick::simcell
