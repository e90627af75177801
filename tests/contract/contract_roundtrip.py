#!/usr/bin/python3
"""Contract check of the wheeljump.planner.v1 gRPC API from Python.

Parses every golden message (golden/<stem>.binpb and .json) with Python stubs generated at
build time from the current proto, and checks that Python reads and writes exactly the wire
bytes that the C++ side committed; imports the gRPC stub module. Run by ctest with Debian's
/usr/bin/python3 (python3-protobuf, python3-grpcio), see CMakeLists.txt in this folder.
"""

import argparse
import pathlib
import sys
import unittest

# Golden file stem -> message name in wheeljump.planner.v1.
GOLDENS = {
    "plan_jump_request": "PlanJumpRequest",
    "plan_jump_response": "PlanJumpResponse",
    "get_stats_response": "GetStatsResponse",
    "warm_cache_progress": "WarmCacheProgress",
}

ARGS = None  # the parsed command line, set in main()


def unknown_field_paths(message, path):
    """Paths of the (sub)messages that hold fields the current proto does not know."""
    paths = [path] if len(message.UnknownFields()) else []
    for field, value in message.ListFields():
        if field.message_type is None:
            continue
        if field.label == field.LABEL_REPEATED:
            for i, item in enumerate(value):
                paths += unknown_field_paths(item, f"{path}.{field.name}[{i}]")
        else:
            paths += unknown_field_paths(value, f"{path}.{field.name}")
    return paths


def minor_of(version):
    """The minor release of a protobuf or gRPC version: '3.21.12' and '4.21.12' give 21."""
    return int(version.split(".")[1])


class ContractTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        stubs_dir = pathlib.Path(ARGS.stubs_dir).resolve()
        sys.path.insert(0, str(stubs_dir))
        from google.protobuf import json_format
        from wheeljump.planner.v1 import jump_planner_pb2, jump_planner_pb2_grpc

        for module in (jump_planner_pb2, jump_planner_pb2_grpc):
            if stubs_dir not in pathlib.Path(module.__file__).resolve().parents:
                raise RuntimeError(f"{module.__name__} was not imported from {stubs_dir}")
        cls.json_format = json_format
        cls.pb2 = jump_planner_pb2
        cls.pb2_grpc = jump_planner_pb2_grpc
        cls.golden_dir = pathlib.Path(ARGS.golden_dir)

    def read_golden(self, stem):
        """(message class, golden bytes, golden JSON text, message parsed from the bytes)."""
        cls = getattr(self.pb2, GOLDENS[stem])
        binary = (self.golden_dir / f"{stem}.binpb").read_bytes()
        json_text = (self.golden_dir / f"{stem}.json").read_text(encoding="utf-8")
        message = cls()
        message.ParseFromString(binary)
        return cls, binary, json_text, message

    def test_runtime_matches_the_code_generator(self):
        """python3-protobuf must be the release of Debian's protoc, grpcio that of gRPC."""
        import google.protobuf
        import grpc

        self.assertEqual(minor_of(google.protobuf.__version__), minor_of(ARGS.protoc_version),
                         f"python protobuf {google.protobuf.__version__} vs "
                         f"protoc {ARGS.protoc_version}")
        self.assertEqual(grpc.__version__.split(".")[:2], ARGS.grpc_version.split(".")[:2],
                         f"grpcio {grpc.__version__} vs gRPC {ARGS.grpc_version}")

    def test_binary_has_only_known_fields(self):
        for stem in GOLDENS:
            with self.subTest(golden=stem):
                _, binary, _, message = self.read_golden(stem)
                self.assertGreater(len(binary), 0)
                self.assertEqual(unknown_field_paths(message, GOLDENS[stem]), [])

    def test_binary_reserializes_to_the_same_bytes(self):
        for stem in GOLDENS:
            with self.subTest(golden=stem):
                _, binary, _, message = self.read_golden(stem)
                self.assertEqual(message.SerializeToString(deterministic=True), binary)

    def test_json_parses_to_the_binary_message(self):
        for stem in GOLDENS:
            with self.subTest(golden=stem):
                cls, binary, json_text, from_binary = self.read_golden(stem)
                from_json = self.json_format.Parse(json_text, cls(), ignore_unknown_fields=False)
                self.assertEqual(from_json, from_binary)
                self.assertEqual(from_json.SerializeToString(deterministic=True), binary)

    def test_printed_json_parses_back_to_the_same_message(self):
        for stem in GOLDENS:
            for preserve_names in (False, True):
                with self.subTest(golden=stem, preserving_proto_field_name=preserve_names):
                    cls, _, _, message = self.read_golden(stem)
                    text = self.json_format.MessageToJson(
                        message, preserving_proto_field_name=preserve_names)
                    self.assertEqual(self.json_format.Parse(text, cls()), message)

    def test_golden_values(self):
        _, _, _, request = self.read_golden("plan_jump_request")
        self.assertEqual(len(request.state.joint_positions_rad), 16)
        self.assertAlmostEqual(request.task.obstacle.height_m, 0.25)
        self.assertEqual(request.task.takeoff_mode, self.pb2.TAKEOFF_MODE_TWO_STEP)
        self.assertEqual(request.budget.seed, 11400714819323198485)
        _, _, _, response = self.read_golden("plan_jump_response")
        joints = response.plan.joints
        self.assertEqual(len(joints.positions_rad), joints.num_samples * 16)
        self.assertEqual(joints.joint_names[5], "RF_HFE")
        self.assertEqual(len(response.plan.force_phases), 2)
        self.assertEqual(response.verification.status, self.pb2.VERIFICATION_STATUS_PASSED)
        self.assertEqual(response.request_id, request.request_id)
        _, _, _, progress = self.read_golden("warm_cache_progress")
        self.assertEqual((progress.done, progress.total), (17, 41))

    def test_grpc_stub_exposes_every_rpc(self):
        import grpc

        self.assertTrue(hasattr(self.pb2_grpc, "JumpPlannerStub"))
        self.assertTrue(hasattr(self.pb2_grpc, "JumpPlannerServicer"))
        self.assertTrue(hasattr(self.pb2_grpc, "add_JumpPlannerServicer_to_server"))
        # Creating a channel does not connect; no server is needed.
        channel = grpc.insecure_channel("localhost:1")
        try:
            stub = self.pb2_grpc.JumpPlannerStub(channel)
            self.assertIsInstance(stub.PlanJump, grpc.UnaryUnaryMultiCallable)
            self.assertIsInstance(stub.GetStats, grpc.UnaryUnaryMultiCallable)
            self.assertIsInstance(stub.WarmCache, grpc.UnaryStreamMultiCallable)
        finally:
            channel.close()
        service = self.pb2.DESCRIPTOR.services_by_name["JumpPlanner"]
        self.assertEqual(service.full_name, "wheeljump.planner.v1.JumpPlanner")
        rpcs = {m.name: (m.input_type.name, m.output_type.name) for m in service.methods}
        self.assertEqual(rpcs, {
            "PlanJump": ("PlanJumpRequest", "PlanJumpResponse"),
            "GetStats": ("GetStatsRequest", "GetStatsResponse"),
            "WarmCache": ("WarmCacheRequest", "WarmCacheProgress"),
        })


def main():
    global ARGS
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--golden-dir", required=True, help="tests/contract/golden")
    parser.add_argument("--stubs-dir", required=True, help="folder of the generated stubs")
    parser.add_argument("--protoc-version", required=True, help="version of protoc, e.g. 3.21.12")
    parser.add_argument("--grpc-version", required=True, help="version of gRPC, e.g. 1.51.1")
    ARGS, rest = parser.parse_known_args()
    unittest.main(argv=[sys.argv[0]] + rest, verbosity=2)


if __name__ == "__main__":
    main()
