#include "vadsim/orbit_table.hpp"

#include <algorithm>
#include <cmath>

namespace vadsim {

namespace {

void evaluate_at(const Model& model, double flow_gpm, double t,
                 const Eigen::Ref<const State>& y, const Modes& modes, Evaluation& ev,
                 OrbitSample& out) {
  model.evaluate(t, flow_gpm, y, modes, ev);
  out.acc = ev.acc;
  out.f_impact = ev.fc[kImpact];
}

/// @brief a + w (b - a), written into out.
void blend(const OrbitSample& a, const OrbitSample& b, double w, OrbitSample& out) {
  out.acc = a.acc + w * (b.acc - a.acc);
  out.f_impact = a.f_impact + w * (b.f_impact - a.f_impact);
}

}  // namespace

OrbitTable::OrbitTable(const Model& model, double flow_gpm, const Orbit& orbit, long m)
    : t0_(orbit.t0()),
      period_(orbit.period()),
      per_second_(static_cast<double>(std::max(1L, m)) / orbit.period()),
      grid_(static_cast<std::size_t>(std::max(1L, m))) {
  const long n = size();
  State y;
  Modes modes;
  Evaluation ev;
  for (long j = 0; j < n; ++j) {
    const double t = time(j);
    orbit.state_at(t, y, modes);
    evaluate_at(model, flow_gpm, t, y, modes, ev, grid_[static_cast<std::size_t>(j)]);
  }
  const auto& pieces = orbit.pieces();
  for (std::size_t p = 0; p + 1 < pieces.size(); ++p) {
    const double t = pieces[p].t_hi;
    if (pieces[p].modes == pieces[p + 1].modes || !(t > t0_) || !(t < t0_ + period_)) continue;
    Corner c;
    c.offset = t - t0_;
    for (int side = 0; side < 2; ++side) {
      const Orbit::Replay piece(orbit, p + side, 0.0);
      evaluate_at(model, flow_gpm, t, piece.interpolate(t), pieces[p + side].modes, ev,
                  side ? c.after : c.before);
    }
    corners_.push_back(c);
  }
  first_corner_.assign(static_cast<std::size_t>(n), -1);
  for (std::size_t k = corners_.size(); k-- > 0;) {
    const long cell = std::clamp(static_cast<long>(std::floor(corners_[k].offset * per_second_)),
                                 0L, n - 1);
    first_corner_[static_cast<std::size_t>(cell)] = static_cast<int>(k);
  }
}

void OrbitTable::at(double t, OrbitSample& out) const {
  const long n = size();
  double tau = std::fmod(t - t0_, period_);
  if (tau < 0) tau += period_;
  const double pos = tau * per_second_;
  const long j = std::min(static_cast<long>(std::floor(pos)), n - 1);
  const OrbitSample& next = grid_[static_cast<std::size_t>((j + 1) % n)];
  int k = first_corner_[static_cast<std::size_t>(j)];
  if (k < 0) {
    blend(grid_[static_cast<std::size_t>(j)], next, pos - static_cast<double>(j), out);
    return;
  }
  // Walk the interval's points in time order: its start, its corners, its end.
  double left_t = static_cast<double>(j) / per_second_;
  const OrbitSample* left = &grid_[static_cast<std::size_t>(j)];
  const double end_t = static_cast<double>(j + 1) / per_second_;
  for (; k < static_cast<int>(corners_.size()) && corners_[k].offset < end_t; ++k) {
    const Corner& c = corners_[static_cast<std::size_t>(k)];
    if (tau < c.offset && c.offset > left_t) {
      blend(*left, c.before, (tau - left_t) / (c.offset - left_t), out);
      return;
    }
    left_t = c.offset;
    left = &c.after;
  }
  blend(*left, next, end_t > left_t ? (tau - left_t) / (end_t - left_t) : 0.0, out);
}

}  // namespace vadsim
