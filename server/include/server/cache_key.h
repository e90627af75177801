#pragma once
/// @file The cache key of a plan: the quantized run-up speed v0 (0.05 m/s bins by default), the
/// quantized target, obstacle and initial attitude and posture, the take-off mode, the seed, and
/// hashes of the robot model and of the planner (and verifier) settings. docs/service.md, "Cache".

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include "planner/jump_planner.h"
#include "planner/jump_task.h"
#include "planner/planner_settings.h"
#include "robot_model/robot_model.h"
#include "server/config.h"

namespace wj::server {

/// Non-wheel joints (HAA, HFE, KFE of each leg) whose positions are part of the key.
inline constexpr int kKeyPostureJoints = 12;

/// A cache key. Plain integers, so that equality is exact and the byte form canonical.
struct CacheKey {
  std::int32_t v0_bin = 0;  ///< round(v0 / v0_bin_m_s)
  std::int32_t target_dx_bin = 0, target_height_bin = 0, target_pitch_bin = 0;
  std::uint8_t event = 0;         ///< planner::TargetEvent
  std::uint8_t mode = 0;          ///< planner::TakeoffMode
  std::uint8_t has_obstacle = 0;  ///< 0 or 1; the obstacle bins are 0 without one
  std::int32_t obstacle_x_min_bin = 0, obstacle_x_max_bin = 0, obstacle_height_bin = 0;
  std::int32_t pitch_bin = 0, pitch_rate_bin = 0;         ///< initial attitude
  std::array<std::int16_t, kKeyPostureJoints> posture{};  ///< HAA, HFE, KFE bins, leg-major
  std::uint64_t seed = 0;                                 ///< the effective DE seed
  std::uint64_t model_hash = 0;                           ///< RobotModel::contentHash()
  std::uint64_t settings_hash = 0;  ///< settingsHash() of planner and verifier settings

  bool operator==(const CacheKey&) const = default;

  static constexpr std::size_t kBytes = 4 * 4 + 3 + 4 * 5 + 2 * kKeyPostureJoints + 8 * 3;
  using Bytes = std::array<char, kBytes>;

  /// Canonical little-endian bytes (kBytes long); the SQLite primary key.
  std::string bytes() const;
  /// The same bytes without allocating (hashed on every lookup of a hit).
  Bytes byteArray() const;
  /// Lower-case hex of bytes().
  std::string hex() const;
  /// Parses bytes(); nullopt if `b` is not kBytes long.
  static std::optional<CacheKey> fromBytes(std::string_view b);
  /// The same key with v0_bin = 0: every key that differs only in v0 has the same family.
  CacheKey family() const;
  /// 64-bit hash of bytes() (for hash maps).
  std::uint64_t hash() const;
};

struct CacheKeyHash {
  std::size_t operator()(const CacheKey& k) const { return static_cast<std::size_t>(k.hash()); }
};

/// FNV-1a, 64 bit, continuing from `h` (default: the offset basis).
std::uint64_t fnv1a64(std::string_view bytes, std::uint64_t h = 0xcbf29ce484222325ULL);

/// Stable hash of the planner settings that change a plan: the solver's settings field by field
/// (all but the DE's thread count and log switch), the model's by a fingerprint of what they
/// compute (see the definition). Same settings and planner code, same hash, in every run;
/// a few tens of milliseconds, computed once at start.
std::uint64_t hashPlannerSettings(const planner::JumpPlanner& planner);

/// Quantizes requests into keys with the configured bins.
class KeyQuantizer {
 public:
  /// `settings_hash` covers the planner and the verifier settings (see PlanningCore).
  KeyQuantizer(const CacheConfig& bins, std::uint64_t model_hash, std::uint64_t settings_hash);

  /// The key of planning `task` from `initial` with DE seed `seed`.
  CacheKey make(const planner::JumpTask& task, const planner::InitialState& initial,
                std::uint64_t seed) const;
  /// Centre of a v0 bin [m/s].
  double v0Of(std::int32_t bin) const { return bin * bins_.v0_bin_m_s; }
  /// The v0 bin of a speed.
  std::int32_t v0Bin(double v0) const;
  const CacheConfig& bins() const { return bins_; }

 private:
  CacheConfig bins_;
  std::uint64_t model_hash_;
  std::uint64_t settings_hash_;
};

}  // namespace wj::server
