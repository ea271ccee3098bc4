#!/usr/bin/python3
"""A second, independent geld client in Python (Debian's python3-grpcio and python3-protobuf).

Submits a compression job, follows its WatchJob stream and fetches the curve with GetCurve:

    /usr/bin/python3 client/python/gel_client.py --stubs build/client/python \\
        --server 127.0.0.1:50051 --preset quick --seed 1

The stubs (gel/v1/*_pb2.py, service_pb2_grpc.py) are generated at build time into
BUILD/client/python by protoc with /usr/bin/grpc_python_plugin (client/CMakeLists.txt).
Exit status: 0 when the job succeeded, 1 on a gRPC error or a failed job, 2 on bad input.
"""
import argparse
import json
import os
import sys


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--server", default=os.environ.get("GELD_SERVER", "127.0.0.1:50051"))
    parser.add_argument("--token-file", default=os.environ.get("GELD_TOKEN_FILE", ""))
    parser.add_argument("--stubs", default=os.environ.get("GEL_PYTHON_STUBS", "build/client/python"),
                        help="directory holding the generated gel/v1/*_pb2.py")
    scene = parser.add_mutually_exclusive_group(required=True)
    scene.add_argument("--preset", help="scene preset, e.g. quick")
    scene.add_argument("--scene", help="scene JSON file (gel.v1.Scene)")
    parser.add_argument("--set", action="append", default=[], metavar="FIELD=VALUE",
                        help="override a scene field, e.g. compression.steps=3")
    parser.add_argument("--seed", type=int, action="append", default=[], help="seed (repeatable: ensemble)")
    parser.add_argument("--name", default="python-client")
    parser.add_argument("--json", action="store_true", help="print the curve as JSON")
    args = parser.parse_args()

    sys.path.insert(0, os.path.abspath(args.stubs))
    try:
        import grpc
        from gel.v1 import service_pb2, service_pb2_grpc
    except ImportError as error:
        print(f"gel_client: cannot import the stubs from {args.stubs}: {error}", file=sys.stderr)
        return 2

    if args.scene:
        with open(args.scene, encoding="utf-8") as f:
            scene_json = json.load(f)
    else:
        scene_json = {"preset": args.preset}
    for assignment in args.set:
        field, _, text = assignment.partition("=")
        try:
            value = json.loads(text)
        except ValueError:
            value = text
        node = scene_json
        *parents, leaf = field.split(".")
        for key in parents:
            node = node.setdefault(key, {})
        node[leaf] = value

    metadata = []
    if args.token_file:
        with open(args.token_file, encoding="utf-8") as f:
            metadata.append(("authorization", "Bearer " + f.readline().strip()))

    channel = grpc.insecure_channel(args.server)
    stub = service_pb2_grpc.GelServiceStub(channel)
    State = service_pb2.JobState
    Update = service_pb2.JobUpdate
    try:
        request = service_pb2.SubmitJobRequest(scene_json=json.dumps(scene_json), seeds=args.seed, name=args.name,
                                               labels={"client": "python"})
        job_id = stub.SubmitJob(request, metadata=metadata, timeout=30).job_id
        print(job_id, flush=True)

        state = State.JOB_STATE_UNSPECIFIED
        rows = 0
        for update in stub.WatchJob(service_pb2.WatchJobRequest(job_id=job_id), metadata=metadata):
            if update.kind in (Update.SNAPSHOT, Update.STATE):
                state = update.job.state
                print(f"{job_id}: {State.Name(state)}", flush=True)
            elif update.kind == Update.ROW:
                rows += 1
                r = update.row
                print(f"  seed {update.seed} k {r.k:2d}  phi {r.phi:.5f}  P {r.p:.5g}", flush=True)
            elif update.kind == Update.PROGRESS:
                p = update.progress
                print(f"  step {p.k}/{p.k_total}  phi {p.phi:.4f} -> {p.target_phi:.4f}  P {p.p:.4g}", flush=True)

        curve = stub.GetCurve(service_pb2.GetCurveRequest(job_id=job_id), metadata=metadata, timeout=30)
    except grpc.RpcError as error:
        print(f"gel_client: {error.code().name}: {error.details()}", file=sys.stderr)
        return 1

    if args.json:
        print(curve.json)
    elif curve.ensemble:
        print(f"{'k':>3} {'n':>2} {'phi':>10} {'P mean':>12} {'P std':>12}")
        for r in curve.ensemble:
            print(f"{r.k:3d} {r.n:2d} {r.phi.mean:10.5f} {r.p.mean:12.5g} {r.p.std:12.5g}")
    else:
        print(f"{'k':>3} {'phi':>10} {'P':>12} {'P_top':>12} {'P_bot':>12} {'z':>7}")
        for member in curve.members:
            for r in member.curve.rows:
                print(f"{r.k:3d} {r.phi:10.5f} {r.p:12.5g} {r.p_top:12.5g} {r.p_bot:12.5g} {r.contact_number:7.3f}")
    stored = sum(len(m.curve.rows) for m in curve.members)
    if stored != rows:
        print(f"gel_client: {rows} rows streamed but {stored} stored", file=sys.stderr)
        return 1
    return 0 if state == State.JOB_STATE_SUCCEEDED else 1


if __name__ == "__main__":
    sys.exit(main())
