#pragma once
// binpick's small benchmark harness: warm-up, trials, median/min/max, thread counts, one JSON object per
// line on stdout (flushed line by line, so a crash of a peer library never loses earlier lines).
//
//   bench_x [--threads 1,2] [--trials N] [--warmup N] [--quick]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <sstream>
#include <string>
#include <vector>

namespace binpick::bench {

struct Options {
  std::vector<int> threads{1, 2};  ///< thread counts to run each case with
  int trials = 15;                 ///< timed repetitions
  int warmup = 3;                  ///< untimed repetitions first
  bool quick = false;              ///< smaller sizes / fewer trials (smoke runs)
};

/// The first line of every run: how this process gets its memory pages, which moves the figures of
/// large clouds a lot on some hosts (page faults in fresh memory, TLB misses in kept memory). "thp" is
/// the kernel's transparent huge page mode; "glibc_tunables" the environment's GLIBC_TUNABLES
/// (glibc.malloc.hugetlb=1 makes malloc ask for huge pages in the "madvise" mode; README). "cpu" and
/// "copy_gb_s" (memcpy of 64 MB into touched memory, median of 5) say what kind of host it is: the
/// full-image kernels are memory bound, and hosts differ by 2x and more there (a 640 x 480 projective
/// ICP took 5.3 ms on one 2-core host and 10.0 ms on another that copied 5.7-8 GB/s).
inline double copy_rate_gb_s() {
  const std::size_t bytes = std::size_t(64) << 20;
  std::vector<char> a(bytes, 1), b(bytes, 0);
  std::vector<double> rate;
  for (int i = 0; i < 5; ++i) {
    a[std::size_t(i)] = char(i);
    const auto t0 = std::chrono::steady_clock::now();
    std::memcpy(b.data(), a.data(), bytes);
    const auto t1 = std::chrono::steady_clock::now();
    rate.push_back(double(bytes) / 1e9 / std::chrono::duration<double>(t1 - t0).count());
  }
  std::sort(rate.begin(), rate.end());
  volatile char sink = b[bytes / 2];  // the copies must happen
  (void)sink;
  return rate[rate.size() / 2];
}

/// `s` with the characters that would end or break a JSON string replaced by '_'.
inline std::string json_safe(std::string s) {
  for (char& ch : s)
    if (ch == '"' || ch == '\\' || static_cast<unsigned char>(ch) < 0x20) ch = '_';
  return s;
}

/// The "model name" line of /proc/cpuinfo ("unknown" elsewhere), made safe for a JSON string (json_safe).
inline std::string cpu_model() {
  std::string model = "unknown";
  if (std::FILE* f = std::fopen("/proc/cpuinfo", "r")) {
    char line[512];
    while (std::fgets(line, sizeof line, f)) {
      const std::string l(line);
      if (l.compare(0, 10, "model name") != 0) continue;
      const std::size_t c = l.find(':');
      if (c != std::string::npos) model = l.substr(c + 1);
      break;
    }
    std::fclose(f);
  }
  while (!model.empty() && (model.back() == '\n' || model.back() == ' ')) model.pop_back();
  while (!model.empty() && model.front() == ' ') model.erase(model.begin());
  return json_safe(model);
}

inline void print_host() {
  std::string thp = "unknown";
  if (std::FILE* f = std::fopen("/sys/kernel/mm/transparent_hugepage/enabled", "r")) {
    char buf[128] = {};
    const std::size_t n = std::fread(buf, 1, sizeof buf - 1, f);
    std::fclose(f);
    const std::string line(buf, n);
    const std::size_t a = line.find('['), b = line.find(']');
    if (a != std::string::npos && b != std::string::npos && b > a) thp = line.substr(a + 1, b - a - 1);
  }
  const char* tunables = std::getenv("GLIBC_TUNABLES");
  const std::string t = json_safe(tunables ? tunables : "");
  std::printf("{\"name\": \"host\", \"cpu\": \"%s\", \"copy_gb_s\": %.2f, \"thp\": \"%s\", \"glibc_tunables\": \"%s\"}\n",
              cpu_model().c_str(), copy_rate_gb_s(), thp.c_str(), t.c_str());
  std::fflush(stdout);
}

inline Options parse_options(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "missing value after %s\n", a.c_str());
        std::exit(2);
      }
      return argv[++i];
    };
    if (a == "--threads") {
      o.threads.clear();
      std::stringstream ss(next());
      std::string t;
      while (std::getline(ss, t, ',')) o.threads.push_back(std::max(1, std::atoi(t.c_str())));
    } else if (a == "--trials") {
      o.trials = std::max(1, std::atoi(next().c_str()));
    } else if (a == "--warmup") {
      o.warmup = std::max(0, std::atoi(next().c_str()));
    } else if (a == "--quick") {
      o.quick = true;
      o.trials = 3;
      o.warmup = 1;
    } else if (a == "--help" || a == "-h") {
      std::printf("usage: %s [--threads 1,2] [--trials N] [--warmup N] [--quick]\n", argv[0]);
      std::exit(0);
    } else {
      std::fprintf(stderr, "unknown option %s\n", a.c_str());
      std::exit(2);
    }
  }
  print_host();
  return o;
}

struct Stats {
  double median = 0, min = 0, max = 0;  ///< in the unit of measure() (milliseconds)
};

/// Runs f() warmup times untimed, then trials times timed; milliseconds.
template <typename F>
Stats measure(F&& f, int warmup, int trials) {
  for (int i = 0; i < warmup; ++i) f();
  std::vector<double> t;
  t.reserve(std::size_t(trials));
  for (int i = 0; i < trials; ++i) {
    const auto t0 = std::chrono::steady_clock::now();
    f();
    const auto t1 = std::chrono::steady_clock::now();
    t.push_back(std::chrono::duration<double, std::milli>(t1 - t0).count());
  }
  std::sort(t.begin(), t.end());
  Stats s;
  s.min = t.front();
  s.max = t.back();
  s.median = t.size() % 2 ? t[t.size() / 2] : 0.5 * (t[t.size() / 2 - 1] + t[t.size() / 2]);
  return s;
}

/// One JSON object on one line: JsonLine("fuse").num("threads", 1).stats(s, "ms").print();
class JsonLine {
 public:
  explicit JsonLine(const std::string& name) { str("name", name); }
  JsonLine& num(const std::string& key, double v) {
    char buf[64];
    if (std::isfinite(v)) std::snprintf(buf, sizeof buf, "%.6g", v);
    else std::snprintf(buf, sizeof buf, "null");
    return raw(key, buf);
  }
  JsonLine& str(const std::string& key, const std::string& v) { return raw(key, "\"" + v + "\""); }
  /// median_<unit>, min_<unit>, max_<unit> and "unit".
  JsonLine& stats(const Stats& s, const std::string& unit = "ms", double scale = 1.0) {
    num("median_" + unit, s.median * scale);
    num("min_" + unit, s.min * scale);
    num("max_" + unit, s.max * scale);
    return str("unit", unit);
  }
  void print() const {
    std::printf("{%s}\n", body_.c_str());
    std::fflush(stdout);
  }

 private:
  JsonLine& raw(const std::string& key, const std::string& v) {
    if (!body_.empty()) body_ += ", ";
    body_ += "\"" + key + "\": " + v;
    return *this;
  }
  std::string body_;
};

/// Keeps the optimizer from discarding a computed value.
template <typename T>
inline void do_not_optimize(const T& v) {
  asm volatile("" : : "g"(&v) : "memory");
}

}  // namespace binpick::bench
