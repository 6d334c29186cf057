/// @file bench_core.cpp
/// @brief Times N runs of the 7in CDE preset (200 gal/min, 400 cycles) and prints the median
/// and min-max wall time per run, with the solver's steps and events, so that a change in
/// speed can be traced to a change in work.
///
/// Two kinds of run, each with its answer: the literal run (Steady::Full, every cycle
/// integrated: the integrator's own speed) and the time to the same answer with Steady::Auto
/// (the run stops at its periodic orbit and builds the window from it), and their ratio.
/// --steady full|auto times one kind only.

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <vector>

#include <cvode/cvode.h>
#include <dlfcn.h>

#include "vadsim/integrator.hpp"

int main(int argc, char** argv) {
  int runs = 21;
  double flow = 200, rtol = 1e-6, out_rate = 0, sum_rate = 20000, atol = 1e-8;
  bool adams = true, accelerations_only = false;
  const char* only = nullptr;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (!std::strcmp(argv[i], "--runs")) runs = std::atoi(argv[i + 1]);
    else if (!std::strcmp(argv[i], "--flow")) flow = std::atof(argv[i + 1]);
    else if (!std::strcmp(argv[i], "--rtol")) rtol = std::atof(argv[i + 1]);
    else if (!std::strcmp(argv[i], "--output-rate")) out_rate = std::atof(argv[i + 1]);
    else if (!std::strcmp(argv[i], "--summary-rate")) sum_rate = std::atof(argv[i + 1]);
    else if (!std::strcmp(argv[i], "--method")) adams = !std::strcmp(argv[i + 1], "adams");
    else if (!std::strcmp(argv[i], "--atol")) atol = std::atof(argv[i + 1]);
    else if (!std::strcmp(argv[i], "--outputs"))
      accelerations_only = !std::strcmp(argv[i + 1], "a");
    else if (!std::strcmp(argv[i], "--steady") &&
             (!std::strcmp(argv[i + 1], "auto") || !std::strcmp(argv[i + 1], "full")))
      only = argv[i + 1];
    else {
      std::fprintf(stderr,
                   "usage: vadsim_bench [--runs N] [--flow GPM] [--rtol R] [--output-rate HZ] "
                   "[--summary-rate HZ] [--method adams|bdf] [--atol M] [--outputs all|a] "
                   "[--steady full|auto]\n");
      return 2;
    }
  }
  vadsim::Params p;  // defaults: 7in CDE, l0 = 0.7 m, wob = 1000 N/kg
  vadsim::Model model(p);
  vadsim::RunOptions o;
  o.flow_gpm = flow;
  o.rtol = rtol;
  o.atol = atol;
  o.method = adams ? vadsim::Method::Adams : vadsim::Method::BDF;
  o.output_rate_hz = out_rate;
  o.record = out_rate > 0 ? vadsim::Record::Window : vadsim::Record::None;
  o.accelerations_only = accelerations_only;
  o.summary_rate_hz = sum_rate;
  Dl_info cvode_lib{};
  const bool found = dladdr(reinterpret_cast<void*>(&CVodeCreate), &cvode_lib) != 0;
  std::printf("CVODE from %s\n", found && cvode_lib.dli_fname ? cvode_lib.dli_fname : "?");
  std::printf("7in CDE, %.0f gal/min, 400 cycles, rtol %.0e, output %.0f Hz (%s), summary "
              "%.0f Hz\n",
              flow, rtol, out_rate, accelerations_only ? "t, a" : "t, x, v, a, forces", sum_rate);
  double medians[2] = {0, 0};
  const char* names[2] = {"full", "auto"};
  for (int kind = 0; kind < 2; ++kind) {
    if (only && std::strcmp(only, names[kind])) continue;
    o.steady = kind == 0 ? vadsim::Steady::Full : vadsim::Steady::Auto;
    std::vector<double> ms;
    vadsim::RunResult r;
    for (int i = 0; i < runs + 1; ++i) {
      const auto t0 = std::chrono::steady_clock::now();
      r = vadsim::simulate(model, o);
      const auto t1 = std::chrono::steady_clock::now();
      if (i > 0) ms.push_back(std::chrono::duration<double, std::milli>(t1 - t0).count());
    }
    std::sort(ms.begin(), ms.end());
    const auto& s = r.stats;
    std::printf("\n%s\n", kind == 0 ? "literal run (steady full: every cycle integrated)"
                                     : "steady auto (stops at its periodic orbit)");
    if (ms.empty()) {
      std::printf("runs 0: the warm-up run alone, untimed (e.g. under callgrind)\n");
    } else {
      medians[kind] = ms[ms.size() / 2];
      std::printf("runs %d  median %.2f ms  min %.2f ms  max %.2f ms\n", runs, medians[kind],
                  ms.front(), ms.back());
    }
    std::printf("steps %ld  rhs %ld  jac %ld  lin_setups %ld  err_fails %ld  root_evals %ld  "
                "reinits %ld  events %zu\n",
                s.steps, s.rhs_evals, s.jac_evals, s.lin_setups, s.err_test_fails, s.root_evals,
                s.reinits, r.events.size());
    if (r.steady.period > 0)
      std::printf("period-%d orbit from cycle %.0f, integration stopped at cycle %.1f\n",
                  r.steady.period, r.steady.detected_cycle, r.steady.stopped_cycle);
    std::printf("Z: spring %.3f impact %.3f off %.3f on %.3f  J*+ %.2f N/kg  J* %.2f N/kg\n",
                r.summary.onsets[0] / 200.0, r.summary.onsets[1] / 200.0,
                r.summary.onsets[2] / 200.0, r.summary.onsets[3] / 200.0,
                r.summary.impulse_pos, r.summary.impulse_mean);
    double pk = 0;
    for (Eigen::Index i = 0; i < r.summary.window_peaks.rows(); ++i)
      pk += r.summary.window_peaks(i, 0);
    std::printf("x1 peak mean %.2f g over %ld windows\n",
                pk / std::max<Eigen::Index>(1, r.summary.window_peaks.rows()) / 9.80665,
                static_cast<long>(r.summary.window_peaks.rows()));
  }
  if (medians[0] > 0 && medians[1] > 0)
    std::printf("\nsteady auto / literal: %.3f (%.1fx faster to the same answer)\n",
                medians[1] / medians[0], medians[0] / medians[1]);
  return 0;
}
