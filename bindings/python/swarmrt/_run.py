"""The notebook API: `run`, `sweep`, `tune` and the `Run` they give back.

An in-process run calls `swarm run --in-process` itself through the native module (the GIL
released), so its run directory holds the CLI's bytes; a process run, a sweep and a tune run
the installed `swarm` binary. Records are read lazily, as pandas DataFrames.
"""

from __future__ import annotations

import json
import subprocess
import tempfile
import tomllib
from functools import cached_property
from pathlib import Path
from typing import Any, Iterable, Mapping, Optional

import pandas as pd

from . import _native
from ._bins import binary
from ._native import ConfigError, SwarmrtError


def _sets(set: Optional[Mapping[str, Any]]) -> list[str]:
    """`{"radio.loss": 0.2}` as the CLI's `--set radio.loss=0.2` words (TOML values)."""
    words = []
    for key, value in (set or {}).items():
        words += ["--set", f"{key}={_toml(value)}"]
    return words


def _toml(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float)):
        return repr(value)
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    if isinstance(value, Mapping):
        return "{" + ", ".join(f"{k} = {_toml(v)}" for k, v in value.items()) + "}"
    raise TypeError(f"cannot write {value!r} as a TOML value")


def _progress(total: Optional[int], desc: str, unit: str = "tick"):
    """A progress bar that draws in a notebook as in a terminal (tqdm.auto)."""
    from tqdm.auto import tqdm

    return tqdm(total=total, desc=desc, unit=unit, leave=False)


def _swarm(args: list[str], rows: Optional[Path] = None, total: Optional[int] = None) -> None:
    """Runs the `swarm` binary; its one-line error as ConfigError (exit 2) or SwarmrtError.
    With `rows`, a progress bar counts the lines the command has written to that CSV file.
    Ctrl-C stops the command as a Ctrl-C in its terminal would (SIGINT), then raises."""
    import signal

    with tempfile.TemporaryFile(mode="w+") as err:
        proc = subprocess.Popen([binary("swarm"), *args], stdout=subprocess.DEVNULL,
                                stderr=err, text=True)
        bar = _progress(total, args[0], unit="run") if rows is not None else None
        try:
            while True:
                try:
                    proc.wait(timeout=0.2)
                    break
                except subprocess.TimeoutExpired:
                    pass
                if bar is not None and rows.is_file():
                    done = max(0, len(rows.read_text().splitlines()) - 1)
                    bar.update(done - bar.n)
        except KeyboardInterrupt:
            proc.send_signal(signal.SIGINT)
            proc.wait()
            raise
        finally:
            if bar is not None:
                bar.close()
        err.seek(0)
        stderr = err.read()
    if proc.returncode == 0:
        return
    lines = [l for l in stderr.splitlines() if l.startswith("error: ")]
    line = lines[-1][len("error: "):] if lines else stderr.strip()
    if proc.returncode == 2:
        raise ConfigError(line)
    if proc.returncode == 130:
        raise KeyboardInterrupt(line)
    raise SwarmrtError(line or f"swarm {args[0]} exited with {proc.returncode}")


class Run:
    """A run directory and its records."""

    def __init__(self, dir: str | Path):
        self.dir = Path(dir)
        if not (self.dir / "config.toml").is_file():
            raise FileNotFoundError(f"{self.dir} holds no run (no config.toml)")

    def __repr__(self) -> str:
        return f"Run({str(self.dir)!r})"

    @cached_property
    def config(self) -> dict:
        """The resolved config the run used (`config.toml`)."""
        with open(self.dir / "config.toml", "rb") as f:
            return tomllib.load(f)

    @cached_property
    def metrics(self) -> dict:
        """`metrics.json`."""
        return json.loads((self.dir / "metrics.json").read_text())

    @cached_property
    def trajectory(self) -> pd.DataFrame:
        """`trajectory.csv`: one row per robot per tick."""
        return pd.read_csv(self.dir / "trajectory.csv")

    @cached_property
    def events(self) -> pd.DataFrame:
        """`events.jsonl`, one row per event (columns are the union of the events' keys)."""
        path = self.dir / "events.jsonl"
        rows = [json.loads(l) for l in path.read_text().splitlines() if l.strip()]
        return pd.DataFrame(rows)

    @cached_property
    def radio(self) -> Optional[pd.DataFrame]:
        """`radio.csv` (every frame's fate) when the run recorded it, else None."""
        path = self.dir / "radio.csv"
        return pd.read_csv(path) if path.is_file() else None

    def to_polars(self):
        """The trajectory as a polars DataFrame (polars must be installed)."""
        import polars as pl

        return pl.read_csv(self.dir / "trajectory.csv")

    def plot(self, ax=None):
        """The map, the goal and every robot's path, like `trajectory.png`; returns the axes."""
        import matplotlib.pyplot as plt
        from matplotlib.patches import Circle, Polygon, Rectangle

        if ax is None:
            _, ax = plt.subplots(figsize=(6, 6))
        m = self.config["map"]
        x0, y0, x1, y1 = m["bounds"]
        ax.add_patch(Rectangle((x0, y0), x1 - x0, y1 - y0, fill=False, lw=1.5, color="black"))
        for c in m.get("circles", []):
            ax.add_patch(Circle((c["x"], c["y"]), c["r"], color="0.6"))
        for r in m.get("rectangles", []):
            ax.add_patch(Rectangle((r["x_min"], r["y_min"]), r["x_max"] - r["x_min"],
                                   r["y_max"] - r["y_min"], color="0.6"))
        for p in m.get("polygons", []):
            ax.add_patch(Polygon(p["points"], color="0.6"))
        g = m["goal"]
        ax.add_patch(Circle((g["x"], g["y"]), g["radius"], color="tab:green", alpha=0.3))
        for robot, path in self.trajectory.groupby("id"):
            ax.plot(path["x"], path["y"], lw=1, label=f"robot {robot}")
            ax.plot(path["x"].iloc[-1], path["y"].iloc[-1], "o", ms=3, color="black")
        ax.set_xlim(x0, x1)
        ax.set_ylim(y0, y1)
        ax.set_aspect("equal")
        ax.set_title(f"{self.config['scenario']['name']} (seed {self.config['scenario']['seed']})")
        return ax

    def view(self, port: int = 0) -> str:
        """Starts `swarm view` on this run in the background; returns the page's URL. The
        page is served until `stop_view()` or the end of this Python process."""
        import atexit

        self.stop_view()
        proc = subprocess.Popen([binary("swarm"), "view", str(self.dir), "--port", str(port)],
                                stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
        line = proc.stdout.readline()
        if "http://" not in line:
            raise SwarmrtError(f"swarm view exited with {proc.wait()}")
        self._viewer = proc
        atexit.register(self.stop_view)
        return line.strip()

    def stop_view(self) -> None:
        """Stops the page `view()` started, if any."""
        proc = getattr(self, "_viewer", None)
        if proc is not None and proc.poll() is None:
            proc.terminate()
            proc.wait()
        self._viewer = None

    def export_mcap(self, path: str | Path) -> Path:
        """Writes the run as an MCAP file (Foxglove) at `path`."""
        _swarm(["export", str(self.dir), "--mcap", str(path)])
        return Path(path)


def run(config: str | Path, seed: Optional[int] = None, set: Optional[Mapping[str, Any]] = None,
        ticks: Optional[int] = None, in_process: bool = True, out: Optional[str | Path] = None,
        progress: bool = True) -> Run:
    """Runs `config` (with `set` overrides) and returns the `Run`. In-process, the cores run
    in this process and write the bytes `swarm run --in-process` writes; otherwise a world
    and one process per robot. Without `out`, the run goes to a new temporary directory."""
    if out is None:
        out = tempfile.mkdtemp(prefix="swarmrt-run-")
    args = ["run", str(config), "--out", str(out), *_sets(set)]
    if seed is not None:
        args += ["--seed", str(seed)]
    if ticks is not None:
        args += ["--ticks", str(ticks)]
    if not in_process:
        _swarm(args)
        return Run(out)
    words = [w for i, w in enumerate(args) if i and args[i - 1] == "--set"]
    if seed is not None:
        words.append(f"scenario.seed={seed}")
    if ticks is not None:
        words.append(f"scenario.ticks={ticks}")
    name, _, total, _ = _native.check_config(str(config), words)
    bar = _progress(total, name) if progress else None
    try:
        def tick(done: int) -> None:
            if bar is not None:
                bar.update(done - bar.n)

        return Run(_native.run([*args, "--in-process"], tick))
    finally:
        if bar is not None:
            bar.close()


def _list(values: Iterable[Any]) -> str:
    return ",".join(_toml(v) for v in values)


def sweep(config: str | Path, vary: Mapping[str, Iterable[Any]], seeds: int = 1,
          jobs: Optional[int] = None, in_process: bool = True,
          set: Optional[Mapping[str, Any]] = None, out: Optional[str | Path] = None) -> pd.DataFrame:
    """`swarm sweep`: every combination of `vary` for `seeds` seeds; the rows of `sweep.csv`
    (one per run) as a DataFrame, its directory in `.attrs["dir"]`."""
    if out is None:
        out = Path(tempfile.mkdtemp(prefix="swarmrt-sweep-")) / "sweep"
    args = ["sweep", str(config), "--seeds", str(seeds), "--out", str(out), *_sets(set)]
    for key, values in vary.items():
        args += ["--vary", f"{key}={_list(values)}"]
    if jobs is not None:
        args += ["--jobs", str(jobs)]
    if in_process:
        args.append("--in-process")
    runs = seeds
    for values in vary.values():
        runs *= len(list(values))
    _swarm(args, rows=Path(out) / "sweep.csv", total=runs)
    table = pd.read_csv(Path(out) / "sweep.csv")
    table.attrs["dir"] = str(out)
    return table


def tune(config: str | Path, params: Mapping[str, tuple[float, float]], fitness: str,
         maximize: bool = False, particles: int = 7, iterations: int = 25, seed: int = 1,
         seeds: int = 1, jobs: Optional[int] = None, in_process: bool = True,
         set: Optional[Mapping[str, Any]] = None, out: Optional[str | Path] = None) -> dict:
    """`swarm tune` (NR-PSO over `params`, each `(lo, hi)`): `{"table": tune.csv (every
    evaluation) as a DataFrame, "best": tune.json's summary, "best_toml": best.toml's
    overrides, "dir": its directory}`."""
    if out is None:
        out = Path(tempfile.mkdtemp(prefix="swarmrt-tune-")) / "tune"
    args = ["tune", str(config), "--fitness", fitness, "--particles", str(particles),
            "--iterations", str(iterations), "--seed", str(seed), "--seeds", str(seeds),
            "--out", str(out), *_sets(set)]
    for key, (lo, hi) in params.items():
        args += ["--param", f"{key}={lo}:{hi}"]
    if maximize:
        args.append("--maximize")
    if jobs is not None:
        args += ["--jobs", str(jobs)]
    if in_process:
        args.append("--in-process")
    # tune.csv gains a row per evaluation: 2P an iteration by default (`swarm tune --help`).
    _swarm(args, rows=Path(out) / "tune.csv", total=2 * particles * iterations)
    out = Path(out)
    with open(out / "best.toml", "rb") as f:
        best_toml = tomllib.load(f)
    return {
        "table": pd.read_csv(out / "tune.csv"),
        "best": json.loads((out / "tune.json").read_text()),
        "best_toml": best_toml,
        "dir": str(out),
    }
