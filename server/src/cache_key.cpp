#include "server/cache_key.h"

#include <algorithm>
#include <bit>
#include <cassert>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <utility>

namespace wj::server {

namespace {

// Little-endian writers of fixed-width integers and doubles: into a growing string, or into a
// fixed array (the cache key, hashed on every lookup: no allocation).
template <typename T>
void putLittleEndian(char* out, T value) {
  static_assert(std::is_integral_v<T> || std::is_enum_v<T>);
  using U = std::make_unsigned_t<std::conditional_t<std::is_enum_v<T>, int, T>>;
  auto u = static_cast<U>(value);
  for (std::size_t i = 0; i < sizeof(U); ++i) {
    out[i] = static_cast<char>(u & 0xffu);
    u = static_cast<U>(u >> 8);
  }
}

template <typename T>
constexpr std::size_t encodedSize() {
  return sizeof(std::make_unsigned_t<std::conditional_t<std::is_enum_v<T>, int, T>>);
}

class ByteWriter {
 public:
  template <typename T>
  void put(T value) {
    char b[encodedSize<T>()];
    putLittleEndian(b, value);
    out_.append(b, sizeof b);
  }
  void putDouble(double v) { put(std::bit_cast<std::uint64_t>(v == 0.0 ? 0.0 : v)); }
  void putBool(bool b) { put(static_cast<std::uint8_t>(b ? 1 : 0)); }
  const std::string& bytes() const { return out_; }

 private:
  std::string out_;
};

class KeyWriter {
 public:
  explicit KeyWriter(CacheKey::Bytes& out) : out_(out) {}
  template <typename T>
  void put(T value) {
    putLittleEndian(out_.data() + at_, value);
    at_ += encodedSize<T>();
  }
  std::size_t written() const { return at_; }

 private:
  CacheKey::Bytes& out_;
  std::size_t at_ = 0;
};

class ByteReader {
 public:
  explicit ByteReader(std::string_view in) : in_(in) {}
  template <typename T>
  T get() {
    using U = std::make_unsigned_t<T>;
    U u = 0;
    for (std::size_t i = 0; i < sizeof(U); ++i)
      u = static_cast<U>(u |
                         (static_cast<U>(static_cast<unsigned char>(in_[pos_ + i])) << (8 * i)));
    pos_ += sizeof(U);
    return static_cast<T>(u);
  }

 private:
  std::string_view in_;
  std::size_t pos_ = 0;
};

std::int32_t quantize(double value, double bin) {
  const double q = std::round(value / bin);
  // Inputs are validated and finite; the clamp only keeps the cast defined.
  return static_cast<std::int32_t>(std::clamp(q, -2.0e9, 2.0e9));
}

}  // namespace

std::uint64_t fnv1a64(std::string_view bytes, std::uint64_t h) {
  for (const char c : bytes) {
    h ^= static_cast<unsigned char>(c);
    h *= 0x100000001b3ULL;
  }
  return h;
}

CacheKey::Bytes CacheKey::byteArray() const {
  Bytes out;
  KeyWriter w(out);
  w.put(v0_bin);
  w.put(target_dx_bin);
  w.put(target_height_bin);
  w.put(target_pitch_bin);
  w.put(event);
  w.put(mode);
  w.put(has_obstacle);
  w.put(obstacle_x_min_bin);
  w.put(obstacle_x_max_bin);
  w.put(obstacle_height_bin);
  w.put(pitch_bin);
  w.put(pitch_rate_bin);
  for (const auto p : posture) w.put(p);
  w.put(seed);
  w.put(model_hash);
  w.put(settings_hash);
  assert(w.written() == kBytes);
  return out;
}

std::string CacheKey::bytes() const {
  const Bytes b = byteArray();
  return std::string(b.data(), b.size());
}

std::optional<CacheKey> CacheKey::fromBytes(std::string_view b) {
  if (b.size() != kBytes) return std::nullopt;
  ByteReader r(b);
  CacheKey k;
  k.v0_bin = r.get<std::int32_t>();
  k.target_dx_bin = r.get<std::int32_t>();
  k.target_height_bin = r.get<std::int32_t>();
  k.target_pitch_bin = r.get<std::int32_t>();
  k.event = r.get<std::uint8_t>();
  k.mode = r.get<std::uint8_t>();
  k.has_obstacle = r.get<std::uint8_t>();
  k.obstacle_x_min_bin = r.get<std::int32_t>();
  k.obstacle_x_max_bin = r.get<std::int32_t>();
  k.obstacle_height_bin = r.get<std::int32_t>();
  k.pitch_bin = r.get<std::int32_t>();
  k.pitch_rate_bin = r.get<std::int32_t>();
  for (auto& p : k.posture) p = r.get<std::int16_t>();
  k.seed = r.get<std::uint64_t>();
  k.model_hash = r.get<std::uint64_t>();
  k.settings_hash = r.get<std::uint64_t>();
  return k;
}

std::string CacheKey::hex() const {
  static constexpr char kDigits[] = "0123456789abcdef";
  std::string out;
  for (const char c : bytes()) {
    const auto u = static_cast<unsigned char>(c);
    out += kDigits[u >> 4];
    out += kDigits[u & 0xf];
  }
  return out;
}

CacheKey CacheKey::family() const {
  CacheKey k = *this;
  k.v0_bin = 0;
  return k;
}

std::uint64_t CacheKey::hash() const {
  const Bytes b = byteArray();
  return fnv1a64(std::string_view(b.data(), b.size()));
}

namespace {

// A double rounded to 30 significant bits, so that last-bit differences between builds (FMA,
// vectorisation) do not change the fingerprint.
void putRounded(ByteWriter& w, double v) {
  if (!std::isfinite(v)) {
    w.put(static_cast<std::int64_t>(std::isnan(v) ? 1 : (v > 0 ? 2 : 3)));
    return;
  }
  int exponent = 0;
  const double mantissa = std::frexp(v, &exponent);
  w.put(static_cast<std::int64_t>(std::llround(std::ldexp(mantissa, 30))));
  w.put(static_cast<std::int32_t>(mantissa == 0.0 ? 0 : exponent));
}

void putEvaluation(ByteWriter& w, const planner::Evaluation& ev) {
  w.putBool(ev.valid);
  for (const double v : {ev.cost, ev.penalty, ev.target_cost, ev.energy_j, ev.err_dx, ev.err_height,
                         ev.err_pitch, ev.err_landing_pitch})
    putRounded(w, v);
  for (const auto& m : ev.margins) {
    putRounded(w, m.worst);
    putRounded(w, m.t);
    w.put(m.location);
  }
  for (const auto* e : {&ev.predicted.takeoff, &ev.predicted.apex, &ev.predicted.touchdown})
    for (const double v : {e->t, e->state.x, e->state.z, e->state.pitch, e->base_z})
      putRounded(w, v);
}

}  // namespace

// The settings a plan depends on are of two kinds. The solver's (DE, restarts, polish) are
// hashed field by field. The model's (physics, postures, sampling, bounds, cost: a struct the
// planner keeps extending) are hashed by what they do: the search box and the evaluation of fixed
// probe points of two canonical jumps, a dense plan, and a tiny seeded search. This also changes
// when the planner's code changes what it computes, which makes cached solutions stale too.
std::uint64_t hashPlannerSettings(const planner::JumpPlanner& jp) {
  const planner::PlannerSettings& s = jp.settings();
  ByteWriter w;
  // Layout version of this hash; also bumped when the polish's code changes what it returns
  // (5: the stall count's fix and the closest approach for out-of-reach targets; 6: the QP's
  // Newton matrix built without the bound rows, which changes its last bits; 7: the QP's rows
  // screened against the step box; 8: a touchdown target over the obstacle lands on it, which
  // the probes below, over the ground beyond their box, do not see; 9: the backflip's box and
  // initial guess below; 10: a backflip's hind roll from its phase-1 speed at t1, which no probe
  // (none is a flip) sees, and platform_margin_m below; 11: wall_extend_start_fraction below;
  // 12: takeoff_unload_s below; 13: the backflip's hind knee clearance and front brake share
  // below; 14: balanced_stance below; 15: the loaded tyre below; 16: the tyre's sink below; 17: the
  // restarts while the budget lasts; 18: stance_momentum below; 19: the flight's feed-forward and
  // the drive-limited tuck below), which the probes below, run without the polish, do not see.
  w.put(std::uint32_t{19});
  const auto& d = s.de;
  w.put(d.population_size);
  w.put(static_cast<int>(d.strategy));
  w.put(static_cast<int>(d.adaptation));
  w.put(static_cast<int>(d.initialization));
  for (const double v : {d.F, d.CR, d.p_best, d.time_budget_s, d.tolerance, d.target_cost})
    w.putDouble(v);
  w.put(d.max_generations);
  w.put(d.max_evaluations);
  w.put(d.stagnation_generations);
  w.putDouble(d.stagnation_tolerance);
  w.put(d.seed);
  w.put(d.shade_memory_size);
  // d.threads, d.keep_log and d.bounded_trials do not change the result (same seed, same plan).
  w.put(s.de_restarts);
  w.putBool(s.de_restart_while_budget);
  w.put(s.warm_start_cloud);
  w.putDouble(s.warm_start_spread);
  w.putBool(s.polish);
  w.put(s.polish_max_iterations);
  w.put(s.polish_warm_max_iterations);
  w.putDouble(s.polish_tolerance);
  w.put(s.polish_retries);
  w.put(s.polish_stall_iterations);
  w.putBool(s.polish_between_attempts);
  w.putDouble(s.polish_backoff);
  w.put(static_cast<int>(s.polish_solver));
  // The backflip's search box and initial guess (JumpTask::isBackflip(); no probe is a flip).
  for (const auto& b : {s.flip_t1_s, s.flip_t2_minus_t1_s, s.flip_takeoff_dpitch_rad,
                        s.flip_takeoff_pitch_rate_rad_s, s.flip_takeoff_vz_m_s}) {
    w.putDouble(b[0]);
    w.putDouble(b[1]);
  }
  w.put(static_cast<std::uint64_t>(s.flip_initial_guess.size()));
  for (const double v : s.flip_initial_guess) w.putDouble(v);
  w.putDouble(s.flip_hind_knee_clearance_rad);
  w.putDouble(s.flip_front_brake_share);
  // The clearance a platform landing keeps (no probe lands on a box).
  w.putDouble(s.platform_margin_m);
  // When a wall jump's legs start extending (the probes' worst clearance need not fall there).
  w.putDouble(s.wall_extend_start_fraction);
  // The lift-off's unloading tail (the "up" probe sees it; hashed as well so that a cache never
  // mixes the two models' plans).
  w.putDouble(s.takeoff_unload_s);
  // The balanced stance (the "up" probe's plan sees it too; hashed so that a cache never mixes
  // the two models' plans).
  w.putBool(s.balanced_stance);
  // The take-off's pitch on the whole robot's momentum (the probes see it; hashed for the same
  // reason).
  w.putBool(s.stance_momentum);
  // The flight's feed-forward (a plan's rows only: no probe's evaluation sees it) and the tuck's
  // profile (the probes' flights see it; hashed so that a cache never mixes the two).
  w.putBool(s.flight_feedforward);
  w.putBool(s.drive_limited_tuck);
  // The loaded tyre of the wheels' margins (the probes bind no wheel margin near the no-load
  // speed, where it matters).
  w.putDouble(s.tyre_rolling_radius_ratio);
  w.putDouble(s.tyre_slip_stiffness_n_s_m);
  // The tyre's sink (the probes' plans see it too; hashed so that a cache never mixes the
  // rigid and the compliant wheel's plans).
  w.putDouble(s.tyre_contact_modulus_pa);

  // Two canonical jumps from the take-off posture: straight up (simultaneous), and forward over
  // a box with a two-step take-off (every decision variable free).
  planner::JumpTask up;
  up.target = {0.0, 0.8, 0.0, planner::TargetEvent::Apex};
  planner::JumpTask over;
  over.target = {1.5, 0.35, 0.0, planner::TargetEvent::Touchdown};
  over.mode = planner::TakeoffMode::TwoStep;
  over.obstacle = planner::BoxObstacle{0.8, 0.9, 0.15};
  planner::InitialState initial;
  initial.q = jp.standPosture();
  for (const auto& [task, v0] : {std::pair{up, 0.5}, std::pair{over, 2.0}}) {
    initial.v0 = v0;
    const planner::JumpModel model(jp.robot(), s, task, initial);
    const Eigen::VectorXd lo = model.lowerBounds(), hi = model.upperBounds();
    for (Eigen::Index i = 0; i < lo.size(); ++i) {
      putRounded(w, lo[i]);
      putRounded(w, hi[i]);
    }
    bool planned = false;
    planner::Evaluation ev;
    for (int k = 1; k <= 7; ++k) {
      // Deterministic points spread over the box (a Weyl sequence per dimension).
      Eigen::VectorXd u(lo.size());
      for (Eigen::Index i = 0; i < lo.size(); ++i) {
        const double frac =
            std::fmod(0.5 + k * (0.6180339887498949 + 0.1 * static_cast<double>(i)), 1.0);
        u[i] = lo[i] + frac * (hi[i] - lo[i]);
      }
      model.evaluate(u, ev);
      putEvaluation(w, ev);
      if (ev.valid && !planned) {
        const planner::JumpPlan plan = model.buildPlan(u);
        w.put(plan.numSamples());
        for (const double v : {plan.dt, plan.t1, plan.t2, plan.t3}) putRounded(w, v);
        if (plan.numSamples() > 0) {
          for (Eigen::Index j = 0; j < plan.q.cols(); ++j) {
            putRounded(w, plan.q(plan.q.rows() - 1, j));
            putRounded(w, plan.q(plan.q.rows() / 2, j));
            putRounded(w, plan.tau(0, j));
          }
        }
        planned = true;
      }
    }
  }
  // A tiny seeded search: the DE, its restarts and the candidate bookkeeping.
  planner::PlanOptions o;
  o.seed = 1;
  o.max_evaluations = 3 * s.de.population_size;
  o.threads = 1;
  o.polish = false;
  initial.v0 = 0.5;
  const planner::PlannerResult r = jp.plan(up, initial, o);
  w.put(r.de.evaluations);
  for (Eigen::Index i = 0; i < r.u.size(); ++i) putRounded(w, r.u[i]);
  putRounded(w, r.final_cost);
  return fnv1a64(w.bytes());
}

KeyQuantizer::KeyQuantizer(const CacheConfig& bins, std::uint64_t model_hash,
                           std::uint64_t settings_hash)
    : bins_(bins), model_hash_(model_hash), settings_hash_(settings_hash) {}

std::int32_t KeyQuantizer::v0Bin(double v0) const {
  return quantize(v0, bins_.v0_bin_m_s);
}

CacheKey KeyQuantizer::make(const planner::JumpTask& task, const planner::InitialState& initial,
                            std::uint64_t seed) const {
  CacheKey k;
  k.v0_bin = v0Bin(initial.v0);
  k.target_dx_bin = quantize(task.target.dx, bins_.target_bin_m);
  k.target_height_bin = quantize(task.target.height, bins_.target_bin_m);
  k.target_pitch_bin = quantize(task.target.pitch_change, bins_.target_bin_rad);
  k.event = static_cast<std::uint8_t>(task.target.event);
  k.mode = static_cast<std::uint8_t>(task.mode);
  if (task.obstacle) {
    k.has_obstacle = 1;
    k.obstacle_x_min_bin = quantize(task.obstacle->x_min, bins_.obstacle_bin_m);
    k.obstacle_x_max_bin = quantize(task.obstacle->x_max, bins_.obstacle_bin_m);
    k.obstacle_height_bin = quantize(task.obstacle->height, bins_.obstacle_bin_m);
  }
  k.pitch_bin = quantize(initial.pitch, bins_.pitch_bin_rad);
  k.pitch_rate_bin = quantize(initial.pitch_rate, bins_.pitch_rate_bin_rad_s);
  int i = 0;
  for (const model::Leg leg : model::kLegs) {
    for (const model::JointKind kind :
         {model::JointKind::HAA, model::JointKind::HFE, model::JointKind::KFE}) {
      const std::int32_t b =
          quantize(initial.q[model::jointIndex(leg, kind)], bins_.posture_bin_rad);
      k.posture[static_cast<std::size_t>(i++)] =
          static_cast<std::int16_t>(std::clamp(b, -32000, 32000));
    }
  }
  k.seed = seed;
  k.model_hash = model_hash_;
  k.settings_hash = settings_hash_;
  return k;
}

}  // namespace wj::server
