"""The notebook API: runs, records as DataFrames, errors, sweeps, plots."""

import subprocess

import matplotlib
import numpy as np
import pandas as pd
import pytest

import swarmrt
from conftest import CONFIGS, SWARM

matplotlib.use("Agg")


def test_the_package_is_the_installed_wheel_with_its_binaries():
    assert "site-packages" in swarmrt.__file__, swarmrt.__file__
    for name in ("swarm", "swarm-world", "swarm-agent", "swarm-host"):
        assert (SWARM.parent / name).is_file(), name
    out = subprocess.run([str(SWARM), "--version"], capture_output=True, text=True, check=True)
    assert out.stdout.startswith("swarm ")


def test_an_in_process_run_writes_the_clis_bytes_and_the_dataframe_is_the_file(tmp_path):
    cfg = CONFIGS / "flocking_crossing.toml"
    run = swarmrt.run(cfg, ticks=80, set={"radio.loss": 0.2}, out=tmp_path / "py",
                      progress=False)
    subprocess.run([str(SWARM), "run", str(cfg), "--in-process", "--ticks", "80",
                    "--set", "radio.loss=0.2", "--out", str(tmp_path / "cli")],
                   check=True, capture_output=True)
    for name in ("trajectory.csv", "events.jsonl"):
        assert (run.dir / name).read_bytes() == (tmp_path / "cli" / name).read_bytes(), name
    pd.testing.assert_frame_equal(run.trajectory, pd.read_csv(tmp_path / "cli" / "trajectory.csv"))
    assert run.metrics["ticks"] == 80
    assert run.metrics["mode"] == "in-process"
    lines = (tmp_path / "cli" / "events.jsonl").read_text().splitlines()
    assert len(run.events) == len(lines)
    assert run.config["scenario"]["name"] == "flocking_crossing"
    assert run.radio is None, "the config records no radio"


def test_a_process_run_uses_the_installed_binaries(tmp_path):
    run = swarmrt.run(CONFIGS / "goto_simple.toml", ticks=20, in_process=False,
                      out=tmp_path / "p")
    assert run.metrics["mode"] == "processes"
    assert len(run.metrics["processes"]) == 9
    assert run.trajectory["tick"].max() == 20


def test_a_config_typo_raises_config_error_with_the_clis_one_line():
    with pytest.raises(swarmrt.ConfigError) as typo:
        swarmrt.run(CONFIGS / "goto_simple.toml", set={"radio.losss": 0.1}, progress=False)
    line = str(typo.value)
    assert "goto_simple.toml" in line and "key `radio.losss`" in line and "\n" not in line
    with pytest.raises(swarmrt.ConfigError, match="robots.count"):
        swarmrt.run(CONFIGS / "goto_simple.toml", set={"robots.count": 0}, in_process=False)
    with pytest.raises(swarmrt.ConfigError):
        swarmrt.run(CONFIGS / "no_such_config.toml")


def test_a_sweep_over_radio_loss_gives_one_row_per_run():
    table = swarmrt.sweep(CONFIGS / "goto_simple.toml", vary={"radio.loss": [0.0, 0.5]},
                          seeds=2, set={"scenario.ticks": 30})
    assert len(table) == 4
    assert sorted(table["radio.loss"]) == [0.0, 0.0, 0.5, 0.5]
    lossy = table[table["radio.loss"] == 0.5]
    assert (lossy["radio.dropped_loss"] > 0).all()
    assert (table[table["radio.loss"] == 0.0]["radio.dropped_loss"] == 0).all()


def test_plot_draws_the_map_and_every_path(tmp_path):
    run = swarmrt.run(CONFIGS / "goto_simple.toml", ticks=60, progress=False)
    ax = run.plot()
    assert len(ax.lines) == 2 * 9, "a path and an end marker per robot"
    path = tmp_path / "plot.png"
    ax.figure.savefig(path)
    pixels = matplotlib.image.imread(path)
    assert pixels.std() > 0.01, "the figure is not blank"
    assert np.isclose(ax.get_xlim()[1], run.config["map"]["bounds"][2])


def test_a_tune_gives_its_table_and_best_values():
    result = swarmrt.tune(CONFIGS / "goto_simple.toml", params={"behaviour.speed": (0.2, 1.0)},
                          fitness="steps_to_target", particles=3, iterations=2,
                          set={"scenario.ticks": 200})
    assert len(result["table"]) == 2 * 3 * 2, "2P evaluations an iteration"
    best = result["best_toml"]["behaviour"]["speed"]
    assert 0.2 <= best <= 1.0
    assert result["best"]


def test_view_serves_the_run_until_stopped():
    import urllib.request

    run = swarmrt.run(CONFIGS / "goto_simple.toml", ticks=10, progress=False)
    url = run.view()
    assert url.startswith("http://127.0.0.1:")
    with urllib.request.urlopen(url, timeout=10) as page:
        assert page.status == 200
    proc = run._viewer
    run.stop_view()
    assert proc.poll() is not None
