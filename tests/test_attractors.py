"""The attractor census (studies/attractors, ``stickslip attractors``, docs/attractors.md).

Statistics and classification on closed forms and synthetic waves (no FE, milliseconds);
one census of the tiny smoke scene (36 and 48 contact nodes, 0.05 s) for the bookkeeping:
every start counted exactly once, also after SIGTERM and SIGKILL and a rerun.
"""

from __future__ import annotations

import json
import math
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from faults import wait_released
from scipy.stats import binom
from test_sweep import _env, _starts  # the child's environment; '== start' lines per run

from stickslip.studies.attractors.classify import (
    CLASSES,
    classify,
    frame_spread,
    group_members,
    member_description,
    spread_trend,
)
from stickslip.studies.attractors.starts import StartDistribution, parse_meshes, parse_structured
from stickslip.studies.attractors.statistics import (
    Z95,
    fisher_consistent,
    ladder,
    mean_spread,
    mesh_members,
    observed_order,
    wilson,
)

REPO = Path(__file__).resolve().parents[1]
SMOKE = REPO / "scenes" / "smoke.toml"

# ------------------------------------------------------------------------------ statistics


def test_wilson_interval_closed_forms_and_coverage():
    z2 = Z95 * Z95
    # x = 0 and x = n: the interval ends at 0 (1) and its other end is z²/(n + z²)
    # (n/(n + z²)): the closed form of the score interval's boundary cases, to round-off.
    assert wilson(0, 10) == pytest.approx((0.0, z2 / (10 + z2)), abs=1e-15)
    assert wilson(10, 10) == pytest.approx((10 / (10 + z2), 1.0), abs=1e-15)
    # 5/10: symmetric about 1/2; the tabulated value 0.2366-0.7634 (four digits).
    lo, hi = wilson(5, 10)
    assert lo + hi == pytest.approx(1.0, abs=1e-15)
    assert (lo, hi) == pytest.approx((0.2366, 0.7634), abs=5e-5)
    # Coverage P(lo <= p <= hi) summed exactly over the binomial law: the score interval
    # keeps close to its nominal 95 % (within 0.93-0.98 for these n, p; Brown, Cai and
    # DasGupta 2001, Fig. 4), where the Wald interval drops to ~0.6 for p = 0.05.
    for n, p in ((20, 0.3), (64, 0.05), (64, 0.5)):
        cover = sum(binom.pmf(x, n, p) for x in range(n + 1)
                    if wilson(x, n)[0] <= p <= wilson(x, n)[1])
        assert 0.93 <= cover <= 0.98, (n, p, cover)


def test_fisher_order_and_spread():
    # Equal counts: p = 1 exactly. 10/10 against 0/10: only the observed table is as extreme
    # on either side, p = 2 / C(20, 10) (hypergeometric), to round-off.
    assert fisher_consistent(4, 8, 4, 8) == pytest.approx(1.0)
    assert fisher_consistent(10, 10, 0, 10) == pytest.approx(2 / math.comb(20, 10), rel=1e-9)
    # q(N) = q* + C N^-2 on N = 66, 132, 264: the observed order is 2 to round-off.
    ns = (66, 132, 264)
    assert observed_order(ns, [1.0 + 5.0 / n**2 for n in ns]) == pytest.approx(2.0, rel=1e-9)
    assert math.isnan(observed_order((66, 132, 396), [1.0, 2.0, 2.5]))  # two ratios: none
    m, sd, n = mean_spread([1.0, 2.0, 3.0, None, math.nan])
    assert (m, sd, n) == (2.0, 1.0, 3)


def _row(seed, cls, k=None, direction=None, regime=None, c=None, n=132, **values):
    return {"seed": seed, "class": cls, "k": k, "direction": direction, "regime": regime,
            "celerity_m_s": c, "n_inner": n, "start": "random", "member": None,
            **{key: values.get(key, 1.0) for key in (
                "frequency_hz", "fraction_separation", "fraction_stick", "fraction_slip",
                "psi1", "psi2", "amplitude_m", "rms_amplitude_m")}}


def test_members_shares_and_ladder():
    sss = "stick-slip-separation"
    coarse = [_row(1, "wave", 11, "opposite", sss, -935.6), _row(2, "wave", 11, "opposite",
              sss, -936.0), _row(3, "wave", 11, "opposite", sss, -990.0),
              _row(4, "wave", 8, "rotation", sss, 1930.0), _row(5, "diverged")]
    stationary_cycle = _row(6, "multi-wave", 11, "opposite", sss, -935.7)
    group_members([*coarse, stationary_cycle], celerity_tol=0.02)
    # -935.6 and -936.0 are 0.04 % apart (one member), -990 is 5.8 % away (a second one);
    # rows without features: a non-rigid cycle at the same celerity is not the rigid wave
    assert [r["member"] for r in coarse] == ["k11-opposite-SSS", "k11-opposite-SSS",
                                             "k11-opposite-SSS#2", "k8-rotation-SSS",
                                             "diverged"]
    assert stationary_cycle["member"] == "multi-wave-k11-opposite-SSS"
    assert member_description("multi-wave-k11-opposite-SSS") == (
        "multi-wave k = 11 against the rotation, stick-slip-separation")
    assert member_description("k8-rotation-SSS") == \
        "k = 8 with the rotation, stick-slip-separation"
    assert member_description("unsettled-k13-opposite-SSS#2") == ("unsettled k = 13 against "
        "the rotation, stick-slip-separation (group 2)")
    table = mesh_members(coarse)
    assert sum(m["share"] for m in table) == pytest.approx(1.0)  # diverged counted too
    top = table[0]
    assert (top["member"], top["count"], top["starts"]) == ("k11-opposite-SSS", 2, 5)
    assert top["celerity_m_s"] == pytest.approx(-935.8)
    assert top["celerity_m_s_sd"] == pytest.approx(0.4 / math.sqrt(2))
    fine = [_row(i, "wave", 11, "opposite", sss, -929.0, n=264) for i in range(1, 6)]
    group_members(fine)
    lad = ladder({132: table, 264: mesh_members(fine)})
    assert lad["members"]["k11-opposite-SSS"]["differences"]["celerity_m_s"][0] == \
        pytest.approx((-929.0 + 935.8) / 935.8)
    assert lad["sets"][264] == ["k11-opposite-SSS"]
    assert lad["stable_from"] is None  # the set changes from 132 to 264: nothing to say


def test_start_distribution_and_arguments():
    dist = StartDistribution(starts=3, seed=5, structured=(4, 5))
    pts = dist.points((132, 264))
    assert len(pts) == 10 and pts[0] == {"mesh.n_inner": 132, "initial.perturbation": "random",
                                          "initial.seed": 5}
    assert pts[4]["initial.mode"] == 5 and "seeds 5..7" in dist.describe()
    assert parse_structured("1:12", 66) == tuple(range(1, 13))
    # huge values are refused before any list is made (they raised OverflowError, or filled
    # the memory with starts)
    with pytest.raises(ValueError, match="1 <= k <= 66"):
        parse_structured("1:99999999999999999999", 66)
    with pytest.raises(ValueError, match="K1 <= K2"):
        parse_structured("5:3", 66)
    with pytest.raises(ValueError, match="1 <= M <= 10000"):
        StartDistribution(starts=2**31)
    with pytest.raises(ValueError, match="64-bit"):
        StartDistribution(starts=4, seed=2**63 - 2)
    assert parse_meshes("264,132") == (132, 264)
    for bad in ("", "132,132", "a"):
        with pytest.raises(ValueError, match="--meshes"):
            parse_meshes(bad)


# ----------------------------------------------------------------------- classification


def _waves(n=64, samples=400, k=5, omega=-300.0, second=0.0):
    theta = 2 * np.pi * np.arange(n) / n
    t = np.linspace(0.0, 0.02, samples)
    phase = k * (theta[None, :] - omega * t[:, None])
    u_theta = 1e-3 * np.cos(phase) + 2e-4  # + an axisymmetric part, which is not the wave
    u_r = 1e-3 + 3e-4 * np.sin(phase)
    if second:  # a second wave, turning two turns per 0.01 s in the first one's frame
        rel = 400.0 * np.pi / 3.0  # 3 rel 0.01 s = 4 pi
        u_theta = u_theta + second * 1e-3 * np.cos(
            3 * (theta[None, :] - (omega + rel) * t[:, None]))
    return t, theta, u_r, u_theta


def test_frame_spread_rigid_and_modulated():
    t, theta, u_r, u_theta = _waves()
    spread, rms = frame_spread(t, theta, u_r, u_theta, -300.0, t[-1] / 2)
    # A band-limited rigid wave is shifted exactly by the Fourier shift: round-off only.
    assert spread < 1e-12
    # RMS of the travelling part: sqrt((1e-3)² / 2 + (3e-4)² / 2), exact on a uniform grid.
    assert rms == pytest.approx(math.sqrt(0.5 * (1e-6 + 9e-8)), rel=1e-12)
    # A second wave of half the amplitude at another speed: in the first wave's frame it
    # turns (by two whole turns over the window, so its mean is zero to O(1/samples)), so
    # spread = its RMS over the first's: 0.5 / sqrt(1 + 0.09) (the u_r part has no second
    # wave). Tolerance 1 %: the window's part-turn, 200 samples.
    t, theta, u_r, u_theta = _waves(second=0.5)
    spread, _ = frame_spread(t, theta, u_r, u_theta, -300.0, 0.01)
    assert spread == pytest.approx(0.5 / math.sqrt(1.09), rel=1e-2)
    # The same second wave decaying as exp(-t / 0.01): over a 0.01 s window its RMS in the
    # second half is exp(-0.5) of the first half's (to O(1 %): the halves' mean decay), so
    # the spread trend is exp(-0.5) - 1 = -0.39: a cycle still settling.
    decaying = _waves()[3] + (u_theta - _waves()[3]) * np.exp(-t / 0.01)[:, None]
    trend = spread_trend(t, theta, u_r, decaying, -300.0, 0.01)
    assert trend == pytest.approx(math.exp(-0.5) - 1.0, rel=0.05)


def test_classes():
    wave = {"regime": "stick-slip", "limit_cycle": True}
    assert classify("completed", wave, 0.05) == "wave"
    assert classify("completed", wave, 0.3) == "multi-wave"
    assert classify("completed", wave, 0.3, trend=-0.02) == "multi-wave"  # not decaying
    assert classify("completed", wave, 0.3, trend=-0.11) == "unsettled"  # still decaying
    assert classify("completed", dict(wave, limit_cycle=False), 0.0) == "unsettled"
    assert classify("completed", {"regime": "steady-sliding"}, math.nan) == "steady-sliding"
    assert classify("diverged", {}, math.nan) == "diverged"
    assert classify("failed", {}, math.nan) == "failed"
    assert classify("completed", {}, math.nan) == "failed"  # no analysis: shown, not dropped


# ----------------------------------------------------------------------------- the command


def _cmd(out: Path, *extra: str) -> list[str]:
    # Stick-slip physics on the smoke mesh (Omega = 20 rad/s, delta = 5e-3; its sweep test
    # measures a stick-slip wave there), long enough to be killed in flight.
    return [sys.executable, "-m", "stickslip.cli.main", "attractors", str(SMOKE), "--starts", "3",
            "--meshes", "36,48", "--structured", "4:4", "--end-time", "0.05",
            "--set", "loading.omega=20", "--set", "geometry.delta=0.005", "-o", str(out),
            "--no-certify", *extra]


def _kill_after(cmd: list[str], out: Path, sig: int, log: Path, timeout: float = 300.0) -> None:
    """Start ``cmd``, send ``sig`` once some start is finished (or running, for SIGKILL):
    the starts' own summaries are the marker; ``timeout`` only guards against a hang."""
    with open(log, "w") as fh:
        proc = subprocess.Popen(cmd, cwd=REPO, env=_env(), stdout=fh, stderr=subprocess.STDOUT)
        t0 = time.monotonic()
        try:
            want = '"completed"' if sig == signal.SIGTERM else '"running"'
            seen = False
            while proc.poll() is None and not seen:
                seen = any(want in p.read_text() for p in out.glob("starts/runs/*/summary.json"))
                assert seen or time.monotonic() - t0 < timeout, "the census hangs"
                if not seen:
                    time.sleep(0.02)
            assert seen and proc.poll() is None, log.read_text()  # it lands mid-census
            proc.send_signal(sig)
            proc.wait(timeout=timeout)
            wait_released(out)  # its watchdogs, which outlive a SIGKILL, have ended
        finally:
            if proc.poll() is None:
                proc.kill()


def test_census_killed_and_rerun_counts_every_start_once(tmp_path, capsys):
    """SIGTERM, then SIGKILL, then a rerun: every start once in the answer, none lost."""
    pytest.importorskip("dolfinx")
    out = tmp_path / "census"
    for sig in (signal.SIGTERM, signal.SIGKILL):
        _kill_after(_cmd(out), out, sig, tmp_path / f"killed{sig}.log")
    res = subprocess.run(_cmd(out, "--json"), cwd=REPO, env=_env(), capture_output=True,
                         text=True, timeout=300)
    assert res.returncode == 0, res.stdout + res.stderr
    answer = json.loads(res.stdout)
    rows = answer["starts"]
    ids = [r["id"] for r in rows]
    assert len(ids) == len(set(ids)) == 8  # 3 random + 1 structured on each of 2 meshes
    assert all(r["class"] in CLASSES for r in rows)
    for n, members in answer["members"].items():  # random starts only, every one counted
        assert sum(m["count"] for m in members) == 3, n
        assert sum(m["share"] for m in members) == pytest.approx(1.0)
        for m in members:
            assert m["share_lo"] <= m["share"] <= m["share_hi"]
    assert [len(v) for v in answer["structured"].values()] == [1, 1]
    for r in rows:  # a wave's member carries its own k, direction and regime
        if r["class"] == "wave":
            assert r["member"].startswith(f"k{r['k']}-{r['direction']}-")
            assert r["frame_spread"] <= answer["spread_tol"]
    starts = _starts(out / "starts")
    assert set(starts) == set(ids) and all(1 <= v <= 3 for v in starts.values())
    assert len((out / "attractors.csv").read_text().splitlines()) == 1 + 8
    assert (out / "members.csv").is_file()
    # A rerun of a finished census runs nothing and gives the same answer; so does reading
    # the directory itself (in this process: no second start-up).
    from stickslip.cli.main import main

    capsys.readouterr()
    assert main([*_cmd(out, "--json")[3:]]) == 0 and _starts(out / "starts") == starts
    assert json.loads(capsys.readouterr().out)["members"] == answer["members"]
    assert main(["attractors", str(out)]) == 0 and _starts(out / "starts") == starts


@pytest.mark.parametrize("args, words", [
    (["--starts", "0"], "--starts 0"),
    (["--meshes", ""], "ladder is empty"),
    (["--meshes", "4"], "mesh.n_inner = 4"),  # no such mesh
    (["--meshes", "20"], "n_modes"),  # modes 1..16 of the random start: not on 20 nodes
    (["--structured", "5:2"], "--structured"),
    (["--end-time", "-1"], "--end-time"),
    (["--along", "omega=30:100:8"], "--along"),  # not a dotted scene key
    (["--along", "loading.omegaa=30,40"], "omegaa"),  # no such scene key
    (["--along", "loading.f=-1,0.5"], "loading.f"),  # a value out of range
    (["--cea-fmax-hz", "0"], "--cea-fmax-hz"),
])
def test_bad_arguments_one_line_exit_2(tmp_path, capsys, args, words):
    pytest.importorskip("mpi4py")
    from stickslip.cli.main import main

    rc = main(["attractors", str(SMOKE), "-o", str(tmp_path / "c"), *args])
    err = capsys.readouterr().err.strip()
    assert rc == 2 and len(err.splitlines()) == 1 and words in err, err
    assert not (tmp_path / "c").exists()  # nothing created


def test_sweep_with_an_attractors_table_maps_every_point(tmp_path, capsys):
    """``[attractors] starts = 2`` in a sweep file: 2 random starts at each of 2 points."""
    pytest.importorskip("dolfinx")
    from stickslip.cli.main import main
    from stickslip.studies.attractors.maps import expand
    from stickslip.studies.sweep import SweepError, load_sweep

    body = (f'name = "amap"\nbase = "{SMOKE}"\nset = ["time.end_time=0.02"]\n'
            '[grid]\n"loading.omega" = [20.0, 50.0]\n[map]\nx = "loading.omega"\n')
    sweep = tmp_path / "amap.toml"
    sweep.write_text(body + "[attractors]\nstarts = 2\nseed = 7\n")
    spec = expand(load_sweep(sweep))
    assert [t.id for t in spec.tasks] == ["omega-20.0_seed-7", "omega-20.0_seed-8",
                                          "omega-50.0_seed-7", "omega-50.0_seed-8"]
    out = tmp_path / "out"
    assert main(["sweep", str(sweep), "-o", str(out), "--plot"]) == 0
    points = json.loads((out / "attractors_map.json").read_text())["points"]
    assert [p["point"] for p in points] == ["omega-20.0", "omega-50.0"]
    for p in points:  # both starts of each point counted, the interval holds the estimate
        assert p["starts"] == p["finished"] == 2
        assert p["p_sss_lo"] <= p["p_sss"] <= p["p_sss_hi"]
    printed = capsys.readouterr().out
    assert "attractors" in printed and f"figure: {out / 'regime_map.png'}" in printed
    _assert_census_map(out)
    bad = tmp_path / "bad.toml"
    bad.write_text(body + "[attractors]\nstart = 2\n")
    with pytest.raises(SweepError, match="attractors.start"):
        expand(load_sweep(bad))


def test_census_cells_of_points_without_a_wave():
    """A map cell whose dominant end state is no wave names its class; a point with no
    finished start says so (its share and P(SSS) are null in attractors_map.json)."""
    from stickslip.studies.sweep.regime_map import census_cells

    def point(name, dominant, table, p_sss):
        return {"point": name, "loading.f": 0.5, "starts": 4, "finished": 4 if table else 0,
                "attractors": 0, "dominant": dominant, "dominant_share": 0.75 if table else None,
                "dominant_lo": 0.3, "dominant_hi": 0.95, "p_sss": p_sss, "p_sss_lo": 0.0,
                "p_sss_hi": 0.49 if table else 1.0, "table": table}

    sliding = {"member": "steady-sliding", "class": "steady-sliding", "k": None,
               "direction": None, "regime": None}
    cells = census_cells({"keys": ["loading.f"], "points": [
        point("a", "steady-sliding", [sliding], 0.0), point("b", None, [], None)]})
    assert [c["category"] for c in cells] == ["steady-sliding", None]
    assert cells[0]["text"] == "steady sliding\n75 % of 4\n0 attractors"
    assert cells[0]["p_text"] == "0 %\n[0, 49]" and cells[0]["modes"] == []
    assert cells[1]["text"] == "pending\n0 of 4" and cells[1]["p_text"] == "no start\nfinished"


def _assert_census_map(out: Path) -> None:
    """The sweep's regime map of a census is one map over the grid (no map per seed), and
    the cells it draws (``census_cells``) say what ``attractors_map.json`` says, which in
    turn agrees with the runs' own rows in ``sweep.json``."""
    from stickslip.studies.sweep import plot_sweep
    from stickslip.studies.sweep.regime_map import census_cells

    assert plot_sweep(out) == [out / "regime_map.png"]
    assert (out / "regime_map.png").stat().st_size > 10_000  # a drawn figure, not a stub
    assert not list(out.glob("regime_map_*.png"))
    meta = json.loads((out / "attractors_map.json").read_text())
    runs = json.loads((out / "sweep.json").read_text())["rows"]
    cells = census_cells(meta)
    assert [c["loading.omega"] for c in cells] == [20.0, 50.0]
    for cell, point in zip(cells, meta["points"], strict=True):
        assert (cell["dominant"], cell["attractors"]) == (point["dominant"], point["attractors"])
        assert (cell["share"], cell["p_sss"], cell["p_sss_lo"], cell["p_sss_hi"]) == (
            point["dominant_share"], point["p_sss"], point["p_sss_lo"], point["p_sss_hi"])
        # The same numbers from the runs themselves: the share of the starts that end in
        # stick-slip-separation and its Wilson interval (exact: the same closed form), and
        # the dominant member's (k, direction = sign of the celerity, regime) is a most
        # frequent one among the starts (ties are broken by the member's name).
        mine = [r for r in runs if r["id"].startswith(cell["point"] + "_seed-")]
        assert len(mine) == 2 and all(r["status"] == "completed" for r in mine)
        n_sss = sum(r["regime"] == "stick-slip-separation" for r in mine)
        assert cell["p_sss"] == n_sss / 2
        assert (cell["p_sss_lo"], cell["p_sss_hi"]) == wilson(n_sss, 2)
        keys = [(r["mode"], "rotation" if r["celerity_m_s"] > 0 else "opposite", r["regime"])
                for r in mine]
        top = max(keys.count(k) for k in keys)
        assert (cell["k"], cell["direction"], cell["regime"]) in keys
        assert keys.count((cell["k"], cell["direction"], cell["regime"])) == top
        assert cell["share"] == top / 2 and cell["category"] == cell["regime"]
        # The drawn text: member, share, attractors; P(SSS) with its interval in percent.
        sign = "+" if cell["direction"] == "rotation" else "−"
        assert cell["text"].startswith(f"k = {cell['k']} {sign}")
        assert f"{100 * cell['share']:.0f} % of 2" in cell["text"]
        assert f"{cell['attractors']} attractor" in cell["text"]
        assert cell["p_text"] == (f"{100 * cell['p_sss']:.0f} %\n[{100 * cell['p_sss_lo']:.0f},"
                                  f" {100 * cell['p_sss_hi']:.0f}]")


def test_certification_adapter(monkeypatch, tmp_path):
    """The direct solver's numbers, or its refusal, in the certificate and its line; a
    certificate from elsewhere that says it was not made is shown as such. The stability
    is λ₁ of the start at its own step (``chaos.fe_lyapunov`` over 2W, renormalised every
    W/20), unstable when > 1 1/s beyond 3 standard errors; a run with no twin (the implicit
    scheme's), gets the transient test instead, and the certificate says which judged."""
    import stickslip.studies.attractors.chaos as chaos
    import stickslip.studies.travel as travel
    from stickslip.studies.attractors.certify import certificate_line, certify, failures

    assert "unavailable" in certificate_line({"available": False,
                                              "message": "certification unavailable"})

    class NotRigidWave(ValueError):
        pass

    def wave_from_run(run_dir, *, dt_limit=False, window=None):
        return {"converged": True, "residual": 1e-11, "celerity_m_s": -935.6, "k": 11,
                "frequency_hz": 1639.6, "direction": "opposite",
                "difference": {"celerity_rel": 0.001},
                "dt_limit": {"celerity_m_s": -925.0, "run_dt_error": 0.0115, "levels": []}}

    asked = []

    def twin(exponent, error):
        def fe_lyapunov(run_dir, duration, tau):
            asked.append((duration, tau))
            return chaos.Lyapunov(exponent, error, tau, 40, ())
        return fe_lyapunov

    monkeypatch.setattr(travel, "wave_from_run", wave_from_run, raising=False)
    monkeypatch.setattr(chaos, "fe_lyapunov", twin(23.4, 2.0))
    cert = certify(tmp_path, window=0.1)
    assert asked == [(0.2, 0.005)]
    assert cert["at_dt"]["residual"] == 1e-11 and cert["stable"] is False
    assert cert["stability_test"] == "lyapunov"
    assert certificate_line(cert) == (
        "direct solver residual 1.0e-11, -935.6 m/s (+0.10 % vs the transient); Δt → 0: "
        "-925.0 m/s (the run's Δt error +1.15 %); unstable (λ₁ = 23 ± 2 1/s at the run's "
        "step)")
    why = failures({"stable": False, "direct": cert})
    assert why == ["unstable in the direct solver (λ₁ = 23 ± 2 1/s at the run's step)"]
    # λ₁ − 3 SE > 1 1/s: unstable (3 − 1.8 = 1.2); at or within it, not shown unstable
    for exponent, error, stable in ((0.2, 0.85, True), (3.0, 0.7, True), (3.0, 0.6, False),
                                    (-8.5, 4.4, True)):
        monkeypatch.setattr(chaos, "fe_lyapunov", twin(exponent, error))
        assert certify(tmp_path, window=0.1)["stable"] is stable, (exponent, error)

    def one_scene(run_dir, duration, tau):
        raise chaos.NoTwin(f"{run_dir}: the implicit scheme's runs are not kicked")

    def no_finer_wave(run_dir, *, dt_limit=False, window=None):  # the wave at 2S or 4S is not found
        return {"converged": True, "residual": 1e-11, "celerity_m_s": -935.6, "k": 11,
                "frequency_hz": 1639.6, "direction": "opposite",
                "samples": 2, "difference": {"celerity_rel": 0.001}, "dt_limit": None,
                "dt_limit_message": "NotConverged: no wave at 4S"}

    monkeypatch.setattr(travel, "wave_from_run", no_finer_wave)
    monkeypatch.setattr(chaos, "fe_lyapunov", one_scene)
    monkeypatch.setattr(travel, "wave_stability", lambda run_dir, *, end_time=0.05,
                        window=None: {"stable": True, "drift": 1e-4, "samples": 3},
                        raising=False)
    cert = certify(tmp_path)  # the wave at the run's step is kept, its limit says why not
    assert cert["at_dt"]["residual"] == 1e-11 and cert["stable"] is True
    assert cert["stability_test"] == "transient"
    assert cert["dt_to_0"] == {"message": "NotConverged: no wave at 4S"}
    assert cert["stability_samples"] == 3  # tested at S' = ceil(tau / dt)
    assert certificate_line(cert).endswith("(+0.10 % vs the transient); Δt → 0 wave not "
                                           "found (NotConverged); stable (a transient next "
                                           "to the wave)")

    def not_rigid(run_dir, *, dt_limit=False, window=None):
        raise NotRigidWave("frame spread 0.45")

    monkeypatch.setattr(travel, "wave_from_run", not_rigid)
    cert = certify(tmp_path)
    assert "NotRigidWave: frame spread 0.45" in certificate_line(cert)


def test_a_census_refused_for_its_cost_leaves_no_directory(tmp_path, capsys):
    """The cost refusal came after the census had claimed and filled its directory, which was
    left behind; a refused census now leaves nothing, and says why in one line (exit 2)."""
    pytest.importorskip("dolfinx")
    from stickslip.cli.main import main

    out = tmp_path / "census"
    rc = main(["attractors", str(SMOKE), "--starts", "2", "--meshes", "36", "--end-time",
               "1e7", "--max-time", "1e7", "--no-certify", "-o", str(out)])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and "--yes-i-know" in err[0], err
    assert not out.exists()
