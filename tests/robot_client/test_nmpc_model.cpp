// The centroidal model: kinematics against the URDF model, every analytic derivative against
// central finite differences, the discrete dynamics and the base/state conversion.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "nmpc/centroidal_model.h"
#include "nmpc/discretization.h"
#include "nmpc/rotation.h"
#include "nmpc_test_util.h"

namespace wj::nmpc {
namespace {

using test::numericJacobian;
using test::relativeError;

class ModelTest : public ::testing::Test {
 protected:
  model::RobotModel robot_ = test::loadRobot();
  CentroidalModel model_{robot_};
  std::mt19937 rng_{42};
};

TEST_F(ModelTest, RotationDerivativesMatchFiniteDifferences) {
  for (int trial = 0; trial < 5; ++trial) {
    const Eigen::Vector3d theta = test::randomState(model_, rng_).head<3>();
    const auto dR = calcRotationDerivatives(theta);
    for (int k = 0; k < 3; ++k) {
      const auto f = [&](const Eigen::VectorXd& s) {
        Eigen::Vector3d t = theta;
        t[k] = s[0];
        return Eigen::Map<const Eigen::VectorXd>(calcRotation(t).eval().data(), 9).eval();
      };
      const Eigen::MatrixXd num = numericJacobian(f, Eigen::VectorXd::Constant(1, theta[k]));
      EXPECT_LT(relativeError(Eigen::Map<const Eigen::VectorXd>(dR[k].data(), 9), num), 1e-8);
    }
    const Eigen::Matrix3d R = calcRotation(theta);
    EXPECT_LT((R * R.transpose() - Eigen::Matrix3d::Identity()).norm(), 1e-12);
    EXPECT_LT((calcEulerAngles(R, theta.z()) - theta).norm(), 1e-12);
  }
}

TEST_F(ModelTest, EulerRatesInvertTheAngularVelocityMap) {
  for (int trial = 0; trial < 5; ++trial) {
    const State x = test::randomState(model_, rng_);
    const Eigen::Vector3d theta = x.head<3>(), w = x.segment<3>(state_index::kOmega);
    const Eigen::Vector3d rates = calcEulerRates(theta, w);
    // omega_W from the rates through dR/dt R^T = [omega]x.
    const auto dR = calcRotationDerivatives(theta);
    const Eigen::Matrix3d Rdot = dR[0] * rates[0] + dR[1] * rates[1] + dR[2] * rates[2];
    const Eigen::Matrix3d W = Rdot * calcRotation(theta).transpose();
    EXPECT_LT((Eigen::Vector3d(W(2, 1), W(0, 2), W(1, 0)) - w).norm(), 1e-12);
    Eigen::Matrix3d d_theta, d_omega;
    calcEulerRatesJacobians(theta, w, d_theta, d_omega);
    const auto f_theta = [&](const Eigen::VectorXd& t) {
      return Eigen::VectorXd(calcEulerRates(t, w));
    };
    const auto f_omega = [&](const Eigen::VectorXd& v) {
      return Eigen::VectorXd(calcEulerRates(theta, v));
    };
    EXPECT_LT(relativeError(d_theta, numericJacobian(f_theta, theta)), 1e-8);
    EXPECT_LT(relativeError(d_omega, numericJacobian(f_omega, w)), 1e-8);
  }
}

TEST_F(ModelTest, LegKinematicsMatchTheUrdfModel) {
  for (int trial = 0; trial < 5; ++trial) {
    const State x = test::randomState(model_, rng_);
    Eigen::VectorXd q16 = Eigen::VectorXd::Zero(model::kNumJoints);
    for (int leg = 0; leg < kNumLegs; ++leg)
      for (int j = 0; j < kLegDofs; ++j)
        q16[robotJointIndex(leg, j)] = x[state_index::joints(leg) + j];
    const auto X_BL = robot_.calcLinkPoses(q16);
    for (int leg = 0; leg < kNumLegs; ++leg) {
      LegKinematics k;
      const Eigen::Vector3d q = x.segment<3>(state_index::joints(leg));
      model_.calcLegKinematics(leg, q, k);
      const int wheel_link = robot_.joints()[robotJointIndex(leg, 3)].child_link;
      EXPECT_LT((k.p_B - X_BL[wheel_link].translation()).norm(), 1e-12);
      EXPECT_LT((k.axis_B - X_BL[wheel_link].linear() * Eigen::Vector3d::UnitY()).norm(), 1e-12);
      const auto pos = [&](const Eigen::VectorXd& v) {
        LegKinematics kk;
        model_.calcLegKinematics(leg, v, kk);
        return Eigen::VectorXd(kk.p_B);
      };
      const auto axis = [&](const Eigen::VectorXd& v) {
        LegKinematics kk;
        model_.calcLegKinematics(leg, v, kk);
        return Eigen::VectorXd(kk.axis_B);
      };
      EXPECT_LT(relativeError(k.J, numericJacobian(pos, q)), 1e-8);
      EXPECT_LT(relativeError(k.d_axis, numericJacobian(axis, q)), 1e-8);
      for (int c = 0; c < kLegDofs; ++c) {
        const auto col = [&](const Eigen::VectorXd& v) {
          LegKinematics kk;
          model_.calcLegKinematics(leg, v, kk);
          return Eigen::VectorXd(kk.J.col(c));
        };
        const Eigen::MatrixXd num = numericJacobian(col, q);  // columns: d J.col(c) / dq_k
        for (int kq = 0; kq < kLegDofs; ++kq)
          EXPECT_LT((k.dJ[kq].col(c) - num.col(kq)).norm(), 1e-8) << leg << " " << c << " " << kq;
      }
    }
  }
}

TEST_F(ModelTest, NominalPostureAndCompositeInertiaComeFromTheUrdf) {
  Eigen::VectorXd q16 = Eigen::VectorXd::Zero(model::kNumJoints);
  for (int leg = 0; leg < kNumLegs; ++leg)
    for (int j = 0; j < kLegDofs; ++j)
      q16[robotJointIndex(leg, j)] = model_.nominalJoints()[kLegDofs * leg + j];
  const model::Inertia ref = robot_.calcCompositeInertia(q16);
  EXPECT_DOUBLE_EQ(model_.mass(), robot_.totalMass());
  EXPECT_LT((model_.comOffset() - ref.com).norm(), 1e-12);
  EXPECT_LT((model_.inertia() - ref.inertia_com).norm(), 1e-12);
  // Nominal posture: wheels straight under the HFE axes, wheel bottoms at -h.
  ModelData data;
  State x = State::Zero();
  x.segment<kNumLegJoints>(state_index::kJoints) = model_.nominalJoints();
  model_.updateData(x, data);
  for (int leg = 0; leg < kNumLegs; ++leg) {
    const model::LegGeometry& g = robot_.legGeometry(static_cast<model::Leg>(leg));
    EXPECT_NEAR(data.legs[leg].p_B.x(), g.p_BH.x() + g.p_HT.x(), 1e-12);
    EXPECT_NEAR(data.legs[leg].p_B.z() - robot_.wheelRadius(),
                -model_.settings().nominal_base_height_m, 1e-12);
  }
}

TEST_F(ModelTest, FlowMapJacobiansMatchFiniteDifferences) {
  const Eigen::Vector3d n = Eigen::Vector3d(-0.2, 0.1, 1.0).normalized();
  for (int trial = 0; trial < 5; ++trial) {
    const State x = test::randomState(model_, rng_);
    const Input u = test::randomInput(model_, rng_);
    ModelData data;
    model_.updateData(x, data);
    State f, f2;
    StateMatrix A;
    StateInputMatrix B;
    model_.calcFlowMapJacobians(x, u, n, data, f, A, B);
    model_.calcFlowMap(x, u, n, data, f2);
    EXPECT_LT((f - f2).norm(), 1e-12);
    const auto fx = [&](const Eigen::VectorXd& xv) {
      ModelData d;
      State s = xv, out;
      model_.updateData(s, d);
      model_.calcFlowMap(s, u, n, d, out);
      return Eigen::VectorXd(out);
    };
    const auto fu = [&](const Eigen::VectorXd& uv) {
      State out;
      model_.calcFlowMap(x, Input(uv), n, data, out);
      return Eigen::VectorXd(out);
    };
    EXPECT_LT(relativeError(A, numericJacobian(fx, x)), 1e-7);
    EXPECT_LT(relativeError(B, numericJacobian(fu, u)), 1e-7);
  }
}

TEST_F(ModelTest, FlowMapIsNewtonEulerOfOneRigidBody) {
  // Linear: m vdot = sum f + m g. Angular, at rest: I_W omegadot = sum (c_i - p) x f_i, with
  // the contact point a wheel radius below the wheel centre.
  const State x = test::randomState(model_, rng_);
  State x0 = x;
  x0.segment<3>(state_index::kOmega).setZero();
  const Input u = test::randomInput(model_, rng_);
  const Eigen::Vector3d n = Eigen::Vector3d::UnitZ();
  ModelData data;
  model_.updateData(x0, data);
  State f;
  model_.calcFlowMap(x0, u, n, data, f);
  Eigen::Vector3d F = Eigen::Vector3d::Zero(), T = Eigen::Vector3d::Zero();
  for (int leg = 0; leg < kNumLegs; ++leg) {
    const Eigen::Vector3d fi = u.segment<3>(input_index::force(leg));
    const Eigen::Vector3d c = model_.calcWheelCenter(leg, x0, data) - robot_.wheelRadius() * n;
    F += fi;
    T += (c - x0.segment<3>(state_index::kPos)).cross(fi);
  }
  EXPECT_LT((model_.mass() * f.segment<3>(state_index::kVel) - F - model_.mass() * model_.gravity())
                .norm(),
            1e-9);
  const Eigen::Matrix3d I_W = data.R * model_.inertia() * data.R.transpose();
  EXPECT_LT((I_W * f.segment<3>(state_index::kOmega) - T).norm(), 1e-9);
}

TEST_F(ModelTest, WheelVelocityIsTheTimeDerivativeOfTheWheelCentre) {
  const Eigen::Vector3d n = Eigen::Vector3d::UnitZ();
  for (int trial = 0; trial < 5; ++trial) {
    const State x = test::randomState(model_, rng_);
    const Input u = test::randomInput(model_, rng_);
    ModelData data;
    model_.updateData(x, data);
    State f;
    model_.calcFlowMap(x, u, n, data, f);
    const double h = 1e-6;
    for (int leg = 0; leg < kNumLegs; ++leg) {
      ModelData dp, dm;
      const State xp = x + h * f, xm = x - h * f;
      model_.updateData(xp, dp);
      model_.updateData(xm, dm);
      const Eigen::Vector3d num =
          (model_.calcWheelCenter(leg, xp, dp) - model_.calcWheelCenter(leg, xm, dm)) / (2 * h);
      EXPECT_LT((model_.calcWheelVelocity(leg, x, u, data) - num).norm(), 1e-7);
    }
  }
}

TEST_F(ModelTest, WheelVelocityAndAxisJacobiansMatchFiniteDifferences) {
  for (int trial = 0; trial < 5; ++trial) {
    const State x = test::randomState(model_, rng_);
    const Input u = test::randomInput(model_, rng_);
    ModelData data;
    model_.updateData(x, data);
    for (int leg = 0; leg < kNumLegs; ++leg) {
      WheelVelocity wv;
      model_.calcWheelVelocityJacobians(leg, x, u, data, wv);
      EXPECT_LT((wv.v - model_.calcWheelVelocity(leg, x, u, data)).norm(), 1e-12);
      const auto vx = [&](const Eigen::VectorXd& xv) {
        ModelData d;
        model_.updateData(State(xv), d);
        return Eigen::VectorXd(model_.calcWheelVelocity(leg, State(xv), u, d));
      };
      const auto vu = [&](const Eigen::VectorXd& uv) {
        return Eigen::VectorXd(model_.calcWheelVelocity(leg, x, Input(uv), data));
      };
      const auto ax = [&](const Eigen::VectorXd& xv) {
        ModelData d;
        model_.updateData(State(xv), d);
        return Eigen::VectorXd(model_.calcWheelAxis(leg, d));
      };
      EXPECT_LT(relativeError(wv.dx, numericJacobian(vx, x)), 1e-7);
      const Eigen::MatrixXd du = numericJacobian(vu, u);
      EXPECT_LT(relativeError(wv.dqd, du.middleCols(input_index::jointVel(leg), 3)), 1e-8);
      EXPECT_LT(du.leftCols(input_index::jointVel(leg)).norm(), 1e-9);
      EXPECT_LT(relativeError(model_.calcWheelAxisJacobian(leg, data), numericJacobian(ax, x)),
                1e-8);
    }
  }
}

TEST_F(ModelTest, DiscreteDynamicsJacobiansMatchFiniteDifferences) {
  const Eigen::Vector3d n = Eigen::Vector3d(0.1, 0.0, 1.0).normalized();
  const double dt = 0.015;
  for (const Integrator integrator : {Integrator::ForwardEuler, Integrator::RungeKutta4}) {
    const State x = test::randomState(model_, rng_);
    const Input u = test::randomInput(model_, rng_);
    ModelData data, scratch;
    model_.updateData(x, data);
    State xn, xn2;
    StateMatrix A;
    StateInputMatrix B;
    calcDiscreteDynamicsJacobians(model_, integrator, x, u, n, dt, data, scratch, xn, A, B);
    calcDiscreteDynamics(model_, integrator, x, u, n, dt, data, scratch, xn2);
    EXPECT_LT((xn - xn2).norm(), 1e-12);
    const auto Fx = [&](const Eigen::VectorXd& xv) {
      ModelData d, s;
      State out;
      model_.updateData(State(xv), d);
      calcDiscreteDynamics(model_, integrator, State(xv), u, n, dt, d, s, out);
      return Eigen::VectorXd(out);
    };
    const auto Fu = [&](const Eigen::VectorXd& uv) {
      ModelData s;
      State out;
      calcDiscreteDynamics(model_, integrator, x, Input(uv), n, dt, data, s, out);
      return Eigen::VectorXd(out);
    };
    EXPECT_LT(relativeError(A, numericJacobian(Fx, x)), 1e-8) << toString(integrator);
    EXPECT_LT(relativeError(B, numericJacobian(Fu, u)), 1e-8) << toString(integrator);
  }
}

TEST_F(ModelTest, RungeKutta4IsFourthOrder) {
  // Halving dt divides the one-step error of RK4 by about 32 (local error O(dt^5)).
  const State x = test::randomState(model_, rng_);
  const Input u = test::randomInput(model_, rng_);
  const Eigen::Vector3d n = Eigen::Vector3d::UnitZ();
  const auto step = [&](double dt, int steps) {
    State s = x;
    ModelData d, scratch;
    for (int i = 0; i < steps; ++i) {
      model_.updateData(s, d);
      State next;
      calcDiscreteDynamics(model_, Integrator::RungeKutta4, s, u, n, dt, d, scratch, next);
      s = next;
    }
    return s;
  };
  const State ref = step(0.05 / 64, 64);
  const double e1 = (step(0.05, 1) - ref).norm(), e2 = (step(0.025, 2) - ref).norm();
  EXPECT_GT(e1 / e2, 12.0);
}

TEST_F(ModelTest, StateFromBaseRoundTrips) {
  const State x = test::randomState(model_, rng_);
  const Eigen::Isometry3d X_WB = model_.calcBasePose(x);
  const Eigen::Vector3d v_WB = model_.calcBaseVelocity(x);
  Eigen::Matrix<double, model::kNumJoints, 1> q16 = Eigen::Matrix<double, 16, 1>::Zero();
  for (int leg = 0; leg < kNumLegs; ++leg)
    for (int j = 0; j < kLegDofs; ++j)
      q16[robotJointIndex(leg, j)] = x[state_index::joints(leg) + j];
  const State back = model_.calcStateFromBase(X_WB, v_WB, x.segment<3>(state_index::kOmega), q16,
                                              x[state_index::kTheta + 2]);
  EXPECT_LT((back - x).norm(), 1e-12);
}

}  // namespace
}  // namespace wj::nmpc
