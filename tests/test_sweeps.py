"""rollsim sweep: grids, the three stages, determinism across workers and schedulers, resume, bad input.

Clusters are real: local Dask clusters started by rollsim, and an external
``dask scheduler`` with two ``dask worker`` processes started by the test.
"""

import json
import re
import signal
import subprocess
import sys
import tempfile

import pyarrow.parquet as pq
import pytest

from clitools import assert_one_error, run_rollsim, start_rollsim, wait_for
from rollsim.channel import analytic
from rollsim.cli import main
from rollsim.errors import RollsimError
from rollsim.sweeps import parse_values, run_sweep, spec_from_arguments, validate_cells
from rollsim.sweeps.grid import build_cells, grid_axis, zip_axis

SMALL = ["camera.width_px=160", "camera.height_px=120", "camera.row_time_us=250"]
TIMINGS = {"seconds", "render_s", "decode_s"}


def _table(directory):
    return pq.read_table(directory / "results.parquet").to_pylist()


def _without_timings(rows):
    return [{k: v for k, v in row.items() if k not in TIMINGS} for row in rows]


# ------------------------------------------------------------------ grids


@pytest.mark.parametrize(
    "text, values",
    [("5,10,15", [5, 10, 15]), ("rp,rs", ["rp", "rs"]), ("5:40:5", [5, 10, 15, 20, 25, 30, 35, 40]),
     ("5:42:5", [5, 10, 15, 20, 25, 30, 35, 40]), ("0.1:0.5:0.1", [0.1, 0.2, 0.3, 0.4, 0.5]),
     ("40:30:-5", [40, 35, 30]), ("geom:10:10000:4", [10, 100, 1000, 10000]), ("1e-3,0.5", [0.001, 0.5]),
     ("7", [7])],
)
def test_values(text, values):
    assert parse_values(text) == values


@pytest.mark.parametrize(
    "text, message",
    [("", "no values"), ("5:40:0", "step of start:stop:step must not be 0"), ("5:1:1", "holds no value"),
     ("5:40", "expected a comma list"), ("geom:0:1:3", "start and stop > 0"), ("geom:1:10:2.5", "must be an integer"),
     ("1,,2", "an empty item"), ("a:b:c", "is not a number"), ("[1", "cannot parse")],
)
def test_malformed_values_are_one_line(text, message):
    with pytest.raises(RollsimError, match=re.escape(message)):
        parse_values(text, "--grid link.distance_cm")


def test_cells_are_the_product_then_the_zip_and_their_seeds_depend_on_values_only():
    cells = build_cells([grid_axis("a", "1,2"), grid_axis("b", "x,y,z"), zip_axis({"c": "1,2", "d": "3,4"})])
    assert len(cells) == 12
    assert cells[0].values == {"a": 1, "b": "x", "c": 1, "d": 3}
    assert cells[1].values == {"a": 1, "b": "x", "c": 2, "d": 4}
    assert cells[-1].values == {"a": 2, "b": "z", "c": 2, "d": 4}
    other = build_cells([grid_axis("b", "z,y,x"), grid_axis("a", "2,1"), zip_axis({"d": "4,3", "c": "2,1"})])
    assert {c.id: c.seed(7) for c in cells} == {c.id: c.seed(7) for c in other}
    assert len({c.seed(7) for c in cells}) == 12 and all(0 <= c.seed(7) < 2**63 for c in cells)
    with pytest.raises(RollsimError, match="equally many values"):
        zip_axis({"c": "1,2", "d": "3"})
    with pytest.raises(RollsimError, match="the grid is empty"):
        build_cells([])
    with pytest.raises(RollsimError, match="a: swept twice"):
        build_cells([grid_axis("a", "1"), grid_axis("a", "2")])


def test_every_cell_is_validated_first_naming_cell_and_field():
    spec = spec_from_arguments("paper-default", grid=["link.distance_cm=5,0.2,-1,10"])
    with pytest.raises(RollsimError) as info:
        validate_cells(spec)
    lines = info.value.lines
    assert lines == [
        "cell 1 (link.distance_cm=0.2): paper-default: link.distance_cm = 0.2: the LED must be farther than the "
        "focal length (3.97 mm), where the thin lens diverges",
        "cell 2 (link.distance_cm=-1): paper-default: link.distance_cm = -1: out of range, allowed (0, 100000]",
    ]
    spec = spec_from_arguments("paper-default", grid=["link.distnce_cm=5,10"])
    with pytest.raises(RollsimError) as info:
        validate_cells(spec)
    assert info.value.lines == ["cell 0 (link.distnce_cm=5) (and 1 more cells): paper-default: link.distnce_cm: "
                                "unknown key; did you mean 'link.distance_cm'?"]


def test_sweep_file_with_flags_over_it(tmp_path):
    (tmp_path / "scene.yaml").write_text("name: mine\nlink:\n  distance_cm: 7\n")
    (tmp_path / "sweep.yaml").write_text(
        "scene: scene.yaml\nset: [channel.p_e=0.01]\ngrid:\n  link.distance_cm: [5, 10]\n  link.repeats: 1:3:1\n"
        "stage: simulate\nruns: 50\n")
    spec = spec_from_arguments(str(tmp_path / "sweep.yaml"), grid=["link.repeats=2"], options={"runs": 20})
    assert spec.scene == str(tmp_path / "scene.yaml") and spec.stage == "simulate" and spec.runs == 20
    assert [c.values for c in spec.cells()] == [{"link.distance_cm": 5, "link.repeats": 2},
                                                {"link.distance_cm": 10, "link.repeats": 2}]
    assert spec.overrides == ("channel.p_e=0.01",)
    (tmp_path / "bad.yaml").write_text("scene: scene.yaml\ngrid: {link.repeats: 1}\nstages: run\n")
    with pytest.raises(RollsimError, match="stages: unknown key; did you mean 'stage'"):
        spec_from_arguments(str(tmp_path / "bad.yaml"))


# ------------------------------------------------------------------ stages


@pytest.fixture(scope="module")
def client():
    from distributed import Client

    from rollsim.sweeps.engine import local_cluster

    with local_cluster(2, dashboard_address=":0") as cluster:
        with Client(cluster, set_as_default=False) as active:
            yield active


# The geometric LED, whose rows (and M) follow the thin lens: known answers.
GEOMETRIC = "paper-geometric"


def test_analytic_stage_3x2_equals_the_analytic_tools(tmp_path, client):
    spec = spec_from_arguments(GEOMETRIC, grid=["link.distance_cm=5,10,15", "channel.p_e=0.001,0.01"])
    result = run_sweep(spec, tmp_path / "out", client=client)
    rows = _table(tmp_path / "out")
    assert len(rows) == 6 and result.failed == 0 and all(r["status"] == "ok" for r in rows)
    assert [(r["link.distance_cm"], r["channel.p_e"]) for r in rows] == [
        (5, 0.001), (5, 0.01), (10, 0.001), (10, 0.01), (15, 0.001), (15, 0.01)]
    # The physics: the LED's share of the frame, and M, fall with distance.
    assert [r["M"] for r in rows[::2]] == [3, 1, 0] and rows[0]["roi_ratio"] > rows[2]["roi_ratio"] > rows[4]["roi_ratio"]
    goodput = [r["goodput_rp_bps"] for r in rows[::2]]
    assert goodput[0] > goodput[1] > goodput[2] == 0.0
    for row in rows:
        M, N, p_e, n = row["M"], row["N"], row["p_e"], row["n_packets"]
        assert row["p0_rp"] == analytic.mmbp_p0_rp(M, N, 1, p_e)
        assert row["p_message_rs"] == analytic.mmbp_p_message(M, N, 1, p_e, n, "rs")
        assert row["goodput_rs_bps"] == analytic.mmbp_expected_goodput_bps(M, N, 1, p_e, n, "rs", 19, row["sdu_duration_s"])
    # ... and rollsim analytic prints the same numbers for the same M, N, p_e.
    assert main(["analytic", "--M", "3", "--N", "2", "--p-e", "0.01", "--n-packets", "22", "--r-max", "1",
                 "--json", str(tmp_path / "a.json")]) == 0
    printed = json.loads((tmp_path / "a.json").read_text())["rows"][0]
    assert printed["mmbp_p0_rp"] == rows[1]["p0_rp"] and printed["mmbp_p_message_rp"] == rows[1]["p_message_rp"]


def test_simulate_stage_3x2_goodput_falls_with_distance(tmp_path, client):
    spec = spec_from_arguments(GEOMETRIC, grid=["link.distance_cm=5,7.5,10", "link.repeats=1,2"],
                               stage="simulate", options={"runs": 200})
    run_sweep(spec, tmp_path / "out", client=client)
    rows = _table(tmp_path / "out")
    assert len(rows) == 6 and all(r["status"] == "ok" and r["runs"] == 200 for r in rows)
    for repeats in (1, 2):
        goodput = [r["goodput_bps_mean"] for r in rows if r["link.repeats"] == repeats]
        assert goodput[0] > goodput[1] > goodput[2] > 0
        for r in rows:
            assert r["goodput_bps_ci_low"] <= r["goodput_bps_mean"] <= r["goodput_bps_ci_high"]
    # Each cell is rollsim simulate of its scene with the cell's seed.
    from rollsim.channel.scene_channel import simulate_scene
    from rollsim.scene import load_scene

    scene = load_scene(GEOMETRIC, ["link.distance_cm=7.5", "link.repeats=2", f"seed={rows[3]['seed']}"])
    expected = simulate_scene(scene, "mmbp", runs=200, workers=1).summary()["metrics"]["goodput_bps"]["mean"]
    assert rows[3]["goodput_bps_mean"] == expected


def test_run_stage_3x2_decodes_and_fits_the_physics(tmp_path, client):
    spec = spec_from_arguments(GEOMETRIC, grid=["link.distance_cm=5,10,20", "link.clock_hz=8000,6000"],
                               stage="run", overrides=["camera.width_px=480"], options={"frames": 24})
    run_sweep(spec, tmp_path / "out", client=client)
    rows = _table(tmp_path / "out")
    assert len(rows) == 6 and all(r["status"] == "ok" and r["frames"] == 24 for r in rows)
    near = [r for r in rows if r["link.distance_cm"] == 5]
    for r in near:
        assert r["ok"] > 0 and r["error_rate"] < 0.05 and r["false_decodes"] == 0
        assert (r["M"], r["N"]) == (r["M_physics"], r["N_physics"])
        assert r["p_e_ci_low"] <= r["p_e"] <= r["p_e_ci_high"]
    far = [r for r in rows if r["link.distance_cm"] == 20]
    # No PHY-SDU is fully visible at 20 cm. The decoder may still read one
    # whose last chip only its last row partly saw (its sequence detection
    # weighs that share): an ok outcome outside the fully visible ones, never
    # a wrong one. Without any, the fit has no success to go on.
    assert all(r["fully_visible"] == 0 and r["M_physics"] == 0 for r in far)
    assert all(r["false_decodes"] == 0 and r["undetected_error"] == 0 and r["corrupted"] == 0 for r in far)
    assert all("no success" in r["fit_error"] for r in far if r["ok"] == 0)
    assert any(r["ok"] == 0 for r in far)
    assert near[0]["goodput_replayed_bps"] > 0


def test_a_cell_that_fails_fails_alone_with_its_error(tmp_path, client):
    # p_e so close to 1 that the exact expected goodput is out of reach.
    spec = spec_from_arguments("paper-default", grid=["channel.p_e=0.001,0.99999999"])
    result = run_sweep(spec, tmp_path / "out", client=client)
    rows = _table(tmp_path / "out")
    assert [r["status"] for r in rows] == ["ok", "error"] and result.failed == 1
    assert "too close to 1 for the exact sum" in rows[1]["error"] and rows[1]["M"] is None
    assert rows[0]["error"] is None and rows[0]["goodput_rp_bps"] > 0


def test_keep_frames_writes_a_decodable_render_directory_per_cell(tmp_path, client):
    spec = spec_from_arguments("paper-default", grid=["link.distance_cm=5"], stage="run",
                               overrides=SMALL, options={"frames": 3, "keep_frames": True})
    run_sweep(spec, tmp_path / "out", client=client)
    [row] = _table(tmp_path / "out")
    cell_dir = tmp_path / "out" / "frames" / row["cell_id"]
    assert len(list((cell_dir / "frames").glob("*.png"))) == 3 and (cell_dir / "truth.jsonl").exists()
    assert main(["decode", str(cell_dir), "--quiet", "--workers", "1"]) == 0


# ------------------------------------------------------- determinism, resume


def _sweep_cli(out, *extra, cwd):
    return run_rollsim("sweep", "paper-default", "--grid", "link.distance_cm=5,10,15", "--grid", "link.repeats=1,2",
                       "--stage", "simulate", "--runs", "100", "--out", out, "--quiet", *extra, cwd=cwd)


def _dask_process(*args, cwd):
    return subprocess.Popen([sys.executable, "-m", "distributed.cli." + args[0], *args[1:]], cwd=cwd,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)


def test_identical_results_with_1_and_2_workers_and_an_external_cluster(tmp_path):
    one = _sweep_cli("one", "--workers", "1", cwd=tmp_path)
    two = _sweep_cli("two", "--workers", "2", cwd=tmp_path)
    assert one.returncode == 0 and two.returncode == 0, (one.stderr, two.stderr)
    scheduler_file = tmp_path / "scheduler.json"
    scheduler = _dask_process("dask_scheduler", "--scheduler-file", str(scheduler_file), "--host", "127.0.0.1",
                              "--port", "0", "--dashboard-address", ":0", cwd=tmp_path)
    workers = []
    try:
        wait_for(scheduler_file.exists, timeout=60)
        wait_for(lambda: "address" in scheduler_file.read_text(), timeout=60)
        address = json.loads(scheduler_file.read_text())["address"]
        workers = [_dask_process("dask_worker", address, "--nthreads", "1", "--nworkers", "1", "--no-nanny",
                                 cwd=tmp_path) for _ in range(2)]
        external = _sweep_cli("external", "--scheduler", address, cwd=tmp_path)
        assert external.returncode == 0, external.stderr
    finally:
        for process in [*workers, scheduler]:
            process.terminate()
        for process in [*workers, scheduler]:
            try:
                process.wait(timeout=10)
            except subprocess.TimeoutExpired:  # a worker still saying goodbye to a closed scheduler
                process.kill()
                process.wait()
    tables = [_without_timings(_table(tmp_path / name)) for name in ("one", "two", "external")]
    assert tables[0] == tables[1] == tables[2]
    assert len(tables[0]) == 6 and all(r["status"] == "ok" for r in tables[0])


def test_resume_after_a_kill_computes_only_the_missing_cells(tmp_path):
    args = ["sweep", "paper-default", "--grid", "link.distance_cm=5:12:0.5", "--stage", "simulate", "--runs", "300",
            "--workers", "2", "--quiet"]
    process = start_rollsim(*args, "--out", "killed", cwd=tmp_path)
    journal = tmp_path / "killed" / "cells.jsonl"
    wait_for(lambda: journal.exists() and len(journal.read_bytes().splitlines()) >= 3, timeout=120)
    process.send_signal(signal.SIGKILL)
    process.wait(timeout=30)
    done = len(journal.read_bytes().splitlines())
    assert 3 <= done < 15 and not (tmp_path / "killed" / "results.parquet").exists()
    resumed = run_rollsim(*args, "--out", "killed", "--resume", cwd=tmp_path)
    assert resumed.returncode == 0, resumed.stderr
    assert f"15 cells ({15 - done} computed now)" in resumed.stdout
    whole = run_rollsim(*args, "--out", "whole", cwd=tmp_path)
    assert whole.returncode == 0
    assert _without_timings(_table(tmp_path / "killed")) == _without_timings(_table(tmp_path / "whole"))
    # A second resume has nothing left to do.
    again = run_rollsim(*args, "--out", "killed", "--resume", cwd=tmp_path)
    assert "(0 computed now)" in again.stdout


def test_sigterm_stops_the_sweep_and_its_workers_and_keeps_the_committed_cells(tmp_path):
    process = start_rollsim("sweep", "paper-default", "--grid", "link.distance_cm=5:40:0.5", "--stage", "simulate",
                            "--runs", "400", "--out", "out", "--quiet", cwd=tmp_path)
    journal = tmp_path / "out" / "cells.jsonl"
    wait_for(lambda: journal.exists() and journal.stat().st_size > 0, timeout=120)
    from clitools import alive, descendants

    children = descendants(process.pid)
    process.send_signal(signal.SIGTERM)
    _, err = process.communicate(timeout=30)
    assert process.returncode == 143
    wait_for(lambda: not any(alive(pid) for pid in children), timeout=5)
    lines = err.strip().splitlines()
    assert lines[-1].startswith("rollsim: stopped by SIGTERM; ") and "cells are committed in out" in lines[-1]
    assert "--resume continues" in lines[-1]


# --------------------------------------------------------------- bad input


@pytest.mark.parametrize(
    "argv, fragments",
    [
        (["--grid", "link.distnce_cm=5,10"], ["link.distnce_cm: unknown key; did you mean 'link.distance_cm'?"]),
        (["--grid", "link.distance_cm=5:40"], ["--grid link.distance_cm", "expected a comma list"]),
        (["--grid", "link.distance_cm"], ["--grid 'link.distance_cm': expected KEY=VALUES"]),
        ([], ["the grid is empty"]),
        (["--zip", "link.clock_hz=4000,8000", "--zip", "link.payload_bits=19"], ["equally many values"]),
    ],
)
def test_bad_sweeps_are_one_line_and_start_nothing(tmp_path, capsys, argv, fragments):
    code = main(["sweep", "paper-default", *argv, "--out", str(tmp_path / "out")])
    assert_one_error(capsys.readouterr().err, 2, *fragments)
    assert code == 2 and not (tmp_path / "out").exists()


def test_an_unreachable_scheduler_is_one_line_within_10_s(tmp_path):
    import socket

    with socket.socket() as sock:  # a port nobody listens on
        sock.bind(("127.0.0.1", 0))
        port = sock.getsockname()[1]
    result = run_rollsim("sweep", "paper-default", "--grid", "link.distance_cm=5", "--out", "out",
                         "--scheduler", f"tcp://127.0.0.1:{port}", cwd=tmp_path)
    assert_one_error(result, 1, f"--scheduler tcp://127.0.0.1:{port}: nothing listens there (connection refused)")
    assert result.seconds < 10.0 + 2.0  # start-up of the command itself


def test_existing_directory_needs_resume_or_force_and_resume_checks_the_sweep(tmp_path, client, capsys):
    spec = spec_from_arguments("paper-default", grid=["link.distance_cm=5,10"])
    run_sweep(spec, tmp_path / "out", client=client)
    code = main(["sweep", "paper-default", "--grid", "link.distance_cm=5,10", "--out", str(tmp_path / "out")])
    assert code == 2 and "use --force" in capsys.readouterr().err
    code = main(["sweep", "paper-default", "--grid", "link.distance_cm=5,20", "--out", str(tmp_path / "out"),
                 "--resume"])
    assert_one_error(capsys.readouterr().err, 2, "holds another sweep (grid differ)")
    (tmp_path / "out" / "notes.txt").write_text("mine")
    code = main(["sweep", "paper-default", "--grid", "link.distance_cm=5,10", "--out", str(tmp_path / "out"),
                 "--force"])
    assert code == 2 and "notes.txt" in capsys.readouterr().err
    assert (tmp_path / "out" / "notes.txt").read_text() == "mine"


def test_python_api_returns_a_dataframe_or_the_directory(tmp_path, client):
    import importlib.util

    import rollsim

    table = rollsim.sweep(GEOMETRIC, grid={"link.distance_cm": [5, 10]}, out=tmp_path / "api", client=client)
    if importlib.util.find_spec("pandas") is None:
        assert table == tmp_path / "api"
        assert [row["M"] for row in _table(table)] == [3, 1]
    else:
        assert list(table["M"]) == [3, 1] and table.attrs["sweep_dir"] == str(tmp_path / "api")
        assert list(table.columns[:2]) == ["cell", "link.distance_cm"]


@pytest.mark.parametrize("grid, kind", [
    (["link.distance_cm=5:15:5"], "line"),
    (["link.distance_cm=5,10", "link.repeats=1,2", "channel.p_e=0.001,0.01"], "small multiples"),
])
def test_report_has_a_plot_per_figure_for_any_number_of_axes(tmp_path, client, grid, kind):
    spec = spec_from_arguments("paper-default", grid=grid)
    run_sweep(spec, tmp_path / "out", client=client)
    report = (tmp_path / "out" / "report.md").read_text()
    plots = sorted((tmp_path / "out" / "plots").glob("*.png"))
    assert {p.stem for p in plots} >= {"goodput_rp_bps", "p_message_rs", "M", "N", "roi_ratio"}
    assert all(p.read_bytes().startswith(b"\x89PNG") for p in plots)
    assert all(f"![{p.stem}](plots/{p.name})" in report for p in plots)
    from rollsim.plumbing.outputs import foreign_entries

    assert foreign_entries(tmp_path / "out") == []  # everything in it is the sweep's own


@pytest.mark.parametrize("option", ["--grid", "--zip"])
def test_a_key_given_twice_is_refused_not_half_dropped(tmp_path, option):
    result = run_rollsim("sweep", "paper-default", option, "link.distance_cm=5,10", option, "link.distance_cm=20",
                         "--out", "out", cwd=tmp_path)
    assert_one_error(result, 2, f"{option} link.distance_cm: given twice")
    assert list(tmp_path.iterdir()) == []


def test_the_api_sweeps_a_scene_object_and_a_failed_call_leaves_no_temporary_folder(tmp_path, monkeypatch):
    import rollsim as rs

    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    scene = rs.load_scene("paper-default", overrides={"link.distance_cm": 10})
    table = rs.sweep(scene, grid={"link.distance_cm": [5, 20]}, workers=1)
    assert list(table["link.distance_cm"]) == [5, 20] and (table["status"] == "ok").all()
    def ours():  # Dask keeps its own scratch space there too
        return sorted(p for p in tmp_path.iterdir() if p.name.startswith("rollsim-"))

    kept = ours()
    assert len(kept) == 1 and kept[0].name.startswith("rollsim-sweep-")
    with pytest.raises(RollsimError, match=r"cell 1 \(link.distance_cm=-1\)"):
        rs.sweep(scene, grid={"link.distance_cm": [5, -1]}, workers=1)
    with pytest.raises(RollsimError, match="nothing listens there"):
        rs.sweep(scene, grid={"link.distance_cm": [5]}, scheduler="tcp://127.0.0.1:1")
    assert ours() == kept
