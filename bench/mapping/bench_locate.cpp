// Lookup benchmark: locates per second on one core and accuracy, for the Locator (coarse table +
// Levenberg–Marquardt on the map interpolant) and the seed-001 triangulation baseline, on a
// synthetic seed-001 map whose truth is the analytic model; then position error against charge
// noise (optionally plotted: --plot PNG).
//   bench_locate [--presses N] [--plot docs/img/lookup_error_vs_noise.png]
//   bench_locate --profile   (only the 6-start lookup, 50 passes: for perf record)
//   bench_locate --tracking  (only the stream tracker against the full search)
//   bench_locate --profile-tracking  (only the tracker on the realistic stream, 20 passes: for perf record)
#include "pvdf/core/constants.hpp"
#include "pvdf/plot/plot.hpp"
#include "pvdf/mapping/locator.hpp"
#include "pvdf/mapping/synthetic.hpp"
#include "pvdf/mapping/tracker.hpp"
#include "pvdf/mapping/triangulation.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <functional>
#include <random>
#include <string>
#include <thread>
#include <vector>

using namespace pvdf::mapping;

namespace {

struct Press {
  double x, y, F;
};

double median(std::vector<double> v) {
  if (v.empty()) return std::nan("");
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}
double percentile(std::vector<double> v, double p) {
  if (v.empty()) return std::nan("");
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, std::size_t(p * double(v.size())))];
}

struct Row {
  std::string method;
  double rate = 0, med = 0, p95 = 0, force = 0, ambiguous = 0, flagged = 0;
};

/// Runs `locate` over all presses (timed, best of 3 passes) and scores the answers.
Row run(const std::string& name, const std::vector<Press>& presses, const std::vector<std::array<double, 3>>& q,
        const std::function<Location(const double*, double)>& locate) {
  Row row;
  row.method = name;
  double best = 1e30;
  std::vector<Location> results(presses.size());
  // Process CPU time (one thread), best of 3 passes: on a shared machine wall time would
  // measure the other users.
  for (int pass = 0; pass < 3; ++pass) {
    const std::clock_t t0 = std::clock();
    for (std::size_t i = 0; i < presses.size(); ++i) results[i] = locate(q[i].data(), presses[i].F);
    best = std::min(best, double(std::clock() - t0) / CLOCKS_PER_SEC);
  }
  row.rate = double(presses.size()) / best;
  std::vector<double> e, f;
  int amb = 0, flagged = 0;
  for (std::size_t i = 0; i < presses.size(); ++i) {
    const Location& r = results[i];
    if (!r.has_position()) {
      ++flagged;
      continue;
    }
    double ex = std::hypot(r.x_m - presses[i].x, r.y_m - presses[i].y), fx = std::abs(r.force_N / presses[i].F - 1);
    if (r.flags & flag::ambiguous) {
      ++amb;
      for (int a = 0; a < r.n_alternatives; ++a) {  // the answer nearest the truth among those reported
        const auto& alt = r.alternatives[std::size_t(a)];
        const double ea = std::hypot(alt.x_m - presses[i].x, alt.y_m - presses[i].y);
        if (ea < ex) {
          ex = ea;
          fx = std::abs(alt.force_N / presses[i].F - 1);
        }
      }
    }
    e.push_back(ex);
    f.push_back(fx);
  }
  row.med = median(e);
  row.p95 = percentile(e, 0.95);
  row.force = median(f);
  row.ambiguous = double(amb) / double(presses.size());
  row.flagged = double(flagged) / double(presses.size());
  return row;
}


/// A realistic sensor stream at 10 kHz: presses of 50-500 ms separated by 20-100 ms of nothing,
/// each a raised-cosine force ramp up (10-30 % of the press), a hold and a ramp down, to a peak
/// of 0.5-2 N; half of them still, half moving along a straight line at up to 50 mm/s; within
/// 12 mm of the centre; Gaussian charge noise of `noise_C` on every sample.
std::vector<std::array<double, 3>> realistic_stream(const SyntheticModel& model, double duration_s, double noise_C,
                                                    unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  std::normal_distribution<double> noise(0, noise_C);
  const double dt = 1e-4;
  std::vector<std::array<double, 3>> q;
  const std::size_t n = std::size_t(duration_s / dt);
  while (q.size() < n) {
    const std::size_t gap = std::size_t((0.02 + 0.08 * u(rng)) / dt);
    for (std::size_t i = 0; i < gap && q.size() < n; ++i) q.push_back({noise(rng), noise(rng), noise(rng)});
    const double length_s = 0.05 + 0.45 * u(rng), rise_s = length_s * (0.1 + 0.2 * u(rng)), peak_N = 0.5 + 1.5 * u(rng);
    double x = 0, y = 0;
    do {
      x = (2 * u(rng) - 1) * 0.012;
      y = (2 * u(rng) - 1) * 0.012;
    } while (std::hypot(x, y) > 0.012);
    const bool moving = u(rng) < 0.5;
    const double speed = moving ? 0.05 * u(rng) : 0.0, heading = 2 * pvdf::pi * u(rng);
    const std::size_t samples = std::size_t(length_s / dt);
    for (std::size_t i = 0; i < samples && q.size() < n; ++i) {
      const double t = double(i) * dt;
      const double ramp = t < rise_s ? 0.5 - 0.5 * std::cos(pvdf::pi * t / rise_s)
                          : t > length_s - rise_s ? 0.5 - 0.5 * std::cos(pvdf::pi * (length_s - t) / rise_s) : 1.0;
      const double F = std::max(peak_N * ramp, 1e-6);
      const double px = std::clamp(x + speed * t * std::cos(heading), -0.014, 0.014);
      const double py = std::clamp(y + speed * t * std::sin(heading), -0.014, 0.014);
      std::array<double, 3> c{};
      for (std::size_t k = 0; k < 3; ++k) c[k] = model.charge_C(px, py, F, k) + noise(rng);
      q.push_back(c);
    }
  }
  return q;
}

/// The tracker's time by kind of answer (per-sample timings, each capped at 20× the median so
/// that a preempted sample does not count): no press, no position, one, two, more solutions.
void time_by_kind(const std::vector<double>& latency, const std::vector<Location>& answers) {
  const double cap = 20 * median(latency);
  double sum[5] = {0, 0, 0, 0, 0}, total = 0;
  std::size_t count[5] = {0, 0, 0, 0, 0};
  for (std::size_t i = 0; i < latency.size(); ++i) {
    const Location& r = answers[i];
    const int kind = (r.flags & flag::no_press) ? 0 : !r.has_position() ? 1 : r.n_solutions == 1 ? 2 : r.n_solutions == 2 ? 3 : 4;
    sum[kind] += std::min(latency[i], cap);
    total += std::min(latency[i], cap);
    ++count[kind];
  }
  const char* names[5] = {"no press", "no position", "1 solution", "2 solutions", "> 2 solutions"};
  std::printf("  tracker's time by answer:");
  for (int k = 0; k < 5; ++k) std::printf(" %s %.0f %% (%zu samples)%s", names[k], 100 * sum[k] / total, count[k], k < 4 ? "," : "\n\n");
}

/// What a stream's consumer keeps of an answer: the main answer, its σ's, flags and count.
struct Answer {
  double x_m = 0, y_m = 0, force_N = 0, sigma_x_m = 0, sigma_y_m = 0, sigma_F_N = 0, probability = 0;
  std::uint32_t flags = 0;
  int n_solutions = 0;
  Answer() = default;
  explicit Answer(const Location& r)
      : x_m(r.x_m), y_m(r.y_m), force_N(r.force_N), sigma_x_m(r.sigma_x_m), sigma_y_m(r.sigma_y_m),
        sigma_F_N(r.sigma_F_N), probability(r.probability), flags(r.flags), n_solutions(r.n_solutions) {}
};

/// The tracker against the full search on a realistic stream: samples/s of each (CPU time of
/// one thread, best of 3), how often the tracker's answer equals the full search's, and the
/// tracker's latency per sample. Agreement: both without a position, or both with one and the
/// tracker's most probable answer within a tenth of the full search's σ of the full search's
/// most probable answer (x, y and F each); disagreements are split into "with/without a
/// position" (and how many of those positions have σ > 1 mm) and "another main answer".
void tracking_rows(const Locator& locator, const SyntheticModel& model, const TrackerOptions& options) {
  const auto q = realistic_stream(model, 10.0, 0.05e-12, 7);
  const std::size_t n = q.size();
  // The timed passes keep what a consumer of the stream keeps (main answer, σ's, flags, count);
  // the whole answers (624 bytes each: storing them would time 62 MB of memory writes per pass)
  // come from one more untimed pass of each (both are deterministic).
  std::vector<Answer> kept(n);
  double best_full = 1e30, best_tracked = 1e30;
  for (int pass = 0; pass < 3; ++pass) {
    std::clock_t t0 = std::clock();
    for (std::size_t i = 0; i < n; ++i) kept[i] = Answer(locator.locate(q[i].data()));
    best_full = std::min(best_full, double(std::clock() - t0) / CLOCKS_PER_SEC);
    Tracker tracker(locator, options);
    t0 = std::clock();
    for (std::size_t i = 0; i < n; ++i) kept[i] = Answer(tracker.next(q[i].data()));
    best_tracked = std::min(best_tracked, double(std::clock() - t0) / CLOCKS_PER_SEC);
  }
  std::vector<Location> full(n), tracked(n);
  {
    Tracker tracker(locator, options);
    for (std::size_t i = 0; i < n; ++i) {
      full[i] = locator.locate(q[i].data());
      tracked[i] = tracker.next(q[i].data());
    }
  }
  std::size_t agree = 0, with_position = 0, agree_position = 0, differ_presence = 0, differ_presence_wide = 0;
  std::size_t differ_count = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const Location& a = full[i];
    const Location& b = tracked[i];
    bool same = a.has_position() == b.has_position();
    if (!same) {
      ++differ_presence;
      const Location& p = a.has_position() ? a : b;
      differ_presence_wide += std::max(p.sigma_x_m, p.sigma_y_m) > 1e-3;
    }
    differ_count += same && a.has_position() && a.n_solutions != b.n_solutions;
    if (same && a.has_position()) {
      ++with_position;
      same = std::abs(a.x_m - b.x_m) <= 0.1 * a.sigma_x_m + 1e-12 && std::abs(a.y_m - b.y_m) <= 0.1 * a.sigma_y_m + 1e-12 &&
             std::abs(a.force_N - b.force_N) <= 0.1 * a.sigma_F_N + 1e-12;
      agree_position += same;
    }
    agree += same;
  }
  // Latency: each sample timed on its own (steady clock), a fresh tracker.
  Tracker tracker(locator, options);
  std::vector<double> latency(n);
  for (std::size_t i = 0; i < n; ++i) {
    const auto t0 = std::chrono::steady_clock::now();
    tracker.next(q[i].data());
    latency[i] = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  }
  const TrackerSummary& s = tracker.summary();
  std::printf("tracking a realistic stream (10 s at 10 kHz: presses of 50-500 ms, still and moving up to 50 mm/s, "
              "force ramps to 0.5-2 N, 0.05 pC noise; %zu samples, %zu with a position in both):\n", n, with_position);
  std::printf("  full search every sample       %10.0f samples/s\n", double(n) / best_full);
  std::printf("  tracker (search interval %4d) %10.0f samples/s  (%.2fx)\n", options.search_interval,
              double(n) / best_tracked, best_full / best_tracked);
  std::printf("  agreement with the full search within sigma/10: %.3f %% of samples (%.3f %% of those with a position "
              "in both)\n", 100.0 * double(agree) / double(n),
              100.0 * double(agree_position) / double(std::max<std::size_t>(with_position, 1)));
  std::printf("  disagreements: %zu with/without a position (%zu of those positions with sigma > 1 mm), %zu another "
              "main answer; %zu with another number of solutions\n", differ_presence, differ_presence_wide,
              with_position - agree_position, differ_count);
  std::printf("  tracker: %llu full searches (onset %llu, interval %llu), %llu tracked\n",
              (unsigned long long)s.full_searches, (unsigned long long)s.onsets, (unsigned long long)s.intervals,
              (unsigned long long)s.tracked);
  std::printf("  latency per sample: median %.2f us, p99 %.2f us, max %.2f us\n", median(latency) * 1e6,
              percentile(latency, 0.99) * 1e6, *std::max_element(latency.begin(), latency.end()) * 1e6);
  time_by_kind(latency, tracked);
}

/// Command line of the benchmark.
struct Args {
  std::size_t n = 2000;
  std::string plot_path;
  bool tracking_only = false;   ///< --tracking: only the tracker against the full search
  bool profile = false;         ///< --profile: only the first lookup row, repeated (for perf record)
  bool profile_tracking = false;  ///< --profile-tracking: only the tracker on the stream, repeated
};

Args parse_args(int argc, char** argv) {
  Args a;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--presses") && i + 1 < argc) a.n = std::size_t(std::atol(argv[++i]));
    if (!std::strcmp(argv[i], "--plot") && i + 1 < argc) a.plot_path = argv[++i];
    if (!std::strcmp(argv[i], "--profile")) a.profile = true;
    if (!std::strcmp(argv[i], "--tracking")) a.tracking_only = true;
    if (!std::strcmp(argv[i], "--profile-tracking")) a.profile_tracking = true;
  }
  return a;
}

/// Random presses within 15 mm of the centre at 0.5-2 N and their noise-free charges.
void random_presses(const SyntheticModel& model, std::size_t n, std::mt19937& rng, std::vector<Press>& presses,
                    std::vector<std::array<double, 3>>& q) {
  std::uniform_real_distribution<double> u(0, 1);
  presses.clear();
  while (presses.size() < n) {
    const double x = (2 * u(rng) - 1) * 0.015, y = (2 * u(rng) - 1) * 0.015;
    if (std::hypot(x, y) <= 0.015) presses.push_back({x, y, 0.5 * std::pow(4.0, u(rng))});
  }
  q.assign(n, {});
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t k = 0; k < 3; ++k) q[i][k] = model.charge_C(presses[i].x, presses[i].y, presses[i].F, k);
  }
}

void print_row(const Row& r) {
  std::printf("%-46s %12.0f %12.5f %12.4f %12.4f %9.1f%% %7.1f%%\n", r.method.c_str(), r.rate, r.med * 1e3,
              r.p95 * 1e3, r.force * 100, r.ambiguous * 100, r.flagged * 100);
}

/// The lookup's variants and the triangulation baseline on noise-free presses, then the fits
/// alone started at the full lookup's solutions (what a perfect coarse search would leave).
void method_rows(const Locator& locator, const Locator& fast, const Triangulation& tri, const std::vector<Press>& presses,
                 const std::vector<std::array<double, 3>>& q) {
  const std::size_t n = presses.size();
  std::printf("%-46s %12s %12s %12s %12s %10s %8s\n", "method", "locates/s", "median_mm", "p95_mm", "force_med_%",
              "ambiguous", "flagged");
  print_row(run("lookup, force unknown (6 starts, ambiguity)", presses, q,
                [&](const double* c, double) { return locator.locate(c); }));
  print_row(run("lookup, force unknown (1 start, no ambiguity)", presses, q,
                [&](const double* c, double) { return fast.locate(c); }));
  print_row(run("lookup, force known", presses, q, [&](const double* c, double F) { return locator.locate(c, F); }));
  print_row(run("triangulation (seed 001 eq. 6), force known", presses, q,
                [&](const double* c, double F) { return tri.locate(c, F); }));
  print_row(run("triangulation (seed 001 eq. 6), force unknown", presses, q,
                [&](const double* c, double) { return tri.locate(c); }));
  std::vector<std::array<std::array<double, 3>, 4>> seeds(n);
  std::vector<int> n_seeds(n, 0);
  for (std::size_t i = 0; i < n; ++i) {
    const Location r = locator.locate(q[i].data());
    if (!r.has_position()) continue;
    seeds[i][0] = {r.x_m, r.y_m, r.force_N};
    for (int a = 0; a < r.n_alternatives && a < 3; ++a) {
      const auto& alt = r.alternatives[std::size_t(a)];
      seeds[i][std::size_t(a + 1)] = {alt.x_m, alt.y_m, alt.force_N};
    }
    n_seeds[i] = 1 + std::min(r.n_alternatives, 3);
  }
  print_row(run("fits only, started at the solutions (floor)", presses, q, [&](const double* c, double) {
    const std::size_t i = std::size_t(c - q[0].data()) / 3;
    return locator.locate_from(c, seeds[i].data(), n_seeds[i]);
  }));
}

/// A deployed sensor's stream: one press moving over the film, sampled at 10 kHz (the paper's
/// front end) — same lookup, no warm start, but consecutive samples touch the same cells.
void rose_stream_rows(const Locator& locator, const SyntheticModel& model) {
  const std::size_t m = 20000;  // 2 s of samples
  std::vector<Press> path;
  for (std::size_t i = 0; i < m; ++i) {
    const double t = double(i) * 1e-4;  // s
    const double r = 0.012 * std::abs(std::sin(2.0 * pvdf::pi * 0.7 * t)), a = 2.0 * pvdf::pi * 0.9 * t;
    path.push_back({r * std::cos(a), r * std::sin(a), 1.0 + 0.5 * std::sin(2.0 * pvdf::pi * 2.3 * t)});
  }
  std::vector<std::array<double, 3>> qp(m);
  for (std::size_t i = 0; i < m; ++i) {
    for (std::size_t k = 0; k < 3; ++k) qp[i][k] = model.charge_C(path[i].x, path[i].y, path[i].F, k);
  }
  print_row(run("stream 10 kHz, force unknown (6 starts, amb.)", path, qp,
                [&](const double* c, double) { return locator.locate(c); }));
  print_row(run("stream 10 kHz, force known", path, qp, [&](const double* c, double F) { return locator.locate(c, F); }));
}

/// One Locator shared by T threads, each locating its share of the presses (wall time, best of
/// 3; on a loaded machine the other users' load shows here).
void thread_rows(const Locator& locator, const std::vector<std::array<double, 3>>& q) {
  const std::size_t n = q.size();
  const unsigned n_threads = std::max(2u, std::thread::hardware_concurrency());
  for (unsigned T : {1u, n_threads}) {
    double best = 1e30;
    for (int pass = 0; pass < 3; ++pass) {
      const auto t0 = std::chrono::steady_clock::now();
      std::vector<std::thread> workers;
      std::vector<double> sink(T, 0.0);
      for (unsigned w = 0; w < T; ++w) {
        workers.emplace_back([&, w] {
          for (std::size_t i = w; i < n; i += T) sink[w] += locator.locate(q[i].data()).x_m;
        });
      }
      for (auto& t : workers) t.join();
      best = std::min(best, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    }
    std::printf("lookup, force unknown (6 starts, ambiguity), %u thread(s): %.0f locates/s wall clock\n", T,
                double(n) / best);
  }
  std::printf("\n");
}

/// Median position errors against charge noise (one curve each for the lookup with the force
/// known and unknown, the reported σ, and the triangulation).
struct NoiseCurves {
  std::vector<double> noise_pC{0.01, 0.03, 0.1, 0.3, 1.0, 3.0};
  std::vector<double> lm_known, lm_free, tri_known, sigma_known;
};

NoiseCurves noise_rows(const ChargeMap& map, const LocatorOptions& options, const Triangulation& tri,
                       const std::vector<Press>& presses, const std::vector<std::array<double, 3>>& q, std::mt19937& rng) {
  NoiseCurves out;
  const std::size_t m = std::min<std::size_t>(presses.size(), 600);
  std::printf("%10s %18s %18s %18s %18s\n", "noise_pC", "lookup_F_known_mm", "reported_sigma_mm", "lookup_F_free_mm",
              "triangulation_mm");
  for (double s_pC : out.noise_pC) {
    LocatorOptions o = options;
    o.noise_C = {s_pC * 1e-12};
    const Locator noisy(map, o);
    std::normal_distribution<double> noise(0.0, s_pC * 1e-12);
    std::vector<double> a, b, c, sk;
    for (std::size_t i = 0; i < m; ++i) {
      std::array<double, 3> qn = q[i];
      for (auto& v : qn) v += noise(rng);
      const Location r1 = noisy.locate(qn.data(), presses[i].F);
      if (r1.has_position()) {
        a.push_back(std::hypot(r1.x_m - presses[i].x, r1.y_m - presses[i].y));
        sk.push_back(std::hypot(r1.sigma_x_m, r1.sigma_y_m));
      }
      const Location r2 = noisy.locate(qn.data());
      if (r2.has_position()) {
        double e = std::hypot(r2.x_m - presses[i].x, r2.y_m - presses[i].y);
        for (int k = 0; k < r2.n_alternatives; ++k) {
          const auto& alt = r2.alternatives[std::size_t(k)];
          e = std::min(e, std::hypot(alt.x_m - presses[i].x, alt.y_m - presses[i].y));
        }
        b.push_back(e);
      }
      const Location r3 = tri.locate(qn.data(), presses[i].F);
      if (r3.has_position()) c.push_back(std::hypot(r3.x_m - presses[i].x, r3.y_m - presses[i].y));
    }
    out.lm_known.push_back(median(a) * 1e3);
    out.sigma_known.push_back(median(sk) * 1e3);
    out.lm_free.push_back(median(b) * 1e3);
    out.tri_known.push_back(median(c) * 1e3);
    std::printf("%10.2f %18.5f %18.5f %18.5f %18.5f\n", s_pC, out.lm_known.back(), out.sigma_known.back(),
                out.lm_free.back(), out.tri_known.back());
  }
  return out;
}

void plot_noise(const NoiseCurves& c, double spacing_m, const std::string& path) {
  pvdf::plot::Figure fig(1000, 700);
  fig.axes()
      .line(c.noise_pC, c.lm_known, "lookup, force known (median error)", std::nullopt, pvdf::plot::LineStyle::solid,
            pvdf::plot::Marker::circle)
      .line(c.noise_pC, c.sigma_known, "lookup, force known (median reported 1-sigma)", std::nullopt,
            pvdf::plot::LineStyle::dashed, pvdf::plot::Marker::none)
      .line(c.noise_pC, c.lm_free, "lookup, force unknown (nearest reported answer)", std::nullopt,
            pvdf::plot::LineStyle::solid, pvdf::plot::Marker::square)
      .line(c.noise_pC, c.tri_known, "triangulation (seed 001 eq. 6), force known", std::nullopt,
            pvdf::plot::LineStyle::solid, pvdf::plot::Marker::triangle)
      .hline(spacing_m * 1e3, pvdf::plot::Color{120, 120, 120}, pvdf::plot::LineStyle::dotted, "map grid spacing")
      .log_x()
      .log_y()
      .title("Position error against charge noise (synthetic seed-001 map, presses within 15 mm)")
      .xlabel("1-sigma charge noise per electrode (pC)")
      .ylabel("median position error (mm)")
      .grid_lines()
      .legend("upper left");
  fig.save_png(path);
  std::printf("\nplot written to %s\n", path.c_str());
}

/// Only the tracker on the realistic stream, 20 passes (for perf record).
void profile_tracking(const Locator& locator, const SyntheticModel& model) {
  const auto q = realistic_stream(model, 10.0, 0.05e-12, 7);
  double sink = 0;
  for (int pass = 0; pass < 20; ++pass) {
    Tracker tracker(locator);
    for (const auto& c : q) sink += tracker.next(c.data()).x_m;
  }
  std::printf("profile: 20 x %zu tracked samples (checksum %g)\n", q.size(), sink);
}

/// The stream's lookup (linearised σ's, as `locate --stream` and `acquire --locate` use it) at
/// three search intervals, then the default lookup (valley σ's, docs/lookup.md §1.6) for its cost.
void tracking_table(const Locator& stream_locator, const Locator& locator, const SyntheticModel& model) {
  for (int interval : {200, 20, 2000}) {
    TrackerOptions o;
    o.search_interval = interval;
    std::printf("stream lookup (linearised sigmas): ");
    tracking_rows(stream_locator, model, o);
  }
  std::printf("default lookup (valley sigmas): ");
  tracking_rows(locator, model, TrackerOptions{});
}
}  // namespace

int main(int argc, char** argv) {
  const Args args = parse_args(argc, argv);
  SyntheticModel model;  // seed-001 triangle, d31/d32 direction factor, anisotropy, core, rim
  model.force_skew = 0.05;
  const std::vector<double> levels{0.25, 0.5, 1.0, 2.0, 4.0};
  const double spacing = 1e-3;
  const auto t_build = std::chrono::steady_clock::now();
  const ChargeMap map = build_synthetic_map(model, spacing, 3e-3, levels, 0.05e-12);
  LocatorOptions options;
  options.min_force_N = levels.front();
  options.max_force_N = levels.back();
  const Locator locator(map, options);
  LocatorOptions stream_options = options;
  stream_options.valley_sigma_cells = 0;  // what a stream uses
  const Locator stream_locator(map, stream_options);
  LocatorOptions fast_options = options;
  fast_options.max_starts = 1;
  const Locator fast(map, fast_options);
  const Triangulation tri(locator, map);
  const double build_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_build).count();

  std::mt19937 rng(1);
  std::vector<Press> presses;
  std::vector<std::array<double, 3>> q;
  random_presses(model, args.n, rng, presses, q);
  if (args.tracking_only) {
    tracking_table(stream_locator, locator, model);
    return 0;
  }
  if (args.profile_tracking) {
    profile_tracking(stream_locator, model);
    return 0;
  }
  if (args.profile) {
    double sink = 0;
    for (int pass = 0; pass < 50; ++pass) {
      for (std::size_t i = 0; i < args.n; ++i) sink += locator.locate(q[i].data()).x_m;
    }
    std::printf("profile: 50 x %zu locates (checksum %g)\n", args.n, sink);
    return 0;
  }
  std::printf("pvdfkit lookup benchmark: synthetic seed-001 map, %zu x %zu nodes (%.1f mm), %zu force levels, "
              "%zu presses within 15 mm, 0.5-2 N, noise-free; map + tables built in %.2f s; locates/s = presses per "
              "CPU second of one thread\n\n",
              map.nx(), map.ny(), spacing * 1e3, map.nf(), args.n, build_s);
  method_rows(locator, fast, tri, presses, q);
  rose_stream_rows(locator, model);
  tracking_table(stream_locator, locator, model);
  std::printf("\n(median/p95: error of the reported answer nearest the truth; 'ambiguous': another solution fits "
              "within noise and is reported too; 'stream': one press moving along a rose curve within 12 mm at "
              "up to 90 mm/s, 0.5-1.5 N, sampled at 10 kHz for 2 s)\n\n");
  thread_rows(locator, q);
  const NoiseCurves curves = noise_rows(map, options, tri, presses, q, rng);
  if (!args.plot_path.empty()) plot_noise(curves, spacing, args.plot_path);
  return 0;
}
