#include "nmpc/gait.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace wj::nmpc {

std::string_view toString(Gait gait) {
  switch (gait) {
    case Gait::Roll:
      return "roll";
    case Gait::Trot:
      return "trot";
  }
  return "?";
}

void GaitSettings::validate() const {
  if (!(trot_period_s > 0.0)) throw std::invalid_argument("GaitSettings.trot_period_s must be > 0");
  if (!(swing_height_m >= 0.0))
    throw std::invalid_argument("GaitSettings.swing_height_m must be >= 0");
}

GaitSchedule::GaitSchedule(const GaitSettings& settings, Gait initial) : settings_(settings) {
  settings_.validate();
  entries_.push_back({-std::numeric_limits<double>::infinity(), initial});
}

void GaitSchedule::setGait(double t_start, Gait gait) {
  while (entries_.size() > 1 && entries_.back().t_start >= t_start) entries_.pop_back();
  if (entries_.size() == 1 && entries_.front().t_start >= t_start) entries_.clear();
  entries_.push_back({t_start, gait});
}

std::size_t GaitSchedule::entryAt(double t) const {
  std::size_t i = 0;
  while (i + 1 < entries_.size() && entries_[i + 1].t_start <= t) ++i;
  return i;
}

Gait GaitSchedule::gaitAt(double t) const {
  return entries_[entryAt(t)].gait;
}

bool GaitSchedule::calcSwingInterval(int leg, double t, double& t0, double& t1) const {
  const std::size_t i = entryAt(t);
  const Entry& e = entries_[i];
  if (e.gait != Gait::Trot || t < e.t_start) return false;
  const double T = settings_.trot_period_s;
  // LF (0) and RH (3) swing in the first half of each cycle, RF (1) and LH (2) in the second.
  const double offset = (leg == 0 || leg == 3) ? 0.0 : 0.5 * T;
  const double cycle = std::floor((t - e.t_start - offset) / T);
  t0 = e.t_start + offset + cycle * T;
  t1 = t0 + 0.5 * T;
  if (t < t0 || t >= t1) return false;
  // A gait change cuts the swing short; the spline then spans the shortened interval.
  if (i + 1 < entries_.size()) t1 = std::min(t1, entries_[i + 1].t_start);
  return t1 > t0;
}

ContactFlags GaitSchedule::contactFlags(double t) const {
  ContactFlags flags{};
  double t0 = 0.0, t1 = 0.0;
  for (int leg = 0; leg < kNumLegs; ++leg) flags[leg] = !calcSwingInterval(leg, t, t0, t1);
  return flags;
}

double GaitSchedule::swingNormalVelocity(int leg, double t) const {
  double t0 = 0.0, t1 = 0.0;
  if (!calcSwingInterval(leg, t, t0, t1)) return 0.0;
  const double T = t1 - t0, s = (t - t0) / T;
  return settings_.swing_height_m * 192.0 * s * s * (1.0 - s) * (1.0 - s) * (1.0 - 2.0 * s) / T;
}

double GaitSchedule::swingHeight(int leg, double t) const {
  double t0 = 0.0, t1 = 0.0;
  if (!calcSwingInterval(leg, t, t0, t1)) return 0.0;
  const double s = (t - t0) / (t1 - t0);
  return settings_.swing_height_m * 64.0 * std::pow(s * (1.0 - s), 3);
}

}  // namespace wj::nmpc
