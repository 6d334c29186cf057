#include "vadsim/contact_tracker.hpp"

#include <algorithm>
#include <cmath>

namespace vadsim {

ContactTracker::ContactTracker(const Model& model, double flow_gpm,
                               std::vector<ContactEvent>& events)
    : model_(model), flow_gpm_(flow_gpm), tiny_(1e-13 * model.params().l0), events_(events) {
  for (int s = 0; s < kSurfaces; ++s)
    if (model_.pushes_only(s)) n_roots_ = 2 * kSurfaces;
}

void ContactTracker::start(const State& y0) {
  for (int s = 0; s < kSurfaces; ++s)
    modes_[s] = model_.indentation(s, y0) > 0 ? ContactMode::Pushing : ContactMode::Open;
  for (int s = 0; s < kSurfaces; ++s) modes_[s] = model_.mode_at(s, y0, 0.0, flow_gpm_, modes_);
}

ContactMode ContactTracker::entered_mode(int s, const State& y) const {
  return (model_.pushes_only(s) && model_.push_indicator(s, y) < 0) ? ContactMode::Lifted
                                                                    : ContactMode::Pushing;
}

void ContactTracker::switch_mode(int s, ContactMode next, double t, const State& y) {
  const ContactMode prev = modes_[s];
  if (next == prev) return;
  EventKind kind;
  if (prev == ContactMode::Open) kind = EventKind::Onset;
  else if (next == ContactMode::Open) kind = EventKind::Release;
  else kind = (next == ContactMode::Lifted) ? EventKind::Lift : EventKind::Relatch;
  modes_[s] = next;
  events_.push_back({t, s, kind, model_.indentation_rate(s, y)});
}

void ContactTracker::resolve_boundaries(double t, const State& y, const int* skip) {
  for (int s = 0; s < kSurfaces; ++s) {
    if ((skip && skip[s] != 0) || std::abs(model_.indentation(s, y)) > tiny_) continue;
    switch_mode(s, model_.mode_at(s, y, t, flow_gpm_, modes_), t, y);
  }
}

void ContactTracker::apply_roots(const int* found, double t, const State& y) {
  int handled[kSurfaces] = {};
  for (int s = 0; s < kSurfaces; ++s) {
    const int dir_d = found[s];
    const int dir_f = (n_roots_ > kSurfaces) ? found[kSurfaces + s] : 0;
    if (dir_d == 0 && dir_f == 0) continue;
    handled[s] = 1;
    const ContactMode mode = modes_[s];
    if (dir_d > 0 && mode == ContactMode::Open) {
      switch_mode(s, entered_mode(s, y), t, y);
    } else if (dir_d < 0 && mode != ContactMode::Open) {
      switch_mode(s, ContactMode::Open, t, y);
    } else if (dir_f < 0 && mode == ContactMode::Pushing) {
      switch_mode(s, ContactMode::Lifted, t, y);
    } else if (dir_f > 0 && mode == ContactMode::Lifted) {
      switch_mode(s, ContactMode::Pushing, t, y);
    }
  }
  resolve_boundaries(t, y, handled);
}

MissedCrossing ContactTracker::find_missed(double t_prev, double t_step,
                                           const Eigen::Ref<const State>& y_step,
                                           const Trajectory& segment) {
  MissedCrossing first{-1, t_step};
  for (int s = 0; s < kSurfaces; ++s) {
    if (!contradicts(s, y_step)) continue;
    double lo = t_prev, hi = t_step;  // consistent at lo, not at hi
    for (int it = 0; it < 200 && hi - lo > 4e-16 * std::max(1.0, std::abs(hi)); ++it) {
      const double mid = 0.5 * (lo + hi);
      (contradicts(s, segment.interpolate(mid)) ? hi : lo) = mid;
    }
    if (hi < first.t || first.surface < 0) first = {s, hi};
  }
  return first;
}

void ContactTracker::apply_missed(const MissedCrossing& c, const State& y) {
  const int s = c.surface;
  switch_mode(s, modes_[s] != ContactMode::Open ? ContactMode::Open : entered_mode(s, y), c.t, y);
  resolve_boundaries(c.t, y, nullptr);
}

}  // namespace vadsim
