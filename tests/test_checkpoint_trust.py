"""Checkpoints are not taken on trust (``stickslip continue``, ``studies.rundir.checkpoint``).

Every array of a real checkpoint is mutated in turn (NaN, inf, one element more, another
dtype, negative and huge counts, left out, one added), its meta edited (kind, counts, clock,
kernel, backend, format, fields), the file truncated or replaced by random bytes: the
continuation's plan (``plan_continuation``, what `continue` runs before it claims anything)
refuses in one ``ReadError`` line naming the file and the field, and the run directory stays
byte for byte as it was, with nothing made beside it. An array mutation is tried twice: with
the meta's layout left as written (the layout check sees it) and with the layout rewritten to
match (the checks against the run must see it). A few cases go through the CLI (exit 2, one
line, nothing claimed, nothing written at -o), and a batch member's checkpoint goes through
``continue_batch`` too.

One real run and one batch of two scenes per module: the smoke mesh (36 contact nodes, 216
dofs) to 0.002 s (26 steps), sampled every 3.5e-4 s with two probes; a few seconds in all.
"""

from __future__ import annotations

import io
import json
import os
import shutil
from pathlib import Path

import numpy as np
import pytest
from faults import digest, leftovers
from test_ownership import cli, one_line, tree

pytest.importorskip("dolfinx")

SMOKE = Path(__file__).resolve().parents[1] / "scenes" / "smoke.toml"
END, UNTIL = 0.002, 0.004
COMMON = ["output.progress=false", "output.sample_interval=3.5e-4",
          "output.probes_deg=[0.0, 100.0]", f"time.end_time={END}"]
BATCH = """
name = "b"
base = "{base}"
set = ["time.end_time = {end}", "output.sample_interval = 3.5e-4",
       "output.probes_deg = [0.0, 100.0]", "output.progress = false"]
[[points]]
"loading.f" = 0.7
[[points]]
"loading.f" = 0.5
"""


@pytest.fixture(scope="module")
def made(tmp_path_factory) -> dict[str, Path]:
    """A finished run and a batch member with their checkpoints (made once, never changed:
    each test works on copies)."""
    from mpi4py import MPI

    from stickslip.solver.scene import load_scene
    from stickslip.studies.rundir import run_scene
    from stickslip.studies.sweep.schedule import run_sweep
    from stickslip.studies.sweep.spec import load_sweep

    root = tmp_path_factory.mktemp("trust")
    run_scene(load_scene(SMOKE, COMMON), root / "run", comm=MPI.COMM_SELF,
              stream=io.StringIO())
    spec = root / "batch.toml"
    spec.write_text(BATCH.format(base=SMOKE, end=END))
    with open(os.devnull, "w") as quiet:
        assert run_sweep(load_sweep(spec), root / "sweep", comm=MPI.COMM_SELF, batch="2",
                         stream=quiet, progress="lines") == 0
    members = sorted((root / "sweep" / "runs").iterdir())
    assert len(members) == 2
    for d in (root / "run", *members):
        assert (d / "checkpoint.npz").is_file()
    return {"run": root / "run", "batch": members[0], "other": members[1]}


def _copy(src: Path, dst: Path) -> Path:
    shutil.copytree(src, dst)
    return dst


def _load(d: Path) -> tuple[dict[str, np.ndarray], dict]:
    with np.load(d / "checkpoint.npz") as z:
        arrays = {k: z[k] for k in z.files}
    return arrays, json.loads(str(arrays.pop("meta")))


def _save(d: Path, arrays: dict[str, np.ndarray], meta: dict, relayout: bool) -> None:
    """Write the checkpoint of ``d``; ``relayout``: its meta's layout rewritten to match."""
    if relayout:
        meta = dict(meta, arrays={k: [a.dtype.str, list(a.shape)] for k, a in arrays.items()})
    np.savez(d / "checkpoint.npz", meta=np.array(json.dumps(meta)), **arrays)


def _refused(d: Path, *words: str) -> str:
    """``plan_continuation(d)`` refuses in one line naming ``words``; nothing changes in
    or beside ``d``."""
    from stickslip.studies.rundir.continuation import plan_continuation
    from stickslip.studies.rundir.readers import ReadError

    before, beside = tree(d), sorted(d.parent.iterdir())
    with pytest.raises(ReadError) as caught:
        plan_continuation(d, UNTIL)
    text = str(caught.value)
    assert "\n" not in text and text.startswith(str(d)), text
    for w in words:
        assert w in text, (w, text)
    assert tree(d) == before and sorted(d.parent.iterdir()) == beside
    return text


# ------------------------------------------------------------------ mutations of one array


def _nan(a: np.ndarray) -> np.ndarray | None:
    if a.dtype.kind not in "fc" or not a.size:
        return None
    b = a.copy()
    b.flat[0] = np.nan
    return b


def _inf(a: np.ndarray) -> np.ndarray | None:
    if a.dtype.kind not in "fc" or not a.size:
        return None
    b = a.copy()
    b.flat[-1] = -np.inf
    return b


def _longer(a: np.ndarray) -> np.ndarray:
    return np.append(a.ravel(), a.ravel()[:1] if a.size else np.zeros(1, a.dtype))


def _retyped(a: np.ndarray) -> np.ndarray:
    if a.dtype.kind == "f":
        return a.astype(np.float32)
    if a.dtype.kind in "iuc":
        return a.real.astype(np.float64) if a.dtype.kind == "c" else a.astype(np.float64)
    return np.float64(1.0)  # text: a number


def _negative(a: np.ndarray) -> np.ndarray | None:
    if a.dtype.kind not in "iu":
        return None
    b = a.astype(np.int64)
    b.flat[0] = -5
    return b


def _huge(a: np.ndarray) -> np.ndarray | None:
    if a.dtype.kind not in "iu":
        return None
    b = a.astype(np.int64)
    b.flat[0] = 10**12
    return b


MUTATIONS = {"nan": _nan, "inf": _inf, "longer": _longer, "retyped": _retyped,
             "negative": _negative, "huge": _huge}


@pytest.mark.parametrize("kind", ["run", "batch"])
@pytest.mark.parametrize("relayout", [False, True], ids=["layout-as-written", "relayout"])
@pytest.mark.parametrize("mutation", sorted(MUTATIONS))
def test_every_array_mutated_is_refused(made, tmp_path, kind, relayout, mutation):
    """Each array of the checkpoint in turn, mutated: one line naming that array (or, for
    counts that then disagree, the meta field they disagree with); the run untouched."""
    d = _copy(made[kind], tmp_path / "r")
    arrays, meta = _load(d)
    tried = 0
    for key, value in arrays.items():
        changed = MUTATIONS[mutation](value)
        if changed is None:
            continue
        _save(d, dict(arrays, **{key: np.asarray(changed)}), meta, relayout)
        text = _refused(d, "checkpoint.npz")
        assert key in text or key.partition("/")[2] in text or "meta." in text, (key, text)
        tried += 1
    assert tried >= 3, tried  # the counts at least


@pytest.mark.parametrize("kind", ["run", "batch"])
def test_a_missing_or_added_array_is_refused(made, tmp_path, kind):
    """Every array left out (the layout as written names it), every array a state must hold
    left out of the layout too, and arrays added (to the layout or not, under a rank's
    name, another rank's, or none): one line naming the array."""
    from stickslip.studies.rundir.checkpoint import REQUIRED

    d = _copy(made[kind], tmp_path / "r")
    arrays, meta = _load(d)
    for key in arrays:
        rest = {k: v for k, v in arrays.items() if k != key}
        _save(d, rest, meta, relayout=False)
        _refused(d, key, "missing")
        if key.partition("/")[2] in REQUIRED[kind]:
            _save(d, rest, meta, relayout=True)
            _refused(d, key, "missing")
    for extra in ("rank0/stepper/bogus", "rank0/run/partition_copy", "rank1/stepper/u",
                  "junk", "rank0/contact/status" if kind == "batch" else "rank0/stepper/kernel"):
        value = arrays["rank0/stepper/u"] if "/u" in extra else np.zeros(3)
        for relayout in (False, True):
            _save(d, dict(arrays, **{extra: value}), meta, relayout)
            _refused(d, extra)


def _edit(meta: dict, field: str, value: object) -> dict:
    out = dict(meta)
    if value is DELETE:
        del out[field]
    else:
        out[field] = value
    return out


DELETE = object()
META_EDITS = [
    ("kind", "other"), ("format", 3), ("format", 1.0), ("format", DELETE),
    ("kernel", DELETE), ("junk", 1),
    ("ranks", 0), ("ranks", -1), ("ranks", 10**9), ("ranks", "1"), ("ranks", 1.0),
    ("step", -5), ("step", 10**12), ("step", 1.5), ("step", True), ("time", float("nan")),
    ("time", -1.0), ("time", "0.002"), ("samples", 10**6), ("samples", -1),
    ("probe_steps", 0), ("status", "diverged"), ("kernel", "numpy"), ("backend", "gpu"),
    ("backend", "tpu"), ("scene", "other"), ("scene_sha256", "0" * 64), ("arrays", []),
    ("arrays", {"rank0/stepper/u": "float64"}),
]


@pytest.mark.parametrize("kind", ["run", "batch"])
def test_meta_edits_are_refused(made, tmp_path, kind):
    """Each field of the meta edited, deleted or added: one line naming it (or, for the
    scene's hash, the scene it no longer fits); the other kind's name for this kind."""
    d = _copy(made[kind], tmp_path / "r")
    arrays, meta = _load(d)
    other = "run" if kind == "batch" else "batch"
    for field, value in [*META_EDITS, ("kind", other)]:
        _save(d, arrays, _edit(meta, field, value), relayout=False)
        text = _refused(d)
        named = (f"meta.{field}", f"meta has no {field!r}", f"meta holds {field!r}")
        assert any(n in text for n in named) or field == "scene_sha256" \
            or (field == "ranks" and "rank(s)" in text), (field, value, text)
    _save(d, arrays, meta, relayout=False)  # the file as it was: accepted again
    from stickslip.studies.rundir.continuation import plan_continuation

    assert plan_continuation(d, UNTIL).kind == kind


def test_a_checkpoint_of_the_first_format_is_read_and_checked(made, tmp_path):
    """A checkpoint written before the meta named its arrays (format 1: no ``arrays``) still
    continues (a run of the earlier version), with every other check: a NaN in its
    stepper's u is refused as in the current format; format 1 with an ``arrays`` field is
    an edited file."""
    from stickslip.studies.rundir.continuation import plan_continuation

    d = _copy(made["run"], tmp_path / "r")
    arrays, meta = _load(d)
    first = {k: v for k, v in meta.items() if k != "arrays"} | {"format": 1}
    _save(d, arrays, first, relayout=False)
    assert plan_continuation(d, UNTIL).kind == "run"
    _save(d, dict(arrays, **{"rank0/stepper/u": _nan(arrays["rank0/stepper/u"])}), first,
          relayout=False)
    _refused(d, "rank0/stepper/u")
    _save(d, arrays, dict(first, arrays=meta["arrays"]), relayout=False)
    _refused(d, "meta holds 'arrays'")


def test_a_damaged_file_is_refused(made, tmp_path):
    """The file truncated anywhere, replaced by random bytes, empty, a bare .npy array, or
    its meta not JSON, a JSON list or a number: one line; the file itself untouched."""
    d = _copy(made["run"], tmp_path / "r")
    p = d / "checkpoint.npz"
    data = p.read_bytes()
    rng = np.random.default_rng(0)
    damaged = [data[:n] for n in (0, 10, len(data) // 3, len(data) // 2, len(data) - 1)]
    damaged += [rng.bytes(len(data)), b"PK\x03\x04" + rng.bytes(200)]
    for content in damaged:
        p.write_bytes(content)
        _refused(d, "checkpoint.npz")
    np.save(tmp_path / "bare.npy", np.zeros(3))
    p.write_bytes((tmp_path / "bare.npy").read_bytes())
    _refused(d, "checkpoint.npz", "bare array")
    arrays, _ = _load(made["run"])
    for meta in ("{", "[1, 2]", "3", '"run"'):
        np.savez(p, meta=np.array(meta), **arrays)
        _refused(d, "checkpoint.npz", "meta")
    np.savez(p, meta=np.arange(3), **arrays)
    _refused(d, "checkpoint.npz", "meta")


def test_the_run_beside_it_must_agree(made, tmp_path):
    """The checkpoint as written, but the run's summary.json or samples.npz edited (steps,
    time, dofs, contact nodes, kind, the steady pressure; a sample or a probe step less):
    refused in one line, nothing changed."""
    for field, value in (("steps", 25), ("sim_time_s", 0.0019), ("dofs", 218),
                         ("dt_s", 1e-5), ("contact_nodes", 35), ("steady_pressure_pa", 1.0),
                         ("batch", {"size": 1, "backend": "cpu"}), ("ranks", 2)):
        d = _copy(made["run"], tmp_path / f"{field}")
        summary = json.loads((d / "summary.json").read_text())
        (d / "summary.json").write_text(json.dumps(dict(summary, **{field: value})))
        _refused(d)
    for key in ("t", "probe_t"):
        d = _copy(made["run"], tmp_path / f"less-{key}")
        with np.load(d / "samples.npz") as z:
            samples = {k: z[k] for k in z.files}
        rows = samples[key].size - 1
        for k in (("t", "u_r", "u_theta", "v_r", "v_theta", "status", "energies", "r_r",
                   "r_theta") if key == "t" else ("probe_t",)):
            samples[k] = samples[k][:rows]
        if key == "probe_t":
            samples["probe_data"] = samples["probe_data"][:, :rows]
        np.savez(d / "samples.npz", **samples)
        _refused(d, "samples")


# ------------------------------------------------------------------ through the CLI


def _mutate(d: Path, key: str, value: object = None, relayout: bool = True,
            **meta_edits: object) -> None:
    arrays, meta = _load(d)
    if key:
        arrays[key] = np.asarray(value)
    _save(d, arrays, dict(meta, **meta_edits), relayout)


@pytest.mark.parametrize("case", ["nan-u", "kind-batch", "samples-1e6", "steps-negative"])
def test_continue_refuses_before_it_claims(made, tmp_path, capsys, case):
    """The report's four: NaN in u (the run was replaced by a diverged one, its checkpoint
    lost), kind "batch" on a run (a KeyError traceback), samples = 1e6 and step_count = -5
    (continued as ``completed`` with 1000259 samples). Now exit 2 and one line, in place
    and with -o; the run byte for byte as it was, nothing at -o, no sibling left."""
    d = _copy(made["run"], tmp_path / "r")
    arrays, _ = _load(d)
    if case == "nan-u":
        u = arrays["rank0/stepper/u"].copy()
        u[3] = np.nan
        _mutate(d, "rank0/stepper/u", u)
    elif case == "kind-batch":
        _mutate(d, "", kind="batch")
    elif case == "samples-1e6":
        _mutate(d, "rank0/run/samples", np.float64(1e6), relayout=False)
    else:
        _mutate(d, "rank0/stepper/step_count", np.int64(-5))
    field = {"nan-u": "rank0/stepper/u", "kind-batch": "meta.kind",
             "samples-1e6": "rank0/run/samples", "steps-negative": "step_count"}[case]
    before = tree(d)
    rc, err = cli(capsys, "continue", d, "--until", str(UNTIL))
    one_line(rc, err, "checkpoint.npz", field)
    rc, err = cli(capsys, "continue", d, "--until", str(UNTIL), "-o", tmp_path / "new")
    one_line(rc, err, "checkpoint.npz", field)
    assert tree(d) == before and not leftovers(d)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r"]


def test_a_batch_member_is_checked_alike(made, tmp_path, capsys):
    """A batch member's checkpoint (a census's or sweep's continuation leg): NaN in its u is
    refused by ``continue`` and by ``continue_batch`` before any member starts; the other
    member, continued with it, is untouched too."""
    from stickslip.studies.rundir import continue_batch
    from stickslip.studies.rundir.readers import ReadError

    root = tmp_path / "runs"
    d, other = _copy(made["batch"], root / "a"), _copy(made["other"], root / "b")
    arrays, _ = _load(d)
    u = arrays["rank0/stepper/u"].copy()
    u[-1] = np.inf
    _mutate(d, "rank0/stepper/u", u)
    before = {p: tree(p) for p in (d, other)}
    rc, err = cli(capsys, "continue", d, "--until", str(UNTIL))
    one_line(rc, err, "checkpoint.npz", "rank0/stepper/u", "NaN or infinite")
    with pytest.raises(ReadError, match="rank0/stepper/u"):
        continue_batch([other, d], UNTIL, stream=io.StringIO())
    assert {p: tree(p) for p in (d, other)} == before
    assert sorted(p.name for p in root.iterdir()) == ["a", "b"]


def test_a_forgery_consistent_in_itself_is_refused_at_restore(made, tmp_path, capsys):
    """A batch member's checkpoint without an array only its kernel writes (zprev), its
    layout rewritten to match: nothing before the build can tell, so the restore refuses it
    (one line, exit 2) and the claim is dropped: the run's files untouched (its lock, which
    names the live holder, was taken), no sibling left."""
    d = _copy(made["batch"], tmp_path / "a")
    arrays, meta = _load(d)
    del arrays["rank0/stepper/zprev"]
    _save(d, arrays, meta, relayout=True)
    before = digest(d)
    rc, err = cli(capsys, "continue", d, "--until", str(UNTIL))
    one_line(rc, err, "checkpoint.npz", "zprev")
    assert digest(d) == before and not leftovers(d)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a"]


def test_an_untouched_checkpoint_still_continues(made, tmp_path):
    """The checks refuse nothing stickslip wrote: the run continues in place to UNTIL."""
    from mpi4py import MPI

    from stickslip.studies.rundir import continue_run

    d = _copy(made["run"], tmp_path / "r")
    summary = continue_run(d, UNTIL, comm=MPI.COMM_SELF, stream=io.StringIO())
    assert summary["status"] == "completed" and summary["sim_time_s"] >= UNTIL * (1 - 1e-12)
    assert (d / "checkpoint.npz").is_file()
