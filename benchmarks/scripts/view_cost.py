#!/usr/bin/env python3
"""What a live view costs a run: the same `swarm run` alternated without and with `--view`.

    python3 benchmarks/scripts/view_cost.py [--robots 100] [--ticks 600] [--rounds 5]
                                            [--bin target/release] [--browser]

Each round runs goto_simple with N robot processes in alternation (this kind of shared VM
drifts by a third between minutes): plain; with `--view` and nobody watching (the server
alone); with `--view` and a client that follows
the run as the page does (server-sent status, then the newest frames chunk and the new
markers at each update); and, with `--browser`, with `--view` and the real page in headless
chromium. The world's own loop time per tick (`shell.timing.seconds / ticks` in
metrics.json: observe + publish + wait + step + record) is compared, as the median over rounds
of each round's ratio. Prints a table; numbers for docs/benchmarks.md.
"""
import argparse
import http.client
import json
import os
import shutil
import signal
import statistics
import subprocess
import sys
import tempfile
import threading
import time
import urllib.request

CHROMIUM_FLAGS = [
    "--headless=new", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
    "--disable-background-networking", "--disable-component-update", "--disable-sync",
    "--window-size=1400,900",
]


def follow(url, stop):
    """Follows the run as the page does, until `stop` is set or the run is over: one stream of
    status events, and one kept-alive connection for the data, as a browser keeps one."""
    try:
        live = urllib.request.urlopen(url + "api/live", timeout=30)
    except OSError:
        return
    host = url[len("http://"):].rstrip("/")
    data = http.client.HTTPConnection(host, timeout=30)

    def get(path):
        data.request("GET", path)
        return data.getresponse().read()

    markers = 0
    have = 0
    for raw in live:
        if stop.is_set():
            break
        line = raw.decode().strip()
        if not line.startswith("data:"):
            continue
        status = json.loads(line[5:])
        frames = status["frames"]
        if frames > have:
            # as the page does when it follows: only the frames that are new
            get(f"/api/frames?from={have}&to={frames}")
            have = frames
        if status["markers"] > markers:
            get(f"/api/markers?from={markers}")
            markers = status["markers"]
        if status["state"] != "live":
            break


def run(binary, robots, ticks, mode, tmp):
    out = os.path.join(tmp, f"{mode}-{time.monotonic_ns()}")
    args = [os.path.join(binary, "swarm"), "run", "configs/goto_simple.toml", "--out", out,
            "--ticks", str(ticks), "--set", f"robots.count={robots}",
            "--set", "scenario.stop_when_done=false"]
    if mode != "plain":
        args.append("--view")
    proc = subprocess.Popen(args, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    stop = threading.Event()
    helpers = []
    if mode != "plain":
        url = None
        for line in proc.stderr:
            if "http://" in line:
                url = line[line.index("http://"):].split()[0]
                break
        if mode == "server":
            pass
        elif mode == "client":
            t = threading.Thread(target=follow, args=(url, stop), daemon=True)
            t.start()
        else:
            profile = tempfile.mkdtemp(prefix="view-cost-chromium-")
            helpers.append(subprocess.Popen(
                ["chromium", *CHROMIUM_FLAGS, f"--user-data-dir={profile}",
                 "--remote-debugging-port=0", url],
                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        while not os.path.exists(os.path.join(out, "metrics.json")):
            time.sleep(0.05)
        time.sleep(0.2)
        stop.set()
        for h in helpers:
            h.kill()
            h.wait()
        proc.send_signal(signal.SIGINT)
    proc.wait()
    with open(os.path.join(out, "metrics.json")) as f:
        m = json.load(f)
    shutil.rmtree(out, ignore_errors=True)
    timing = m["shell"]["timing"]
    return 1e3 * timing["seconds"] / max(1, timing["ticks"]), timing["tick_ms_median"]


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--robots", type=int, default=100)
    p.add_argument("--ticks", type=int, default=600)
    p.add_argument("--rounds", type=int, default=5)
    p.add_argument("--bin", default="target/release")
    p.add_argument("--browser", action="store_true")
    a = p.parse_args()
    modes = ["plain", "server", "client"] + (["browser"] if a.browser else [])
    rows = {m: [] for m in modes}
    with tempfile.TemporaryDirectory() as tmp:
        for r in range(a.rounds):
            for m in modes:
                rows[m].append(run(a.bin, a.robots, a.ticks, m, tmp))
                print(f"round {r}: {m:8} {rows[m][-1][0]:.3f} ms/tick (median tick "
                      f"{rows[m][-1][1]:.3f} ms)", file=sys.stderr)
    print(f"| mode | world ms/tick (median of {a.rounds}) | median tick ms | ratio to plain (median of per-round ratios) |")
    print("|---|---|---|---|")
    for m in modes:
        ratios = [x[0] / p[0] for x, p in zip(rows[m], rows["plain"])]
        print(f"| {m} | {statistics.median(x[0] for x in rows[m]):.3f} | "
              f"{statistics.median(x[1] for x in rows[m]):.3f} | "
              f"{statistics.median(ratios):.3f} (min {min(ratios):.3f}, max {max(ratios):.3f}) |")


if __name__ == "__main__":
    main()
