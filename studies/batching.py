"""Which scenes run as one batch, and the memory its record may take: shared by a batched
sweep (``studies.sweep.batch``) and the continuation of batch members
(``studies.rundir.continuation``).

Scenes that share mesh, material, Δt and scheme run as one batch: ``batch_key`` is the scene
without what only the contact law and the initial state see (``PER_SCENE``: Omega, f, delta,
the initial perturbation, the name), or None for a scene that the scheme registry does not
batch (``solver.schemes.select.batchable``).
"""

from __future__ import annotations

import json

from stickslip.solver.scene import Scene, scene_to_dict
from stickslip.solver.schemes.select import batchable

#: Scene keys that may differ inside a batch (the contact law's data and the initial state).
PER_SCENE = {"name": None, "description": None, "loading": None, "initial": None,
             "geometry": ("delta",)}
#: A batch keeps its whole sample record in memory when it needs at most this fraction of
#: the available memory; otherwise the record is spooled to files under the sweep directory.
SPOOL_MEMORY_FRACTION = 0.1


def batch_key(scene: Scene) -> str | None:
    """The grouping key of ``scene`` (equal keys: same K, M, dt, scheme), or None if the
    scene must run alone."""
    if not batchable(scene):
        return None
    d = scene_to_dict(scene)
    for section, keys in PER_SCENE.items():
        if keys is None:
            d.pop(section, None)
        else:
            for k in keys:
                d[section].pop(k, None)
    return json.dumps(d, sort_keys=True)
