#!/usr/bin/env python3
"""Seed 004's NR-PSO over five tunes per world (Fig. 9-10 of the paper, issue 35 part 2).

Reads `tunes/<world>_s<seed>.csv` (written by `tune.sh`, every evaluation of one tune) and
writes, next to this script:

- `tunes_<world>.svg`: the best parameters so far per iteration, normalised to their bounds,
  one panel per parameter, one line per tune (the paper's Fig. 9-10, five times over), and the
  best personal best's mean fitness;
- `tunes.md`: the spread of the final best weights and fitness over the tunes, when each tune's
  best last changed, how many evaluations the best had behind it, and the noise of a single
  evaluation measured from the re-evaluations of one position.

The personal bests are rebuilt from the CSV with the rule of `orchestrator/src/tune/pso.rs`
(a new position replaces its particle's personal best when its one evaluation beats the
best's mean; re-evaluations add to that mean); the script checks the rebuilt final best
against the tune's own `best.toml` numbers in the CSV's last iteration.

Standard library only: `python3 docs/results/seed004/tunes.py`.
"""

import csv
import json
import math
import statistics
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
WORLDS = {"normal": "environment 4", "calibrated": "environment 4, calibrated"}
# The bounds of tune.sh's --param flags, in the CSV's column order.
BOUNDS = {
    "behaviour.alpha": (0.0, 2.0),
    "behaviour.beta": (1.0, 200.0),
    "behaviour.delta": (1.0, 30.0),
    "behaviour.iota": (-1.0, 1.0),
    "behaviour.zeta": (-1.0, 1.0),
    "behaviour.kappa": (0.0, 1.0),
    "behaviour.mb": (0.0, 1.0),
}
NAMES = {
    "behaviour.alpha": "α",
    "behaviour.beta": "β",
    "behaviour.delta": "δ",
    "behaviour.iota": "ι",
    "behaviour.zeta": "ζ",
    "behaviour.kappa": "κ",
    "behaviour.mb": "M_b",
}
PARTICLES = 7
# A best that moves less than this (in bound widths, every parameter) counts as settled.
SETTLE_TOL = 0.05
# A personal best "confirmed" by at least this many evaluations (its first and two
# re-evaluations): the counterfactual best that only trusts averaged fitness.
CONFIRMED = 3


def load(path):
    """Rows of one tune's CSV, as dicts with floats where numeric."""
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    for r in rows:
        for k in ("eval", "iteration", "particle"):
            r[k] = int(r[k])
        r["fitness"] = float(r["fitness"]) if r["status"] == "ok" else -math.inf
        r["x"] = tuple(float(r[p]) for p in BOUNDS)
    return rows


def replay(rows):
    """Per iteration: (best particle, its position, its mean fitness, its evaluation count) and
    every particle's personal best (position, sum, count), after that iteration's tell.
    Fitness is maximised here, so the rule of pso.rs is mirrored (beat = greater)."""
    iterations = max(r["iteration"] for r in rows) + 1
    pbest = [None] * PARTICLES
    out = []
    for it in range(iterations):
        batch = [r for r in rows if r["iteration"] == it]
        for i in range(PARTICLES):
            mine = [r for r in batch if r["particle"] == i]
            new = [r for r in mine if r["kind"] == "new"][0]
            again = [r["fitness"] for r in mine if r["kind"] == "reeval"]
            if pbest[i] is None:
                pbest[i] = [new["x"], new["fitness"] + sum(again), 1 + len(again)]
            else:
                pbest[i][1] += sum(again)
                pbest[i][2] += len(again)
                if new["fitness"] > pbest[i][1] / pbest[i][2]:
                    pbest[i] = [new["x"], new["fitness"], 1]
        means = [b[1] / b[2] for b in pbest]
        best = max(range(PARTICLES), key=lambda i: (means[i], -i))
        out.append((best, pbest[best][0], means[best], pbest[best][2], [list(b) for b in pbest]))
    return out


def confirmed(history):
    """The same tune read with a best that must have CONFIRMED evaluations behind it: per
    iteration, (position, mean) of the highest-mean such personal best, or of the previous
    iteration's when none has (a position, once confirmed, is remembered even if its
    particle moves on)."""
    out, known = [], {}
    for _, _, _, _, pbest in history:
        for x, total, count in pbest:
            if count >= CONFIRMED:
                known[x] = total / count
        if known:
            x = max(known, key=lambda k: known[k])
            out.append((x, known[x]))
        else:
            out.append(out[-1] if out else (history[0][1], history[0][2]))
    return out


def norm(x):
    return [(v - lo) / (hi - lo) for v, (lo, hi) in zip(x, BOUNDS.values())]


def settled_from(positions):
    """The first iteration from which the best position stays within SETTLE_TOL of the final
    one in every normalised parameter."""
    final = norm(positions[-1])
    first = len(positions) - 1
    for it in range(len(positions) - 1, -1, -1):
        if max(abs(a - b) for a, b in zip(norm(positions[it]), final)) > SETTLE_TOL:
            break
        first = it
    return first


def changes(positions):
    return [it for it in range(1, len(positions)) if positions[it] != positions[it - 1]]


def noise(rows):
    """Spread of repeated evaluations of one position: every position evaluated at least 4
    times (a personal best kept for 3 iterations or more), its sample standard deviation."""
    by_x = {}
    for r in rows:
        by_x.setdefault(r["x"], []).append(r["fitness"])
    sds = [statistics.stdev(f) for f in by_x.values() if len(f) >= 4]
    return sds


def svg_panels(title, series, path):
    """One panel per parameter (best so far, normalised) and one for the best mean fitness;
    one polyline per tune. `series`: per tune, per iteration, (position, mean fitness)."""
    colours = ["#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e"]
    w, h, cols = 260, 170, 4
    panels = [(NAMES[p], d) for d, p in enumerate(BOUNDS)] + [("best F_p (mean)", None)]
    rows_n = math.ceil(len(panels) / cols)
    width, height = cols * w + 20, rows_n * h + 80
    s = [
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" '
        f'font-family="sans-serif" font-size="11">',
        f'<rect width="{width}" height="{height}" fill="white"/>',
        f'<text x="10" y="18" font-size="14">{title}</text>',
    ]
    fit = [m for tune in series for (_, m) in tune]
    flo, fhi = math.floor(min(fit) * 20) / 20, math.ceil(max(fit) * 20) / 20
    for k, (name, d) in enumerate(panels):
        ox, oy = 10 + (k % cols) * w, 30 + (k // cols) * h
        px, py, pw, ph = ox + 34, oy + 18, w - 50, h - 46
        s.append(f'<text x="{ox + w / 2}" y="{oy + 12}" text-anchor="middle">{name}</text>')
        s.append(f'<rect x="{px}" y="{py}" width="{pw}" height="{ph}" fill="none" stroke="#888"/>')
        lo, hi = (0.0, 1.0) if d is not None else (flo, fhi)
        for t in (lo, (lo + hi) / 2, hi):
            y = py + ph - (t - lo) / (hi - lo) * ph
            s.append(f'<text x="{px - 3}" y="{y + 4}" text-anchor="end">{t:.2f}</text>')
        for it in (0, 12, 24):
            x = px + it / 24 * pw
            s.append(f'<text x="{x}" y="{py + ph + 13}" text-anchor="middle">{it}</text>')
        for n, tune in enumerate(series):
            pts = []
            for it, (x, m) in enumerate(tune):
                v = norm(x)[d] if d is not None else m
                pts.append(
                    f"{px + it / (len(tune) - 1) * pw:.1f},{py + ph - (v - lo) / (hi - lo) * ph:.1f}"
                )
            s.append(
                f'<polyline points="{" ".join(pts)}" fill="none" stroke="{colours[n % 5]}" '
                f'stroke-width="1.5"/>'
            )
    ly = 30 + rows_n * h + 8
    for n in range(len(series)):
        lx = 10 + n * 130
        s.append(
            f'<line x1="{lx}" y1="{ly}" x2="{lx + 24}" y2="{ly}" stroke="{colours[n % 5]}" '
            f'stroke-width="2"/><text x="{lx + 30}" y="{ly + 4}">tune --seed {n + 1}</text>'
        )
    s.append(
        f'<text x="10" y="{height - 10}">x: iteration; the weights as a fraction of their '
        f"bounds</text>"
    )
    s.append("</svg>")
    path.write_text("\n".join(s) + "\n")


def main():
    lines = [
        "<!-- Generated by docs/results/seed004/tunes.py from tunes/*.csv; do not edit. -->",
        "",
    ]
    for world in WORLDS:
        files = sorted(HERE.glob(f"tunes/{world}_s*.csv"), key=lambda p: int(p.stem.split("_s")[1]))
        if not files:
            sys.exit(f"no tunes/{world}_s*.csv: run tune.sh first")
        tunes = [load(f) for f in files]
        histories = [replay(rows) for rows in tunes]
        n = len(histories)
        svg_panels(
            f"Seed 004, NR-PSO, {WORLDS[world]}: the best personal best so far per iteration, "
            f"{n} tunes",
            [[(h[1], h[2]) for h in hist] for hist in histories],
            HERE / f"tunes_{world}.svg",
        )
        svg_panels(
            f"Seed 004, NR-PSO, {WORLDS[world]}: the best with {CONFIRMED} or more evaluations "
            f"behind it, {n} tunes",
            [confirmed(hist) for hist in histories],
            HERE / f"tunes_{world}_confirmed.svg",
        )
        lines += [
            f"### {WORLDS[world]} ({world}): {len(files)} tunes",
            "",
            "| tune | best F_p (mean) | evaluations behind it | α | β | δ | ι | ζ | κ | M_b "
            f"| best moved (times) | settled from | confirmed best (≥ {CONFIRMED} evaluations): "
            "F_p, moved, settled from |",
            "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|",
        ]
        finals, counts_at_change, conf_settle = [], [], []
        for f, hist in zip(files, histories):
            best, x, mean, count, _ = hist[-1]
            own = json.loads(f.with_suffix(".json").read_text())["best"]
            if not (abs(own["fitness"] - mean) < 1e-12 and own["evaluations"] == count):
                sys.exit(f"{f}: rebuilt best {mean} ({count}) differs from the tune's {own}")
            positions = [h[1] for h in hist]
            moved = changes(positions)
            counts_at_change += [hist[it][3] for it in moved]
            finals.append((mean, x))
            conf = confirmed(hist)
            cpos = [c[0] for c in conf]
            conf_settle.append(settled_from(cpos))
            lines.append(
                f"| {f.stem} | {mean:.3f} | {count} | "
                + " | ".join(f"{v:.2f}" for v in x)
                + f" | {len(moved)} | {settled_from(positions)} | "
                f"{conf[-1][1]:.3f}, {len(changes(cpos))}, {conf_settle[-1]} |"
            )
        means = [m for m, _ in finals]
        spread = [
            (NAMES[p], min(x[d] for _, x in finals), max(x[d] for _, x in finals), hi - lo)
            for d, (p, (lo, hi)) in enumerate(BOUNDS.items())
        ]
        sds = noise([r for rows in tunes for r in rows])
        gaps = []
        for hist in histories:
            ms = sorted((b[1] / b[2] for b in hist[-1][4]), reverse=True)
            gaps.append(ms[0] - ms[1])
        single = sum(1 for c in counts_at_change if c == 1)
        lines += [
            "",
            f"- Final best F_p over the tunes: {min(means):.3f} to {max(means):.3f} "
            f"(median {statistics.median(means):.3f}).",
            "- Final best weights over the tunes (min to max, as a fraction of the bound "
            "width): "
            + ", ".join(f"{n} {a:.2f}-{b:.2f} ({(b - a) / wdt:.0%})" for n, a, b, wdt in spread)
            + ".",
            f"- Noise of one evaluation: over the {len(sds)} positions evaluated 4 times or "
            f"more, the standard deviation of their fitness has median {statistics.median(sds):.3f} "
            f"(range {min(sds):.3f}-{max(sds):.3f}).",
            f"- The gap between the best and the second-best personal best at the end: median "
            f"{statistics.median(gaps):.3f} (range {min(gaps):.3f}-{max(gaps):.3f}).",
            f"- Of the {len(counts_at_change)} times a tune's best changed position, "
            f"{single} were taken by a position with a single evaluation behind it.",
            f"- The confirmed best settles (stays within {SETTLE_TOL:.0%} of the bound width of "
            f"its final value in every weight) from iteration "
            f"{', '.join(str(c) for c in conf_settle)} of 0-24.",
            "",
        ]
    (HERE / "tunes.md").write_text("\n".join(lines))
    print("\n".join(lines))


if __name__ == "__main__":
    main()
