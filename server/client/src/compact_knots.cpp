#include "planner_client/compact_knots.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <vector>

namespace wj::client {

namespace v1 = wheeljump::planner::v1;

namespace {

constexpr int kJoints = 16;
constexpr int kCentroidal = 6;
constexpr double kHalfSpan = 32767.0;  // |q| at the column's min and max

// Knot-major float columns, `width` of them, `knots` rows: column c at knot k is data[width k + c].
struct Columns {
  const float* data;
  int knots;
  int width;
  float at(int k, int c) const { return data[static_cast<std::size_t>(width) * k + c]; }
};

// Quantizes the listed columns of `in` into `out` (offset, scale, knot-major int16 values).
void quantize(const Columns& in, const std::vector<int>& columns, v1::QuantizedColumns* out) {
  const int n = static_cast<int>(columns.size());
  std::vector<double> offset(columns.size()), inverse(columns.size());
  for (int c = 0; c < n; ++c) {
    double lo = std::numeric_limits<double>::max(), hi = std::numeric_limits<double>::lowest();
    for (int k = 0; k < in.knots; ++k) {
      lo = std::min(lo, static_cast<double>(in.at(k, columns[c])));
      hi = std::max(hi, static_cast<double>(in.at(k, columns[c])));
    }
    const auto o = static_cast<float>((lo + hi) / 2.0);
    auto s = static_cast<float>((hi - lo) / (2.0 * kHalfSpan));
    if (!(s > 0.0f)) s = std::numeric_limits<float>::min();  // a constant column
    out->add_offset(o);
    out->add_scale(s);
    offset[c] = o;
    inverse[c] = 1.0 / static_cast<double>(s);
  }
  std::string* bytes = out->mutable_values();
  bytes->resize(2 * static_cast<std::size_t>(n) * in.knots);
  auto* p = reinterpret_cast<unsigned char*>(bytes->data());
  for (int k = 0; k < in.knots; ++k)
    for (int c = 0; c < n; ++c) {
      const double q =
          std::round((static_cast<double>(in.at(k, columns[c])) - offset[c]) * inverse[c]);
      const auto v = static_cast<std::uint16_t>(
          static_cast<std::int16_t>(std::clamp(q, -kHalfSpan, kHalfSpan)));
      *p++ = static_cast<unsigned char>(v & 0xff);
      *p++ = static_cast<unsigned char>(v >> 8);
    }
}

// Whether columns a and b of `in` hold the same values (sign +1) or opposite ones (sign -1).
bool sameColumn(const Columns& in, int a, int b, float sign) {
  for (int k = 0; k < in.knots; ++k)
    if (in.at(k, a) != sign * in.at(k, b)) return false;
  return true;
}

void compactJoints(const Columns& in, v1::JointColumns* out) {
  std::vector<int> sent;  // the joints whose columns are sent, in order
  std::vector<int> source(kJoints, 0);
  for (int j = 0; j < kJoints; ++j) {
    float constant = in.at(0, j);
    for (int k = 1; k < in.knots && source[j] == 0; ++k)
      if (in.at(k, j) != constant) source[j] = 1;  // not constant; resolved below
    if (source[j] == 0) {
      out->add_source(0);
      out->add_constant(constant);
      continue;
    }
    out->add_constant(0.0f);
    source[j] = 0;
    for (int i = 0; i < j && source[j] == 0; ++i) {
      if (source[i] == 0) continue;
      if (sameColumn(in, j, i, 1.0f)) source[j] = source[i];
      if (sameColumn(in, j, i, -1.0f)) source[j] = -source[i];
    }
    if (source[j] == 0) {
      sent.push_back(j);
      source[j] = static_cast<int>(sent.size());
    }
    out->add_source(source[j]);
  }
  quantize(in, sent, out->mutable_columns());
}

// The values of checked QuantizedColumns, dequantized on the fly.
class Dequantized {
 public:
  explicit Dequantized(const v1::QuantizedColumns& q)
      : offset_(q.offset().data()),
        scale_(q.scale().data()),
        bytes_(reinterpret_cast<const unsigned char*>(q.values().data())),
        width_(static_cast<std::size_t>(q.offset_size())) {}
  // Column c at knot k.
  float at(int k, int c) const {
    const unsigned char* p = bytes_ + 2 * (width_ * static_cast<std::size_t>(k) + c);
    const auto v = static_cast<std::int16_t>(static_cast<std::uint16_t>(p[0] | (p[1] << 8)));
    return static_cast<float>(static_cast<double>(offset_[c]) + static_cast<double>(scale_[c]) * v);
  }

 private:
  const float* offset_;
  const float* scale_;
  const unsigned char* bytes_;
  std::size_t width_;
};

std::string checkColumns(const v1::QuantizedColumns& q, int knots, int expected,
                         const std::string& field) {
  if (q.offset_size() != q.scale_size())
    return field + ".offset and .scale must have the same length, got " +
           std::to_string(q.offset_size()) + " and " + std::to_string(q.scale_size());
  if (expected >= 0 && q.offset_size() != expected)
    return field + " must have " + std::to_string(expected) + " columns, got " +
           std::to_string(q.offset_size());
  for (int c = 0; c < q.offset_size(); ++c)
    if (!std::isfinite(q.offset(c)) || !std::isfinite(q.scale(c)))
      return field + " column " + std::to_string(c) + ": offset and scale must be finite";
  const std::size_t bytes = 2 * static_cast<std::size_t>(q.offset_size()) * knots;
  if (q.values().size() != bytes)
    return field + ".values must hold " + std::to_string(bytes) + " bytes (2 x " +
           std::to_string(knots) + " knots x " + std::to_string(q.offset_size()) +
           " columns), got " + std::to_string(q.values().size());
  return "";
}

std::string expandJoints(const v1::JointColumns& in, int knots, const std::string& field,
                         google::protobuf::RepeatedField<float>* out) {
  if (in.source_size() != kJoints || in.constant_size() != kJoints)
    return field + ".source and .constant must have 16 entries, got " +
           std::to_string(in.source_size()) + " and " + std::to_string(in.constant_size());
  const int columns = in.columns().offset_size();
  if (std::string e = checkColumns(in.columns(), knots, -1, field + ".columns"); !e.empty())
    return e;
  for (int j = 0; j < kJoints; ++j) {
    const int s = in.source(j);
    if (s > columns || s < -columns)
      return field + ".source[" + std::to_string(j) + "] must be in [-" + std::to_string(columns) +
             ", " + std::to_string(columns) + "], got " + std::to_string(s);
    if (!std::isfinite(in.constant(j)))
      return field + ".constant[" + std::to_string(j) + "] must be finite";
  }
  out->Resize(knots * kJoints, 0.0f);
  float* p = out->mutable_data();
  const Dequantized values(in.columns());
  const std::int32_t* source = in.source().data();
  const float* constant = in.constant().data();
  for (int k = 0; k < knots; ++k)
    for (int j = 0; j < kJoints; ++j) {
      const int s = source[j];
      *p++ = s == 0 ? constant[j] : s > 0 ? values.at(k, s - 1) : -values.at(k, -s - 1);
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
  quantize({knots.centroidal().data(), n, kCentroidal}, {0, 1, 2, 3, 4, 5},
           out->mutable_centroidal());
  compactJoints({knots.positions_rad().data(), n, kJoints}, out->mutable_positions_rad());
  compactJoints({knots.velocities_rad_s().data(), n, kJoints}, out->mutable_velocities_rad_s());
  compactJoints({knots.torques_nm().data(), n, kJoints}, out->mutable_torques_nm());
}

std::string expandKnots(const v1::CompactKnots& compact, v1::TrajectoryKnots* out) {
  out->Clear();
  const int n = compact.t_s_size();
  out->mutable_t_s()->Assign(compact.t_s().begin(), compact.t_s().end());
  if (n == 0) return "";
  const v1::QuantizedColumns& c = compact.centroidal();
  if (std::string e = checkColumns(c, n, kCentroidal, "compact_knots.centroidal"); !e.empty())
    return e;
  out->mutable_centroidal()->Resize(n * kCentroidal, 0.0f);
  float* p = out->mutable_centroidal()->mutable_data();
  const Dequantized values(c);
  for (int k = 0; k < n; ++k)
    for (int i = 0; i < kCentroidal; ++i) *p++ = values.at(k, i);
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
