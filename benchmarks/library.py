"""The CMU library the tests and benchmarks plan with: subject 16's ten walks and jogs
(straight, veering and turning both ways) and the 49_05 running leap, read from
``../shared/mocap/cmu`` beside the project (see its README)."""

import glob
import os

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
MOCAP = os.path.join(os.path.dirname(ROOT), "shared", "mocap", "cmu")

#: Trial names (``cmu_<name>_*.bvh``) of the library, in import order.
LIBRARY = ["16_16", "16_11", "16_13", "16_17", "16_19", "16_35", "16_37", "16_39", "16_41", "16_43", "49_05"]

#: Subject 16's start from standing and walk to a stop: ``LIBRARY + ENDS`` starts and stops
#: with its own clips (``bench_characters.py``'s ``cmu``).
ENDS = ["16_31", "16_33"]


def cmu_files(mocap: str = MOCAP, names=LIBRARY) -> list[str]:
    """The BVH paths of ``names`` in ``mocap``; FileNotFoundError naming the first one
    missing."""
    out = []
    for n in names:
        hits = sorted(glob.glob(os.path.join(mocap, f"cmu_{n}_*.bvh")))
        if len(hits) != 1:
            raise FileNotFoundError(f"CMU clip {n!r}: {len(hits)} files match in {mocap}")
        out.append(hits[0])
    return out
