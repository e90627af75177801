// backflip_bound: an upper bound on the backflip's rotation at touchdown over any take-off the
// actuators allow, per knee peak torque and run-up speed, as JSON (docs/backflip.md, "A bound
// on the rotation at 42 Nm").
#include <CLI/CLI.hpp>
#include <iostream>
#include <nlohmann/json.hpp>

#include "backflip_bound.h"

namespace {

nlohmann::json toJson(const wj::bound::BoundTerms& t) {
  return {{"knee_peak_nm", t.knee_peak_nm},
          {"run_up_speed_m_s", t.run_up_speed_m_s},
          {"i_min_kg_m2", t.i_min},
          {"i_max_kg_m2", t.i_max},
          {"theta_liftoff_max_rad", t.theta_liftoff_max_rad},
          {"z_start_m", t.z_start_m},
          {"z_min_m", t.z_min_m},
          {"run_up_energy_j", t.run_up_energy_j},
          {"work_j",
           {{"HAA", t.work_by_kind_j[0]},
            {"HFE", t.work_by_kind_j[1]},
            {"KFE", t.work_by_kind_j[2]},
            {"WHEEL", t.work_by_kind_j[3]},
            {"total", t.work_j}}},
          {"energy_j", t.energy_j},
          {"wheel_momentum_max_kg_m2_s", t.wheel_momentum_max},
          {"momentum_at_best_kg_m2_s", t.momentum_at_best},
          {"vz_at_best_m_s", t.vz_at_best},
          {"flight_time_at_best_s", t.flight_time_at_best_s},
          {"flight_rotation_rad", t.flight_rotation_rad},
          {"shape_rotation_rad", t.shape_rotation_rad},
          {"bound_rad", t.bound_rad},
          {"need_rad", t.need_rad},
          {"certified", t.bound_rad < t.need_rad},
          {"energy_to_certify_j", t.energy_to_certify_j},
          {"loosest_term", t.loosest_term},
          {"alone_exceed_need", t.alone_exceed_need}};
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "Upper bound on the backflip's rotation at touchdown over any admissible take-off (JSON)."};
  wj::bound::BoundSettings settings;
  std::vector<double> knees = {42.0, 47.0, 52.0, 57.0};
  std::vector<double> speeds = {0.0, -0.5, -1.0};
  app.add_option("--knee", knees, "knee peak torques [Nm]")->check(CLI::Range(1.0, 420.0));
  app.add_option("--v0", speeds, "run-up speeds [m/s] (negative: backward)")
      ->check(CLI::Range(-5.0, 5.0));
  app.add_option("--grid", settings.grid_step_rad, "joint grid step [rad]")
      ->check(CLI::Range(0.01, 0.5));
  app.add_option("--stance-time", settings.stance_time_max_s, "longest take-off [s]")
      ->check(CLI::Range(0.05, 5.0));
  app.add_option("--mu", settings.friction_mu, "wheel-ground friction")
      ->check(CLI::Range(0.1, 2.0));
  std::vector<double> liftoff;
  app.add_option("--liftoff", liftoff,
                 "a lift-off to bound the flight from: pitch [rad], H [kg m^2/s], vz [m/s], CoM "
                 "height above its touchdown height [m]")
      ->expected(4)
      ->delimiter(',');
  CLI11_PARSE(app, argc, argv);
  try {
    const auto robot = wj::model::RobotModel::loadDefault();
    // Nothing geometric depends on the knee's torque: one search serves every row.
    const auto geometry = wj::bound::calcGeometry(robot, settings);
    nlohmann::json rows = nlohmann::json::array();
    for (const double knee : knees) {
      const auto variant = robot.withPeakTorque(wj::model::JointKind::KFE, knee);
      for (const double v0 : speeds)
        rows.push_back(toJson(wj::bound::calcBound(variant, geometry, settings, v0)));
    }
    const auto& in = geometry.inertia;
    nlohmann::json out = {
        {"inertia",
         {{"i_min_found_kg_m2", in.i_min},
          {"i_min_lower_kg_m2", in.i_min_lower},
          {"i_max_found_kg_m2", in.i_max_found},
          {"i_max_upper_kg_m2", in.i_max_upper},
          {"q_min", std::vector<double>(in.q_min.data(), in.q_min.data() + in.q_min.size())},
          {"q_max", std::vector<double>(in.q_max.data(), in.q_max.data() + in.q_max.size())}}},
        {"shape_coupling_per_rad",
         {{"HAA", geometry.shape_coupling[0]},
          {"HFE", geometry.shape_coupling[1]},
          {"KFE", geometry.shape_coupling[2]}}},
        {"settings",
         {{"grid_step_rad", settings.grid_step_rad},
          {"stance_time_max_s", settings.stance_time_max_s},
          {"friction_mu", settings.friction_mu},
          {"wheel_speed_max_rad_s", settings.wheel_speed_max_rad_s},
          {"strokes_per_joint_stance", settings.strokes_per_joint_stance},
          {"strokes_per_joint_flight", settings.strokes_per_joint_flight}}},
        {"rows", rows}};
    if (!liftoff.empty()) {
      const wj::bound::LiftoffState state{liftoff[0], liftoff[1], liftoff[2], liftoff[3]};
      std::array<double, 3> terms{};
      const double bound =
          wj::bound::calcBoundFromLiftoff(robot, geometry, settings, state, &terms);
      out["from_liftoff"] = {{"pitch_rad", terms[0]},
                             {"momentum_turn_rad", terms[1]},
                             {"shape_rotation_rad", terms[2]},
                             {"bound_rad", bound}};
    }
    std::cout << out.dump(2) << "\n";
  } catch (const std::exception& e) {
    std::cerr << "backflip_bound: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
