#include "server/cached_solution.h"

#include <zlib.h>

#include <bit>
#include <cmath>
#include <tuple>

#include "planner/liftoff_correction.h"

namespace wj::server {

namespace {

constexpr std::uint8_t kFormatVersion = 4;

class Writer {
 public:
  void u8(std::uint8_t v) { out_.push_back(static_cast<char>(v)); }
  void u16(std::uint16_t v) { uint(v, 2); }
  void u32(std::uint32_t v) { uint(v, 4); }
  void u64(std::uint64_t v) { uint(v, 8); }
  void f32(float v) { u32(std::bit_cast<std::uint32_t>(v)); }
  void f64(double v) { u64(std::bit_cast<std::uint64_t>(v)); }
  void event(const planner::JumpEvent& e) {
    for (const double v : {e.t, e.state.x, e.state.z, e.state.pitch, e.state.vx, e.state.vz,
                           e.state.pitch_rate, e.base_z})
      f64(v);
  }
  std::string take() { return std::move(out_); }

 private:
  void uint(std::uint64_t v, int n) {
    for (int i = 0; i < n; ++i) out_.push_back(static_cast<char>((v >> (8 * i)) & 0xffu));
  }
  std::string out_;
};

class Reader {
 public:
  explicit Reader(std::string_view in) : in_(in) {}
  bool ok() const { return ok_; }
  bool atEnd() const { return pos_ == in_.size(); }
  std::uint8_t u8() { return static_cast<std::uint8_t>(uint(1)); }
  std::uint16_t u16() { return static_cast<std::uint16_t>(uint(2)); }
  std::uint32_t u32() { return static_cast<std::uint32_t>(uint(4)); }
  std::uint64_t u64() { return uint(8); }
  float f32() { return std::bit_cast<float>(u32()); }
  double f64() { return std::bit_cast<double>(u64()); }
  void event(planner::JumpEvent& e) {
    for (double* v : {&e.t, &e.state.x, &e.state.z, &e.state.pitch, &e.state.vx, &e.state.vz,
                      &e.state.pitch_rate, &e.base_z})
      *v = f64();
  }

 private:
  std::uint64_t uint(int n) {
    if (pos_ + static_cast<std::size_t>(n) > in_.size()) {
      ok_ = false;
      return 0;
    }
    std::uint64_t v = 0;
    for (int i = 0; i < n; ++i)
      v |= static_cast<std::uint64_t>(static_cast<unsigned char>(in_[pos_ + i])) << (8 * i);
    pos_ += static_cast<std::size_t>(n);
    return v;
  }
  std::string_view in_;
  std::size_t pos_ = 0;
  bool ok_ = true;
};

int statusRank(VerificationStatus s) {
  switch (s) {
    case VerificationStatus::Passed:
      return 2;
    case VerificationStatus::Failed:
      return 1;
    case VerificationStatus::NotRun:
      return 0;
  }
  return 0;
}

}  // namespace

std::string encodeSolution(const CachedSolution& s) {
  Writer w;
  w.u8(kFormatVersion);
  w.u8(static_cast<std::uint8_t>(planner::kNumDecision));
  for (const double v : s.u) w.f64(v);
  w.f64(s.t1);
  w.f64(s.t2);
  w.f64(s.t3);
  w.u8(static_cast<std::uint8_t>((s.feasible ? 1 : 0) | (s.de_complete ? 2 : 0) |
                                 (s.constraints_ok ? 4 : 0)));
  w.f64(s.de_cost);
  w.f64(s.final_cost);
  w.u64(s.seed);
  w.u64(static_cast<std::uint64_t>(s.evaluations));
  w.u32(static_cast<std::uint32_t>(s.generations));
  w.f32(s.de_ms);
  w.f32(s.polish_ms);
  const auto& v = s.verification;
  w.u8(static_cast<std::uint8_t>(v.status));
  w.u32(v.failure_bits);
  w.event(v.simulated.takeoff);
  w.event(v.simulated.apex);
  w.event(v.simulated.touchdown);
  w.f64(v.simulated.min_obstacle_clearance);
  w.f64(v.max_envelope_ratio);
  w.u8(v.landed_upright ? 1 : 0);
  w.u16(v.candidates_verified);
  w.u16(v.returned_candidate_rank);
  w.f32(v.verify_ms);
  w.u64(static_cast<std::uint64_t>(s.created_unix_ms));
  w.u64(static_cast<std::uint64_t>(s.max_evaluations));
  for (const double c :
       {s.liftoff_correction.vx, s.liftoff_correction.vz, s.liftoff_correction.momentum})
    w.f64(c);
  return w.take();
}

std::optional<CachedSolution> decodeSolution(std::string_view payload) {
  Reader r(payload);
  const std::uint8_t version = r.u8();
  if (version < 1 || version > kFormatVersion || !r.ok()) return std::nullopt;
  if (r.u8() != planner::kNumDecision) return std::nullopt;
  CachedSolution s;
  for (double& v : s.u) v = r.f64();
  s.t1 = r.f64();
  s.t2 = r.f64();
  s.t3 = r.f64();
  const std::uint8_t flags = r.u8();
  if (flags > (version >= 3 ? 7 : 3)) return std::nullopt;
  s.feasible = (flags & 1) != 0;
  s.de_complete = (flags & 2) != 0;
  // Before format 3 only a feasible solution is known to have met every constraint.
  s.constraints_ok = version >= 3 ? (flags & 4) != 0 : s.feasible;
  if (s.feasible && !s.constraints_ok) return std::nullopt;
  s.de_cost = r.f64();
  s.final_cost = r.f64();
  s.seed = r.u64();
  s.evaluations = static_cast<std::int64_t>(r.u64());
  s.generations = static_cast<std::int32_t>(r.u32());
  s.de_ms = r.f32();
  s.polish_ms = r.f32();
  auto& v = s.verification;
  const std::uint8_t status = r.u8();
  if (status > 2) return std::nullopt;
  v.status = static_cast<VerificationStatus>(status);
  v.failure_bits = r.u32();
  r.event(v.simulated.takeoff);
  r.event(v.simulated.apex);
  r.event(v.simulated.touchdown);
  v.simulated.min_obstacle_clearance = r.f64();
  v.max_envelope_ratio = r.f64();
  const std::uint8_t upright = r.u8();
  if (upright > 1) return std::nullopt;
  v.landed_upright = upright == 1;
  v.candidates_verified = r.u16();
  v.returned_candidate_rank = r.u16();
  v.verify_ms = r.f32();
  s.created_unix_ms = static_cast<std::int64_t>(r.u64());
  s.max_evaluations =
      version == 1 ? s.evaluations : static_cast<std::int64_t>(r.u64());  // 1: what it used
  if (version >= 4) {
    s.liftoff_correction.vx = r.f64();
    s.liftoff_correction.vz = r.f64();
    s.liftoff_correction.momentum = r.f64();
    if (!planner::withinBounds(s.liftoff_correction)) return std::nullopt;  // NaN included
  }
  if (!r.ok() || !r.atEnd()) return std::nullopt;
  for (const double x : s.u)
    if (!std::isfinite(x)) return std::nullopt;
  if (!(s.t1 > 0.0 && s.t1 <= s.t2 && s.t2 < s.t3 && std::isfinite(s.t3))) return std::nullopt;
  return s;
}

std::uint32_t rowChecksum(std::string_view key_bytes, std::string_view payload) {
  uLong crc = crc32(0L, Z_NULL, 0);
  crc = crc32(crc, reinterpret_cast<const Bytef*>(key_bytes.data()),
              static_cast<uInt>(key_bytes.size()));
  crc =
      crc32(crc, reinterpret_cast<const Bytef*>(payload.data()), static_cast<uInt>(payload.size()));
  return static_cast<std::uint32_t>(crc);
}

bool isBetterSolution(const CachedSolution& candidate, const CachedSolution& current) {
  const auto score = [](const CachedSolution& s) {
    return std::make_tuple(statusRank(s.verification.status), s.feasible ? 1 : 0, -s.final_cost,
                           s.max_evaluations);
  };
  return score(candidate) > score(current);
}

}  // namespace wj::server
