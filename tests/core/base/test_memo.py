"""Results kept by what they were made from (footstep_planner.core.base.memo, and the clip
analysis that keeps its results with it): a kept result is the one a fresh computation
gives, read only, within its bounds; a changed input is computed again."""

from __future__ import annotations

from dataclasses import dataclass, fields, is_dataclass, replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from footstep_planner.core.base.memo import Memo, digest, freeze
from footstep_planner.core.base.settings import Settings
from footstep_planner.core.clips import analysis
from footstep_planner.core.clips.analysis import AnalysisError, _analyze_clip, analyze_clip, motion_digest
from synth import synthetic_gait


@dataclass
class _Held:
    a: np.ndarray
    parts: list


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 9), st.integers(1, 50)), min_size=1, max_size=40),
       st.integers(1, 5), st.sampled_from([None, 400, 1000]))
def test_the_memo_keeps_the_latest_within_its_bounds(puts, kept, max_bytes):
    memo, order = Memo(kept, max_bytes), []
    for key, n in puts:
        memo.put(key, np.zeros(n))  # (8 n bytes)
        order = [k for k in order if k != key] + [key]
        assert len(memo) <= kept and memo.get(key) is not None  # (the latest is always kept)
        assert memo.bytes == sum(memo.get(k).nbytes for k in order if k in memo)
        assert max_bytes is None or memo.bytes <= max_bytes or len(memo) == 1
    held = [k for k in order if k in memo]
    assert held == order[len(order) - len(held):]  # (the oldest went first)


def test_what_is_kept_is_read_only_and_counted_once():
    shared = np.ones(10)
    held = _Held(shared, [shared, {"b": np.ones(5)}, (np.ones(2), "text")])
    assert freeze(held) == 8 * (10 + 5 + 2)
    with pytest.raises(ValueError):
        shared[0] = 2.0
    assert not held.parts[1]["b"].flags.writeable


def _same(a, b) -> bool:
    """Equal field by field, arrays by value (dataclasses, lists, tuples, nested)."""
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return np.array_equal(a, b)
    if is_dataclass(a) and not isinstance(a, type):
        return type(a) is type(b) and all(_same(getattr(a, f.name), getattr(b, f.name)) for f in fields(a))
    if isinstance(a, (list, tuple)):
        return type(a) is type(b) and len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b))
    return a == b


def _gaits():
    return [synthetic_gait()[0], synthetic_gait(speed=3.0, stride=2.4, duty=0.35)[0],
            synthetic_gait(curvature=0.8)[0], synthetic_gait(start_still=0.5)[0]]


def test_an_analysis_given_again_is_the_fresh_one_with_the_callers_own_motion():
    for motion in _gaits():
        fresh = _analyze_clip(motion, Settings())
        first = analyze_clip(motion)
        again = replace(motion)  # (equal samples, another object)
        second = analyze_clip(again)
        assert second.motion is again and first.motion is motion
        for got in (first, second):
            assert _same(replace(got, motion=None), replace(fresh, motion=None))  # (every figure and array)
        assert not second.balance.flags.writeable  # (kept: read only)
        assert again.times.flags.writeable  # (the caller's own motion is left as it was)


def test_a_changed_clip_or_setting_is_analysed_again():
    motion = synthetic_gait()[0]
    a = analyze_clip(motion)
    moved = replace(motion, root_pos=motion.root_pos * 1.25, heel=motion.heel * 1.25, toe=motion.toe * 1.25)
    assert motion_digest(moved) != motion_digest(motion)
    b = analyze_clip(moved)
    assert b.stride == pytest.approx(1.25 * a.stride, rel=0.02)
    c = analyze_clip(motion, Settings(contact_height=Settings().contact_height * 0.5))
    half = Settings(contact_height=Settings().contact_height * 0.5)
    assert _same(replace(c, motion=None), replace(_analyze_clip(motion, half), motion=None))


def test_a_refusal_is_given_again_as_a_refusal():
    motion = synthetic_gait()[0]
    short = replace(motion, times=motion.times[:20], root_pos=motion.root_pos[:20],
                    root_heading=motion.root_heading[:20], hips_in_root=motion.hips_in_root[:20],
                    local_rot=motion.local_rot[:20], heel=motion.heel[:, :20], toe=motion.toe[:, :20])
    for _ in range(2):
        with pytest.raises(AnalysisError) as err:
            analyze_clip(short)
    assert short.name in str(err.value)
    assert len(analysis._ANALYSED) <= analysis._ANALYSED.kept


@settings(max_examples=60, deadline=None)
@given(st.lists(st.floats(-1e3, 1e3, allow_nan=False), min_size=1, max_size=30), st.integers(0, 29),
       st.sampled_from(["float64", "float32"]))
def test_a_digest_tells_values_by_what_they_hold(values, at, dtype):
    """Equal values (other objects) have one digest; a changed number, shape, type, field or
    order gives another."""
    a = np.array(values, dtype)
    held = _Held(a, [a.reshape(1, -1), {"k": (1, "x")}])
    assert digest(held, 2.0) == digest(_Held(a.copy(), [a.copy().reshape(1, -1), {"k": (1, "x")}]), 2.0)
    changed = a.copy()
    changed[at % len(a)] += 1.0
    others = [_Held(changed, held.parts), _Held(a, [a.reshape(-1, 1) if len(a) > 1 else a, {"k": (1, "x")}]),
              _Held(a.astype("float16" if dtype == "float32" else "float32"), held.parts),
              _Held(a, [a.reshape(1, -1), {"k": (2, "x")}])]
    assert all(digest(o, 2.0) != digest(held, 2.0) for o in others)
    assert digest(held, 2.0) != digest(2.0, held) and digest(held, 2.0) != digest(held, 2)


def test_a_clip_under_another_name_is_given_the_analysis_under_its_own_name():
    """The same samples under another name (another character's copy of a clip) are given
    the kept analysis, named as they are (its motion too); a refusal names its own clip."""
    for motion in _gaits():
        first = analyze_clip(motion)
        other = replace(motion, name=motion.name + " (copy)")
        again = analyze_clip(other)
        assert again.name == other.name and again.motion.name == other.name
        assert _same(replace(again, name=first.name, motion=None), replace(first, motion=None))
        assert first.name == motion.name  # (the first caller's is left as it was)
    motion = synthetic_gait()[0]
    short = replace(motion, times=motion.times[:20], root_pos=motion.root_pos[:20],
                    root_heading=motion.root_heading[:20], hips_in_root=motion.hips_in_root[:20],
                    local_rot=motion.local_rot[:20], heel=motion.heel[:, :20], toe=motion.toe[:, :20])
    for name in ("first take", "second take", "first take"):
        with pytest.raises(AnalysisError) as err:
            analyze_clip(replace(short, name=name))
        assert repr(name) in str(err.value) and ("second" in name) == ("second" in str(err.value))
