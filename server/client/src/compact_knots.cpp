#include "planner_client/compact_knots.h"

#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string_view>
#include <vector>

namespace wj::client {

namespace v1 = wheeljump::planner::v1;

namespace {

constexpr int kJoints = 16;
constexpr int kCentroidal = 6;

// A K x 16 knot-major array.
struct Joints {
  const float* data;
  int knots;
  float at(int k, int j) const { return data[static_cast<std::size_t>(kJoints) * k + j]; }
};

// Whether two floats have the same bits (so that a referred column comes back exactly, zeros'
// signs included).
bool sameBits(float a, float b) {
  return std::bit_cast<std::uint32_t>(a) == std::bit_cast<std::uint32_t>(b);
}

// Whether column a of `in` is column b (sign +1) or its negation (sign -1), bit for bit.
bool sameColumn(const Joints& in, int a, int b, float sign) {
  for (int k = 0; k < in.knots; ++k)
    if (!sameBits(in.at(k, a), sign * in.at(k, b))) return false;
  return true;
}

void compactJoints(const Joints& in, v1::JointColumns* out) {
  std::vector<int> sent;                // the joints whose columns are sent, in order
  std::vector<int> source(kJoints, 0);  // as JointColumns.source
  for (int j = 0; j < kJoints; ++j) {
    bool constant = true;
    for (int k = 1; k < in.knots && constant; ++k) constant = sameBits(in.at(k, j), in.at(0, j));
    if (constant) {
      out->add_source(0);
      out->add_constant(in.at(0, j));
      continue;
    }
    out->add_constant(0.0f);
    for (int i = 0; i < j && source[j] == 0; ++i) {
      if (source[i] == 0) continue;  // constant columns are not referred to
      if (sameColumn(in, j, i, 1.0f))
        source[j] = source[i];
      else if (sameColumn(in, j, i, -1.0f))
        source[j] = -source[i];
    }
    if (source[j] == 0) {
      sent.push_back(j);
      source[j] = static_cast<int>(sent.size());
    }
    out->add_source(source[j]);
  }
  const int c = static_cast<int>(sent.size());
  auto* columns = out->mutable_columns();
  columns->Resize(c * in.knots, 0.0f);
  float* p = columns->mutable_data();
  for (int k = 0; k < in.knots; ++k)
    for (const int j : sent) *p++ = in.at(k, j);
}

std::string expandJoints(const v1::JointColumns& in, int knots, std::string_view field,
                         google::protobuf::RepeatedField<float>* out) {
  const auto error = [field](const std::string& what) { return std::string(field) + what; };
  if (in.source_size() != kJoints || in.constant_size() != kJoints)
    return error(".source and .constant must have 16 entries, got " +
                 std::to_string(in.source_size()) + " and " + std::to_string(in.constant_size()));
  if (in.columns_size() % knots != 0)
    return error(".columns must hold K x C values for K = " + std::to_string(knots) +
                 " knots, got " + std::to_string(in.columns_size()));
  const int columns = in.columns_size() / knots;
  if (columns > kJoints)
    return error(".columns must hold at most 16 columns per knot, got " + std::to_string(columns));
  // Each knot's row of the 16 joints is gathered from a row of its sent columns, their
  // negations and the constants, at an index per joint set once: the loop over the K x 16
  // values has no branch (the robot client expands every plan it receives; docs/service.md,
  // "Hits at the floor"). Negation flips the sign bit only, so the values come back bit for bit.
  std::array<float, 3 * kJoints> row{};  // sent columns, their negations, constants
  std::array<int, kJoints> at{};
  for (int j = 0; j < kJoints; ++j) {
    const int s = in.source(j);
    if (s > columns || s < -columns)
      return error(".source[" + std::to_string(j) + "] must be in [-" + std::to_string(columns) +
                   ", " + std::to_string(columns) + "], got " + std::to_string(s));
    if (!std::isfinite(in.constant(j)))
      return error(".constant[" + std::to_string(j) + "] must be finite");
    const auto u = static_cast<std::size_t>(j);
    at[u] = s == 0 ? 2 * kJoints + j : s > 0 ? s - 1 : kJoints - s - 1;
    row[static_cast<std::size_t>(2 * kJoints + j)] = in.constant(j);
  }
  out->Resize(knots * kJoints, 0.0f);
  float* p = out->mutable_data();
  const float* values = in.columns().data();
  for (int k = 0; k < knots; ++k, values += columns, p += kJoints) {
    for (int c = 0; c < columns; ++c) {
      row[static_cast<std::size_t>(c)] = values[c];
      row[static_cast<std::size_t>(kJoints + c)] = -values[c];
    }
    for (std::size_t j = 0; j < kJoints; ++j) p[j] = row[static_cast<std::size_t>(at[j])];
  }
  return "";
}

}  // namespace

void compactKnots(const v1::TrajectoryKnots& knots, v1::CompactKnots* out) {
  out->Clear();
  const int n = knots.t_s_size();
  if (knots.centroidal_size() != kCentroidal * n || knots.positions_rad_size() != kJoints * n ||
      knots.velocities_rad_s_size() != kJoints * n || knots.torques_nm_size() != kJoints * n)
    throw std::invalid_argument("compactKnots: knot arrays do not match " + std::to_string(n) +
                                " knots");
  out->mutable_t_s()->Assign(knots.t_s().begin(), knots.t_s().end());
  if (n == 0) return;
  out->mutable_centroidal()->Assign(knots.centroidal().begin(), knots.centroidal().end());
  compactJoints({knots.positions_rad().data(), n}, out->mutable_positions_rad());
  compactJoints({knots.velocities_rad_s().data(), n}, out->mutable_velocities_rad_s());
  compactJoints({knots.torques_nm().data(), n}, out->mutable_torques_nm());
}

std::string expandKnots(const v1::CompactKnots& compact, v1::TrajectoryKnots* out) {
  out->Clear();
  const int n = compact.t_s_size();
  out->mutable_t_s()->Assign(compact.t_s().begin(), compact.t_s().end());
  if (n == 0) return "";
  if (compact.centroidal_size() != kCentroidal * n)
    return "compact_knots.centroidal must hold " + std::to_string(kCentroidal * n) +
           " values (6 x " + std::to_string(n) + " knots), got " +
           std::to_string(compact.centroidal_size());
  out->mutable_centroidal()->Assign(compact.centroidal().begin(), compact.centroidal().end());
  if (std::string e = expandJoints(compact.positions_rad(), n, "compact_knots.positions_rad",
                                   out->mutable_positions_rad());
      !e.empty())
    return e;
  if (std::string e = expandJoints(compact.velocities_rad_s(), n, "compact_knots.velocities_rad_s",
                                   out->mutable_velocities_rad_s());
      !e.empty())
    return e;
  return expandJoints(compact.torques_nm(), n, "compact_knots.torques_nm",
                      out->mutable_torques_nm());
}

}  // namespace wj::client
