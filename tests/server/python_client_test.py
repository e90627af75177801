#!/usr/bin/python3
"""The Python contract client against a running planner_server.

Starts planner_server on 127.0.0.1 with an ephemeral port (a memory-only cache, the fast test
planner settings, no verification), then, with the stubs generated from the contract by
tests/contract and Debian's python3-grpcio: plans a jump, gets it again from the cache, checks
the INVALID_ARGUMENT message of a bad request, reads GetStats, calls the standard health service
and lists the services through server reflection (both with raw protobuf bytes, since Debian has
no grpcio-health-checking or grpcio-reflection package). Run by ctest with /usr/bin/python3.
"""

import argparse
import math
import pathlib
import re
import subprocess
import sys
import tempfile
import time
import unittest

ARGS = None  # the parsed command line, set in main()


def replace_line(yaml, key, value):
    """Sets `key: value` in the printed configuration (keys are unique in their section)."""
    pattern = re.compile(rf"^(\s*){re.escape(key)}:.*$", re.MULTILINE)
    result, count = pattern.subn(lambda m: f"{m.group(1)}{key}: {value}", yaml, count=1)
    if count != 1:
        raise ValueError(f"no key {key} in the configuration")
    return result


class PlannerServer:
    """planner_server as a child process on an ephemeral loopback port."""

    def __init__(self, binary, planner_settings, workdir):
        printed = subprocess.run([binary, "--print-config"], check=True, capture_output=True,
                                 text=True, timeout=60).stdout
        config = replace_line(printed, "listen", '"127.0.0.1:0"')
        config = replace_line(config, "path", '""')
        config = replace_line(config, "settings_file", f'"{planner_settings}"')
        config = replace_line(config, "enabled", "false")
        config = replace_line(config, "log_level", "warn")
        path = pathlib.Path(workdir) / "server.yaml"
        path.write_text(config, encoding="utf-8")
        self.log = open(pathlib.Path(workdir) / "server.log", "w+", encoding="utf-8")
        self.process = subprocess.Popen([binary, "--config", str(path)], stdout=self.log,
                                        stderr=subprocess.STDOUT)
        deadline = time.monotonic() + 60
        self.port = None
        while time.monotonic() < deadline and self.port is None:
            self.log.seek(0)
            found = re.search(r"listening on [\d.]+:(\d+)\n", self.log.read())
            if found:
                self.port = int(found.group(1))
            elif self.process.poll() is not None:
                break
            else:
                time.sleep(0.05)
        if self.port is None:
            self.stop()
            self.log.seek(0)
            raise RuntimeError("planner_server did not start:\n" + self.log.read())

    def stop(self):
        if self.process.poll() is None:
            self.process.terminate()
            try:
                self.process.wait(timeout=20)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()
        self.log.close()
        return self.process.returncode


class PythonClientTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        sys.path.insert(0, str(pathlib.Path(ARGS.stubs_dir).resolve()))
        import grpc
        from wheeljump.planner.v1 import jump_planner_pb2, jump_planner_pb2_grpc

        cls.grpc = grpc
        cls.pb2 = jump_planner_pb2
        cls.workdir = tempfile.TemporaryDirectory(prefix="wj-python-client-")
        cls.server = PlannerServer(ARGS.server, ARGS.planner_settings, cls.workdir.name)
        cls.channel = grpc.insecure_channel(f"127.0.0.1:{cls.server.port}")
        cls.stub = jump_planner_pb2_grpc.JumpPlannerStub(cls.channel)

    @classmethod
    def tearDownClass(cls):
        cls.channel.close()
        code = cls.server.stop()
        cls.workdir.cleanup()
        if code != 0:
            raise RuntimeError(f"planner_server exited with {code} after SIGTERM")

    def standing_request(self, v0, request_id="python"):
        pb2 = self.pb2
        request = pb2.PlanJumpRequest(request_id=request_id)
        state = request.state
        state.base_orientation_w.w = 1.0
        state.base_linear_velocity_w_m_s.x = v0
        for _ in range(4):
            state.joint_positions_rad.extend([0.0, 1.0, -2.0, 0.0])
            state.joint_velocities_rad_s.extend([0.0] * 4)
        request.task.target_height_m = 0.8
        request.task.event = pb2.TARGET_EVENT_APEX
        request.task.takeoff_mode = pb2.TAKEOFF_MODE_SIMULTANEOUS
        return request

    def test_a_plans_a_jump_then_gets_it_from_the_cache(self):
        response = self.stub.PlanJump(self.standing_request(0.7, "py-1"), timeout=30)
        self.assertEqual(response.request_id, "py-1")
        self.assertIn(response.source, (self.pb2.PLAN_SOURCE_CACHE_MISS,
                                        self.pb2.PLAN_SOURCE_WARM_START))
        joints = response.plan.joints
        self.assertGreater(joints.num_samples, 10)
        self.assertEqual(len(joints.positions_rad), 16 * joints.num_samples)
        self.assertEqual(list(joints.joint_names)[5], "RF_HFE")
        self.assertEqual(len(response.plan.decision_vector), 12)
        self.assertEqual(len(response.feasibility.margins), 10)
        self.assertTrue(math.isfinite(response.predicted.apex.com_z_m))
        again = self.stub.PlanJump(self.standing_request(0.71, "py-2"), timeout=30)
        self.assertEqual(again.source, self.pb2.PLAN_SOURCE_CACHE_HIT)
        self.assertEqual(again.stats.cache_key, response.stats.cache_key)
        # The same plan as knots: no dense arrays, K x 16 float32 joint arrays, t3 last.
        knots_request = self.standing_request(0.71, "py-3")
        knots_request.trajectory_format = self.pb2.TRAJECTORY_FORMAT_KNOTS
        compact = self.stub.PlanJump(knots_request, timeout=30)
        self.assertEqual(compact.source, self.pb2.PLAN_SOURCE_CACHE_HIT)
        self.assertEqual(compact.plan.joints.num_samples, 0)
        knots = compact.plan.knots
        self.assertGreaterEqual(len(knots.t_s), 4)
        self.assertEqual(len(knots.positions_rad), 16 * len(knots.t_s))
        self.assertEqual(len(knots.centroidal), 6 * len(knots.t_s))
        self.assertAlmostEqual(knots.t_s[-1], compact.plan.phase_times.t3_s, places=9)
        self.assertLess(compact.ByteSize() * 3, again.ByteSize())

    def test_b_invalid_argument_names_the_field(self):
        request = self.standing_request(0.7)
        request.task.target_dx_m = float("nan")
        with self.assertRaises(self.grpc.RpcError) as caught:
            self.stub.PlanJump(request, timeout=10)
        self.assertEqual(caught.exception.code(), self.grpc.StatusCode.INVALID_ARGUMENT)
        self.assertIn("task.target_dx_m", caught.exception.details())
        self.assertIn("[-3, 5]", caught.exception.details())

    def test_c_get_stats(self):
        stats = self.stub.GetStats(self.pb2.GetStatsRequest(), timeout=10)
        self.assertGreaterEqual(stats.requests, 1)
        self.assertEqual([p.path for p in stats.latencies],
                         ["cache_hit", "cache_miss", "warm_start", "coalesced"])

    def test_d_health_service_reports_serving(self):
        # grpc.health.v1.Health/Check with an empty HealthCheckRequest (service ""); the answer
        # HealthCheckResponse{status: SERVING (1)} is the two bytes 08 01.
        check = self.channel.unary_unary("/grpc.health.v1.Health/Check")
        self.assertEqual(check(b"", timeout=10), b"\x08\x01")

    def test_e_reflection_lists_the_service(self):
        # grpc.reflection.v1alpha.ServerReflectionRequest{list_services: ""} is field 7, empty.
        info = self.channel.stream_stream(
            "/grpc.reflection.v1alpha.ServerReflection/ServerReflectionInfo")
        answers = list(info(iter([b"\x3a\x00"]), timeout=10))
        self.assertEqual(len(answers), 1)
        self.assertIn(b"wheeljump.planner.v1.JumpPlanner", answers[0])
        self.assertIn(b"grpc.health.v1.Health", answers[0])


def main():
    global ARGS
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--server", required=True, help="the planner_server binary")
    parser.add_argument("--stubs-dir", required=True, help="Python stubs of the contract")
    parser.add_argument("--planner-settings", required=True, help="planner settings YAML")
    ARGS, rest = parser.parse_known_args()
    unittest.main(argv=[sys.argv[0]] + rest, verbosity=2)


if __name__ == "__main__":
    main()
