#include "sim/telemetry.h"

#include <iomanip>
#include <limits>
#include <ostream>
#include <string>

namespace wj::sim {

void writeTelemetryCsvHeader(std::ostream& out) {
  out << "t,phase,base_x,base_y,base_z,base_qw,base_qx,base_qy,base_qz,base_vx,base_vy,base_vz,"
         "base_wx,base_wy,base_wz,com_x,com_y,com_z,com_vx,com_vy,com_vz";
  for (const char* what : {"q", "qd", "tau"})
    for (const model::Leg leg : model::kLegs)
      for (const model::JointKind kind : model::kJointKinds)
        out << ',' << what << '_' << model::toString(leg) << '_' << model::toString(kind);
  for (const model::Leg leg : model::kLegs)
    for (const char axis : {'x', 'y', 'z'}) out << ",f_" << model::toString(leg) << '_' << axis;
  out << ",obstacle_clearance\n";
}

void writeTelemetryCsvRow(std::ostream& out, const TelemetrySample& s) {
  const auto old_precision = out.precision(std::numeric_limits<double>::max_digits10);
  out << s.t << ',' << toString(s.phase);
  const auto vec = [&](const Eigen::Vector3d& v) {
    out << ',' << v.x() << ',' << v.y() << ',' << v.z();
  };
  vec(s.p_WB);
  out << ',' << s.q_WB.w() << ',' << s.q_WB.x() << ',' << s.q_WB.y() << ',' << s.q_WB.z();
  vec(s.v_WB);
  vec(s.w_WB);
  vec(s.p_WC);
  vec(s.v_WC);
  for (const auto* a : {&s.q, &s.qd, &s.tau})
    for (const double x : *a) out << ',' << x;
  for (const auto& f : s.wheel_force_W) vec(f);
  out << ',' << s.obstacle_clearance_m << '\n';
  out.precision(old_precision);
}

TelemetryCallback TelemetryRecorder::callback() {
  return [this](const TelemetrySample& s) { samples_.push_back(s); };
}

void TelemetryRecorder::writeCsv(std::ostream& out) const {
  writeTelemetryCsvHeader(out);
  for (const auto& s : samples_) writeTelemetryCsvRow(out, s);
}

}  // namespace wj::sim
