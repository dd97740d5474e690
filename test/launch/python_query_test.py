"""The Python binding (module fuse_slam) against a running system: fuse-map, fuse-state and
fuse-update started here, fuse-ingest replaying a simulated recording. Checks that the binding
streams estimates while the replay runs and that, after it, it answers the same pose as
`fuse-query --json` for the same time, in sensor time and in host time, and that a time outside
the history is an error.

    python3 python_query_test.py BIN_DIR CONFIG RECORDING_DIR OUT_DIR DOMAIN
(PYTHONPATH must hold the fuse_slam module.)"""
import json
import math
import os
import shutil
import signal
import subprocess
import sys
import threading
import time

import fuse_slam

BIN, CONFIG, DATA, OUT, DOMAIN = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4], int(sys.argv[5])
REPLAY_TIMEOUT_S = 240  # a 6 s lockstep replay takes a few seconds; generous for a loaded machine
failures = []


def check(condition, what):
    print(("ok: " if condition else "FAILED: ") + what, flush=True)
    if not condition:
        failures.append(what)


def start(service, *extra):
    argv = [os.path.join(BIN, service), "--config", CONFIG, "--domain", str(DOMAIN),
            "--set", "ingest.lockstep_timeout_s=1.5", "--set", "update.map_sync_timeout_s=3", *extra]
    log = open(os.path.join(OUT, service + ".log"), "w")
    return subprocess.Popen(argv, stdout=log, stderr=subprocess.STDOUT)


shutil.rmtree(OUT, ignore_errors=True)
os.makedirs(OUT)
recording = os.path.join(DATA, "recording.mcap")
services = [start("fuse-map", "--map-dir", os.path.join(OUT, "map")),
            start("fuse-state", "--calibration-from", recording),
            start("fuse-update")]
try:
    client = fuse_slam.Client(fuse_slam.ClientOptions(domain_id=DOMAIN, deadline_ms=5000))
    check(client.wait_for_server(60000), "the query server is found")
    streamed = []
    lock = threading.Lock()

    def on_estimate(result):
        with lock:
            streamed.append(result)

    client.subscribe(on_estimate)
    ingest = start("fuse-ingest", "--input", recording, "--mode", "lockstep")
    code = ingest.wait(timeout=REPLAY_TIMEOUT_S)
    check(code == 0, f"fuse-ingest replayed the recording (exit {code})")
    # The last odometry samples may still be in flight: wait for the stream to go quiet.
    deadline = time.monotonic() + 30
    while time.monotonic() < deadline:
        with lock:
            n = len(streamed)
        time.sleep(0.5)
        with lock:
            if len(streamed) == n and n > 0:
                break
    client.subscribe(None)
    with lock:
        ok_stream = [r for r in streamed if r.ok()]
        n_stream = len(streamed)
    check(len(ok_stream) > 100, f"streamed estimates: {n_stream}, {len(ok_stream)} to steer by")
    newest = client.newest()
    check(newest.ok(), f"newest() of the stream: {newest}")

    latest = client.latest()
    check(latest.ok(), f"latest(): {latest} {latest.message}")
    t = latest.estimate.t - 1.0
    r = client.at(t)
    check(r.ok(), f"at({t:.6f}): {r} {r.message}")
    e = r.estimate
    check(e.frame_id == "world" and e.child_frame_id == "imu", f"frames {e.frame_id} <- {e.child_frame_id}")
    check(abs(math.hypot(*e.orientation_xyzw) - 1.0) < 1e-9, "unit quaternion")
    check(all(math.isfinite(w) for w in e.angular_velocity), f"angular velocity {e.angular_velocity}")

    cli = subprocess.run([os.path.join(BIN, "fuse-query"), "--domain", str(DOMAIN), "--json", "--time", repr(t),
                          "--deadline-ms", "5000"], capture_output=True, text=True, timeout=60)
    check(cli.returncode == 0, f"fuse-query --json --time {t!r}: exit {cli.returncode} {cli.stderr.strip()}")
    if cli.returncode == 0:
        j = json.loads(cli.stdout)
        check(j["t"] == e.t and j["status"] == e.status.name, "fuse-query answers the same time and status")
        check(j["position"] == list(e.position) and j["orientation_xyzw"] == list(e.orientation_xyzw),
              f"fuse-query answers the same pose: {j['position']} vs {list(e.position)}")
        check(j["angular_velocity"] == list(e.angular_velocity), "and the same angular velocity")

    hc = e.host_clock
    check(hc.known, f"the host clock mapping is known: realtime offset {hc.realtime_offset:.6f} s")
    if hc.known:
        for clock, offset in ((fuse_slam.Clock.host_realtime, hc.realtime_offset),
                              (fuse_slam.Clock.host_monotonic, hc.monotonic_offset)):
            h = client.at(t + offset, clock)
            # The realtime mapping re-reads CLOCK_REALTIME − CLOCK_MONOTONIC for each call: equal to
            # well under a millisecond unless the host's clock is being stepped.
            check(h.ok() and abs(h.estimate.t - t) < 1e-3, f"at(t on {clock.name}) is t: {h.estimate.t - t:+.2e} s")

    for bad in (t - 10.0, latest.estimate.t + 10.0):
        o = client.at(bad)
        check(o.error == fuse_slam.Error.out_of_range, f"at({bad:.3f}) is out_of_range: {o.message}")
finally:
    for p in reversed(services):
        p.send_signal(signal.SIGTERM)
    for p in reversed(services):
        try:
            p.wait(timeout=20)
        except subprocess.TimeoutExpired:
            p.kill()
if failures:
    for service in ("fuse-map", "fuse-state", "fuse-update", "fuse-ingest"):
        path = os.path.join(OUT, service + ".log")
        if os.path.exists(path):
            print(f"---- {service}\n" + "".join(open(path).readlines()[-15:]))
    sys.exit(1)
print("the Python binding answers as fuse-query does")
