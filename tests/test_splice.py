"""Splicing a re-baked span into the old bake (pure core): outside the span every key is
the old one exactly (shifted after it by the span's change in length); inside, the new
keys, cross-faded in and out."""

import numpy as np
from hypothesis import given, settings, strategies as st

from footstep_planner.core.splice import SpanMap, splice_curve


@settings(max_examples=200, deadline=None)
@given(st.integers(-50, 50), st.integers(30, 200), st.integers(5, 25), st.integers(5, 60),
       st.integers(-20, 20), st.integers(1, 8), st.integers(0, 10), st.integers(0, 2 ** 31 - 1))
def test_outside_the_span_every_key_is_the_old_one(first, n, fa_off, length, dlen, blend, gshift, seed):
    rng = np.random.default_rng(seed)
    fa = first + fa_off
    fb = min(fa + length, first + n - 2)
    new_len = max(fb - fa + dlen, 2)
    ga = first + gshift
    old = rng.normal(size=n)
    new = rng.normal(size=ga - first + new_len + 30)
    span = SpanMap(fa, fb, ga, ga + new_len, blend)
    frames, vals = splice_curve(first, old, first, new, span)
    assert len(frames) == n + span.delta and frames[0] == first
    before = frames <= fa
    assert np.array_equal(vals[before], old[frames[before] - first])
    end = fa + new_len
    after = frames >= end
    assert np.array_equal(vals[after], old[frames[after] - span.delta - first])
    lo, hi = span.changed()
    assert lo == fa + 1 and hi == end - 1


def test_inside_the_span_the_new_keys_play_and_fade_in_and_out():
    old = np.zeros(100)
    new = np.ones(200)
    span = SpanMap(20, 50, 120, 170, 5)  # the span grows from 30 to 50 frames
    frames, vals = splice_curve(0, old, 0, new, span)
    assert len(frames) == 120
    inside = (frames >= 25) & (frames <= 65)
    assert np.allclose(vals[inside], 1.0)
    ramp_in = vals[(frames >= 20) & (frames <= 25)]
    assert np.all(np.diff(ramp_in) >= 0) and ramp_in[0] == 0.0
    ramp_out = vals[(frames >= 65) & (frames <= 70)]
    assert np.all(np.diff(ramp_out) <= 0) and ramp_out[-1] == 0.0
