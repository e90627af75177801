#pragma once
/// @file Gait schedule: which wheels touch the ground when, and the swing spline that the
/// normal velocity of a swinging wheel follows (paper Eq. 7).

#include <cstdint>
#include <string_view>
#include <vector>

#include "nmpc/types.h"

namespace wj::nmpc {

/// Gaits of the locomotion controller.
enum class Gait : std::uint8_t {
  Roll,  ///< all four wheels on the ground, rolling (also standing)
  Trot,  ///< diagonal pairs (LF+RH, RF+LH) swing in turn while the stance wheels roll
};

/// "roll", "trot".
std::string_view toString(Gait gait);

/// Timing and shape of the gaits.
struct GaitSettings {
  double trot_period_s = 0.5;   ///< one trot cycle: each diagonal pair swings for half of it [s]
  double swing_height_m = 0.1;  ///< apex of the swing spline along the ground normal [m]

  /// Throws std::invalid_argument naming the field when a value is out of range.
  void validate() const;
};

/// A sequence of gaits in time: gait i runs from its start time to the next one's start.
/// Allocates only in setGait(); the queries are const, cheap and allocation-free.
class GaitSchedule {
 public:
  /// Gait `initial` from t = -infinity on.
  explicit GaitSchedule(const GaitSettings& settings = {}, Gait initial = Gait::Roll);

  /// Runs `gait` from `t_start` on, dropping whatever was scheduled at or after `t_start`.
  /// A trot cycle starts at `t_start` with the LF+RH pair in swing.
  void setGait(double t_start, Gait gait);

  /// Gait at time t.
  Gait gaitAt(double t) const;
  /// Which wheels are on the ground at time t.
  ContactFlags contactFlags(double t) const;
  /// Desired velocity along the ground normal of the wheel of `leg` at time t (paper Eq. 7)
  /// over level ground: the derivative of the swing bump h 64 s^3 (1 - s)^3, s = swing phase;
  /// 0 in contact [m/s].
  double swingNormalVelocity(int leg, double t) const;
  /// Height of the swing bump of `leg` at time t above its lift-off point [m]; 0 in contact.
  double swingHeight(int leg, double t) const;
  /// True if `leg` swings at time t, with the swing's lift-off t0 and touchdown t1.
  bool calcSwingInterval(int leg, double t, double& t0, double& t1) const;

  /// Timing and shape of the gaits.
  const GaitSettings& settings() const { return settings_; }

 private:
  struct Entry {
    double t_start;
    Gait gait;
  };
  // Index of the entry active at t.
  std::size_t entryAt(double t) const;

  GaitSettings settings_;
  std::vector<Entry> entries_;
};

}  // namespace wj::nmpc
