#!/usr/bin/env python3
"""Soak test of geld: clients submitting, watching, cancelling and listing while the daemon is
SIGKILLed and restarted at random moments; then every promise is checked.

    soak.py --build BUILD_DIR [--seconds 60] [--clients 6] [--seed 1]     # CI runs the short form
    soak.py --build build --seconds 600 --clients 16                       # the long form

One more client is hostile but valid: it submits the largest scenes the daemon's memory budget
(--max-memory, advertised as --max-rss-mb) admits, jobs of many members, and absurd values that
the bounds must refuse, and cancels its large jobs again so that the soak can end.

Checks after the storm (geld restarted one last time and left to finish every job):
  * every job whose SubmitJob was acknowledged is listed exactly once, and nothing else is;
  * every job ended, and ended exactly once (one terminal state in the store's history);
  * succeeded jobs have all their rows, no (member, k) stored twice, for every member;
  * PRAGMA integrity_check of the store is ok;
  * geld's peak resident memory stayed under --max-rss-mb, the budget it was started with;
  * every absurd submission was refused with INVALID_ARGUMENT, none accepted.
Loopback only; every loop is bounded by the deadline. Uses Debian's python3-grpcio and the
project's generated stubs (BUILD_DIR/client/python). Exit status 0 only when every check holds.
"""
import argparse
import atexit
import os
import random
import signal
import socket
import sqlite3
import subprocess
import sys
import tempfile
import threading
import time


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Daemon:
    """geld on a fixed loopback port and data dir, killed and restarted at will."""

    def __init__(self, geld, data_dir, port, memory_budget_bytes):
        self.geld, self.data_dir, self.port = geld, data_dir, port
        self.options = ["--workers", "2", "--log-level", "warn", "--max-memory", str(memory_budget_bytes)]
        self.process = None
        self.kills = 0
        self.peak_rss_kb = 0
        self.log = open(os.path.join(data_dir, "..", "geld.log"), "ab")

    def start(self, deadline=30.0):
        self.process = subprocess.Popen([self.geld, "--listen", f"127.0.0.1:{self.port}", "--data-dir", self.data_dir]
                                        + self.options, stdout=self.log, stderr=self.log)
        end = time.time() + deadline
        while time.time() < end:
            if self.process.poll() is not None:
                # The port of the killed daemon may linger a moment: try again.
                time.sleep(0.2)
                self.process = subprocess.Popen([self.geld, "--listen", f"127.0.0.1:{self.port}", "--data-dir",
                                                 self.data_dir] + self.options, stdout=self.log, stderr=self.log)
                continue
            try:
                with socket.create_connection(("127.0.0.1", self.port), timeout=0.2):
                    return
            except OSError:
                time.sleep(0.05)
        raise RuntimeError("geld did not come up")

    def sample_rss(self):
        try:
            with open(f"/proc/{self.process.pid}/status") as f:
                for line in f:
                    if line.startswith("VmHWM:"):
                        self.peak_rss_kb = max(self.peak_rss_kb, int(line.split()[1]))
        except OSError:
            pass

    def kill(self):
        self.sample_rss()
        self.process.send_signal(signal.SIGKILL)
        self.process.wait()
        self.kills += 1

    def stop(self):
        if self.process and self.process.poll() is None:
            self.sample_rss()
            self.process.send_signal(signal.SIGTERM)
            try:
                self.process.wait(timeout=30)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--build", required=True)
    parser.add_argument("--seconds", type=float, default=60)
    parser.add_argument("--clients", type=int, default=6)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--max-rss-mb", type=float, default=400)
    parser.add_argument("--max-jobs", type=int, default=150,
                        help="submissions stop at this many acknowledged jobs (all must finish afterwards)")
    args = parser.parse_args()
    sys.path.insert(0, os.path.join(args.build, "client", "python"))
    import grpc
    from gel.v1 import scene_pb2, service_pb2, service_pb2_grpc

    work = tempfile.mkdtemp(prefix="geld-soak.")
    data_dir = os.path.join(work, "data")
    os.makedirs(data_dir)
    # The budget geld advertises (--max-memory) is the bound its peak resident memory is held to.
    daemon = Daemon(os.path.join(args.build, "server", "geld"), data_dir, free_port(), int(args.max_rss_mb * 2**20))
    # Whatever goes wrong below (an assertion, a gRPC error), no geld is left running.
    atexit.register(lambda: daemon.process is not None and daemon.process.poll() is None and daemon.process.kill())
    daemon.start()
    channel = grpc.insecure_channel(f"127.0.0.1:{daemon.port}")
    stub = service_pb2_grpc.GelServiceStub(channel)
    rng = random.Random(args.seed)
    lock = threading.Lock()
    acknowledged = {}  # job id -> number of seeds
    counts = {"submits": 0, "cancels": 0, "watches": 0, "lists": 0, "errors": 0}
    hostile_counts = {"large admitted": 0, "over budget": 0, "absurd refused": 0, "absurd accepted": 0, "errors": 0}
    hostile_jobs = []
    deadline = time.time() + args.seconds

    def tiny_scene(seed):
        scene = scene_pb2.Scene()
        scene.preset = "quick"
        scene.compression.fidelity = "fast"
        scene.compression.steps = 2
        scene.generator.n_floc = 8
        scene.generator.n_clusters = 8
        scene.generator.lx = 30
        scene.generator.ly = 50
        scene.generator.seed = seed
        return scene

    def client(number):
        local = random.Random(args.seed * 1000 + number)
        while time.time() < deadline:
            action = local.random()
            try:
                with lock:
                    room = len(acknowledged) < args.max_jobs
                if action < 0.45 and room:
                    seeds = [local.randint(1, 50) for _ in range(local.choice([1, 1, 2]))]
                    reply = stub.SubmitJob(service_pb2.SubmitJobRequest(scene=tiny_scene(seeds[0]), seeds=seeds,
                                                                        name=f"soak-{number}"), timeout=10)
                    with lock:
                        acknowledged[reply.job_id] = len(seeds)
                        counts["submits"] += 1
                elif action < 0.60:
                    with lock:
                        ids = list(acknowledged)
                    if ids:
                        try:
                            stub.CancelJob(service_pb2.CancelJobRequest(job_id=local.choice(ids)), timeout=25)
                            with lock:
                                counts["cancels"] += 1
                        except grpc.RpcError as error:
                            if error.code() != grpc.StatusCode.FAILED_PRECONDITION:  # already ended: fine
                                raise
                elif action < 0.80:
                    with lock:
                        ids = list(acknowledged)
                    if ids:
                        stream = stub.WatchJob(service_pb2.WatchJobRequest(job_id=local.choice(ids)), timeout=3)
                        try:
                            for _, _update in zip(range(local.randint(1, 20)), stream):
                                pass
                        except grpc.RpcError as error:
                            if error.code() != grpc.StatusCode.DEADLINE_EXCEEDED:
                                raise
                        stream.cancel()
                        with lock:
                            counts["watches"] += 1
                else:
                    stub.ListJobs(service_pb2.ListJobsRequest(page_size=20), timeout=10)
                    with lock:
                        counts["lists"] += 1
            except grpc.RpcError:
                # The daemon is down (killed) or busy: expected in a storm; the checks come later.
                with lock:
                    counts["errors"] += 1
                time.sleep(0.05)

    def hostile():
        """The largest scenes the budget admits, many members, absurd values; in a fixed cycle."""
        def large(preset, members):
            return service_pb2.SubmitJobRequest(scene=scene_pb2.Scene(preset=preset), seeds=range(1, members + 1),
                                                name="hostile", rerun=True)

        def absurd(change):
            scene = tiny_scene(1)
            change(scene)
            return service_pb2.SubmitJobRequest(scene=scene, name="hostile-absurd")

        def skin(scene):
            scene.integration.skin = 1e300

        def walk(scene):
            scene.generator.walk_step = 1e-300

        def checkpoint(scene):
            scene.compression.checkpoint_seconds = 1e-300

        def name(scene):
            scene.name = "n" * 3_000_000
        cycle = [large("paper-bond1-16x", 2), large("paper-bond1-16x", 2), large("paper-bond1-4x", 100),
                 absurd(skin), absurd(walk), absurd(checkpoint), absurd(name), None]
        step = 0
        while time.time() < deadline:
            request = cycle[step % len(cycle)]
            step += 1
            try:
                if request is None:  # cancel the large jobs so far, as a user would
                    with lock:
                        ids = list(hostile_jobs)
                    for job_id in ids:
                        try:
                            stub.CancelJob(service_pb2.CancelJobRequest(job_id=job_id), timeout=25)
                        except grpc.RpcError as error:
                            if error.code() != grpc.StatusCode.FAILED_PRECONDITION:
                                raise
                else:
                    reply = stub.SubmitJob(request, timeout=30)
                    with lock:
                        if request.name == "hostile":
                            acknowledged[reply.job_id] = len(request.seeds)
                            hostile_jobs.append(reply.job_id)
                            hostile_counts["large admitted"] += 1
                        else:
                            acknowledged[reply.job_id] = 1
                            hostile_counts["absurd accepted"] += 1
            except grpc.RpcError as error:
                with lock:
                    if error.code() == grpc.StatusCode.RESOURCE_EXHAUSTED:
                        hostile_counts["over budget"] += 1
                    elif error.code() == grpc.StatusCode.INVALID_ARGUMENT and request.name == "hostile-absurd":
                        hostile_counts["absurd refused"] += 1
                    else:
                        hostile_counts["errors"] += 1
            time.sleep(0.5)

    threads = [threading.Thread(target=client, args=(n,), daemon=True) for n in range(args.clients)]
    threads.append(threading.Thread(target=hostile, daemon=True))
    for thread in threads:
        thread.start()
    while time.time() < deadline:
        time.sleep(rng.uniform(1.0, 5.0))
        if time.time() >= deadline:
            break
        daemon.kill()
        daemon.start()
    for thread in threads:
        thread.join(timeout=60)
    storm_counts = dict(counts)

    # Let every job end (a daemon restarted from the last kill goes on with what was queued).
    daemon.kill()
    daemon.start()
    # A fresh channel: the old one may still hold a socket to the killed daemon.
    channel.close()
    stub = service_pb2_grpc.GelServiceStub(grpc.insecure_channel(f"127.0.0.1:{daemon.port}"))

    def settled(call, request):
        """One call of the checking phase, retried while the restarted daemon is not yet there."""
        for attempt in range(40):
            try:
                return call(request, timeout=30, wait_for_ready=True)
            except grpc.RpcError as error:
                if error.code() != grpc.StatusCode.UNAVAILABLE or attempt == 39:
                    raise
                time.sleep(0.25)
    failures = []
    # The large jobs run for hours: cancelled now (a cancel sent before a kill may have been lost).
    for job_id in hostile_jobs:
        try:
            settled(stub.CancelJob, service_pb2.CancelJobRequest(job_id=job_id))
        except grpc.RpcError as error:
            if error.code() != grpc.StatusCode.FAILED_PRECONDITION:
                raise
    # Sanitized builds (GEL_SANITIZED=1 under ctest) run every job several times slower.
    slowdown = 4.0 if os.environ.get("GEL_SANITIZED") == "1" else 1.0
    finish_by = time.time() + slowdown * max(300.0, 2 * args.seconds)
    listed = {}
    while time.time() < finish_by:
        listed, token = {}, ""
        while True:
            reply = settled(stub.ListJobs, service_pb2.ListJobsRequest(page_size=1000, page_token=token))
            for job in reply.jobs:
                listed.setdefault(job.id, []).append(job)
            token = reply.next_page_token
            if not token:
                break
        open_jobs = [i for i, jobs in listed.items()
                     if jobs[0].state in (service_pb2.JOB_STATE_QUEUED, service_pb2.JOB_STATE_RUNNING)]
        if not open_jobs:
            break
        time.sleep(1.0)
    else:
        failures.append(f"{len(open_jobs)} jobs still open after the storm: {open_jobs[:5]}")
    daemon.sample_rss()

    for job_id in acknowledged:
        if len(listed.get(job_id, [])) != 1:
            failures.append(f"acknowledged {job_id} listed {len(listed.get(job_id, []))} times")
    for job_id in listed:
        if job_id not in acknowledged:
            # A submit whose reply was lost to a kill may exist without an acknowledgement: it
            # must then be a complete job of its own, which the checks below cover; count them.
            pass
    succeeded = [i for i, jobs in listed.items() if jobs[0].state == service_pb2.JOB_STATE_SUCCEEDED]
    for job_id in succeeded:
        curve = settled(stub.GetCurve, service_pb2.GetCurveRequest(job_id=job_id))
        seeds = len(listed[job_id][0].seeds)
        if len(curve.members) != seeds:
            failures.append(f"{job_id}: {len(curve.members)} member curves for {seeds} seeds")
        for member in curve.members:
            ks = [row.k for row in member.curve.rows]
            if ks != list(range(3)):
                failures.append(f"{job_id} member {member.member}: rows k = {ks}, expected [0, 1, 2]")
    daemon.stop()

    store = sqlite3.connect(os.path.join(data_dir, "geld.sqlite"))
    integrity = store.execute("PRAGMA integrity_check").fetchall()
    if integrity != [("ok",)]:
        failures.append(f"integrity_check: {integrity[:3]}")
    twice = store.execute("SELECT job_id, COUNT(*) FROM states WHERE state IN ('succeeded', 'failed', 'cancelled') "
                          "GROUP BY job_id HAVING COUNT(*) > 1").fetchall()
    if twice:
        failures.append(f"jobs that ended more than once: {twice[:5]}")
    duplicates = store.execute("SELECT job_id, member, k, COUNT(*) FROM curve_rows GROUP BY job_id, member, k "
                               "HAVING COUNT(*) > 1").fetchall()
    if duplicates:
        failures.append(f"rows stored twice: {duplicates[:5]}")
    states = dict(store.execute("SELECT state, COUNT(*) FROM jobs GROUP BY state").fetchall())
    peak_mb = daemon.peak_rss_kb / 1024
    if peak_mb > args.max_rss_mb:
        failures.append(f"geld peak resident memory {peak_mb:.0f} MB > {args.max_rss_mb:.0f} MB, the budget it advertised")
    if hostile_counts["absurd accepted"]:
        failures.append(f"{hostile_counts['absurd accepted']} absurd submissions were accepted")
    if hostile_counts["large admitted"] == 0:
        failures.append("no large job was admitted: the hostile client tested nothing")

    unacknowledged = len(set(listed) - set(acknowledged))
    print(f"soak: {args.seconds:.0f} s, {args.clients} clients, {daemon.kills} SIGKILLs; {storm_counts}; "
          f"{len(acknowledged)} acknowledged jobs (+{unacknowledged} whose reply a kill lost); final states {states}; "
          f"peak RSS {peak_mb:.0f} MB of a {args.max_rss_mb:.0f} MB budget; hostile client {hostile_counts}")
    for failure in failures:
        print("FAIL:", failure)
    if not failures:
        import shutil
        shutil.rmtree(work, ignore_errors=True)
    else:
        print("kept for inspection:", work)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
