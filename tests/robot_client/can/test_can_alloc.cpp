// Nothing allocates after construction: the in-process bus and CanRobot's control period
// (write, the emulators' answers, advance, read). Counts calls of the global operator new,
// which this test binary replaces.
#include <gtest/gtest.h>

#include "allocation_counter.h"
#include "can_test_util.h"

namespace wj::can {
namespace {

using wj::test::allocations;

TEST(CanAllocation, TheCounterSeesAllocations) {
  const long before = allocations();
  auto* p = new std::array<double, 4>();
  const long after = allocations();
  delete p;
  EXPECT_EQ(after - before, 1);
}

TEST(CanAllocation, InProcessBusDoesNotAllocateAfterConstruction) {
  InProcessCanBus bus(32);
  CanFrame f;
  const long before = allocations();
  for (int k = 0; k < 10000; ++k) {
    f.id = static_cast<std::uint32_t>(k & 0x7FF);
    bus.robotSide().send(f);
    bus.motorSide().send(f);
    if (k % 3 == 0) {
      bus.motorSide().receive(f);
      bus.robotSide().receive(f);
    }
  }
  bus.injectErrorFrame(BusSide::Robot, 0x40);
  (void)bus.robotSide().stats();
  EXPECT_EQ(allocations() - before, 0);
  EXPECT_GT(bus.robotSide().stats().dropped, 0u);  // the loop did fill the queue
}

TEST(CanAllocation, CanRobotControlPeriodDoesNotAllocate) {
  const model::RobotModel m = test::loadRobot();
  test::Harness h(m, CanRobotSettings{});
  model::SensorData out;
  test::MotorStates states{};
  h.enable(states, out);
  model::JointCommands c{};
  const long before = allocations();
  for (int k = 0; k < 2000; ++k) {
    for (int j = 0; j < model::kNumJoints; ++j) {
      c[j] = {0.01 * k, 1.0, 100.0, 1.0, 2.0};
      states[j] = {0.02 * k, 20.0, 1.0};
    }
    if (k == 1000) h.motors[3]->setSilent(true);  // the fault path too
    if (k == 1500) h.motors[5]->sendErrorFrame(0x40);
    h.step(c, states, out);
  }
  (void)h.robot->faults();
  EXPECT_EQ(allocations() - before, 0);
  EXPECT_TRUE(h.robot->hasFault());
}

}  // namespace
}  // namespace wj::can
